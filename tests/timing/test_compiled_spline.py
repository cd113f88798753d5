"""The compiled trial spline is make_path's spline: the same values and derivatives, the same refusals."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.model.robot import load_robot
from pipeline.timing.compiled_spline import trial_spline
from pipeline.timing.joint_path import DUPLICATE_DISTANCE, PathError, make_path


@pytest.fixture(scope="module")
def limits():
    return load_robot("gp7").limits


def _reference(waypoints, limits):
    try:
        return make_path(waypoints, limits.q_min, limits.q_max, "spline")
    except PathError:
        return None


@pytest.mark.parametrize("count", [2, 3, 4, 5, 9, 17])
def test_the_trial_spline_is_make_paths_spline_and_refuses_what_it_refuses(limits, count):
    rng = np.random.default_rng(count)
    s = np.linspace(0.0, 1.0, 401)
    refused = 0
    for trial in range(40):
        if trial % 2:                                   # wide jumps: many of these splines overshoot the limits
            waypoints = rng.uniform(limits.q_min, limits.q_max, size=(count, 6))
        else:
            waypoints = np.clip(np.cumsum(rng.normal(0.0, 0.3, size=(count, 6)), axis=0), limits.q_min, limits.q_max)
        ours, reference = trial_spline(waypoints, limits.q_min, limits.q_max), _reference(waypoints, limits)
        if reference is None:
            refused += 1
            assert ours is None
            continue
        if ours is None:            # exact where make_path samples: a bulge between its samples (never seen here)
            pytest.fail(f"refused a spline make_path accepts: {waypoints.tolist()}")
        assert ours.length == pytest.approx(reference.length, rel=1e-14)
        for order in (0, 1, 2):
            scale = max(1.0, float(np.abs(reference(s, order)).max()))
            np.testing.assert_allclose(ours(s, order), reference(s, order), rtol=0.0, atol=1e-11 * scale)
    assert count < 4 or refused > 0                    # the refusals were exercised


def test_duplicates_are_merged_as_make_path_merges_them(limits):
    waypoints = np.array([[0.0] * 6, [0.1] * 6, [0.1 + DUPLICATE_DISTANCE / 10] * 6, [0.3, 0.2, 0.1, 0.0, 0.1, 0.2]])
    ours, reference = trial_spline(waypoints, limits.q_min, limits.q_max), _reference(waypoints, limits)
    np.testing.assert_array_equal(ours.knots, reference.s_waypoints)
    s = np.linspace(0.0, 1.0, 50)
    np.testing.assert_allclose(ours(s), reference(s), atol=1e-12)
    assert trial_spline(np.zeros((3, 6)), limits.q_min, limits.q_max) is None


def test_a_bulge_between_make_paths_samples_is_refused(limits):
    """The limit check is exact: a spline over the limit by less than make_path's samples can see is refused."""
    q_max = limits.q_max.copy()
    waypoints = np.array([[0.0] * 6, [0.5] * 6, [0.2] * 6, [0.0] * 6])
    spline = trial_spline(waypoints, limits.q_min, q_max)
    s = np.linspace(0.0, 1.0, 100001)
    peak = float(spline(s)[:, 0].max())
    q_max[0] = peak - 1e-9                              # below the peak, above every sample but the nearest
    assert trial_spline(waypoints, limits.q_min, q_max) is None
    q_max[0] = peak + 1e-9
    assert trial_spline(waypoints, limits.q_min, q_max) is not None
