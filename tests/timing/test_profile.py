"""certify(): the judge of every profile. It must catch a violation of each quantity and say where."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.robot_spec import Limits
from pipeline.timing.profile import Profile, certify, scale_limits

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
    """Joint 1 cruises through its range [-1, 1] in 1 s at its speed limit 2 rad/s, a little over."""
    t = np.linspace(0.0, 1.0, 101)
    for excess, passes in ((5e-7, True), (2e-6, False)):
        speed = 2.0 * (1 + excess)
        q, qd = np.zeros((101, 2)), np.zeros((101, 2))
        q[:, 0], qd[:, 0] = speed * (t - 0.5), speed
        report = certify(profile(q=q, qd=qd))
        assert report.passed == passes and report.max_ratio("qd") == pytest.approx(1 + excess, abs=1e-12)


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


def ramped_acceleration(step: float, start: int = 37) -> tuple[np.ndarray, ...]:
    """q, qd, qdd (101, 2) of joint 1 whose acceleration ramps from 0 to ``step`` [rad/s^2] between samples
    ``start`` and ``start + 1`` of ``profile``'s time grid (the exact integrals: the columns agree)."""
    t = np.linspace(0.0, 1.0, 101)
    h, t0 = t[1] - t[0], t[start]
    ramp = np.clip(t - t0, 0.0, h)
    after = np.maximum(t - t0 - h, 0.0)
    q, qd, qdd = np.zeros((101, 2)), np.zeros((101, 2)), np.zeros((101, 2))
    qdd[:, 0] = step * ramp / h
    qd[:, 0] = step * (ramp**2 / (2 * h) + after)
    q[:, 0] = step * (ramp**3 / (6 * h) + ramp**2 / 2 * (after > 0) + h / 2 * after + after**2 / 2)
    return q, qd, qdd


def test_columns_that_agree_pass_the_column_judge():
    q, qd, qdd = ramped_acceleration(0.5 * 0.01 * LIMITS.qddd_max[0])   # half of what the jerk limit allows
    qddd = np.zeros((101, 2))
    qddd[37, 0] = 0.5 * LIMITS.qddd_max[0]
    report = certify(profile(q=q, qd=qd, qdd=qdd, qddd=qddd))
    assert report.passed and report.columns.passed, str(report)
    assert 0.0 < report.columns.ratios["qdd/qddd"] <= 0.5 + 1e-9


def test_qdd_that_jumps_more_than_the_jerk_limit_allows_fails_though_qddd_is_within_it():
    """The fuzz finding: topp3's qdd jumped 1.97x what qddd_max x dt allows between two samples while its
    qddd column stayed within the limit; each column alone passed."""
    q, qd, qdd = ramped_acceleration(1.97 * 0.01 * LIMITS.qddd_max[0])
    report = certify(profile(q=q, qd=qd, qdd=qdd))
    assert report.max_ratio("qddd") == 0.0 and report.worst_ratio <= 1.0    # every column alone passes
    assert not report.passed and not report.columns.passed
    columns = report.columns
    assert (columns.pair, columns.test, columns.joint, columns.sample) == ("qdd/qddd", "mean value", 0, 37)
    assert columns.time == pytest.approx(0.37) and columns.ratio == pytest.approx(1.97, rel=1e-9)
    assert "columns disagree: worst qdd/qddd (mean value) of joint 1 between samples 37 and 38" in str(report)
    assert report.to_dict()["columns"]["worst"] == {
        "pair": "qdd/qddd", "test": "mean value", "joint": 1, "sample": 37, "t_s": columns.time,
        "ratio": columns.ratio, "change": columns.change, "allowed": columns.allowed}


@pytest.mark.parametrize("low, high", [("q", "qd"), ("qd", "qdd")])
def test_a_derivative_column_that_does_not_integrate_to_its_column_fails(low, high):
    """Joint 1 swings as 0.5 sin(2 t) (every limit at most half used); one column 1.5x its true value."""
    t = np.linspace(0.0, 1.0, 101)
    arrays = {name: np.zeros((101, 2)) for name in ("q", "qd", "qdd", "qddd")}
    for order, name in enumerate(("q", "qd", "qdd", "qddd")):
        arrays[name][:, 0] = 0.5 * 2.0**order * np.sin(2.0 * t + order * np.pi / 2)
    assert certify(profile(**arrays)).passed
    arrays[high] = arrays[high] * 1.5
    report = certify(profile(**arrays))
    assert report.worst_ratio <= 1.0 and not report.passed and not report.columns.passed
    assert report.columns.pair == f"{low}/{high}" and report.columns.test == "trapezoid"
