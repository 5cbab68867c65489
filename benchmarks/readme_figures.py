"""Write the README's measured figures from the benchmarks' JSON (never pasted by hand).

Each ``benchmarks/results_<name>.json`` is the stdout of ``python benchmarks/bench_<name>.py``
saved on the project machine (``python benchmarks/bench_pump.py > benchmarks/results_pump.json``).
This script renders them as the table between the markers ``<!-- figures:begin -->`` and
``<!-- figures:end -->`` of README.md; ``--check`` only compares (exit 1 when the README is
stale), which the test suite runs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
README = HERE.parent / "README.md"
BEGIN, END = "<!-- figures:begin -->", "<!-- figures:end -->"


def _pump(d: dict) -> list[str]:
    rows = []
    for valve, v in d["valves"].items():
        rows.append(f"| pump, {valve} valves, fast path (`bench_pump.py`) | "
                    f"{v['fast_cpu_per_simulated_second_median'] * 1e3:.1f} ms CPU per simulated second "
                    f"(thesis {d['thesis_cpu_per_simulated_second']:.0f} s: {d['thesis_cpu_per_simulated_second'] / v['fast_cpu_per_simulated_second_median']:.0f}x); "
                    f"{v['speedup_median']:.0f}x the reference path; {v['fast_steps_per_revolution_median']:.0f} steps "
                    f"per revolution at {v['fast_microseconds_per_step_median']:.2f} us; worst delivery difference "
                    f"{abs(v['worst_delivery_relative_difference']) * 100:.3f} %, angles {v['worst_angle_difference_deg']:.3f} deg |")
    return rows


def _sweep(d: dict) -> list[str]:
    steady = (f", {d['revolutions_mean']:.2f} revolutions per design until cyclic steady state"
              if "revolutions_mean" in d else "")
    target = d.get("target_designs_per_hour")
    if target:
        steady += f"; target {target:,.0f}: {'met' if d.get('meets_target') else 'not met'}"
    return [f"| sweep, {d['designs']} designs on {d['workers']} workers (`bench_sweep.py`) | "
            f"{d['designs_per_hour']:,.0f} designs per hour ({d['wall_seconds']:.1f} s wall, cluster start included"
            f"{steady}); {d.get('failed', 0)} failed |"]


def _fea(d: dict) -> list[str]:
    dofs = [r["dofs"] for r in d["reeds"].values()]
    return [f"| Table 3.3, 3-D solid FEA of the four thesis reeds (`bench_fea.py`) | {d['seconds']:.1f} s "
            f"({min(dofs):,}-{max(dofs):,} DOFs per reed), peak memory {d['peak_rss_mb']:.0f} MB |"]


def _load(d: dict) -> str:
    """The load average the datasets ran at (a range), else the load before the benchmark."""
    lo_hi = d.get("load_average_datasets")
    return f"{lo_hi[0]:.1f}-{lo_hi[1]:.1f}" if lo_hi else f"{d['load_average_before'][0]:.1f}"


def _discrepancy(d: dict) -> list[str]:
    s = d["summary"]
    sc = d.get("scaling") or []
    grow = (f"; {sc[0]['runs']} to {sc[-1]['runs']} runs: {sc[0]['workflow_seconds']:.1f} to "
            f"{sc[-1]['workflow_seconds']:.1f} s" if len(sc) > 1 else "")
    return [f"| discrepancy workflow per six-run dataset of the confusion study, {s['datasets']} datasets "
            f"(`bench_discrepancy.py`) | median {s['median_seconds']:.1f} s, at most {s['max_seconds']:.1f} s wall on "
            f"{d['workers']} worker{'s' if d['workers'] != 1 else ''} (targets 10 and 45 s; load average {_load(d)}); "
            f"{s['median_cpu_seconds']:.1f} s CPU median, {s['median_simulations']:.0f} simulations{grow} |"]


def _reed_dynamics(d: dict) -> list[str]:
    s = d["summary"]
    modal = ", ".join(f"{k.removeprefix('modal')} modes {v['median_ratio_to_one_mode']:.2f}x"
                      for k, v in s.items() if k.startswith("modal") and k != "modal1")
    return [f"| modal reed valve, fast path (`bench_reed_dynamics.py`) | CPU per simulated second against eq 3.21's "
            f"one mode ({s['one-mode']['median_cpu_ms_per_simulated_s']:.1f} ms), median of the six Table 5.6 cases: "
            f"{modal} (three modes worst {s['modal3']['worst_ratio_to_one_mode']:.2f}x; load average "
            f"{d['load_average_before'][0]:.1f}) |"]


def _generic(name: str, d: dict) -> list[str]:
    keys = [k for k in ("designs_per_hour", "wall_seconds", "seconds", "evaluations") if k in d]
    if not keys:
        return []
    text = "; ".join(f"{k.replace('_', ' ')} {d[k]:,.4g}" for k in keys)
    return [f"| {name} (`bench_{name}.py`) | {text} |"]


def _validation(d: dict) -> list[str]:
    full, quick = d["validate_full"], d["validate_quick"]
    det = "; ".join(f"{rig} {v['rig']:.1f} % for the predicted runs together, {v['case']:.1f} % for one run "
                    f"({v['uncalibrated_rig']:.1f} % and {v['uncalibrated_case']:.1f} % without the calibration)"
                    for rig, v in full["detectable_error_pct"].items())
    cal = ", ".join(f"{e['rig']} {e['value']:.4f} +- {e['u']:.4f} (prior {e['prior']:.3f})"
                    for e in full["calibration"] if e.get("u") is not None)
    preds = full["predictions"]
    bad = [p for p in preds if p[3] != "within"]
    verdicts = f"{len(preds) - len(bad)} of {len(preds)} predicted runs within U_val" + (
        " (" + ", ".join(f"{p[0]} E {p[1]:+.2f} % against U_val {p[2]:.2f} %" + (", the suspect run" if p[4] else "")
                         for p in bad) + ")" if bad else "")
    return [f"| the main job, `valvelab validate` (`bench_validation.py`) | smallest model-form error in delivery "
            f"detected with 80 % probability: {det}; air content calibrated on each rig's baseline runs: {cal}; the "
            f"reed's f1, f2 tuned to these runs by the thesis; {verdicts}; one run's repeatability "
            f"{full['repeatability_pct']:.2f} % ({full['repeatability_dof']} dof); {full['wall_seconds']:.0f} s wall "
            f"({quick['wall_seconds']:.0f} s with `--quick`; load average {full['load_average_before_after'][0]:.1f}) |"]


def _coverage(d: dict) -> list[str]:
    cov = d["coverage"]
    held = d["power"]["held_out"]["detected"]
    at = {k: next((x for x, y in zip(d["deltas_pct"], v) if y >= 0.8), None) for k, v in held.items()}
    return [f"| coverage of the validation procedure (`bench_coverage.py`) | {d['draws']:,} synthetic thesis-pump "
            f"datasets through the whole procedure: within U_val in {100 * min(cov.values()):.1f}-"
            f"{100 * max(cov.values()):.1f} % of them (nominal 95.45 %); an injected error found in 80 % of "
            f"{d['per_delta']} datasets from " + ", ".join(
                f"{x:g} %" if x is not None else f"beyond {d['deltas_pct'][-1]:g} %" for x in
                (at["rig_calibrated"], at["prediction"])) + " (the rig test, one predicted run) |"]


FORMATTERS = {"pump": _pump, "sweep": _sweep, "fea": _fea, "discrepancy": _discrepancy,
              "reed_dynamics": _reed_dynamics, "validation": _validation, "coverage": _coverage}


def render(folder: Path = HERE) -> str:
    """The Markdown table of every results_*.json in ``folder`` (sorted by name)."""
    lines = ["| benchmark | measured on the project's 2-core machine |", "| --- | --- |"]
    for path in sorted(folder.glob("results_*.json")):
        name = path.stem.removeprefix("results_")
        data = json.loads(path.read_text())
        fmt = FORMATTERS.get(name)
        lines += fmt(data) if fmt else _generic(name, data)
    return "\n".join(lines)


def updated(readme: str, table: str) -> str:
    """``readme`` with the text between the markers replaced by ``table``."""
    head, sep, rest = readme.partition(BEGIN)
    if not sep or END not in rest:
        raise SystemExit(f"README.md has no {BEGIN} ... {END} block")
    _, _, tail = rest.partition(END)
    return f"{head}{BEGIN}\n{table}\n{END}{tail}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if README.md is not up to date")
    a = ap.parse_args(argv)
    text = README.read_text()
    new = updated(text, render())
    if a.check:
        if new != text:
            print("README.md figures are stale: run python benchmarks/readme_figures.py", file=sys.stderr)
            return 1
        return 0
    README.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
