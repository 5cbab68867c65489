"""Fluid references: the fluid fidelities of the valves, from the lumped laws to laminar Navier-Stokes.

A typed registry (:data:`FIDELITIES`, name -> :class:`FluidFidelity`) like the reed's
structural one (:mod:`fea.fidelities`). Each fidelity says which valve kinds it models and
offers ``point(valve, lift, reynolds, options) -> FlowPoint`` (:mod:`fea.fluid.point`: the
valve with its oil, the lift x [m], the Reynolds number of the kind's definition, a mapping of
options; the point's keys are those of ``valvelab flow --json``):

- ``orifice``: the lumped laws the pump model uses (eqs 2.18, 2.36, 2.38, 2.40, 2.47;
  :mod:`fea.fluid.lumped_laws`), for comparison;
- ``thin_film``: the Reynolds equation on the sealing film (:mod:`fea.fluid.reynolds`, the
  general solver on any 2-D triangle mesh; the disc's conical film in
  :mod:`fea.fluid.disc_film`);
- ``axisymmetric``: steady laminar Navier-Stokes of the disc valve, Taylor-Hood P2-P1 with
  Newton (:mod:`fea.fluid.navier_stokes`, :mod:`fea.fluid.axisymmetric`);
- ``3d``: the reed valve's three-dimensional flow, registered by its own module with
  :func:`register` (``register(FluidFidelity("3d", ("reed",), point_function))``); until then
  asking for it is an input error naming the choices.

The compact forms the pump uses (``fluid = "predicted"`` in a model file) are fitted from the
``axisymmetric`` and ``thin_film`` points by :mod:`fea.fluid.compact`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from geometry.errors import InputError
from lumped.valves import fluid_forms as _fluid_forms

from .axisymmetric import axisymmetric_point
from .compact import predicted_values
from .disc_film import thin_film_point
from .lumped_laws import orifice_point
from .point import FlowPoint, FluidValve, load_fluid_valve


@dataclass(frozen=True)
class FluidFidelity:
    """One fluid model: its name, the valve kinds it applies to and its point function."""

    name: str
    kinds: tuple
    point: Callable
    meshed: bool = True
    summary: str = ""


#: every fluid fidelity, cheapest first (``3d`` is added by the reed's module)
FIDELITIES: dict[str, FluidFidelity] = {
    "orifice": FluidFidelity("orifice", ("disc",), orifice_point, meshed=False,
                             summary="the lumped laws of the pump model (eqs 2.18, 2.36, 2.38, 2.47)"),
    "thin_film": FluidFidelity("thin_film", ("disc",), thin_film_point,
                               summary="Reynolds equation of the sealing film (FE, P1)"),
    "axisymmetric": FluidFidelity("axisymmetric", ("disc",), axisymmetric_point,
                                  summary="laminar Navier-Stokes in (r, z), Taylor-Hood P2-P1, Newton"),
}
#: names a fidelity may have, registered or not yet (the reed's ``3d``)
KNOWN = ("orifice", "thin_film", "axisymmetric", "3d")


def register(fidelity: FluidFidelity) -> None:
    """Add (or replace) a fluid fidelity."""
    FIDELITIES[fidelity.name] = fidelity


def get(name: str, kind: str | None = None, field: str = "name") -> FluidFidelity:
    """The fidelity ``name`` (for a valve of ``kind`` if given); InputError naming ``field`` otherwise."""
    if name not in FIDELITIES:
        extra = " (not available: its module is not installed)" if name in KNOWN else ""
        raise InputError(field, f"expected one of {', '.join(FIDELITIES)}, got {name!r}{extra}")
    fid = FIDELITIES[name]
    if kind is not None and kind not in fid.kinds:
        usable = [n for n, f in FIDELITIES.items() if kind in f.kinds]
        raise InputError(field, f"{name!r} does not model a {kind} valve; for it use one of "
                         f"{', '.join(usable) or 'none yet'}")
    return fid


# fluid = "predicted" in a model file reads the disc's compact forms (also an entry point, pyproject.toml)
_fluid_forms.register("disc", predicted_values)


def _reed_predicted(valve, oil) -> dict:
    """The reed's predicted fluid parameters (:func:`fea.fluid.reed_compact.predicted_values`, imported when asked)."""
    from .reed_compact import predicted_values as reed_values

    return reed_values(valve, oil)


_fluid_forms.register("reed", _reed_predicted)


def _reed_point(valve, lift, reynolds, options=None):
    """The reed's 3-D point (:func:`fea.fluid.reed_flux.reed_point`, imported when asked)."""
    from .reed_flux import reed_point

    return reed_point(valve, lift, reynolds, options)


register(FluidFidelity("3d", ("reed",), _reed_point,
                       summary="the reed valve's laminar Navier-Stokes flow in 3-D, Taylor-Hood P2-P1, Newton"))

__all__ = ["FIDELITIES", "FlowPoint", "FluidFidelity", "FluidValve", "get", "load_fluid_valve", "register"]
