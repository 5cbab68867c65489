"""validate's figures as a fluid-power engineer would put them in a report: legends beside the data (never over an
axes), a unit on every axis, the disc delivery valve's seat compression drawn and explained, and labels that say
only the model is drawn."""

import re

import numpy as np
import pytest


def _check(fig):
    """Every legend outside every axes' area, every axis label with a unit in brackets."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    axes = fig.get_axes()
    legends = [ax.get_legend() for ax in axes if ax.get_legend() is not None] + list(fig.legends)
    assert legends
    for leg in legends:
        box = leg.get_window_extent(renderer)
        for ax in axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), (leg, ax)
    for ax in axes:
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if label:
                assert re.search(r"\[[^\]]+\]", label), label
        assert ax.get_ylabel() and (ax.get_xlabel() or ax is not axes[-1])


def test_case_figure_shows_the_seat_compression_and_no_measured_claim():
    import matplotlib.pyplot as plt

    from studies.validation import chain as V

    case = next(c for c in V.cases(valve="disc") if c["condition"] == "high_pressure"
                and c["measured_valve"] == "delivery")
    res = V.run_case(case, quick=True, method="fast")
    fig = V.case_figure(case, res)
    _check(fig)
    labels = [t.get_text() for ax in fig.get_axes() for t in ax.get_legend().get_texts()]
    assert any("O-ring" in t and "below its seat" in t for t in labels)
    assert not any("measured in the thesis" in t for t in labels)
    assert "not available as data" in fig._suptitle.get_text()
    low = float(res.trace.delivery_position.min()) * 1e3
    assert f"{low:.2f} mm" in " ".join(labels).replace("\n", " ")
    plt.close(fig)


def test_comparison_figure_keeps_its_legend_off_the_data():
    import matplotlib.pyplot as plt

    from studies.validation import joint, procedure
    from studies.validation.figures import comparison_figure
    from tests.test_validation_procedure import _rig

    G = np.column_stack([np.full(6, 0.064), np.full(6, 0.006)])
    rig = _rig(G, S=np.full(6, 1.7), D=np.full(6, 1.68), n=512)
    part = procedure.analyse(rig, np.random.default_rng(0), procedure.Options(calibrate={"disc": ("oil.air_content",)},
                                                                               samples=2000))
    fig = comparison_figure(part, part["validation"])
    _check(fig)
    plt.close(fig)
    assert joint.COVERAGE == pytest.approx(0.9545)
