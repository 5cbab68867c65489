"""The flat parameter array the physics reads: its layout comes from the declarations.

``numba`` compiles functions of floats and arrays, not of dataclasses, so a resolved
:class:`~lumped.model.PumpModel` and an operating point are packed into one float64
array: the global block (:data:`lumped.pump.G`: the operating point, derived pump
quantities and every Pump/Oil/Circuit field declared ``packed=True``), then one block
per valve (its kind's ``block``: :data:`lumped.valve.COMMON`, the kind's packed fields,
its derived quantities). Adding a packed parameter is one declaration: its slot and
its value here follow from it.
"""

from __future__ import annotations

import math

import numpy as np

from geometry.declare import specs
from lumped.effect_library import resolve
from lumped.model import PumpModel
from lumped.pump import G, NG, NP, OFF_DEL, OFF_IN
from lumped.valve import COMMON, kind_of


def _number(v) -> float:
    return (1.0 if v else 0.0) if isinstance(v, bool) else float(v)


def pack_valve(valve, oil, out: np.ndarray, offset: int) -> None:
    """Write a valve's block (COMMON, packed fields, derived quantities) at ``offset``."""
    kind = kind_of(valve)
    derived = valve.derived(oil)
    derived["kind_id"] = float(kind.id)
    derived["orifice_start"] = 0.0          # scratch of the orifice solve, not a parameter
    fields = {n: getattr(valve, n) for n, s in specs(valve)}
    for name, idx in kind.block._asdict().items():
        if name in derived:
            out[offset + idx] = _number(derived[name])
        elif fields.get(name) is not None:
            out[offset + idx] = _number(fields[name])
        else:
            raise KeyError(f"{type(valve).__name__}.derived() gives no {name!r} (a {'common' if name in COMMON else 'derived'} "
                           "packed quantity)")


def pack(model: PumpModel, speed_rpm: float, load_pressure: float, circuit: str | None = None,
         needle_area: float | None = None) -> np.ndarray:
    """Flat float64 parameter array of the right-hand side (``lumped.pump.evaluate``).

    ``model`` is resolved first (its effects applied). ``circuit`` overrides the model's
    circuit kind; ``needle_area`` its needle valve area (complete circuit; None and no
    area in the model: 0, the driver tunes it).
    """
    m = resolve(model)
    p = np.zeros(NP)
    pump, oil, circ = m.pump, m.oil, m.circuit
    for comp in (pump, oil, circ):
        for n, s in specs(comp):
            if s.packed:
                p[getattr(G, n)] = _number(getattr(comp, n))
    p[G.omega] = speed_rpm * 2.0 * math.pi / 60.0
    p[G.load_pressure] = load_pressure
    p[G.piston_area] = pump.piston_area
    p[G.leak] = pump.leakage_coefficient(oil.viscosity)
    complete = (circuit or circ.kind) == "complete"
    p[G.complete] = 1.0 if complete else 0.0
    area = circ.needle_area if needle_area is None else needle_area
    p[G.needle_cda] = 0.0 if area is None else circ.needle_discharge * area
    # liquid density at the vapour pressure: the cylinder cavitates below it (0: never, the air
    # of eq 4.11 expands without bound as P -> 0)
    cavitates = oil.vapour_pressure > 0.0 or oil.air_content <= 0.0
    p[G.rho_vapour] = oil.density_at(oil.vapour_pressure) if cavitates else 0.0
    p[G.rho_tank] = oil.density_at(pump.tank_pressure)       # constant: packed, not recomputed per call
    p[G.rho_load] = oil.density_at(load_pressure)
    p[G.pressure_start] = 0.0           # scratch of the cylinder pressure inversion, not a parameter
    assert len(G) <= NG
    pack_valve(m.inlet, oil, p, OFF_IN)
    pack_valve(m.delivery, oil, p, OFF_DEL)
    return p
