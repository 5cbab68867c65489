"""Write docs/performance.md and its figures from the benchmarks' JSON (never typed by hand).

Reads benchmarks/results_periodic.json, results_sweep.json, results_optimize.json and
results_validation.json (each saved by its script with ``--save``) and writes docs/performance.md
and docs/figures/{sweep,optimize,validate}_scaling.png (matplotlib, units on the axes).
``--check`` only compares the page with what the JSON gives (exit 1 when stale; the test suite
runs it).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PAGE = ROOT / "docs" / "performance.md"
FIGURES = ROOT / "docs" / "figures"


def _load(name: str) -> dict | None:
    p = HERE / f"results_{name}.json"
    return json.loads(p.read_text()) if p.is_file() else None


def _n(x, fmt="{:,.0f}") -> str:
    return "n/a" if x is None else fmt.format(x)


def _e(x) -> str:
    return "n/a" if x is None else f"{x:.1e}"


def _load_text(pair) -> str:
    return "" if not pair else f" (load average {pair[0]:g} before, {pair[-1]:g} after)"


def section_steady(d: dict | None) -> list[str]:
    out = ["## Steady state and warm starts", "",
           "Every study runs a design until the cyclic steady-state test passes (CONTRACT.md, \"Steady state and "
           "warm starts\"), not a fixed count, and starts it from the state of its solved neighbours. "
           "`python benchmarks/periodic_solver.py --save` measures why two revolutions suffice and whether a "
           "periodic solver would do better, on the 12 validation cases and random designs of every valve kind "
           "at rtol 1e-3 and 1e-4:", ""]
    if d is None:
        return out + ["(not measured yet)", ""]
    out += [f"- the revolution map contracts: the second revolution's delivery error is "
            f"{_e(d['contraction_ratio_median'])} of the first's in the median and at most "
            f"{d['contraction_ratio_max']:.2f} ({d['contraction_ratios']} runs where the first error stands above the "
            "integrator's noise), so a change below 1e-3 leaves the last revolution within 1e-4 of the cycle;",
            f"- revolutions until the test passes at {d['tol']:g} (mean, max) and the delivery's error against the "
            "cycle then (median, max):", "",
            "| way to the cycle | from today's start | error | from a near design's cycle | error |",
            "| --- | --- | --- | --- | --- |"]
    names = {"plain": "plain revolutions (the studies)", "anderson": "Anderson acceleration, memory 2",
             "newton": "Newton, forward-difference Jacobian"}
    for k, v in d["solvers"].items():
        c, w = v["cold"], v["warm"]
        out.append(f"| {names.get(k, k)} | {_n(c['revolutions_mean'], '{:.2f}')}, {_n(c['revolutions_max'], '{}')} | "
                   f"{_e(c['delivery_error_median'])}, {_e(c['delivery_error_max'])} | "
                   f"{_n(w['revolutions_mean'], '{:.2f}')}, {_n(w['revolutions_max'], '{}')} | "
                   f"{_e(w['delivery_error_median'])}, {_e(w['delivery_error_max'])} |")
    out += ["", f"Fewest revolutions from a near design: {names.get(d['fewest_revolutions_warm'])}. The map forgets "
            "its start within a revolution (a valve that reseats forgets its past), so acceleration has nothing to "
            "gain and a Jacobian costs a revolution per state; the studies use plain revolutions (load average "
            f"{d.get('load_average')} when measured).", ""]
    if d.get("predictors"):
        p = d["predictors"]
        out += [f"Warm starts on an optimiser-like population ({p['rows']} evaluations: {p['designs']} reed designs "
                f"near the prototype x {p['points']} speeds, visited in a nearest-neighbour chain): from the nearest "
                f"solved design's state {p['nearest']['revolutions_mean']:.2f} revolutions each (first revolution "
                f"{_e(p['nearest']['first_error_median'])} off in the median); from a weighted linear fit through the "
                f"nearest ones (lumped.WarmStarts.predict) {p['linear']['revolutions_mean']:.2f} "
                f"({_e(p['linear']['first_error_median'])}).", ""]
    return out


def _quantile_table(rows) -> list[str]:
    """A markdown table of (name, quantiles of |relative difference|) rows, and a blank line."""
    out = ["| | median | 90 % | 99 % | max | within 1e-4 |", "| --- | --- | --- | --- | --- | --- |"]
    out += [f"| {name} | {_e(q['median'])} | {_e(q['p90'])} | {_e(q['p99'])} | {_e(q['max'])} | "
            f"{q['within_1e-4']} of {q['count']} |" for name, q in rows]
    return out + [""]


def section_sweep(d: dict | None) -> list[str]:
    out = ["## Sweeps", "", "`python benchmarks/bench_sweep.py --save` (100,000 Sobol designs over valve type, speed "
           "450-950 rpm, load 1.5-4.5 MPa, air 0-3 %; fast path; a fresh LocalCluster of 2 workers, its start "
           "included; the same sweep with the former five revolutions from today's start; each size of the "
           "figure; 200 designs against 40-revolution runs and a sharp reference). A warm-started design stops "
           "after one revolution when its state at top dead centre is a fixed point of the revolution map "
           "(CONTRACT.md, \"One revolution from a warm start\"):", ""]
    if d is None:
        return out + ["(not measured yet)", ""]
    b = d.get("before") or {}
    out += ["| | designs | wall [s] | designs per hour | revolutions per design | CPU per design [ms] |",
            "| --- | --- | --- | --- | --- | --- |",
            f"| until steady state, warm-started | {d['designs']:,} | {d['wall_seconds']:.1f} | "
            f"{d['designs_per_hour']:,} | {d['revolutions_mean']:.3f} | {d['cpu_seconds_per_design_mean'] * 1e3:.2f} |"]
    if b:
        out.append(f"| five revolutions from today's start (before) | {b['designs']:,} | {b['wall_seconds']:.1f} | "
                   f"{b['designs_per_hour']:,} | {b['revolutions_mean']:.3f} | "
                   f"{b['cpu_seconds_per_design_mean'] * 1e3:.2f} |")
    out += ["", f"Target: {d['target_designs_per_hour']:,} designs per hour: "
            f"{'met' if d['meets_target'] else '**not met**'}"
            + (f"; {d['speedup']:.2f}x the five-revolution sweep" if d.get("speedup") else "")
            + f"{_load_text(d.get('load_average_before_after'))}. "
            f"{d['warm_started_fraction'] * 100:.1f} % of the designs started warm; "
            f"{d['failed']} failed, {d['not_cyclic']} not cyclic.", ""]
    a = d.get("accuracy")
    if a:
        rows = [("until steady state, warm-started", a["after"])]
        if a.get("before"):
            rows.append(("five revolutions (before)", a["before"]))
        rows.append(("the 40-revolution run's own spread (last ten)", a["long_run_spread_last_10"]))
        out += [f"Delivery against {a['reference']} ({a['designs_checked']} designs drawn at random), "
                "relative difference:", ""] + _quantile_table(rows)
        if a.get("after_vs_sharp"):
            rows = [("until steady state, warm-started", a["after_vs_sharp"])]
            if a.get("before_vs_sharp"):
                rows.append(("five revolutions (before)", a["before_vs_sharp"]))
            rows.append(("40 revolutions at the sweep's rtol", a["long_run_vs_sharp"]))
            out += [f"The same deliveries against a sharp reference ({a['sharp_reference']}): what differs "
                    "between the rows above is mostly the integrator's error at rtol 1e-3, which a 40-revolution "
                    "run carries as well; the stop rule adds to it what a row here shows beyond the last one:", ""]
            out += _quantile_table(rows)
    out += ["![sweep wall time against designs](figures/sweep_scaling.png)", ""]
    return out


def section_optimize(d: dict | None) -> list[str]:
    out = ["## Optimisation", "", "`python benchmarks/bench_optimize.py --save` runs `valvelab optimize "
           "docs/examples/optimize_reed.toml` as a user does (NSGA-II, 40 x 40 designs x 3 speeds, the stress "
           "calibration, the solid FEA and reference re-check of 12 front designs, the reports), then the loop "
           "alone at 5, 10 and 20 generations:", ""]
    if d is None:
        return out + ["(not measured yet)", ""]
    f, b = d.get("full"), d.get("before", {})
    if f:
        st = f.get("stage_seconds") or {}
        out += [f"- the whole run: **{f['wall_seconds']:.0f} s** (target {f['target_seconds']:.0f} s: "
                f"{'met' if f['meets_target'] else '**not met**'}){_load_text(d.get('load_average_before_after'))}; "
                f"before the steady-state stop and warm start {b.get('wall_seconds', 0):.0f} s (saved, "
                f"`benchmarks/optimize_front_before.json`, its loop {b.get('loop_wall_seconds', 0):.0f} s);",
                "- stages [s]: " + ", ".join(f"{k.replace('_', ' ')} {v:.0f}" for k, v in st.items()) + ";",
                f"- {f['evaluated_designs']} designs, {f['feasible_designs']} feasible, {f['front_size']} on the front, "
                f"{f['dominating_baseline']} dominating the prototype;"]
        fr = f["front"]
        out += [f"- the loop's front against the saved one (objectives scaled by its range): mean distance "
                f"{fr['igd_after_to_before']:.4f} from the new to the old and {fr['igd_before_to_after']:.4f} back "
                f"(tolerance {fr['tolerance']:g}, the optimiser's own test: "
                f"{'within' if fr['within_tolerance'] else '**beyond**'}); the re-checked objectives "
                f"{f['front_rechecked']['igd_after_to_before']:.4f} and {f['front_rechecked']['igd_before_to_after']:.4f}.",
                ""]
    out += ["| population x generations | evaluations | loop [s] | whole run without re-check [s] |",
            "| --- | --- | --- | --- |"]
    for r in d.get("scaling", []):
        out.append(f"| {r['population']} x {r['generations']} | {r['evaluations']:,} | {r['loop_wall_seconds']:.1f} | "
                   f"{r['wall_seconds']:.1f} |")
    out += ["", "![optimisation wall time against evaluations](figures/optimize_scaling.png)", ""]
    return out


def section_validate(d: dict | None) -> list[str]:
    out = ["## Validation", "", "`python benchmarks/bench_validation.py --before 52bf526 --save` runs `valvelab "
           "validate` as a user does, without the uncertainty (`--no-uncertainty`), with it and `--quick`, the "
           "same with the code before the steady-state stop (a temporary worktree of that commit), and compares "
           "every table cell with the ones saved in `benchmarks/validate_before/`:", ""]
    if d is None:
        return out + ["(not measured yet)", ""]
    b = d.get("before", {})
    out += ["| run | wall [s] | limit [s] | before [s] | load average | table cells compared | differing |",
            "| --- | --- | --- | --- | --- | --- | --- |"]
    for key, name in (("validate_plain", "`validate --no-uncertainty`"), ("validate_full", "`validate`"),
                      ("validate_quick", "`validate --quick`")):
        r = d.get(key)
        if not r or "wall_seconds" not in r:
            continue
        t = r.get("tables") or {}
        load = r.get("load_average_before_after")
        out.append(f"| {name} | {r['wall_seconds']:.1f} | {r['limit_seconds']:.0f} | "
                   f"{_n((b.get(key) or {}).get('wall_seconds'), '{:.1f}')} | "
                   f"{_n(None if not load else max(load), '{:.1f}')} | {_n(t.get('cells_compared'), '{}')} | "
                   f"{_n(t.get('cells_differing'), '{}')} |")
    diffs, seen = [], set()
    for key in ("validate_plain", "validate_full"):
        for x in ((d.get(key) or {}).get("tables") or {}).get("differences", []):
            k = (x.get("file"), x.get("row"), x.get("column"), x.get("before"), x.get("after"))
            if k not in seen:
                seen.add(k)
                diffs.append(x)
    if diffs:
        out += ["", "The cells that differ (the revolutions run, the new `cycle_change` column and the measured "
                "seconds are not compared):", ""]
        for x in diffs:
            out.append(f"- `{x['file']}` row {x['row']}, {x['column']}: {x['before']} -> {x['after']}")
        delivery = [x for x in diffs if "cc" in str(x.get("column", "")) or x.get("column") == "S"]
        out += ["", "No delivery of the 12 cases differs to its printed digits." if not delivery else
                f"{len(delivery)} delivery cells differ."]
        spread = (_load("periodic") or {}).get("reference_spread")
        if spread:
            lo, hi = spread["worst_peak_range_mm"]
            out.append(f"What does differ moves as much between revolutions of one cycle: a reed valve's peak opening "
                       f"(the largest opening at the reference stepper's step ends) spans {lo:.5f}-{hi:.5f} mm over "
                       f"{spread['revolutions']} of its revolutions in {spread['worst_peak_case']} (its delivery within "
                       f"{spread['delivery_spread_max_cc']:.1e} cc; `benchmarks/periodic_solver.py`), and a u_num below "
                       "1e-7 cc follows the reference delivery's ninth digit.")
    out.append("")
    if d.get("scaling"):
        out += ["| pump cases | wall [s] |", "| --- | --- |"]
        for r in d["scaling"]:
            out.append(f"| {r['cases']} (`{r['command']}`) | {r['wall_seconds']:.1f} |")
        out += ["", "![validate wall time against cases](figures/validate_scaling.png)", ""]
    return out


def section_accuracy(d: dict | None) -> list[str]:
    out = ["## The fast path's accuracy check", "",
           "`python benchmarks/fast_accuracy_study.py --designs 320 --save` draws random designs of every valve design "
           "(each kind and each ordered pair of kinds, lumped.model.random_designs over each kind's design ranges, "
           "speed 450-950 rpm, load 1.5-4.5 MPa, air 0-3 %) with every candidate effect of the effect library "
           "switched on in turn, runs each three revolutions on the reference path (scipy Radau, rtol = atol = "
           "1e-6) and on the fast path at its defaults, with its accuracy check (lumped.run.accuracy: the reported "
           "revolution integrated again from its state at TDC at 10, then 100 times tighter tolerances; the first "
           "level the next confirms within half the limits is the answer, one that never settles carries a "
           "`numerical_accuracy` warning) and without it. A miss is an opening or closing angle more than 0.5 deg "
           "or a delivery more than 0.05 % from the reference; a silent miss is one without the warning.", ""]
    if d is None:
        return out + ["(not measured yet)", ""]
    cost_cpu, cost_steps = d.get("cost_ratio_cpu"), d.get("cost_ratio_steps")
    out += ["| fast path | misses | silent misses | worst angle [deg] | worst delivery | warned |",
            "| --- | --- | --- | --- | --- | --- |",
            f"| without the check | {d['misses_without_check']} | {d['misses_without_check']} | "
            f"{d['worst_unchecked_angle_dev_deg']:.3g} | {_e(d['worst_unchecked_delivery_dev'])} | - |",
            f"| with the check (the default) | {d['misses']} | {d['silent_misses']} | {d['worst_angle_dev_deg']:.3g} | "
            f"{_e(d['worst_delivery_dev'])} | {d['warned']} |", "",
            f"{d['compared']} of {d['designs']} designs compared ({len(d.get('left_out') or [])} left out: the "
            f"reference or the fast path failed); valve designs {', '.join(d.get('valve_designs') or [])}; "
            f"effects on ({', '.join(f'{k} {v}' for k, v in (d.get('effects') or {}).items())}), none on "
            f"{d.get('bare', 0)}. Load average {max(d.get('load_average_before_after') or [0]):.1f} (2 workers).", ""]
    if cost_cpu is not None:
        out += [f"The cost: {cost_steps:.2f}x the Rosenbrock steps and {cost_cpu:.2f}x the CPU time of the same "
                "three-revolution runs without the check (one revolution at a tenth of the tolerances, two where the "
                "first is rejected); a five-revolution `valvelab pump` run pays the same revolution on five. A "
                "warm-started sweep design runs about one revolution, so the check would more than double its cost: "
                "sweeps and the design studies built on them (sensitivity, optimisation) run without it unless a "
                "sweep's `[fixed]` sets `accuracy_check = true` (their designs per hour are unchanged), and rely on "
                "each kind's tolerances, which the row without the check measures. Before the ball's seat velocity "
                "tolerance was tightened (lumped/valves/ball.py) the fast path without the check missed 13 of the "
                "same designs against the fast path at rtol 1e-6, 6 of them a ball's inlet opening 5-14 deg late.", ""]
    return out


def render() -> str:
    head = ["# Performance: how long the answers take", "",
            "Generated by `python benchmarks/performance_doc.py` from the benchmarks' JSON "
            "(`benchmarks/results_*.json`), measured on the project's 2-core machine; the load average says how "
            "busy it was. Each benchmark is one command and saves its JSON with `--save`.", ""]
    body = (section_steady(_load("periodic")) + section_sweep(_load("sweep")) + section_accuracy(_load("fast_accuracy"))
            + section_optimize(_load("optimize")) + section_validate(_load("validation")))
    return "\n".join(head + body).rstrip() + "\n"


def figures() -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGURES.mkdir(parents=True, exist_ok=True)
    out = []
    sw = _load("sweep")
    if sw and sw.get("scaling"):
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        xs = [r["designs"] for r in sw["scaling"]]
        ax.loglog(xs, [r["wall_seconds"] for r in sw["scaling"]], "o-", label="until steady state, warm-started")
        if sw.get("before"):
            ax.loglog([sw["before"]["designs"]], [sw["before"]["wall_seconds"]], "s", label="five revolutions (before)")
        ax.loglog(xs, [x / sw["target_designs_per_hour"] * 3600 for x in xs], "k--", lw=0.8,
                  label=f"target {sw['target_designs_per_hour']:,} designs/h")
        ax.set_xlabel("designs [-]")
        ax.set_ylabel("wall time [s]")
        ax.set_title("pump sweep on 2 workers (cluster start included)", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
        out.append(_save(fig, "sweep_scaling.png"))
    op = _load("optimize")
    if op and op.get("scaling"):
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        xs = [r["evaluations"] for r in op["scaling"]]
        ax.plot(xs, [r["loop_wall_seconds"] for r in op["scaling"]], "o-", label="loop (population 40)")
        if op.get("full"):
            f = op["full"]
            ax.plot([f["evaluations"]], [f["wall_seconds"]], "s", label="whole example with re-check")
            ax.plot([f["evaluations"]], [f["loop_wall_seconds"]], "^", label="its loop")
        ax.axhline(300.0, color="k", ls="--", lw=0.8, label="target 300 s")
        top = max([300.0] + [r["loop_wall_seconds"] for r in op["scaling"]] + ([op["full"]["wall_seconds"]]
                                                                              if op.get("full") else []))
        ax.set_ylim(0, 1.15 * top)
        ax.set_xlabel("pump evaluations (designs x 3 speeds) [-]")
        ax.set_ylabel("wall time [s]")
        ax.set_title("valvelab optimize, reed example, 2 workers", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        out.append(_save(fig, "optimize_scaling.png"))
    va = _load("validation")
    if va and va.get("scaling"):
        fig, ax = plt.subplots(figsize=(5.5, 3.8))
        ax.plot([r["cases"] for r in va["scaling"]], [r["wall_seconds"] for r in va["scaling"]], "o-",
                label="--no-uncertainty --skip-reed-chain")
        if va.get("validate_plain"):
            ax.plot([12], [va["validate_plain"]["wall_seconds"]], "s", label="--no-uncertainty (reed chain too)")
        ax.axhline(30.0, color="k", ls="--", lw=0.8, label="limit 30 s")
        ax.set_xlim(0, 13)
        ax.set_ylim(0, 1.2 * max([30.0] + [r["wall_seconds"] for r in va["scaling"]]))
        ax.set_xlabel("pump cases [-]")
        ax.set_ylabel("wall time [s]")
        ax.set_title("valvelab validate, process start included", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        out.append(_save(fig, "validate_scaling.png"))
    return out


def _save(fig, name: str) -> Path:
    import matplotlib.pyplot as plt

    path = FIGURES / name
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if docs/performance.md is not up to date")
    a = ap.parse_args(argv)
    text = render()
    if a.check:
        if not PAGE.is_file() or PAGE.read_text() != text:
            print("docs/performance.md is stale: run python benchmarks/performance_doc.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(text)
    figures()
    return 0


if __name__ == "__main__":
    sys.exit(main())
