"""Per-move limits in the timing back ends (``LimitSchedule`` over the path's s), ``time_path`` without the
certification, and ``certify`` judging a profile's schedule."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pipeline.timing
from pipeline import load_robot
from pipeline.errors import ConfigurationError
from pipeline.timing import retime, time_path
from pipeline.timing.joint_path import make_path
from pipeline.timing.profile import certify, limits_summary
from pipeline.timing.schedule import LimitSchedule
from pipeline.timing.tcp import TcpMotion

INF3 = np.full(3, np.inf)


@pytest.fixture(scope="module")
def gp7():
    return load_robot("gp7")


@pytest.fixture(scope="module")
def path(gp7):
    waypoints = gp7.random_configurations(np.random.default_rng(3), 4, 0.2)
    return make_path(waypoints, gp7.limits.q_min, gp7.limits.q_max)


def middle_slowed(joint_speed: float = 0.5) -> LimitSchedule:
    """The middle 40 % of s at ``joint_speed`` of the joint speed limits."""
    return LimitSchedule(np.array([0.0, 0.3, 0.7, 1.0]), np.array([1.0, joint_speed, 1.0]), INF3, INF3)


def inside(profile, k: int) -> np.ndarray:
    """The samples of ``profile`` on interval k of its schedule (mapped to time)."""
    bounds = profile.schedule.bounds
    return (profile.t >= bounds[k]) & (profile.t <= bounds[k + 1])


@pytest.mark.parametrize("method", ["toppra", "topp3"])
def test_a_slowed_interval_meets_its_own_joint_speed_limit(gp7, path, method):
    profile = retime(gp7, path, method=method, schedule=middle_slowed(0.5))
    ratios = np.abs(profile.qd) / gp7.limits.qd_max
    middle = inside(profile, 1)
    assert 0.98 * 0.5 < ratios[middle].max() <= 0.5 * (1.0 + 1e-6)     # reaches the halved limit, never more
    assert ratios[~middle].max() > 0.7                             # elsewhere the joints go faster
    assert profile.schedule.bounds[0] == 0.0 and profile.schedule.bounds[-1] == pytest.approx(profile.duration)
    assert profile.certificate.passed and profile.certificate.max_ratio("qd") <= 1.0 + 1e-6


def test_a_move_at_half_speed_is_timed_as_with_its_joint_speed_limits_halved(gp7, path):
    half = LimitSchedule.uniform(0.0, 1.0, joint_speed=0.5)
    scheduled = retime(gp7, path, schedule=half)
    halved = retime(gp7, path, limits=dataclasses.replace(gp7.limits, qd_max=gp7.limits.qd_max * 0.5))
    assert scheduled.duration == pytest.approx(halved.duration, rel=1e-3)


def test_a_tcp_speed_limit_on_one_interval_holds_there_only(gp7, path):
    schedule = LimitSchedule(np.array([0.0, 0.3, 0.7, 1.0]), np.ones(3), np.array([np.inf, 0.3, np.inf]), INF3)
    profile = retime(gp7, path, schedule=schedule, tcp=TcpMotion(gp7))
    middle = inside(profile, 1)
    assert profile.tcp.speed[middle].max() <= 0.3 * (1.0 + 1e-6)
    assert profile.tcp.speed[~middle].max() > 1.0
    assert profile.certificate.max_ratio("tcp_speed") > 0.98


def test_a_schedule_that_limits_the_tcp_needs_the_tcp(gp7, path):
    schedule = LimitSchedule.uniform(0.0, 1.0, tcp_speed=0.3)
    with pytest.raises(ConfigurationError, match="TCP"):
        retime(gp7, path, schedule=schedule)


def slowed_down(profile, k: float):
    """``profile`` k times slower (time x k, qd / k, qdd / k^2, qddd / k^3)."""
    return dataclasses.replace(profile, t=profile.t * k, qd=profile.qd / k, qdd=profile.qdd / k**2,
                               qddd=profile.qddd / k**3)


def test_certify_judges_each_sample_against_the_schedule_that_applied(gp7, path):
    profile = retime(gp7, path)                           # full speed everywhere: qd reaches its limit
    slower = slowed_down(profile, 1.6)                    # qd at most 0.625 of its limit
    T = slower.duration
    middle = LimitSchedule(np.array([0.0, T / 3, 2 * T / 3, T]), np.array([1.0, 0.5, 1.0]), INF3, INF3)
    assert certify(slower).passed
    report = certify(dataclasses.replace(slower, schedule=middle))
    assert not report.passed and report.worst_quantity == "qd" and report.max_ratio("qd") > 1.05
    assert T / 3 <= report.worst_time <= 2 * T / 3
    assert certify(dataclasses.replace(slowed_down(profile, 2.1), schedule=middle.mapped(middle.bounds * 2.1 / 1.6)))\
        .passed                                           # 1 / 2.1 of the limit meets the middle's half
    # the TCP: a schedule's speed limit below the profile's TCP speed fails; without TCP samples it cannot judge
    tool = retime(gp7, path, tcp=TcpMotion(gp7))
    peak = tool.tcp.speed.max()
    limited = dataclasses.replace(tool, schedule=LimitSchedule.uniform(0.0, tool.duration, tcp_speed=0.5 * peak))
    assert certify(tool).passed and not certify(limited).passed
    assert certify(limited).max_ratio("tcp_speed") == pytest.approx(2.0, rel=1e-9)
    with pytest.raises(ConfigurationError, match="TCP samples"):
        certify(dataclasses.replace(limited, tcp=None))


def test_ruckig_refuses_a_schedule(gp7, path):
    with pytest.raises(ConfigurationError, match="toppra or topp3"):
        retime(gp7, path.waypoints, method="ruckig", schedule=middle_slowed())


def test_time_path_does_not_certify_and_retime_certifies_once(gp7, path, monkeypatch):
    calls = []
    real = pipeline.timing.certify
    monkeypatch.setattr(pipeline.timing, "certify", lambda *args, **kwargs: calls.append(1) or real(*args, **kwargs))
    profile = time_path(gp7, path, schedule=middle_slowed())
    assert calls == [] and profile.certificate is None and profile.schedule is not None
    assert profile.speed_scale == 1.0 and profile.unscaled_limits is gp7.limits
    retime(gp7, path)
    assert calls == [1]


def test_a_tcp_acceleration_limit_through_a_turn_in_place_needs_no_uniform_slow_down(gp7):
    """At the middle vertex of this monotone path every joint turns back (dq/ds = 0, d2q/ds2 not): the TCP's
    acceleration rows at the grid points alone left toppra's path acceleration free there, and the dense check
    found the limit exceeded 2.5 times between grid points (the whole piece was slowed 1.4x)."""
    waypoints = np.array([[0.499347, 0.387442, -0.030465, 0.0, -1.152889, 0.024252],
                          [-0.516962, 0.065809, 0.743078, 0.516609, -0.310005, 0.494812],
                          [-0.499347, 0.387442, -0.030465, 0.0, -1.152889, -0.024252]])
    limits = dataclasses.replace(gp7.limits, tcp_speed_max=0.5, tcp_accel_max=2.5)
    profile = retime(gp7, waypoints, shape="monotone", limits=limits, tcp=TcpMotion(gp7))
    assert profile.details.time_stretch < 1.001
    assert profile.certificate.max_ratio("tcp_accel") > 0.99


def test_a_bound_a_hair_from_a_breakpoint_takes_its_place_on_the_grid(path):
    """A schedule's bound 1.4e-17 from a breakpoint made a grid interval of nothing: the joint acceleration
    of toppra's solution there came out 2.6e8 times its limit."""
    from pipeline.timing.toppra_backend import MIN_GRID_GAP, grid_for

    bound = np.nextafter(path.breakpoints[1], 1.0)
    grid = grid_for(path, 2000, include=[0.0, bound, 1.0])
    assert bound in grid and path.breakpoints[1] not in grid
    assert np.diff(grid).min() >= MIN_GRID_GAP and grid[0] == 0.0 and grid[-1] == 1.0


def test_speed_scale_scales_the_schedules_tcp_speed_as_the_limits(gp7, path):
    schedule = LimitSchedule(np.array([0.0, 0.3, 0.7, 1.0]), np.ones(3), np.array([np.inf, 0.3, np.inf]), INF3)
    profile = retime(gp7, path, schedule=schedule, tcp=TcpMotion(gp7), speed_scale=0.5)
    assert profile.tcp.speed[inside(profile, 1)].max() <= 0.15 * (1.0 + 1e-6)
    assert profile.certificate.max_ratio("tcp_speed") > 0.98
    summary = limits_summary(profile)                  # the robot's own limits and the schedule's own speeds
    assert summary["unscaled"]["max_ratio"]["tcp_speed"] == pytest.approx(
        summary["timed"]["max_ratio"]["tcp_speed"] / 2.0, rel=1e-9)
