"""Integrator convergence study of the pump model: delivery vs tolerance and method.

Run on demand: ``python benchmarks/pump_convergence.py [--quick]``; prints one JSON object.
For each valve type at its baseline condition (disc: 593 rpm, 2.76 MPa; reed: 595 rpm,
2.76 MPa), the delivery of the third revolution is computed with Radau and BDF over a
ladder of tolerances (atol = rtol, atol in units of each state's scale) and compared
with a tight Radau reference (rtol = 1e-10).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped.run.simulate import simulate  # noqa: E402

CASES = {"disc": (593.0, 2.76e6), "reed": (595.0, 2.76e6)}


def study(quick: bool = False) -> dict:
    ladder = [1e-4, 1e-5, 1e-6, 1e-7] if quick else [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    methods = ["Radau"] if quick else ["Radau", "BDF"]
    out = {}
    for valve, (rpm, pl) in CASES.items():
        ref = simulate(f"thesis-{valve}", rpm, pl, revolutions=3, rtol=1e-10, atol=1e-10, method="reference")
        rows = []
        for method in methods:
            for tol in ladder:
                r = simulate(f"thesis-{valve}", rpm, pl, revolutions=3, rtol=tol, atol=tol,
                             method="reference" if method == "Radau" else method)
                rows.append({
                    "method": method, "rtol": tol, "delivery_cc": r.delivery_per_rev * 1e6,
                    "rel_diff_vs_reference": (r.delivery_per_rev - ref.delivery_per_rev) / ref.delivery_per_rev,
                    "cpu_per_simulated_second": r.cpu_per_simulated_second, "rhs_evaluations": r.rhs_evaluations,
                    "mass_balance_error": r.mass_balance_error,
                })
                print(valve, method, tol, rows[-1], file=sys.stderr, flush=True)
        out[valve] = {"reference_delivery_cc": ref.delivery_per_rev * 1e6,
                      "reference_cpu_per_simulated_second": ref.cpu_per_simulated_second, "rows": rows}
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    print(json.dumps(study(ap.parse_args().quick), indent=2))
