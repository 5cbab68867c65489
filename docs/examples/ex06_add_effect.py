"""
Adding an effect: a trapped volume on the cylinder (a gauge port, a drilled passage)
====================================================================================

One `register(Effect(...))`, as docs/extending.md says, and the effect works everywhere an
effect does: in a model's effects, in `valvelab synth --effect`, in the discrepancy
workflow's candidates and in sweeps (here: in this process; a permanent one goes into
lumped/model/effect_library.py).

Headline number: a trapped volume V adds to the dead volume, so with air-free oil the
delivery falls by V (p_load - p_tank) / beta per revolution (eqs 4.11, 4.17); simulated
within 3 %.
"""

from dataclasses import replace

from lumped import LIBRARY, load_model, simulate
from lumped.model.effect_library import set_fields
from lumped.model.effects import PUMP, Applied, Effect, Parameter

effect = LIBRARY.register(Effect(
    name="trapped_volume",
    summary="an oil volume connected to the cylinder that the baseline leaves out",
    parameters=(Parameter("volume", "m^3", prior=1e-6, bounds=(1e-8, 1e-4), plausible=(1e-8, 1e-5),
                          source="drawing of the manifold (a gauge port is ~1 cc)"),),
    apply=lambda model, values, target: set_fields(
        model, "pump", **{"pump.dead_volume": model.pump.dead_volume + values["volume"]}),
    targets=PUMP,
))

# the thesis disc pump with air-free oil and rigid seats (its own O-ring effect removed)
base = load_model("thesis-disc")
base = replace(base, effects=(), oil=replace(base.oil, air_content=0.0))
with_volume = replace(base, effects=(Applied.of("trapped_volume", "pump", {"volume": 2.0e-6}),))

speed, load = 300.0, 6.0e6
before = simulate(base, speed, load, revolutions=4, max_revolutions=20)
after = simulate(with_volume, speed, load, revolutions=4, max_revolutions=20)
drop = before.delivery_per_rev - after.delivery_per_rev
closed = 2.0e-6 * (load - base.pump.tank_pressure) / base.oil.bulk_modulus
print(f"delivery {before.delivery_per_rev * 1e6:.5f} -> {after.delivery_per_rev * 1e6:.5f} cc/rev: "
      f"drop {drop * 1e9:.3f} mm^3 (closed form {closed * 1e9:.3f} mm^3)")

assert abs(drop / closed - 1.0) < 0.03, (drop, closed)

# %%
# The delivery drop against the closed form, for a few trapped volumes
import matplotlib.pyplot as plt

from studies.plots import legend_outside

volumes = [0.5e-6, 1.0e-6, 2.0e-6, 4.0e-6]
drops = [before.delivery_per_rev - simulate(
    replace(base, effects=(Applied.of("trapped_volume", "pump", {"volume": v}),)), speed, load,
    revolutions=4, max_revolutions=20).delivery_per_rev for v in volumes]
fig, ax = plt.subplots(figsize=(7.5, 3.5), layout="constrained")
ax.plot([v * 1e6 for v in volumes], [d * 1e9 for d in drops], "o", label="simulated")
ax.plot([v * 1e6 for v in volumes], [v * (load - base.pump.tank_pressure) / base.oil.bulk_modulus * 1e9
                                     for v in volumes], "k--", label="V (p_load - p_tank) / beta")
ax.set_xlabel("trapped volume [cc]")
ax.set_ylabel("delivery lost [mm^3/rev]")
legend_outside(ax, fontsize=8)
plt.show()
