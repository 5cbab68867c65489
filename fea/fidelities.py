"""The reed fidelities a study can choose: exact Euler-Bernoulli and the beam, plate, solid FEA.

A typed registry (:data:`FIDELITIES`, name -> :class:`Fidelity`) in the layer that owns the
finite-element models. Each fidelity's module offers ``reed_properties(reed, mesh_size=None)
-> ReedProperties`` and ``properties_and_modes(reed, n, mesh_size=None) -> (ReedProperties,
modes)`` (``modes.first(n)`` -> frequencies [rad/s], labels); the FE ones also
``default_mesh_size(reed)`` [m], ``mode_shapes`` and ``write_modes_vtu``. The pump only needs
``reed_properties``, which :mod:`lumped.reed.fidelities` reaches through the entry points
declared in pyproject.toml (so ``lumped`` never imports this layer).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Callable

from geometry.errors import InputError
from lumped.reed import euler_bernoulli as reed_beam
from lumped.reed import fidelities as _lumped_registry

from . import beam, plate, solid


@dataclass(frozen=True)
class Fidelity:
    """One reed model: its name, its module and whether it meshes (``mesh_size`` matters)."""

    name: str
    module: ModuleType
    meshed: bool

    @property
    def reed_properties(self) -> Callable:
        """``f(reed, mesh_size=None) -> ReedProperties`` (kappa [N/m], omega_n [rad/s], gamma1..3, h_eff [m])."""
        return self.module.reed_properties

    @property
    def properties_and_modes(self) -> Callable:
        """``f(reed, n, mesh_size=None) -> (ReedProperties, modes)``."""
        return self.module.properties_and_modes

    def default_mesh_size(self, reed) -> float:
        """The element size [m] this fidelity uses for ``reed`` when none is given."""
        if not self.meshed:
            raise ValueError(f"fidelity {self.name!r} has no mesh")
        return self.module.default_mesh_size(reed)

    @property
    def free_mode_shape(self) -> Callable | None:
        """``f(reed, mesh_size=None) -> (s [m], w)`` of the first free-vibration mode, if offered."""
        return getattr(self.module, "free_mode_shape", None)


#: every fidelity, cheapest first
FIDELITIES: dict[str, Fidelity] = {
    "analytic": Fidelity("analytic", reed_beam, meshed=False),
    "beam": Fidelity("beam", beam, meshed=True),
    "plate": Fidelity("plate", plate, meshed=True),
    "solid": Fidelity("solid", solid, meshed=True),
}
#: the finite-element ones (a mesh-convergence study applies to them)
MESHED = tuple(n for n, f in FIDELITIES.items() if f.meshed)


def get(name: str, field: str = "--fidelity") -> Fidelity:
    """The fidelity called ``name``; InputError naming ``field`` (with the choices) otherwise."""
    if name not in FIDELITIES:
        extra = [n for n in _lumped_registry.names() if n not in FIDELITIES]
        raise InputError(field, f"expected one of {', '.join([*FIDELITIES, *extra])}, got {name!r}"
                         + (" (a fidelity registered in lumped.reed.fidelities only gives the pump its "
                            "parameters; studies of modes need one of these)" if name in extra else ""))
    return FIDELITIES[name]
