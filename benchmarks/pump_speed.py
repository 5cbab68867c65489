"""CPU seconds per simulated second of pumping, per valve type (thesis section 5.6: 23 s).

Run on demand: ``python benchmarks/pump_speed.py``; prints one JSON object. Each valve
type runs its three thesis conditions (inlet-measured cases of Tables 5.4 and 5.6) for
five revolutions on the reference stepper (scipy Radau) at its default tolerances.
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lumped.run.simulate import simulate  # noqa: E402
from studies.validation.chain import cases  # noqa: E402


def main() -> dict:
    out = {"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
           "thesis_cpu_per_simulated_second": 23.0, "valves": {}}
    for valve in ("disc", "reed"):
        cpu = sim = 0.0
        runs = []
        for c in cases(valve=valve):
            if c["measured_valve"] != "inlet":
                continue
            r = simulate(f"thesis-{valve}", c["speed_rpm"], c["load_pressure"], air_content=c["air_content"],
                         revolutions=5, method="reference")
            cpu += r.cpu_seconds
            sim += r.simulated_seconds
            runs.append({"condition": c["condition"], "cpu_seconds": r.cpu_seconds,
                         "simulated_seconds": r.simulated_seconds, "rhs_evaluations": r.rhs_evaluations,
                         "cpu_per_simulated_second": r.cpu_per_simulated_second})
        out["valves"][valve] = {"cpu_per_simulated_second": cpu / sim, "runs": runs}
    return out


if __name__ == "__main__":
    print(json.dumps(main(), indent=2))
