"""Long FEA studies (pytest -m slow): converged Table 3.3 meshes, nu = 0.3, through-thickness refinement."""

from dataclasses import replace

import pytest

from fea import solid
from fea.convergence import convergence_study, default_sizes, plot_convergence
from geometry import load_reed
from studies.thesis import thesis_values

pytestmark = pytest.mark.slow
REEDS = ("uniform", "stepped1", "stepped2", "prototype")


@pytest.mark.parametrize("name", REEDS)
def test_default_mesh_discretisation_error_below_0_3_percent(name, tmp_path):
    """Three meshes (sqrt 2 h, h, h / sqrt 2) around the default: error of the default mesh < 0.3 %."""
    study = convergence_study(load_reed(name), "solid", sizes=default_sizes(solid.DEFAULT_MESH_SIZE),
                              quantities=("omega_n", "kappa"), progress=False)
    for q, r in study["quantities"].items():
        assert r["error_pct"][1] < 0.3, (name, q, r)
    plot_convergence(study, tmp_path / "c.png")
    assert (tmp_path / "c.png").stat().st_size > 1000


@pytest.mark.parametrize("name", REEDS)
def test_nu_0_3_reproduces_the_thesis_fea(name):
    """The thesis never states nu; 0.3 reproduces its FEA omega and kappa within 0.5 %."""
    reed = load_reed(name)
    reed = replace(reed, material=replace(reed.material, poisson_ratio=0.3))
    r = solid.solve(reed)
    tv = thesis_values()
    assert r.omega_n == pytest.approx(tv["table_3_3"][name]["omega_fea"], rel=0.005)
    kappa = {"stepped1": "kappa_fea_stepped1", "stepped2": "kappa_fea_stepped2", "prototype": "kappa_fea"}
    if name in kappa:
        assert r.kappa == pytest.approx(tv["table_3_13"][kappa[name]], rel=0.005)


def test_through_thickness_refinement_is_below_0_1_percent():
    reed = load_reed("stepped2")
    a, b = solid.solve(reed, layers=1), solid.solve(reed, layers=2)
    assert a.omega_n == pytest.approx(b.omega_n, rel=1e-3)
    assert a.kappa == pytest.approx(b.kappa, rel=1e-3)
