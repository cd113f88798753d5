"""Geometric joint paths: through the waypoints, derivatives, limit checks, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import TimingError
from pipeline.model.robot import load_robot
from pipeline.timing.joint_path import (
    DUPLICATE_DISTANCE,
    MONOTONE_SLOPE_LIMIT,
    MONOTONE_TURN,
    SEPTIC,
    PathError,
    make_path,
)

LO, HI = -np.ones(2) * 2.0, np.ones(2) * 2.0
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


@pytest.mark.parametrize("shape", ["monotone", "spline", "linear"])
def test_derivatives_match_finite_differences(shape):
    path = make_path(SQUARE, LO, HI, shape)
    s = np.linspace(0.01, 0.99, 9001)
    h = 1e-6
    np.testing.assert_allclose(path(s, 1), (path(s + h) - path(s - h)) / (2 * h), atol=1e-5)
    smooth = np.all(np.abs(path(s + 1e-4, 2) - path(s - 1e-4, 2)) < 1e-3, axis=1)   # away from jumps
    fd2 = (path(s + h, 1) - path(s - h, 1)) / (2 * h)
    np.testing.assert_allclose(path(s, 2)[smooth], fd2[smooth], atol=1e-3)


def test_spline_passes_through_every_waypoint_and_ends():
    path = make_path(SQUARE, LO, HI, "spline")
    np.testing.assert_allclose(path(path.s_waypoints), SQUARE, atol=1e-12)
    assert path.s_waypoints[0] == 0.0 and path.s_waypoints[-1] == 1.0
    assert path.length == pytest.approx(3.0)


def test_linear_path_hits_the_ends_and_blends_corners_inside_the_limits():
    path = make_path(SQUARE, np.zeros(2), np.ones(2), "linear", blend=0.2)
    np.testing.assert_allclose(path(0.0), SQUARE[0], atol=1e-15)
    np.testing.assert_allclose(path(1.0), SQUARE[-1], atol=1e-15)
    q = path(np.linspace(0, 1, 10001))
    assert q.min() >= 0.0 and q.max() <= 1.0          # a box is convex: blends stay inside
    corner = path(path.s_waypoints[1])
    assert 0 < np.linalg.norm(corner - SQUARE[1]) < 0.2


def test_duplicate_waypoints_are_merged():
    path = make_path(np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1e-7]]), LO, HI)
    assert len(path.waypoints) == 2


def test_a_chain_of_tiny_steps_keeps_its_motion_and_ends_at_the_last_waypoint():
    """Each step below DUPLICATE_DISTANCE, 40 of them: compared with the last waypoint kept (not the
    previous one), the chain is not dropped whole, and the path ends exactly at the last waypoint."""
    waypoints = np.array([[0.0, 0.0]]) + np.arange(41)[:, None] * [0.4 * DUPLICATE_DISTANCE, 0.0]
    path = make_path(waypoints, LO, HI)
    np.testing.assert_array_equal(path.waypoints[-1], waypoints[-1])
    assert len(path.waypoints) == 14                 # every third step (1.2e-6 apart), the last replacing 39
    assert np.all(np.diff(path.waypoints[:, 0]) > DUPLICATE_DISTANCE)


def test_monotone_pieces_are_monotone_at_every_corner_of_their_parameters():
    """The proof in path.py: on a segment of rise 1 over length 1, dq/dt is linear in the slopes
    (alpha, beta) and turns (gamma0, gamma1), so it is >= 0 on their whole set when it is at its corners."""
    t = np.linspace(0.0, 1.0, 20001)
    derivative = np.stack([np.where(n > 0, n * t ** np.maximum(n - 1, 0), 0.0) for n in range(8)], axis=1) @ SEPTIC
    A, G = MONOTONE_SLOPE_LIMIT, MONOTONE_TURN
    for alpha, gamma0 in ((0, 0), (A, 0), (0, G)):
        for beta, gamma1 in ((0, 0), (A, 0), (0, -G)):
            ends = [0, alpha, gamma0, 0, 1, beta, gamma1, 0]
            assert (derivative @ ends).min() >= -1e-12, (alpha, beta, gamma0, gamma1)
    # and it is not: with slopes of 2 x the secant the same piece overshoots
    assert (derivative @ [0, 2, 0, 0, 1, 2, 0, 0]).min() < 0


@pytest.mark.parametrize("name", ["gp7", "irb1600", "arm5"])
def test_the_default_path_never_leaves_the_box_of_its_waypoints(name):
    robot = load_robot(name)
    rng = np.random.default_rng(7)
    for _ in range(50):
        waypoints = robot.random_configurations(rng, int(rng.integers(2, 12)), margin=0.1)
        on_limit = np.where(rng.random(waypoints.shape) < 0.5, robot.limits.q_min, robot.limits.q_max)
        waypoints = np.where(rng.random(waypoints.shape) < 0.2, on_limit, waypoints)      # some exactly on a limit
        path = make_path(waypoints, robot.limits.q_min, robot.limits.q_max)
        np.testing.assert_allclose(path(path.s_waypoints), path.waypoints, atol=1e-12)
        for k in range(len(path.waypoints) - 1):
            s = np.linspace(path.s_waypoints[k], path.s_waypoints[k + 1], 400)
            low, high = np.minimum(*path.waypoints[k:k + 2]), np.maximum(*path.waypoints[k:k + 2])
            q = path(s)
            assert np.all(q >= low) and np.all(q <= high)
            rise = np.sign(path.waypoints[k + 1] - path.waypoints[k])
            assert np.all(path(s, 1) * rise >= -1e-9 * np.abs(path(s, 1)).max())
        knots = path.s_waypoints[1:-1]
        for order in (1, 2, 3):                                  # C3 at the knots
            np.testing.assert_allclose(path(knots - 1e-9, order), path(knots + 1e-9, order), rtol=1e-4,
                                       atol=1e-4 * np.abs(path(np.linspace(0, 1, 1001), order)).max())


def test_spline_leaving_the_limits_is_rejected_naming_segment_and_joint():
    waypoints = np.array([[0.0, 0.0], [1.9, 0.5], [0.0, 1.0], [1.95, 1.5]])
    with pytest.raises(PathError, match=r"joint 1 between waypoints \d and \d") as info:
        make_path(waypoints, LO, HI, "spline")
    assert isinstance(info.value, TimingError)
    make_path(waypoints, LO, HI, "linear")             # the linear shape is always inside


@pytest.mark.parametrize("waypoints, message", [
    (np.zeros((1, 2)), "at least 2"),
    (np.zeros((3, 3)), "shape"),
    (np.array([[0.0, 0.0], [np.nan, 0.0]]), "waypoint 1"),
    (np.array([[0.0, 0.0], [0.0, 2.5]]), "waypoint 1: joint 2"),
    (np.zeros((3, 2)), "same configuration"),
])
def test_bad_waypoints_are_typed_errors_naming_the_waypoint(waypoints, message):
    with pytest.raises(PathError, match=message):
        make_path(waypoints, LO, HI)


def test_bad_shape_and_blend():
    with pytest.raises(PathError, match="shape"):
        make_path(SQUARE, LO, HI, "bezier")
    with pytest.raises(PathError, match="blend"):
        make_path(SQUARE, LO, HI, "linear", blend=0.7)
