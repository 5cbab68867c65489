"""
A third valve kind: the ball check valve, added as docs/extending.md says, and checked
======================================================================================

`lumped/valves/ball.py` (the kind: parameters, acceleration, registration), one import line in
`lumped/__init__.py` and the shipped model `thesis-ball` (the thesis pump of Table 5.4 with
ball valves) are all it took; every command, mixed pumps and the effects that apply to a
ball then work, and `lumped.check_valve_kind` checks the kind against the contract by
running it.

Headline number: a seated ball has no flow and no speed, so the inlet ball lifts off where the
pressure difference over its seat circle balances the spring's preload,
(P_tank - P_cyl) pi d_c^2 / 4 = k x_pre with d_c = d_b cos(alpha) (lumped/valves/ball.py): the
cylinder pressure at the located opening matches that closed form to the pressure change of
0.05 deg of crank.
"""

import math

import numpy as np

from lumped import check_valve_kind, load_model, simulate
from lumped.model.model_file import describe, parse_model

model = load_model("thesis-ball")
ball = model.inlet
print(f"{model.name}: {describe(model)['inlet']['ball']}")

r = simulate(model, 593.0, 2.76e6, revolutions=3, trace=True, trace_points=72_000)
print(f"delivery {r.delivery_per_rev * 1e6:.4f} cc/rev, volumetric efficiency {r.volumetric_efficiency:.3f}, "
      f"inlet opens at {math.degrees(r.inlet.opening_angle):.2f} deg")

# the lift-off against the closed form
dp_star = ball.spring_stiffness * ball.spring_preload / ball.seat_area
tr = r.trace
deg = tr.crank_deg
pc = np.interp(math.degrees(r.inlet.opening_angle), deg, tr.cylinder_pressure)
rate = np.interp(math.degrees(r.inlet.opening_angle), deg[1:], np.diff(tr.cylinder_pressure) / np.diff(deg))
lift_off_dp = model.pump.tank_pressure - pc
print(f"lift-off at dP = {lift_off_dp:.1f} Pa; closed form k x_pre / (pi d_c^2 / 4) = {dp_star:.1f} Pa")
assert abs(lift_off_dp - dp_star) < 0.05 * abs(rate), (lift_off_dp, dp_star, rate)

# a mixed pump: a ball inlet valve with the prototype reed as the delivery valve
mixed = parse_model({"name": "ball-reed", "valves": {"inlet": {"kind": "ball"}, "delivery": {"kind": "reed"}}})
m = simulate(mixed, 593.0, 2.76e6, revolutions=3)
print(f"ball inlet / reed delivery: {m.delivery_per_rev * 1e6:.4f} cc/rev")
assert 0.5 < m.volumetric_efficiency < 1.0

# the kind against its contract (quick: the pump with balls at both positions, one operating point)
report = check_valve_kind("ball", points=1, quick=True)
print(report)
assert report.passed

# %%
# The ball pump over its last revolution: openings and pressures
import matplotlib.pyplot as plt

r.plot()
plt.show()
