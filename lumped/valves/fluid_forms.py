"""A valve's predicted fluid parameters (``fluid = "predicted"`` in a model file).

The compact forms are computed by the fluid references of the ``fea`` layer (fea.fluid.compact:
Navier-Stokes and thin-film FE of the valve's own geometry, cached on disk), which this layer may
not import. A kind's function ``f(valve, oil) -> {field name: value}`` is registered here by
:func:`register` (``fea.fluid`` does on import) or found through the entry points of the group
``valvelab.fluid_forms`` (pyproject.toml); :func:`apply` replaces the declared fluid parameters
of every valve whose ``fluid`` is "predicted", so the packed physics reads them like any other
value and the "empirical" default stays exactly the thesis's model.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

from geometry.errors import InputError
from lumped import plugins
from lumped.valves.kind import kind_of

GROUP = "valvelab.fluid_forms"
#: kind name -> f(valve, oil) -> {field: value}
FORMS: dict[str, Callable] = {}
_loaded = {"entry_points": False}


def register(kind: str, func: Callable) -> None:
    """Add (or replace) the predicted-parameter function of a valve kind.

    Parameters
    ----------
    kind : str
        The registered valve kind's name (``"disc"``, ``"reed"``).
    func : callable
        ``func(valve, oil) -> {field name: value}``: the kind's fluid parameters in SI (Cd(Re)
        coefficients of eqs 2.47/3.88 [-], f1, f2 of eqs 2.42/3.26 [-], ...) for the valve's geometry.
    """
    FORMS[kind] = func


def forms_for(kind: str, field: str) -> Callable:
    """The function of ``kind``; InputError naming ``field`` when no installed package offers it.

    Parameters
    ----------
    kind : str
        The valve kind's name.
    field : str
        The model-file key an error names (``valves.<position>.fluid``).

    Returns
    -------
    callable
        ``f(valve, oil) -> {field name: value}`` (registered, else from the entry points of the group ``valvelab.fluid_forms``).
    """
    if kind not in FORMS and not _loaded["entry_points"]:
        _loaded["entry_points"] = True
        for name, func in plugins.entry_points(GROUP).items():
            FORMS.setdefault(name, func)
    if kind not in FORMS:
        raise InputError(field, f'"predicted" needs the fluid references of the {kind} valve (the fea package, '
                         f'entry point group {GROUP}); none is installed: use "empirical"')
    return FORMS[kind]


def predicted(valve, oil, where: str):
    """``valve`` with its fluid parameters replaced by the compact forms for its geometry and ``oil``.

    Parameters
    ----------
    valve : ValveParams
        A valve of any kind that offers predicted parameters.
    oil : lumped.fluid.oil.Oil
        The oil (density [kg/m^3], viscosity [Pa s]) the forms are evaluated for.
    where : str
        The valve's model-file table (``valves.inlet``), named in errors.

    Returns
    -------
    ValveParams
        A copy with the predicted values (SI) in place of the empirical ones.
    """
    kind = kind_of(valve).name
    values = forms_for(kind, f"{where}.fluid")(valve, oil)
    return replace(valve, **values)


def apply(model):
    """The model with every ``fluid = "predicted"`` valve's fluid parameters predicted (the rest as is).

    Parameters
    ----------
    model : lumped.model.pump_model.PumpModel
        A pump model whose valves may say ``fluid = "predicted"``.

    Returns
    -------
    PumpModel
        ``model`` itself when no valve asks for predicted parameters, else a copy with them.
    """
    changed = {}
    for pos in ("inlet", "delivery"):
        valve = model.valve(pos)
        if getattr(valve, "fluid", "empirical") == "predicted":
            changed[pos] = predicted(valve, model.oil, f"valves.{pos}")
    return replace(model, **changed) if changed else model
