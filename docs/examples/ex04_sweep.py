"""
A sweep: eight load pressures on a grid, run on a dask cluster, read back as a table
====================================================================================

Headline number: with air-free oil and a compliant-free disc valve the delivery per
revolution falls linearly with load pressure at the slope of the oil's compressibility in
the dead volume, d(delivery)/d(p_load) = -V_dead / beta (eqs 4.11, 4.17); the sweep's
fitted slope matches it within 3 % (the valves' closing delays add a small, nearly
load-independent loss).
"""

import tempfile
from pathlib import Path

import numpy as np
from distributed import Client

from lumped import load_model
from studies.sweeps import parse_spec, read_results, run_sweep

SPEC = """
[sweep]
model = "thesis-disc"
sampler = "grid"

[factors.load_pressure]
low = 1.0e6
high = 8.0e6
levels = 8

[fixed]
speed_rpm = 300.0
air_content = 0.0
revolutions = 4
effect.seat_compliance = false   # the thesis rig's O-ring off: rigid seats
"""

model = load_model("thesis-disc")
with tempfile.TemporaryDirectory() as tmp, Client(processes=False, n_workers=1, threads_per_worker=1,
                                                           dashboard_address=":0") as client:
    import tomllib

    spec = parse_spec(tomllib.loads(SPEC), SPEC)
    summary = run_sweep(spec, Path(tmp) / "sweep", client=client, progress=False)
    df, _ = read_results(Path(tmp) / "sweep")

ok = df[df["status"] == "ok"].sort_values("load_pressure")
print(ok[["load_pressure", "delivery_m3_per_rev", "volumetric_efficiency"]].to_string(index=False))
slope = np.polyfit(ok["load_pressure"], ok["delivery_m3_per_rev"], 1)[0]     # m^3 per rev per Pa
closed = -model.pump.dead_volume / model.oil.bulk_modulus
print(f"slope {slope:.4g} m^3/Pa per rev; closed form -V_dead/beta = {closed:.4g}")

assert summary["designs"] == 8 and len(ok) == 8
assert abs(slope / closed - 1.0) < 0.03, (slope, closed)

# %%
# Delivery against load pressure, with the closed-form compressibility slope
import matplotlib.pyplot as plt

from studies.plots import legend_outside

p_mpa = ok["load_pressure"].to_numpy() / 1e6
fig, ax = plt.subplots(figsize=(7.5, 3.5), layout="constrained")
ax.plot(p_mpa, ok["delivery_m3_per_rev"] * 1e6, "o", label="sweep (simulated)")
mid = ok["delivery_m3_per_rev"].mean() * 1e6, ok["load_pressure"].mean()
ax.plot(p_mpa, mid[0] + closed * (ok["load_pressure"] - mid[1]) * 1e6, "k--", label="slope -V_dead / beta")
ax.set_xlabel("load pressure [MPa]")
ax.set_ylabel("delivery [cc/rev]")
legend_outside(ax, fontsize=8)
plt.show()
