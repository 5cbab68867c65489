"""The rectangular duct the 3-D Navier-Stokes tests check against: a tetrahedral mesh and the closed-form laminar
flow rate (White, Viscous Fluid Flow, eq 3-48), shared by tests/test_fluid_reed3d.py and test_fluid_reed_flux.py."""

import numpy as np
import skfem

MU, RHO = 0.0683, 876.0
A, B, LD = 1.0e-3, 0.25e-3, 6.0e-3       # duct half width, half height, length [m]


def duct(n: int) -> skfem.MeshTet:
    """The 2a x 2b x L duct with n cells across its half width, boundaries inlet, outlet and wall."""
    m = skfem.MeshTet.init_tensor(np.linspace(0, LD, 3 * n + 1), np.linspace(-A, A, 2 * n + 1),
                                  np.linspace(-B, B, max(2, n // 2) + 1))
    return m.with_boundaries({"inlet": lambda x: np.isclose(x[0], 0.0), "outlet": lambda x: np.isclose(x[0], LD),
                              "wall": lambda x: np.isclose(np.abs(x[1]), A) | np.isclose(np.abs(x[2]), B)})


def duct_flow(dp: float) -> float:
    """Q [m^3/s] that dP [Pa] drives through the 2a x 2b duct of length L (White, Viscous Fluid Flow, eq 3-48)."""
    n = np.arange(1, 400, 2)
    series = 1 - 192 * B / (np.pi**5 * A) * np.sum(np.tanh(n * np.pi * A / (2 * B)) / n**5)
    return 4 * A * B**3 * dp / (3 * MU * LD) * series
