"""Does the V&V 20 verdict mean what it says? Coverage of the validation interval on synthetic measurements.

The model itself is the truth: synthetic measured deliveries D_j = T (1 + eps_j), eps_j
normal with the known relative standard uncertainty ``u_D_rel`` (the delivery error model of
``studies.discrepancy.synth``), T the model's own delivery at the case's condition (inputs
known exactly: no u_input). For each of ``draws`` seeded draws the V&V 20 row is built as
``valvelab validate`` builds it (S from the reference stepper, u_num from the tolerance
ladder, u_D stated). With no model error the verdict should be "within" in about 95 % of
the draws (k = 2); with a hidden model error (the truth's discharge coefficient 3 % higher,
the ``discharge_scale`` effect the synthetic generator can inject, lumped/model/effect_library.py)
the verdict should be a model-form error whose interval contains the model's true error
S - T. The default u_D makes that error four u_D: 0.075 % of the delivery.

``inputs = True`` adds the case with uncertain inputs: each draw's truth has its inputs
drawn from the model's declarations (a Monte Carlo draw), S stays the nominal model and
u_input comes from :func:`studies.validation.input_uncertainty.propagate`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

#: the default measurement uncertainty of the synthetic deliveries (relative, standard)
U_D_REL = 0.00075
#: the hidden model error: discharge coefficients x this (effects.discharge_scale.scale)
BIAS_SCALE = 1.03


def coverage_study(case: dict | None = None, *, draws: int = 200, seed: int = 0, u_D_rel: float = U_D_REL,
                   bias_scale: float = BIAS_SCALE, inputs: bool = False) -> dict:
    """Fractions of ``draws`` synthetic measurements with each verdict (see the module docstring)."""
    from lumped.run.simulate import simulate
    from lumped.model.model_file import with_values
    from studies.validation.chain import LEGACY, case_name, cases, thesis_model_of
    from studies.validation.numerical import numerical_uncertainty, output_values
    from studies.validation.vv20 import vv20_row

    case = case or cases(valve="disc")[0]
    nominal = with_values(thesis_model_of(case), {"oil.air_content": case["air_content"]})
    known = replace(nominal, uncertainties=())
    run = dict(revolutions=LEGACY["revolutions"], max_revolutions=LEGACY["max_revolutions"])
    sp, lp = case["speed_rpm"], case["load_pressure"]
    ref = simulate(known, sp, lp, method="reference", **run)
    S = ref.delivery_per_rev * 1e6
    u_num = numerical_uncertainty(known, sp, lp, reported=output_values(ref), **run)["delivery_cc_per_rev"].u
    biased = simulate(with_values(known, {"effects.discharge_scale.scale": bias_scale}), sp, lp, method="reference",
                      **run).delivery_per_rev * 1e6
    rng = np.random.default_rng(seed)
    eps = rng.normal(0.0, u_D_rel, size=(2, draws))

    def rows(truth, e, u_input=0.0, dof_input=math.inf):
        out = []
        for t, x in zip(np.broadcast_to(truth, e.shape), e):
            D = t * (1.0 + x)
            out.append(vv20_row(case_name(case), "delivery_cc_per_rev", "cc/rev", S, D, u_num, u_input,
                                u_D_rel * D, dof=(math.inf, dof_input, math.inf)))
        return out

    clean = rows(S, eps[0])
    bad = rows(biased, eps[1])
    error = S - biased                                   # the model's true error, cc/rev
    contains = [r["delta_model"][0] <= error <= r["delta_model"][1] for r in bad]
    mfe = [r["verdict"] == "model_form_error" for r in bad]
    out = {
        "case": case_name(case), "draws": draws, "seed": seed, "u_D_rel": u_D_rel, "S_cc": S, "u_num_cc": u_num,
        "within_fraction": float(np.mean([r["verdict"] == "within" for r in clean])),
        "bias": {"discharge_scale": bias_scale, "truth_cc": biased, "model_error_cc": error,
                 "model_error_pct": error / biased * 100.0,
                 "model_form_error_fraction": float(np.mean(mfe)),
                 "interval_contains_error_fraction": float(np.mean(contains)),
                 "model_form_error_and_contains_fraction": float(np.mean(np.logical_and(mfe, contains)))},
        "expected_within_fraction": 0.9545,
    }
    if inputs:
        from lumped.model.uncertainty import numeric_keys, sample_values, standard_scores
        from scipy.stats import qmc

        from studies.validation.input_uncertainty import MC_ATOL, MC_RTOL, Point, propagate

        est = propagate([Point("case", nominal, sp, lp, **run)], seed=seed, outputs=("delivery_cc_per_rev",))
        e = est["case"]["delivery_cc_per_rev"]
        decls = nominal.uncertainties
        m = max(1, math.ceil(math.log2(draws)))       # a balanced Sobol block, its first `draws` points
        z = standard_scores(decls, qmc.Sobol(len(decls), scramble=True, rng=rng).random_base2(m)[:draws])
        keys = numeric_keys(known)
        truths = [simulate(with_values(known, sample_values(known, decls, zj, keys)), sp, lp, method="fast",
                           rtol=MC_RTOL, atol=MC_ATOL, **run).delivery_per_rev * 1e6 for zj in z]
        eps_in = rng.normal(0.0, u_D_rel, size=draws)
        with_in = rows(np.asarray(truths), eps_in, e.u, e.dof)
        out["uncertain_inputs"] = {"u_input_cc": e.u, "within_fraction":
                                   float(np.mean([r["verdict"] == "within" for r in with_in]))}
    return out
