"""``valvelab validate``: the multi-fidelity chain and the 12 pump cases of chapter 5, written to ``out/``.

The run is a list of steps (:data:`STEPS`), each reading and adding to one :class:`Run`: the
reed parameters by fidelity (``studies.validation.reed_check``) with the V&V 20 table of the
analytic model against each FEA fidelity, beside the 12 pump cases of Tables 5.4 and 5.6 to
cyclic steady state; the one-mode reed against N modes and the whole FE reed in the pump
(``studies.validation.reed_dynamics``); the geometry chain's reed parameters in the reed pump;
the validation that can fail (``studies.validation.pump_vv20``: every run, a calibration of the
air content on one condition per rig, the other runs predicted, differences between
conditions, rig-level tests and the smallest detectable model-form error); the tables and
plots; the summary. A new report is a new step in :data:`STEPS`.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from geometry.errors import InputError
from studies.cli import flags
from studies.outputs import finite_or_none

HELP = "run the full validation (reed parameters, 12 pump cases) and write tables and plots to out/"


def configure(p):
    p.add_argument("--out", default="out", help="output folder (default out/)")
    p.add_argument("--quick", action="store_true", help="fewer revolutions, one traced revolution, coarse FEA (tests)")
    p.add_argument("--force", action="store_true", help="write into a non-empty folder valvelab did not create")
    p.add_argument("--jobs", type=flags.integer(1, 256), default=None,
                   help="processes for the pump cases, the reed chain and the plots (default one per core, at most 4, "
                        "or $VALVELAB_JOBS)")
    p.add_argument("--valve", choices=("disc", "reed"), default=None, help="only the cases of one valve type")
    p.add_argument("--skip-reed-chain", action="store_true", help="skip the reed parameters by fidelity")
    p.add_argument("--no-uncertainty", action="store_true",
                   help="skip the validation uncertainty (u_num, u_input, u_D, the calibration and the V&V 20 tables)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="dask scheduler for the Monte Carlo of u_input (default: a local cluster; --quick: this process)")
    p.add_argument("--workers", type=flags.integer(1, 256), default=None,
                   help="local dask workers for the Monte Carlo (default: one per core)")


def _log(msg: str) -> None:
    sys.stderr.write(msg + "\n")
    sys.stderr.flush()


class Run:
    """What the steps share: the arguments, the output folder, the process pool, the summary being built and the
    intermediate results (``state``)."""

    def __init__(self, args, out: Path, pool, jobs: int):
        self.args, self.out, self.pool, self.jobs = args, out, pool, jobs
        self.summary: dict = {"out": str(out), "quick": bool(args.quick), "steps": {}}
        self.state: dict = {}
        self.uncertainty = not args.no_uncertainty
        self.reed_chain = not args.skip_reed_chain and args.valve != "disc"

    def submit(self, fn, *a):
        """``fn(*a)`` in the pool (a future), or a finished stand-in when there is none."""
        if self.pool is not None:
            return self.pool.submit(fn, *a)
        return _Done(fn(*a))


class _Done:
    def __init__(self, value):
        self.value = value

    def result(self):
        return self.value


def plan_words(args, n_cases: int) -> str:
    """What a run of ``valvelab validate`` with these arguments computes, with its counts (said before it starts)."""
    from studies.validation.pump_vv20 import PER_SCRAMBLE, PER_SCRAMBLE_QUICK

    tables = {"disc": "Table 5.4", "reed": "Table 5.6"}.get(args.valve, "Tables 5.4 and 5.6")
    parts = [f"{n_cases} pump cases of {tables} to cyclic steady state"]
    if args.valve != "disc":
        parts.append("the reed in the pump by model (7 runs)")
        if not args.skip_reed_chain:
            parts.append("the prototype reed's parameters by FEA fidelity")
    if not args.no_uncertainty:
        per = (PER_SCRAMBLE_QUICK if args.quick else PER_SCRAMBLE) * 8
        parts.append(f"u_num ladders and u_input from {per} joint draws per rig ({per * n_cases} fast runs)")
    if args.valve != "reed":
        parts.append("the fluid references")
    return ", ".join(parts) + (" (quick: cheaper and coarser)" if args.quick else "")


def _announce(args, n_cases: int) -> None:
    """Say what the run computes and about how long it takes (the whole run measured; a part of it, less)."""
    from studies.costs import SECONDS, compile_note
    from studies.outputs import announce

    whole = not (args.valve or args.skip_reed_chain or args.no_uncertainty)
    seconds = SECONDS["validate:quick" if args.quick else "validate"]
    basis = "a measured whole run" if whole else "a measured whole run; this part takes less"
    notes = compile_note(one_dof=True) or compile_note(one_dof=False)
    announce("validate", plan_words(args, n_cases) + notes, seconds, basis=basis, always=True)


def run(args) -> dict:
    from concurrent.futures import ProcessPoolExecutor

    if args.scheduler is not None and args.workers is not None:
        raise InputError("--workers", "applies to the local cluster only; the scheduler at --scheduler has its own")
    from studies.outputs import prepare_output_dir
    from studies.validation import chain as V

    jobs = V.default_jobs() if args.jobs is None else args.jobs
    out = prepare_output_dir(args.out, "--out", args.force, kind="validate")
    _announce(args, len(V.cases(valve=args.valve)))
    # the pump cases, the reed chain (its FEA) and the plots share one pool of processes
    pool = ProcessPoolExecutor(max_workers=jobs) if jobs > 1 else None
    try:
        r = Run(args, out, pool, jobs)
        t0 = time.time()
        for i, (title, step) in enumerate(STEPS, 1):
            _log(f"step {i}/{len(STEPS)}: {title}")
            step(r)
        r.summary["wall_seconds"] = round(time.time() - t0, 1)
        return _finish(r)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)


# --------------------------------------------------------------------------- the steps
def _reed_step(quick: bool, uncertainty: bool, progress: bool) -> tuple[dict, object]:
    """The reed parameters by fidelity and (with the uncertainty) the V&V 20 table of the analytic model against
    each FEA fidelity; runs beside the pump cases (in a process of its own when there are jobs)."""
    from studies.validation import chain as V

    chain = V.reed_parameter_chain(quick=quick, progress=progress)
    reed_table = None
    if chain["rows"] and uncertainty and len(chain["rows"]) > 1:
        from geometry import load_reed
        from studies.validation.vv20 import reed_validation

        reed_table = reed_validation(load_reed("prototype"), chain["rows"], quick=quick, progress=progress)
    return chain, reed_table


def step_start_reed_chain(r: Run) -> None:
    """Start the reed parameters of the prototype reed by fidelity (beside the pump cases when there is a pool)."""
    if not r.reed_chain:
        r.state["reed"] = _Done(({"status": "skipped", "reason": "--skip-reed-chain" if r.args.skip_reed_chain else
                                  "--valve disc", "rows": [], "selected": None}, None))
        return
    r.state["reed"] = r.submit(_reed_step, r.args.quick, r.uncertainty, r.pool is None)


def step_pump_cases(r: Run) -> None:
    """The pump cases to cyclic steady state on the reference stepper, each from the fast path's cycle; their plots
    start in the pool."""
    from studies.validation import chain as V

    selected = V.cases(valve=r.args.valve)
    _log(f"  {len(selected)} pump cases ({'quick' if r.args.quick else 'full'} settings)")
    results = V.run_cases(selected, quick=r.args.quick, progress=True, workers=r.pool or r.jobs)
    plots = []
    for c, res in zip(selected, results):
        fig = V.FIGURES[(c["valve"], c["measured_valve"], c["condition"])]
        plots.append(r.submit(V.plot_case, c, res, r.out / f"fig_{fig.replace('.', '_')}_{V.case_name(c)}.png"))
    r.state.update(selected=selected, results=results, plots=plots)


def step_reed_report(r: Run) -> None:
    """The reed chain's tables (reed_parameters, reed_validation) and the one-mode reed in the pump."""
    from studies.validation import chain as V
    from studies.validation.summary import reed_parameter_rows

    chain, reed_table = r.state["reed"].result()
    r.state.update(chain=chain, reed_table=reed_table)
    if chain["status"] not in ("ok", "skipped"):
        _log(f"  {chain['reason']}: the pump uses Table 3.13 only")
    if chain["rows"]:
        if reed_table is not None:
            reed_table.write(r.out / "reed_validation")
            reed_table.plot(r.out / "reed_validation.png", relative=True)
        rows, notes = reed_parameter_rows(chain, reed_table)
        V.write_table(rows, r.out / "reed_parameters",
                      "Prototype reed parameters by fidelity, beside the thesis's FEA", notes)
    r.summary["reed_dynamics"] = _reed_dynamics(r)
    sel = chain["selected"]
    r.summary["steps"]["reed_parameters"] = {
        "status": chain["status"], "reason": chain["reason"], "fidelities": len(chain["rows"]),
        "flagged": list(chain.get("flagged", [])),
        "selected": None if sel is None else {
            "fidelity": sel.fidelity,
            **{k: finite_or_none(getattr(sel, k)) for k in ("omega_n", "kappa", "gamma1", "gamma2", "gamma3", "h_eff")}},
    }


def _reed_dynamics(r: Run) -> dict:
    """The prototype reed in the pump: eq 3.21 against N modes and the whole FE reed
    (studies.validation.reed_dynamics.prototype_adequacy), written to reed_dynamics.{md,csv}."""
    if not r.reed_chain:
        return {"status": "skipped", "reason": "--skip-reed-chain" if r.args.skip_reed_chain else "--valve disc"}
    from studies.validation import reed_dynamics as rd

    _log("  the prototype reed in the pump: eq 3.21 against 1, 2, 3, 6 modes"
         + (" (quick: no FE reed)" if r.args.quick else " and the whole FE reed (one case of Table 5.6)"))
    t0 = time.time()
    result = rd.prototype_adequacy(quick=r.args.quick, progress=True)
    rd.write_adequacy(result, r.out / "reed_dynamics")
    return {"status": "ok", "verdict": rd.adequacy_words(result), **result, "wall_seconds": round(time.time() - t0, 1)}


def step_geometry_chain(r: Run) -> None:
    """The geometry chain's reed parameters (the selected fidelity) in the reed cases: an auxiliary column of
    Table 5.6 on the fast path (within 0.1 % of the reference), five revolutions from today's start as ever."""
    from studies.validation import chain as V

    sel = r.state["chain"]["selected"]
    reed_sel = [c for c in r.state["selected"] if c["valve"] == "reed"]
    r.state["geometry"] = {}
    if sel is None or not reed_sel:
        return
    _log(f"  the {len(reed_sel)} reed cases with kappa, gammas, h_eff of the {sel.fidelity} model (fast path)")
    model = V.reed_model_from(sel)
    rs = V.run_cases(reed_sel, params_for=lambda c: model, quick=r.args.quick, trace=False, progress=True,
                     method="fast", settings=None if r.args.quick else V.LEGACY)
    r.state["geometry"] = {V.case_name(c): res for c, res in zip(reed_sel, rs)}


def step_uncertainty(r: Run) -> None:
    """The validation that can fail: every run, the calibration, the predictions, the differences, the rig tests
    and the detectable errors, with their tables and figure."""
    if not r.uncertainty:
        return
    from studies.validation.figures import plot_comparisons

    t0 = time.time()
    table, extra = _pump_uncertainty(r.args, r.state["selected"], r.state["results"])
    for name, t in extra.pop("tables").items():
        t.write(r.out / name)
    plot_comparisons(extra, table.rows, r.out / "validation.png")
    r.state.update(pump_table=table, extra=extra, t_unc=time.time() - t0)


def _pump_uncertainty(args, selected, results):
    """The procedure on the pump cases; the Monte Carlo on dask (--quick: in this process unless a cluster is named)."""
    from studies.sweeps.design.runner import Cluster
    from studies.validation.pump_vv20 import PER_SCRAMBLE, PER_SCRAMBLE_QUICK, pump_validation

    per = (PER_SCRAMBLE_QUICK if args.quick else PER_SCRAMBLE) * 8
    _log(f"  u_num (tolerance ladders), u_input ({per} joint draws per rig), u_D (paired runs), the calibration "
         "and the predictions" + (" - quick: cheaper and coarser" if args.quick else ""))
    local = args.quick and args.scheduler is None and args.workers is None
    cluster = None if local else Cluster(scheduler=args.scheduler, workers=args.workers)
    try:
        if cluster is not None:
            cluster.check_reachable()
        return pump_validation(selected, results, quick=args.quick, cluster=cluster, progress=True)
    finally:
        if cluster is not None:
            cluster.close()


def step_tables(r: Run) -> None:
    """Tables 5.4, 5.6 (with the geometry chain's column and Table 5.1's dead volume), Table 2.3 and the plots."""
    from studies.tables.pump import REED_NOTE, table_2_3
    from studies.validation import chain as V

    selected, results, geo = r.state["selected"], r.state["results"], r.state["geometry"]
    sel = r.state["chain"]["selected"]
    tables = {}
    for table, valve in (("5.4", "disc"), ("5.6", "reed")):
        pairs = [(c, res) for c, res in zip(selected, results) if c["table"] == table]
        if not pairs:
            continue
        rows = V.table_rows([c for c, _ in pairs], [res for _, res in pairs])
        for row, (c, _) in zip(rows, pairs):
            g = geo.get(V.case_name(c))
            if g is not None:
                row[f"modeled_cc_{sel.fidelity}"] = round(g.delivery_per_rev * 1e6, 5)
        notes = []
        if valve == "reed":
            _log("  reed cases again with Table 5.1's dead volume (docs/errata.md)")
            V.add_table_5_1_column([c for c, _ in pairs], rows, quick=r.args.quick, progress=True)
            notes = [REED_NOTE] + ([V.GEOMETRY_NOTE.format(fidelity=sel.fidelity)] if geo else [])
        V.write_table(rows, r.out / f"table_{table.replace('.', '_')}",
                      f"Table {table}: {valve} valve pump delivery (cc/rev)", notes)
        tables[table] = rows
    t23 = table_2_3()
    V.write_table(t23["rows"], r.out / "table_2_3", "Table 2.3: disc valve parameters", t23["notes"])
    for p in r.state["plots"]:
        p.result()
    r.state["tables"] = tables


def step_fluid(r: Run) -> None:
    """The fluid references (:mod:`studies.validation.fluid`): each fluid parameter of the disc and the reed
    valves, empirical against predicted, and Tables 5.4 and 5.6 with ``fluid = "predicted"``, written to
    fluid_validation.{md,csv}."""
    from studies.validation.fluid import fluid_validation

    kinds = (r.args.valve,) if r.args.valve in ("disc", "reed") else ("disc", "reed")
    fl = fluid_validation(r.out, quick=r.args.quick, progress=True, kinds=kinds)
    r.summary.update(fluid_validation=fl["fluid_validation"], fluid_pump=fl["fluid_pump"],
                     fluid_pump_reed=fl["fluid_pump_reed"])


def step_summary(r: Run) -> None:
    """The summary: what the data can detect first, then the chain, the tables and the verdicts (written last, with
    the wall time, as summary.md and summary.json)."""
    from studies.validation.summary import build_summary

    build_summary(r.summary, r.state)


#: the steps of a run, in order: (title printed on stderr, function of the :class:`Run`)
STEPS = (
    ("reed parameters of the prototype reed, analytic vs FEA (started beside the pump cases)", step_start_reed_chain),
    ("the pump cases of Tables 5.4 and 5.6 to cyclic steady state", step_pump_cases),
    ("the reed chain's tables and the one-mode reed in the pump", step_reed_report),
    ("the geometry chain's reed parameters in the reed pump", step_geometry_chain),
    ("the validation that can fail (ASME V&V 20: calibration, predictions, differences, power)", step_uncertainty),
    ("tables and plots", step_tables),
    ("the fluid references: disc parameters predicted from geometry, Table 5.4 with them", step_fluid),
    ("summary", step_summary),
)


def _finish(r: Run) -> dict:
    """summary.md, then summary.json with the files the folder holds (the count printed is the count written)."""
    from studies.outputs import MARKER
    from studies.validation.summary import summary_markdown

    (r.out / "summary.md").write_text(summary_markdown(r.summary))
    names = sorted({p.name for p in r.out.iterdir() if p.name != MARKER} | {"summary.json"})
    r.summary["files"] = names
    (r.out / "summary.json").write_text(json.dumps(r.summary, indent=2) + "\n")
    return r.summary


def render(s: dict) -> str:
    from studies.validation.summary import console_lines

    return "\n".join(console_lines(s))
