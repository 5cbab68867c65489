"""Cost of the modal reed in the pump: CPU per simulated second with N modes against one mode (eq 3.21).

    python benchmarks/bench_reed_dynamics.py [--quick] [--repeat R] [--revolutions K] [--no-fe] [--save]
    python benchmarks/bench_reed_dynamics.py --markdown benchmarks/results_reed_dynamics.json

Prints one JSON object. The thesis reed pump with the prototype reed (beam fidelity) at both
valves, on the six cases of Table 5.6 (``--quick``: the first), five revolutions each: the fast
path (compiled Rodas4P, its default tolerances for each model) with eq 3.21's one mode and the
modal reed with 1, 2, 3 and 6 modes, run in turn (interleaved, so that a change of the machine's
load hits every model alike), R times each (default 5), the minimum CPU time counted; and the
whole FE reed on the reference stepper once per case (``--no-fe`` leaves it out). Per model:
CPU ms per simulated second (median over the cases), steps per revolution, and the ratio to one
mode. The target: three modes at most twice the one-mode cost (``target_met``). ``--save`` writes
benchmarks/results_reed_dynamics.json; ``--markdown FILE`` prints a saved result as a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped import load_model, simulate, with_values  # noqa: E402
from lumped.run.simulate import ensure_compiled  # noqa: E402
from studies.validation.chain import cases as table_cases  # noqa: E402

GEOMETRY = {"valves.geometry": "prototype", "valves.fidelity": "beam"}
MODELS = {"one-mode": {}, "modal1": {"valves.dynamics": "modal", "valves.modes": 1},
          "modal2": {"valves.dynamics": "modal", "valves.modes": 2},
          "modal3": {"valves.dynamics": "modal", "valves.modes": 3},
          "modal6": {"valves.dynamics": "modal", "valves.modes": 6}}
TARGET_RATIO = 2.0


def run(quick: bool, repeat: int, revolutions: int, fe: bool) -> dict:
    t0 = time.perf_counter()
    load_before = os.getloadavg()
    compile_s = ensure_compiled()
    base = load_model("thesis-reed")
    models = {name: with_values(base, {**GEOMETRY, **keys}) for name, keys in MODELS.items()}
    cases = table_cases(valve="reed")[:1 if quick else None]
    # compile each layout's solver once, outside the timing
    for m in models.values():
        simulate(m, cases[0]["speed_rpm"], cases[0]["load_pressure"], revolutions=2)
    per_case = []
    for c in cases:
        args = (c["speed_rpm"], c["load_pressure"])
        kw = dict(air_content=c["air_content"], revolutions=revolutions)
        cpu = {name: [] for name in models}
        res = {}
        for _ in range(repeat):
            for name, m in models.items():
                r = simulate(m, *args, **kw)
                cpu[name].append(r.cpu_seconds / r.simulated_seconds)
                res[name] = r
        row = {"case": f"{c['condition']}_{c['measured_valve']}", "speed_rpm": c["speed_rpm"],
               "load_pressure_mpa": c["load_pressure"] / 1e6, "models": {}}
        for name, r in res.items():
            row["models"][name] = {"cpu_ms_per_simulated_s": round(min(cpu[name]) * 1e3, 3),
                                   "steps_per_revolution": round(r.steps / r.revolutions, 1),
                                   "delivery_cc": r.delivery_per_rev * 1e6}
        if fe:
            r = simulate(with_values(base, {**GEOMETRY, "valves.dynamics": "fe"}), *args, method="reference", **kw)
            row["models"]["fe (reference stepper)"] = {
                "cpu_ms_per_simulated_s": round(r.cpu_seconds / r.simulated_seconds * 1e3, 1),
                "steps_per_revolution": round(r.steps / r.revolutions, 1), "delivery_cc": r.delivery_per_rev * 1e6}
        one = row["models"]["one-mode"]["cpu_ms_per_simulated_s"]
        for v in row["models"].values():
            v["ratio_to_one_mode"] = round(v["cpu_ms_per_simulated_s"] / one, 3)
        per_case.append(row)
        print(f"{row['case']}: " + ", ".join(f"{k} {v['cpu_ms_per_simulated_s']:.1f} ms"
                                             for k, v in row["models"].items()), file=sys.stderr, flush=True)
    names = list(per_case[0]["models"])
    summary = {name: {"median_cpu_ms_per_simulated_s": statistics.median(r["models"][name]["cpu_ms_per_simulated_s"]
                                                                          for r in per_case),
                      "median_ratio_to_one_mode": statistics.median(r["models"][name]["ratio_to_one_mode"]
                                                                     for r in per_case),
                      "worst_ratio_to_one_mode": max(r["models"][name]["ratio_to_one_mode"] for r in per_case)}
               for name in names}
    return {"benchmark": "reed_dynamics", "machine": platform.machine(), "cpus": os.cpu_count(),
            "python": platform.python_version(), "revolutions": revolutions, "repeats": repeat,
            "compile_or_cache_load_seconds": round(compile_s, 3), "cases": per_case, "summary": summary,
            "target": f"modal3 at most {TARGET_RATIO:g}x the one-mode CPU per simulated second",
            "target_met": summary["modal3"]["worst_ratio_to_one_mode"] <= TARGET_RATIO,
            "load_average_before": [round(x, 2) for x in load_before],
            "load_average_after": [round(x, 2) for x in os.getloadavg()],
            "wall_seconds": round(time.perf_counter() - t0, 1)}


def markdown(result: dict) -> str:
    """A saved result as a Markdown table: per model the median CPU per simulated second, its ratio to one mode
    (median and worst over the cases) and the median steps per revolution; the machine's load under it."""
    lines = ["| model | CPU per simulated second [ms] (median) | ratio to one mode: median / worst | "
             "steps per revolution (median) |", "|---|---|---|---|"]
    for name, s in result["summary"].items():
        steps = statistics.median(c["models"][name]["steps_per_revolution"] for c in result["cases"])
        lines.append(f"| {name} | {s['median_cpu_ms_per_simulated_s']:.4g} | {s['median_ratio_to_one_mode']:.3g} / "
                     f"{s['worst_ratio_to_one_mode']:.3g} | {steps:.0f} |")
    lines += ["", f"{len(result['cases'])} cases of Table 5.6, {result['revolutions']} revolutions each from rest, "
                  f"the least of {result['repeats']} runs; load average before/after "
                  f"{result['load_average_before'][0]:.2f} / {result['load_average_after'][0]:.2f} on "
                  f"{result['cpus']} CPUs; target ({result['target']}) met: {result['target_met']}."]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the first case of Table 5.6 only")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each fast model per case (minimum counted)")
    ap.add_argument("--revolutions", type=int, default=5)
    ap.add_argument("--no-fe", action="store_true", help="leave out the whole FE reed (reference stepper)")
    ap.add_argument("--save", action="store_true", help="write benchmarks/results_reed_dynamics.json")
    ap.add_argument("--markdown", metavar="FILE", help="print a saved result (JSON) as a Markdown table and exit")
    a = ap.parse_args()
    if a.markdown:
        print(markdown(json.loads(Path(a.markdown).read_text())))
        return
    text = json.dumps(run(a.quick, a.repeat, a.revolutions, not a.no_fe), indent=2)
    print(text)
    if a.save:
        (Path(__file__).resolve().parent / "results_reed_dynamics.json").write_text(text + "\n")


if __name__ == "__main__":
    main()
