"""The fast path's a-posteriori accuracy check (lumped.run.accuracy): a result that is right, or says it is not.

The check integrates the reported revolution again from its state at TDC with the tolerances 10 (and 100) times
tighter; the answer is the first level that the next one confirms within half the limits (0.5 deg on event
angles, 0.05 % on the delivery, 1 % of the lift on peak openings), and a level that never settles carries a
``numerical_accuracy`` warning. The random-design study behind it: benchmarks/fast_accuracy_study.py and
docs/performance.md.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.errors import InputError
from lumped.model.random_designs import random_design
from lumped.run import accuracy
from lumped.run.simulate import simulate


def _angles(r):
    return [r.inlet.opening_angle, r.inlet.closing_angle, r.delivery.opening_angle, r.delivery.closing_angle]


def test_the_ball_design_the_fast_path_got_wrong_is_right_by_default():
    """Ball design 18 (649.7 rpm, 3.65 MPa): every event within 0.5 deg and the delivery within 0.05 % of the
    reference path (scipy Radau at rtol 1e-6), with and without the check (the ball's seat tolerance)."""
    speed, load, air, model = random_design(np.random.default_rng(18), "ball")
    ref = simulate(model, speed, load, air_content=air, revolutions=3, method="reference")
    for check in (True, False):
        f = simulate(model, speed, load, air_content=air, revolutions=3, accuracy_check=check)
        for a, b in zip(_angles(f), _angles(ref)):
            d = abs(a - b) % (2 * math.pi)
            assert min(d, 2 * math.pi - d) < math.radians(0.5), (check, math.degrees(a), math.degrees(b))
        assert f.delivery_per_rev == pytest.approx(ref.delivery_per_rev, rel=5e-4)
        assert "numerical_accuracy" not in [w.code for w in f.warnings]


def test_a_resolved_run_keeps_its_answer():
    """The thesis disc at 593 rpm: the tighter revolution confirms the run's (level 0, no warning); the check
    off gives the same answer and no record."""
    checked = simulate("thesis-disc", 593, 2.76e6)
    plain = simulate("thesis-disc", 593, 2.76e6, accuracy_check=False)
    assert checked.accuracy["level"] == 0 and checked.accuracy["resolved"]
    assert checked.delivery_per_rev == plain.delivery_per_rev and plain.accuracy is None
    assert checked.steps > plain.steps          # the extra revolution is counted
    assert "numerical_accuracy" not in [w.code for w in checked.warnings]


def test_an_answer_that_does_not_settle_is_flagged(monkeypatch):
    """Limits no integration can meet: every level is rejected, the tightest is reported with a
    numerical_accuracy warning giving the differences found."""
    monkeypatch.setattr(accuracy, "DELIVERY_LIMIT", 1e-15)
    r = simulate("thesis-disc", 593, 2.76e6, revolutions=2)
    assert r.accuracy["level"] == accuracy.MAX_LEVELS and not r.accuracy["resolved"]
    said = [w for w in r.warnings if w.code == "numerical_accuracy"]
    assert len(said) == 1 and "the delivery by" in said[0].message and "method='reference'" in said[0].message


def test_accuracy_check_is_a_switch():
    with pytest.raises(InputError) as exc:
        simulate("thesis-disc", 593, 2.76e6, accuracy_check="yes")
    assert exc.value.field == "accuracy_check"
