"""Geometric joint paths: through the waypoints, derivatives, limit checks, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import TimingError
from pipeline.path import PathError, make_path

LO, HI = -np.ones(2) * 2.0, np.ones(2) * 2.0
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


@pytest.mark.parametrize("shape", ["spline", "linear"])
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
