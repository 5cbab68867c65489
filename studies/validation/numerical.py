"""u_num of the pump model: a refinement ladder of the integrator tolerance and a GCI-style estimate.

The pump model has no mesh; its discretisation is the integrator's error control, so the
"grid" is the tolerance tau (rtol, with atol = tau / 100 in state scales: the fast path's
default ratio 1e-3 / 1e-5). Every reported output (delivery, each valve's opening and
closing angle, peak opening, seat and stop impact speed) is computed on the fast path at
tau = 1e-3, 1e-4, 1e-5 (``--quick``: 1e-3, 1e-4) and the ladder goes through
:func:`fea.convergence.gci` (Celik et al. 2008; refinement ratio 10):

- converging monotonically on three levels: GCI with Fs = 1.25; the band of the reported
  value S is Fs x max(|S - f_ext|, |S - f_finest|) (for S on the finest level that is GCI21;
  for the reference stepper, scipy Radau at 1e-6, its distance to the ladder's limit);
- two levels: Fs = 3 with the assumed order 1 in tau (tolerance proportionality: the global
  error of an error-per-step controller scales with the tolerance);
- not monotonic (oscillating, a zero change, growing changes): reported as such, with the
  conservative band Fs = 3 x the largest change (Roache), never hidden.

The standard uncertainty is u_num = U / 1.15 (ASME V&V 20-2009, section 2-4:
:data:`fea.convergence.GCI_STANDARD_FACTOR`). An output that is undefined (a valve that
never opens or never reseats) has no u_num on the levels where it is missing: ``u`` is None
and ``note`` says where. The cycle is part of the ladder: each level runs to cyclic steady
state with the steady-state tolerance the integrator's rtol sets (lumped.run.simulate), so the
iteration error of the periodic solution is included.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from fea.convergence import FS_TWO, GCI_STANDARD_FACTOR, gci
from studies.validation.point import Point

#: fast-path tolerances of the ladder (coarse to fine) and of ``--quick``
LADDER = (1e-3, 1e-4, 1e-5)
QUICK_LADDER = (1e-3, 1e-4)
#: atol / rtol at every level (the fast path's default 1e-5 / 1e-3)
ATOL_PER_RTOL = 1e-2
#: assumed order in the tolerance of a two-level ladder
TWO_LEVEL_ORDER = 1.0
#: outputs with a ladder: name -> unit (studies.sweeps.design.outputs names)
OUTPUTS = {"delivery_cc_per_rev": "cc/rev"}
for _pos in ("inlet", "delivery"):
    OUTPUTS.update({f"{_pos}_opening_angle_deg": "deg", f"{_pos}_closing_angle_deg": "deg",
                    f"{_pos}_peak_opening_mm": "mm", f"{_pos}_seat_impact_m_s": "m/s",
                    f"{_pos}_stop_impact_m_s": "m/s"})


@dataclass(frozen=True)
class NumericalUncertainty:
    """u_num of one output (output units): the ladder, its GCI and the band of the reported value."""

    output: str
    unit: str
    tolerances: tuple[float, ...]          # fast-path rtol, fine to coarse
    values: tuple[float | None, ...]       # the output at each tolerance
    reported: float | None                 # the value whose uncertainty this is (S)
    reported_by: str                       # "reference" or "fast rtol 0.001"
    U: float | None                        # band (GCI-style expanded numerical uncertainty)
    u: float | None                        # standard uncertainty U / 1.15
    order: float | None
    extrapolated: float | None
    safety_factor: float | None
    converging: bool | None                # None: two levels (not checkable) or undefined
    note: str

    def as_dict(self) -> dict:
        return asdict(self)


def output_values(result, outputs=OUTPUTS) -> dict:
    """{output: value or None} of a PumpResult (angles unwrapped: delivery in [180, 540) deg)."""
    from studies.sweeps.design.outputs import PUMP_OUTPUTS
    from studies.sweeps.pump import outputs_of

    row = outputs_of(result)
    return {name: PUMP_OUTPUTS[name].value(row) for name in outputs}


def estimate(output: str, unit: str, tolerances, values, reported, reported_by: str) -> NumericalUncertainty:
    """The band of ``reported`` from a ladder of ``values`` at ``tolerances`` (both fine to coarse)."""
    tol = tuple(float(t) for t in tolerances)
    vals = tuple(None if v is None else float(v) for v in values)
    base = dict(output=output, unit=unit, tolerances=tol, values=vals, reported=reported, reported_by=reported_by)
    missing = [t for t, v in zip(tol, vals) if v is None]
    if reported is None or missing:
        if reported is None and len(missing) == len(vals):
            note = "undefined: the valve never opens or never reseats at any tolerance"
        else:
            where = ", ".join(f"rtol {t:g}" for t in missing) or reported_by
            note = f"undefined at {where} (the valve event appears at some tolerances only): no estimate"
        return NumericalUncertainty(**base, U=None, u=None, order=None, extrapolated=None, safety_factor=None,
                                    converging=None, note=note)
    g = gci(vals, sizes=tol, order=TWO_LEVEL_ORDER if len(vals) == 2 else None)
    finest = vals[0]
    if g.converging is False:
        changes = [abs(b - a) for a, b in zip(vals, vals[1:])] + [abs(reported - finest)]
        U = FS_TWO * max(changes)
        note = g.note
    else:
        U = g.safety_factor * max(abs(reported - g.extrapolated), abs(reported - finest))
        note = g.note if g.converging else g.note.replace("convergence not checked",
                                                           "monotonic convergence not checked")
    return NumericalUncertainty(**base, U=float(U), u=float(U / GCI_STANDARD_FACTOR), order=g.order,
                                extrapolated=g.extrapolated, safety_factor=g.safety_factor,
                                converging=g.converging, note=note)


def ladder_tolerances(quick: bool = False, rtol: float | None = None) -> tuple[float, ...]:
    """Fast-path tolerances, coarse to fine: the ladder, or one starting at a reported fast run's ``rtol``."""
    if rtol is None:
        return QUICK_LADDER if quick else LADDER
    n = 2 if quick else 3
    return tuple(rtol / 10.0**k for k in range(n))


def run_ladder(point: Point, tolerances, outputs=OUTPUTS) -> list[dict]:
    """{output: value} of the fast path at each tolerance (coarse to fine, as given) at ``point``."""
    from lumped.run.simulate import simulate

    out = []
    for t in tolerances:
        # each level at its own tolerance: the accuracy check would replace a loose level by a tighter one
        r = simulate(point.model, point.speed_rpm, point.load_pressure, method="fast", rtol=t, atol=t * ATOL_PER_RTOL,
                     revolutions=point.revolutions, max_revolutions=point.max_revolutions, circuit=point.circuit,
                     accuracy_check=False)
        out.append(output_values(r, outputs))
    return out


def numerical_uncertainty(point: Point, *, reported: dict | None = None, reported_method: str = "reference",
                          reported_rtol: float | None = None, quick: bool = False,
                          outputs=OUTPUTS) -> dict[str, NumericalUncertainty]:
    """u_num of every output at one operating point (see the module docstring).

    ``point``: the model, speed, load, revolutions and circuit each level of the ladder runs
    (:class:`~studies.validation.point.Point`; the studies run 5 revolutions after at most 12).
    ``reported``: the outputs of the run being reported ({output: value}); for
    ``reported_method = "fast"`` its ``reported_rtol`` starts the ladder and ``reported`` may be
    None (its level is the reported run); for "reference" the ladder is :data:`LADDER` and
    ``reported`` is required.
    """
    fast = reported_method == "fast"
    if not fast and reported is None:
        raise ValueError("the reference stepper's outputs are needed as `reported`")
    tol = ladder_tolerances(quick, reported_rtol if fast else None)
    levels = run_ladder(point, tol, outputs)
    if fast:
        reported = levels[0] if reported is None else reported
        by = f"fast rtol {tol[0]:g}"
    else:
        by = "reference"
    fine_first = tol[::-1]
    return {name: estimate(name, unit, fine_first, [lv[name] for lv in levels[::-1]], reported.get(name), by)
            for name, unit in outputs.items()}
