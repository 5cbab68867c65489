"""What each predicted fluid displacement parameter does to Table 5.6's six deliveries.

The thesis reed pump (everything the thesis's, its tuned f1 = 0.22, f2 = 0.35) run with the f1 of the shipped
compact forms alone, their f2 alone and both, on both valves (quick reference runs, the case's air content), printed
as JSON lines [cc/rev]. About 1-2 min on two cores.

    python benchmarks/reed_displacement_deliveries.py
"""

from __future__ import annotations

import json
import sys

from fea.fluid.reed_compact import compact_forms
from fea.fluid.reed3d import prototype_valve
from lumped.model.model_file import load_model, with_values
from studies.validation.chain import case_name, cases, run_case


def main() -> list[dict]:
    forms = compact_forms(prototype_valve())["forms"]
    pred = {"f1": float(forms["f1"]), "f2": float(forms["f2"])}
    print(f"predicted f1 {pred['f1']:.4f}, f2 {pred['f2']:.4f}: six cases x four runs (1-2 min)", file=sys.stderr)
    base, out = load_model("thesis-reed"), []
    for c in cases(valve="reed"):
        row = {"case": case_name(c), "measured_cc": c["measured_delivery"] * 1e6}
        for tag, vals in (("thesis", {}), ("f1", {"f1": pred["f1"]}), ("f2", {"f2": pred["f2"]}), ("both", pred)):
            keys = {f"valves.{v}.flow.{k}": x for v in ("inlet", "delivery") for k, x in vals.items()}
            m = with_values(base, {**keys, "oil.air_content": c["air_content"]})
            row[tag] = run_case(c, params=m, quick=True, trace=False, method="reference").delivery_per_rev * 1e6
        out.append(row)
        print(json.dumps(row), flush=True)
    return out


if __name__ == "__main__":
    main()
