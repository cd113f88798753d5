"""certify(): the judge of every profile. It must catch a violation of each quantity and say where."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.profile import Profile, certify, scale_limits
from pipeline.robot_spec import Limits

LIMITS = Limits(q_min=np.array([-1.0, -2.0]), q_max=np.array([1.0, 0.0]), qd_max=np.array([2.0, 1.0]),
                qdd_max=np.array([4.0, 3.0]), qddd_max=np.array([50.0, 40.0]))


def profile(q=None, qd=None, qdd=None, qddd=None) -> Profile:
    t = np.linspace(0.0, 1.0, 101)
    zeros = np.zeros((101, 2))
    pick = lambda a: zeros.copy() if a is None else a
    q = pick(q)
    q[:, 1] += -1.0                       # joint 2's range is [-2, 0]: -1 is its middle
    return Profile(t, q, pick(qd), pick(qdd), pick(qddd), "test", LIMITS, ("a", "b"))


def test_a_profile_at_rest_in_the_middle_passes_with_zero_ratios():
    report = certify(profile())
    assert report.passed
    for name in ("q", "qd", "qdd", "qddd"):
        assert report.max_ratio(name) == 0.0


@pytest.mark.parametrize("quantity, joint, value, ratio", [
    ("q", 0, 1.01, 1.01), ("q", 1, 1.5, 1.5), ("qd", 1, -1.2, 1.2), ("qdd", 0, 4.4, 1.1), ("qddd", 1, 60.0, 1.5),
])
def test_each_quantity_over_its_limit_fails_and_names_the_worst_sample(quantity, joint, value, ratio):
    arrays = {name: np.zeros((101, 2)) for name in ("q", "qd", "qdd", "qddd")}
    arrays[quantity][37, joint] = value
    report = certify(profile(**arrays))
    assert not report.passed
    assert report.worst_quantity == quantity and report.worst_joint == joint
    assert report.worst_index == 37 and report.worst_time == pytest.approx(0.37)
    assert report.worst_ratio == pytest.approx(ratio)
    assert "FAIL" in str(report) and report.to_dict()["worst"]["joint"] == joint + 1


def test_tolerance_is_one_part_per_million():
    qd = np.zeros((101, 2))
    qd[5, 0] = 2.0 * (1 + 5e-7)
    assert certify(profile(qd=qd)).passed
    qd[5, 0] = 2.0 * (1 + 2e-6)
    assert not certify(profile(qd=qd)).passed


def test_jerk_is_judged_only_when_it_was_limited():
    qddd = np.full((101, 2), 1e6)
    unlimited = Limits(LIMITS.q_min, LIMITS.q_max, LIMITS.qd_max, LIMITS.qdd_max, None)
    report = certify(profile(qddd=qddd), unlimited)
    assert report.passed and "qddd" not in report.ratios


def test_speed_scale_scales_each_derivative_by_its_power():
    half = scale_limits(LIMITS, 0.5)
    np.testing.assert_allclose(half.qd_max, LIMITS.qd_max * 0.5)
    np.testing.assert_allclose(half.qdd_max, LIMITS.qdd_max * 0.25)
    np.testing.assert_allclose(half.qddd_max, LIMITS.qddd_max * 0.125)
    np.testing.assert_array_equal(half.q_min, LIMITS.q_min)
    for bad in (0.0, -0.5, 1.5, float("nan")):
        with pytest.raises(ConfigurationError):
            scale_limits(LIMITS, bad)
