"""Chapter 3 reed tables (3.8, 3.9, 3.11, 3.12, 3.13) from the analytic models, beside the printed values.

Each table is a plain function returning row dicts (or {"rows", "notes"}), registered in
``studies/cli/table.py``; thesis values sit in ``thesis_<field>`` (studies/data/thesis_values.toml,
never used as inputs except where a row says it reproduces the thesis's own arithmetic).
"""

from __future__ import annotations

from functools import cache

from geometry import THESIS_PRESETS, load_reed
from lumped.reed import euler_bernoulli as rb
from lumped.reed import fluid as rf
from lumped.reed.mode_function import gamma1_alternative

from studies.tables.thesis import thesis_values

REEDS = THESIS_PRESETS      # Table 3.1's reeds


@cache
def _reed(name: str):
    return load_reed(name)


def _valve():
    """The prototype reed valve (the inlet of lumped/data/models/thesis-reed.toml, Table 3.13)."""
    from lumped.model.model_file import load_model

    return load_model("thesis-reed").inlet


# -- Table 3.8 ----------------------------------------------------------------------------

#: case -> (reed, shape used by the thesis); the stepped #2 shape is the rigid-tip approximation
_CASES_3_8 = {
    "uniform/free": ("uniform", "free"),
    "uniform/load": ("uniform", "load"),
    "stepped1/free": ("stepped1", "free"),
    "stepped1/load": ("stepped1", "load"),
    "stepped2/load": ("stepped2", "three_section"),
}


def table_3_8() -> dict:
    """The mode-function parameters gamma1..3 of the uniform and stepped reeds, in free vibration and under load.

    Returns
    -------
    dict
        ``rows``: per case gamma1..3 [-] by the thesis's method (Table 3.4's integrals; eqs
        3.42-3.45 for stepped #2's rigid tip) beside Table 3.8's, and by exact Euler-Bernoulli;
        ``notes``.

    References
    ----------
    Knutson (2016), Tables 3.4 and 3.8, eqs 3.42-3.45.
    """
    tv = thesis_values()["table_3_8"]
    rows = []
    for case, (name, kind) in _CASES_3_8.items():
        reed = _reed(name)
        g = rb.shape_mode_parameters(reed, kind)
        exact = rb.shape_mode_parameters(reed, "free" if kind == "free" else "load")
        row = {"case": case,
               "method": {"free": "E-B free vibration (exact)", "load": "E-B uniform load (exact)",
                          "three_section": "eqs 3.42-3.45 (rigid tip)"}[kind]}
        for i in range(3):
            row[f"gamma{i + 1}"] = g[i]
            row[f"thesis_gamma{i + 1}"] = tv[case][f"gamma{i + 1}"]
        for i in range(3):
            row[f"exact_gamma{i + 1}"] = exact[i]
        rows.append(row)
    notes = [
        "gamma1..3 by the thesis's method; exact_gamma1..3 from exact E-B on the real profile "
        "(they differ only for stepped #2, whose rounded tip the thesis takes as rigid).",
        "eq 3.44 is used with L2 theta1 where the thesis prints (s - L1) theta1 (docs/errata.md).",
    ]
    return {"rows": rows, "notes": notes}


# -- Table 3.9 ----------------------------------------------------------------------------


def table_3_9() -> dict:
    """The first mode-function parameter of stepped reed #1: direct integration against eq 3.48.

    Returns
    -------
    dict
        ``rows``: omega_n [rad/s] (the stepped-beam determinant, Naguleswaran 2002), kappa [Pa/m]
        (eq 3.40) and gamma1 [-] by each method, beside Table 3.9's; ``notes``.

    References
    ----------
    Knutson (2016), eqs 3.40, 3.48 and Table 3.9; Naguleswaran (2002), J. Sound Vib. 252, 751-767.
    """
    tv = thesis_values()["table_3_9"]
    reed = _reed("stepped1")
    m = reed.material
    omega = rb.natural_frequency(reed)  # Naguleswaran determinant
    kappa = rb.stiffness_eq_3_40(m.youngs_modulus, reed.thickness, reed.width_root, reed.width_tip,
                                 reed.step_location, reed.length - reed.step_location)
    g_direct = rb.shape_mode_parameters(reed, "load")[0]
    # eq 3.48 with the nominal thickness: the reed has no grooves
    g_alt = gamma1_alternative(m.density, reed.thickness, omega, kappa)
    rows = []
    for method, g in (("eb_direct", g_direct), ("eb_alternative", g_alt)):
        rows.append({"method": method, "omega": omega, "kappa": kappa, "gamma1": g,
                     "thesis_omega": tv[method]["omega"], "thesis_kappa": tv[method]["kappa"],
                     "thesis_gamma1": tv[method]["gamma1"]})
    notes = ["omega: exact stepped-beam determinant (Naguleswaran 2002); kappa: eq 3.40; "
             "eb_direct integrates the uniform-load shape (Table 3.4), eb_alternative is eq 3.48 "
             "with h_eff = h = 1.35 mm."]
    return {"rows": rows, "notes": notes}


# -- Table 3.11 ---------------------------------------------------------------------------


def table_3_11() -> dict:
    """The natural frequency parameter alpha of the four reeds.

    Returns
    -------
    dict
        ``rows``: per reed omega_n [rad/s] by exact Euler-Bernoulli and alpha [-] by eq 3.75 from it
        and from the thesis's FEA omega, beside Table 3.11's; ``notes``.

    References
    ----------
    Knutson (2016), eq 3.75 and Table 3.11.
    """
    tv = thesis_values()["table_3_11"]
    h_eff_valve = _valve().effective_thickness
    rows = []
    for name in REEDS:
        reed = _reed(name)
        m = reed.material
        props = rb.reed_properties(reed)
        # eq 3.75 uses the nominal h for solid reeds and h_eff for the grooved one (as the thesis)
        h_an = props.h_eff if reed.grooves else reed.thickness
        h_fea = h_eff_valve if reed.grooves else reed.thickness
        alpha = rb.frequency_parameter_from_omega(props.omega_n, h_an, reed.length,
                                                  m.youngs_modulus, m.density)
        t = tv[name]
        rows.append({
            "case": name,
            "omega_analytic": props.omega_n,
            "alpha_analytic": alpha,
            "thesis_alpha_analytic": t.get("alpha_analytic"),
            "thesis_omega_fea": t["omega_fea"],
            "alpha_from_thesis_fea": rb.frequency_parameter_from_omega(
                t["omega_fea"], h_fea, reed.length, m.youngs_modulus, m.density),
            "thesis_alpha_fea": t["alpha_fea"],
        })
    notes = [
        "alpha_analytic: exact E-B omega_n through eq 3.75 (h = 1.35 mm; the prototype uses its "
        "analytic h_eff by eq 3.62); for uniform and stepped #1 it is the determinant's root.",
        "alpha_from_thesis_fea: eq 3.75 applied to the printed FEA omegas (prototype: h_eff = 1.161 mm). "
        "Stepped #1 gives 1.659, not the printed 1.695; the prototype's printed 1.845 needs "
        "h_eff = 1.155 mm (docs/errata.md).",
    ]
    return {"rows": rows, "notes": notes}


# -- Table 3.12 ---------------------------------------------------------------------------


def table_3_12() -> dict:
    """The Poiseuille-regime pressure load multiplier X against the base pressure fraction F4.

    Returns
    -------
    dict
        ``rows``: per F4 [-] X [-] by eq 3.60 on the rigid-tip shape (as the thesis) and on the exact
        load shape, beside Table 3.12's; ``notes`` (the reconstructed sealing sections, Figure 3.14).

    References
    ----------
    Knutson (2016), eqs 3.59-3.60, Figure 3.14 and Table 3.12.
    """
    tv = thesis_values()["table_3_12"]
    reed = _reed("stepped2")  # the prototype's outline; the thesis uses stepped #2's load shape
    approx = lambda s: rb.three_section_shape(reed, s)  # noqa: E731
    exact = lambda s: rb.shape(reed, "load", s)[1]  # noqa: E731
    lay = rf.SealingLayout.thesis()
    rows = []
    for F4, X_t in zip(tv["F4"], tv["X"]):
        rows.append({"F4": F4, "X": rf.poiseuille_multiplier(reed, approx, F4, lay), "thesis_X": X_t,
                     "X_exact_shape": rf.poiseuille_multiplier(reed, exact, F4, lay)})
    F3 = rf.annulus_pressure_fraction(reed.tip_radius - lay.land_width, reed.tip_radius)
    notes = [
        f"sections (Figure 3.14, reconstructed): sealing land {lay.land_width * 1e3:.4g} mm along the sides "
        f"(F2 = 0.5) and around the tip (F3 = {F3:.4f}, thesis {tv['F3']}), base = full width for "
        f"s < {lay.base_length * 1e3:.3g} mm (F4), the rest F1 = 1 (lumped/data/reed_fluid.toml).",
        "X uses the rigid-tip shape of eqs 3.42-3.45 as the thesis; X_exact_shape the exact E-B load shape.",
    ]
    return {"rows": rows, "notes": notes}


# -- Table 3.13 ---------------------------------------------------------------------------


def _row(quantity, value, thesis_value, unit, source):
    return {"quantity": quantity, "value": float(value),
            "thesis_value": None if thesis_value is None else float(thesis_value),
            "unit": unit, "source": source}


def _mode_rows(s2, tv8) -> list:
    """gamma1..3 of stepped #2 under load (rigid tip), as the thesis uses for the prototype (Table 3.4)."""
    bm = rb.BeamModel.of(s2)
    g = rb.mode_integrals(bm.quad, rb.three_section_shape(s2, bm.quad.s), bm.W, s2.width_tip)
    return [_row(key, g[i], tv8[key], "1", "Table 3.4 on stepped #2's load shape (eqs 3.42-3.45)")
            for i, key in enumerate(("gamma1", "gamma2", "gamma3"))]


def _stiffness_rows(tv) -> list:
    """kappa of stepped #1 (eq 3.40), stepped #2 (three sections; exact E-B), the prototype and its h_eff."""
    s1, s2, proto = _reed("stepped1"), _reed("stepped2"), _reed("prototype")
    kap40 = rb.stiffness_eq_3_40(proto.material.youngs_modulus, s1.thickness, s1.width_root, s1.width_tip,
                                 s1.step_location, s1.length - s1.step_location)
    pp = rb.reed_properties(proto)
    return [
        _row("kappa stepped #1", kap40, tv["kappa_eq_3_40_stepped1"], "Pa/m", "eq 3.40"),
        _row("kappa stepped #2", rb.three_section_stiffness(s2), tv["kappa_three_section_stepped2"], "Pa/m",
             "three-section method, Table 3.6, eqs 3.37-3.39"),
        _row("kappa stepped #2 (exact E-B)", rb.exact_stiffness(s2), None, "Pa/m",
             f"exact E-B, flexible tip (thesis FEA {tv['kappa_fea_stepped2'] / 1e6:.4g} MPa/m)"),
        _row("kappa prototype (exact E-B)", pp.kappa, None, "Pa/m",
             f"exact E-B, grooves as reduced sections (thesis FEA {tv['kappa_fea'] / 1e6:.4g} MPa/m)"),
        _row("h_eff", pp.h_eff, tv["h_eff"], "m",
             "eq 3.62 with exact E-B prototype gamma1, kappa, omega_n (thesis: FEA kappa, omega)"),
    ]


def _added_mass_rows(tv, omega_fea: float, gamma3: float) -> list:
    """kappa_n (eq 3.14), Gamma_f (eq 3.13), from the thesis's FEA omega and from exact E-B; the air's mass ratio."""
    proto, valve = _reed("prototype"), _valve()
    E, rho_c, A = proto.material.youngs_modulus, proto.material.density, proto.face_area
    alpha_fea = rb.frequency_parameter_from_omega(omega_fea, valve.effective_thickness, proto.length, E, rho_c)
    kn_fea = rf.normalised_mode_number_area(alpha_fea, A, proto.length)
    pp = rb.reed_properties(proto)
    kn_an = rf.normalised_mode_number_area(
        rb.frequency_parameter_from_omega(pp.omega_n, pp.h_eff, proto.length, E, rho_c), A, proto.length)
    rho_air = rf.fluid_data()["air"]["density"]
    mass_ratio = rf.added_to_reed_mass_ratio(gamma3, rho_air, proto.width_tip, rf.hydrodynamic_function(kn_fea),
                                             rho_c, proto.thickness)
    return [
        _row("kappa_n", kn_fea, tv["kappa_n"], "1",
             "eq 3.14, alpha by eq 3.75 from the thesis's FEA omega 2523 rad/s, h_eff 1.161 mm"),
        _row("Gamma_f", rf.hydrodynamic_function(kn_fea), tv["Gamma_f"], "1", "eq 3.13 at that kappa_n"),
        _row("Gamma_f at the printed kappa_n", rf.hydrodynamic_function(tv["kappa_n"]), tv["Gamma_f"], "1",
             "eq 3.13 at kappa_n = 0.9677 (checks the Pade approximant)"),
        _row("kappa_n (exact E-B)", kn_an, None, "1", "eq 3.14 with the exact E-B alpha of the prototype"),
        _row("Gamma_f (exact E-B)", rf.hydrodynamic_function(kn_an), None, "1", "eq 3.13"),
        _row("air mass ratio", mass_ratio, tv["air_mass_ratio"], "1",
             f"eq 3.76, rho_air = {rho_air} kg/m^3 (not in the thesis)"),
    ]


def _damping_rows(tv) -> list:
    """R_k (eq 3.79), R_f, c_f (eq 3.80) and c (eq 3.81), omega_n of the prototype from the valve (eq 3.72)."""
    s2, proto, valve = _reed("stepped2"), _reed("prototype"), _valve()
    rho_oil, mu = rf.oil_properties()
    bm = rb.BeamModel.of(s2)
    psi = rb.three_section_shape(s2, bm.quad.s)
    omega = (valve.gamma1 * valve.stiffness / (valve.density * valve.effective_thickness)) ** 0.5
    c_f = rf.fluid_damping(bm.quad.s, psi, bm.W, mu, weights=bm.quad.weights)
    return [
        _row("R_k", rf.kinetic_reynolds(rho_oil, omega, proto.width_tip, mu), tv["R_k"], "1",
             f"eq 3.79, W2, omega_n = {omega:.0f} rad/s by eq 3.72 (thesis: measured 2786 rad/s)"),
        _row("R_f", rf.damping_per_length(mu), tv["R_f"], "Pa s",
             f"(c_v/mu) mu, c_v/mu = 500 (Naik et al. 2003), mu = {mu:.4g} Pa s"),
        _row("c_f", c_f, tv["c_f"], "Pa s/m", "eq 3.80 on stepped #2's load shape (Table 3.13 swaps c, c_f)"),
        _row("c", valve.internal_damping + c_f, tv["c"], "Pa s/m", "eq 3.81, c_c = 77.50 Pa s/m (Table 3.10)"),
    ]


def _flow_rows(tv, F3_thesis: float) -> list:
    """A2 (eq 3.29) and the face area, X (eq 3.60), F3 (eq 3.59), the opening where X reaches 0 (eq 3.83)."""
    s2, proto, valve = _reed("stepped2"), _reed("prototype"), _valve()
    bm = rb.BeamModel.of(s2)
    psi = rb.three_section_shape(s2, bm.quad.s)
    lay = rf.SealingLayout.thesis()
    X = rf.poiseuille_multiplier(s2, lambda s: rb.three_section_shape(s2, s),
                                 rf.fluid_data()["sealing"]["base_fraction"], lay)
    return [
        _row("A2 (eq 3.29)", rf.fluid_displacement_area(bm.quad.s, psi, bm.W, weights=bm.quad.weights), tv["A2"],
             "m^2", "int W psi ds on stepped #2's load shape; the printed 338.4 mm^2 is the face area"),
        _row("face area", proto.face_area, tv["A2"], "m^2", "W1 L1 + W2 (L - L1) - (2 - pi/2) R^2 (Table 3.5)"),
        _row("X (Poiseuille)", X, valve.multiplier_poiseuille, "1",
             "eq 3.60, F4 = 0.5, reconstructed sections (Table 3.12)"),
        _row("F3", rf.annulus_pressure_fraction(proto.tip_radius - lay.land_width, proto.tip_radius), F3_thesis, "1",
             "eq 3.59, R_i = 6.35 mm, R_o = 7.94 mm"),
        _row("opening where X reaches 0", rf.PressureMultiplierFit.thesis().closing_opening, None, "m",
             "numerator root of eq 3.83 (the text: about 1.4 mm)"),
    ]


def table_3_13() -> dict:
    """The analytically computable entries of the prototype reed valve's parameter table (Table 3.13).

    Returns
    -------
    dict
        ``rows``: one per quantity, its ``value`` (SI), ``thesis_value``, ``unit`` and ``source``
        (the equation); ``notes``.

    References
    ----------
    Knutson (2016), Table 3.13 and the equations each row names (section 3.4).
    """
    tv = thesis_values()["table_3_13"]
    mode_rows = _mode_rows(_reed("stepped2"), thesis_values()["table_3_8"]["stepped2/load"])
    rows = (mode_rows + _stiffness_rows(tv)
            + _added_mass_rows(tv, thesis_values()["table_3_11"]["prototype"]["omega_fea"], mode_rows[2]["value"])
            + _damping_rows(tv) + _flow_rows(tv, thesis_values()["table_3_12"]["F3"]))
    notes = ["value: computed by valvelab; thesis_value: printed (Table 3.13 or the text)."]
    return {"rows": rows, "notes": notes}
