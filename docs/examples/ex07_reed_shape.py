"""
A reed shape of your own: a triangular (width-tapered) reed described in a geometry file
========================================================================================

No code: `[[reed.sections]]` with `taper_to` gives a linear width taper, and every fidelity
reads it. Headline number: under uniform pressure p a cantilever of constant thickness h
whose width falls linearly to zero carries the moment p b0 (L-s)^3 / (6 L) on a section of
stiffness E b0 (1 - s/L) h^3 / 12, so its curvature 2 p (L-s)^2 / (E h^3) does not depend on
the width and the tip deflects by p L^4 / (2 E h^3): kappa = 2 E h^3 / L^4 [Pa/m] (the
thesis's reed stiffness, eq 3.40's quantity). With a tip 1/1000 of the root width, the
exact Euler-Bernoulli model is within 0.5 % of it and the FE beam within 1 %.
"""

import tomllib

from fea.fidelities import FIDELITIES
from geometry import parse_reed

L, W, H, E = 25.4e-3, 16.0e-3, 1.35e-3, 2.9e9
GEOMETRY = f"""
[reed]
name = "triangle"
length = {L}              # m
thickness = {H}           # m

[[reed.sections]]
s_end = {L}               # m: one section over the whole length
width = {W}               # m at the clamp
taper_to = {W * 1e-3}     # m at the tip

[reed.material]
youngs_modulus = {E}      # Pa, Delrin (Table 3.1)
density = 1410.0          # kg/m^3
poisson_ratio = 0.35
"""

reed = parse_reed(tomllib.loads(GEOMETRY), "triangle")
closed = 2.0 * E * H**3 / L**4
for name in ("analytic", "beam"):
    kappa = FIDELITIES[name].reed_properties(reed).kappa
    print(f"{name:8s} kappa = {kappa / 1e6:.4f} MPa/m (closed form {closed / 1e6:.4f})")
    assert abs(kappa / closed - 1.0) < (0.005 if name == "analytic" else 0.01), (name, kappa)

# %%
# The triangular reed's outline, and its deflection under 1 bar: the beam FE model against the closed form
# w(s) = 2 p / (3 E h^3) [L^3 s - (L^4 - (L - s)^4) / 4], the curvature above integrated twice
import matplotlib.pyplot as plt

from studies.plots import legend_outside
import numpy as np

from fea import beam

p = 1e5                                                    # Pa
fe = beam.solve(reed)
sc = np.linspace(0.0, L, 200)
w_closed = 2 * p / (3 * E * H**3) * (L**3 * sc - (L**4 - (L - sc) ** 4) / 4)
fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 4.5), layout="constrained")
half = np.asarray(reed.width(sc)) / 2 * 1e3
a1.fill_between(sc * 1e3, -half, half, color="tab:gray")
a1.set_ylabel("y [mm]")
a2.plot(fe.s * 1e3, fe.psi_static * p / fe.kappa * 1e6, label="beam FE")
a2.plot(sc * 1e3, w_closed * 1e6, "k--", label="closed form")
a2.set_xlabel("s, from the clamp [mm]")
a2.set_ylabel("deflection at 1 bar [um]")
legend_outside(a2, fontsize=8)
plt.show()
