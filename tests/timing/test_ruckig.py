"""Ruckig timing through retime(): rest-to-rest durations are Ruckig's own, through-waypoint
velocities, exact jerk, and bad input."""

from __future__ import annotations

import re

import numpy as np
import pytest
import ruckig

from pipeline.errors import TimingError
from pipeline.files.robot_spec import Limits
from pipeline.model.robot import load_robot
from pipeline.timing import retime
from pipeline.timing.profile import CERTIFY_TOLERANCE, certify
from pipeline.timing.ruckig_backend import SegmentSolver, segment_jerk

ROBOTS = ("gp7", "irb1600")
DURATION_TOLERANCE = 1e-9       # [s]
REST_TOLERANCE = 1e-9           # [rad/s, rad/s^2]


def waypoints_for(robot, seed: int, count: int = 4) -> np.ndarray:
    return robot.random_configurations(np.random.default_rng(seed), count, margin=0.2)


def assert_certified_at_rest(profile, waypoints):
    """Certified on q, qd, qdd and qddd; from the first to the last waypoint; at rest at both ends."""
    report = certify(profile)
    assert report.passed, str(report)
    assert set(report.ratios) == {"q", "qd", "qdd", "qddd"}
    for name in report.ratios:
        assert report.max_ratio(name) <= 1 + CERTIFY_TOLERANCE, name
    np.testing.assert_allclose(profile.q[[0, -1]], waypoints[[0, -1]], rtol=0, atol=1e-12)
    for values in (profile.qd, profile.qdd):
        np.testing.assert_allclose(values[[0, -1]], 0.0, rtol=0, atol=REST_TOLERANCE)
    assert np.all(np.diff(profile.t) > 0)


def ruckig_own_duration(limits: Limits, start, target, target_velocity=None) -> float:
    """The duration Ruckig itself computes for one segment from rest, called directly."""
    dof = len(start)
    inp = ruckig.InputParameter(dof)
    inp.current_position, inp.target_position = list(start), list(target)
    inp.current_velocity = inp.current_acceleration = inp.target_acceleration = [0.0] * dof
    inp.target_velocity = [0.0] * dof if target_velocity is None else list(target_velocity)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = (list(x) for x in (limits.qd_max, limits.qdd_max,
                                                                                   limits.qddd_max))
    trajectory = ruckig.Trajectory(dof)
    assert ruckig.Ruckig(dof).calculate(inp, trajectory) == ruckig.Result.Working
    return trajectory.duration


def segment_ends(profile) -> np.ndarray:
    """Sample indices of the segment ends (the profile samples every one of them)."""
    ends = np.cumsum(profile.details.segment_durations_s)
    return np.searchsorted(profile.t, ends - 1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_rest_to_rest_durations_are_ruckigs_own(name):
    robot = load_robot(name)
    waypoints = waypoints_for(robot, 1, count=5)
    profile = retime(robot, waypoints, method="ruckig")
    assert_certified_at_rest(profile, waypoints)
    own = [ruckig_own_duration(robot.limits, a, b) for a, b in zip(waypoints[:-1], waypoints[1:])]
    np.testing.assert_allclose(profile.details.segment_durations_s, own, rtol=0, atol=DURATION_TOLERANCE)
    assert abs(profile.duration - sum(own)) <= DURATION_TOLERANCE
    ends = segment_ends(profile)
    np.testing.assert_allclose(profile.q[ends], waypoints[1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(profile.qd[ends], 0.0, rtol=0, atol=REST_TOLERANCE)
    assert np.diff(profile.t).max() <= 0.004 + 1e-12
    assert profile.details.rest_at_waypoints and profile.details.jerk_exact


@pytest.mark.parametrize("name", ROBOTS)
def test_through_waypoints_with_toppra_velocities(name):
    """Velocities at the waypoints taken from the toppra profile: the Ruckig profile passes every
    waypoint with that velocity (zero acceleration), and is faster than stopping at each."""
    robot = load_robot(name)
    waypoints = waypoints_for(robot, 3)
    toppra = retime(robot, waypoints, method="toppra")
    nearest = [int(np.argmin(np.linalg.norm(toppra.q - q, axis=1))) for q in waypoints]
    velocities = np.clip(toppra.qd[nearest], -robot.limits.qd_max, robot.limits.qd_max)
    velocities[[0, -1]] = 0.0
    assert np.abs(velocities[1:-1]).max() > 0.1
    profile = retime(robot, waypoints, method="ruckig", waypoint_velocities=velocities)
    assert_certified_at_rest(profile, waypoints)
    ends = segment_ends(profile)
    np.testing.assert_allclose(profile.q[ends], waypoints[1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(profile.qd[ends], velocities[1:], rtol=0, atol=1e-9)
    np.testing.assert_allclose(profile.qdd[ends], 0.0, rtol=0, atol=1e-9)
    assert not profile.details.rest_at_waypoints
    first = ruckig_own_duration(robot.limits, waypoints[0], waypoints[1], velocities[1])
    assert abs(profile.details.segment_durations_s[0] - first) <= DURATION_TOLERANCE
    assert profile.duration < retime(robot, waypoints, method="ruckig").duration


def test_jerk_is_the_derivative_of_ruckigs_acceleration():
    """The jerk we report is exact: inside each phase it equals the central difference of the
    acceleration Ruckig's at_time returns, and it never exceeds the jerk limit."""
    limits = load_robot("gp7").limits
    start = (np.zeros(6), np.zeros(6), np.zeros(6))
    target = (np.full(6, 0.8), 0.3 * limits.qd_max, 0.2 * limits.qdd_max)
    trajectory = SegmentSolver(limits).solve(start, target, "a test segment")
    h = 1e-6
    tau = np.linspace(h, trajectory.duration - h, 2001)
    acceleration = [np.array([trajectory.at_time(float(t))[2] for t in tau + d]) for d in (-h, h)]
    jerk, before, after = (segment_jerk(trajectory, tau + d) for d in (0.0, -h, h))
    inside = np.all(before == after, axis=1)
    assert inside.mean() > 0.95
    central = (acceleration[1] - acceleration[0]) / (2 * h)
    np.testing.assert_allclose(central[inside], jerk[inside], rtol=0, atol=1e-6 * limits.qddd_max.max())
    assert np.all(np.abs(jerk) <= limits.qddd_max * (1 + 1e-12))
    assert np.abs(jerk).max() > 0.99 * limits.qddd_max.min()


@pytest.mark.parametrize("method", ["ruckig", "topp3"])
@pytest.mark.parametrize("missing", ["qddd_max", "qdd_max"])
def test_missing_jerk_or_acceleration_limits_are_a_timing_error(method, missing):
    robot = load_robot("gp7")
    limits = robot.limits
    values = {"qdd_max": limits.qdd_max, "qddd_max": limits.qddd_max, missing: None}
    bare = Limits(limits.q_min, limits.q_max, limits.qd_max, values["qdd_max"], values["qddd_max"])
    with pytest.raises(TimingError, match=re.escape(method) + f" needs .*{missing}"):
        retime(robot, waypoints_for(robot, 0), method=method, limits=bare)


@pytest.mark.parametrize("change, match", [
    (lambda v, qd_max: v.__setitem__((0, 0), 0.1), "zero at the first and last waypoint"),
    (lambda v, qd_max: v.__setitem__((1, 2), 1.5 * qd_max[2]), "waypoint 1: velocity of joint 3"),
    (lambda v, qd_max: v.__setitem__((2, 0), np.nan), "waypoint velocity 2 has a non-finite value for joint 1"),
])
def test_bad_waypoint_velocities_are_timing_errors(change, match):
    robot = load_robot("gp7")
    waypoints = waypoints_for(robot, 0)
    velocities = np.zeros_like(waypoints)
    change(velocities, robot.limits.qd_max)
    with pytest.raises(TimingError, match=match):
        retime(robot, waypoints, method="ruckig", waypoint_velocities=velocities)


def test_a_segment_ruckig_cannot_keep_inside_the_limits_is_named():
    """Passing a waypoint near a position limit at speed towards it: the next segment must overshoot."""
    robot = load_robot("gp7")
    waypoints = np.zeros((3, 6))
    waypoints[1, 0] = robot.limits.q_max[0] - 1e-3
    velocities = np.zeros((3, 6))
    velocities[1, 0] = 0.5 * robot.limits.qd_max[0]
    with pytest.raises(TimingError, match=r"segment 1 \(waypoint 1 to 2\) leaves the limits of joint 1"):
        retime(robot, waypoints, method="ruckig", waypoint_velocities=velocities)


def test_exact_boundary_case_is_retried_and_certified():
    """Ruckig 0.19.4 itself fails on this IRB 1600 move (limits that are exact multiples of each
    other): the segment is retried with limits smaller by 1e-9 and the profile still certifies."""
    robot = load_robot("irb1600")
    waypoints = np.radians([[-30, 30, -40, -20, 60, -30], [0, 0, 0, 0, 30, 0]])
    profile = retime(robot, waypoints, method="ruckig")
    assert profile.details.ruckig_boundary_retries == 1
    assert certify(profile).passed


@pytest.mark.parametrize("seed", [1000130, 1000677])
def test_ruckigs_position_precision_at_a_waypoint_is_not_a_column_disagreement(seed):
    """Tiny motions (fuzz seeds, arm5 and irb1600): Ruckig ends a segment 6.8e-9 rad from its target and the
    profile holds the target itself; certify's q/qd agreement allows that POSITION_PRECISION (it refused both)."""
    from .test_timing_fuzz import make_case, robot_named, unscaled_limits

    case = make_case(seed)
    robot = robot_named(case.robot)
    profile = retime(robot, case.waypoints, method="ruckig", speed_scale=case.speed_scale, dt=case.dt,
                     limits=unscaled_limits(robot, False))
    assert profile.certificate.passed and profile.certificate.columns.ratios["q/qd"] <= 1.0
    assert np.abs(np.diff(profile.q, axis=0)).max() > 0.0        # there is motion to judge
