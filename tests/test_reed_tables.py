"""The chapter 3 table functions (studies/tables/reed.py): computed values beside the printed ones."""

import pytest

from studies.tables import reed as T
from studies.tables.thesis import thesis_values

TV = thesis_values()


def by(rows, key):
    return {r[key]: r for r in rows}


def test_table_3_8_every_gamma_within_0_1_percent():
    rows = T.table_3_8()["rows"]
    assert len(rows) == 5
    for r in rows:
        for i in (1, 2, 3):
            assert r[f"gamma{i}"] == pytest.approx(r[f"thesis_gamma{i}"], rel=1e-3), (r["case"], i)
    # only the rigid-tip row differs from exact E-B
    for r in rows:
        same = r["case"] != "stepped2/load"
        assert (r["gamma1"] == pytest.approx(r["exact_gamma1"], rel=1e-9)) == same


def test_table_3_9_eb_rows():
    rows = by(T.table_3_9()["rows"], "method")
    assert set(rows) == {"eb_direct", "eb_alternative"}
    for r in rows.values():
        assert r["omega"] == pytest.approx(r["thesis_omega"], rel=1e-3)
        assert r["kappa"] == pytest.approx(r["thesis_kappa"], rel=1e-3)
        assert r["gamma1"] == pytest.approx(r["thesis_gamma1"], rel=2e-3)


def test_table_3_11():
    rows = by(T.table_3_11()["rows"], "case")
    assert list(rows) == ["uniform", "stepped1", "stepped2", "prototype"]
    for case in ("uniform", "stepped1"):
        assert rows[case]["alpha_analytic"] == pytest.approx(rows[case]["thesis_alpha_analytic"], rel=1e-3)
    # eq 3.75 on the printed FEA omegas reproduces uniform and stepped #2 ...
    for case in ("uniform", "stepped2"):
        assert rows[case]["alpha_from_thesis_fea"] == pytest.approx(rows[case]["thesis_alpha_fea"], abs=6e-4)
    # ... but not stepped #1 (erratum: 1.659, printed 1.695) nor the prototype with h_eff = 1.161 mm
    assert rows["stepped1"]["alpha_from_thesis_fea"] == pytest.approx(1.659, abs=6e-4)
    assert rows["prototype"]["alpha_from_thesis_fea"] == pytest.approx(1.840, abs=6e-4)
    # a rounded tip raises alpha above the square stepped reed's; all are finite for every reed
    assert rows["stepped2"]["alpha_analytic"] > rows["stepped1"]["alpha_analytic"]


def test_table_3_12():
    rows = T.table_3_12()["rows"]
    assert [r["F4"] for r in rows] == [0.0, 0.5, 1.0]
    for r in rows:
        assert abs(r["X"] - r["thesis_X"]) < 0.002
        assert abs(r["X_exact_shape"] - r["thesis_X"]) < 0.002


def test_table_3_13_analytic_entries():
    rows = by(T.table_3_13()["rows"], "quantity")
    tol = {  # relative tolerance per entry, from the acceptance list and the printed digits
        "gamma1": 1e-3, "gamma2": 1e-3, "gamma3": 1e-3,
        "kappa stepped #1": 1e-3, "kappa stepped #2": 1e-3,
        "Gamma_f at the printed kappa_n": 1e-4, "Gamma_f": 2e-3, "kappa_n": 5e-3,
        "c_f": 0.01, "c": 0.01, "R_k": 0.005, "R_f": 1e-3, "X (Poiseuille)": 0.002 / 0.835,
        "F3": 1e-3, "face area": 1e-3, "h_eff": 1e-3, "air mass ratio": 0.03,
    }
    for q, t in tol.items():
        r = rows[q]
        assert r["value"] == pytest.approx(r["thesis_value"], rel=t), q
    assert rows["A2 (eq 3.29)"]["value"] == pytest.approx(145.5e-6, rel=1e-3)  # not the printed 338.4
    assert rows["opening where X reaches 0"]["value"] == pytest.approx(1.369e-3, rel=1e-3)
    assert all(r["unit"] and r["source"] for r in rows.values())
