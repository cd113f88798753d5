"""Time parameterisation behind two functions: ``retime(robot, path_or_waypoints, method=...)`` and
``time_path`` (the same without the certification, for callers that join timed pieces and certify once).

Methods: ``toppra`` (time-optimal along the path, velocity and acceleration limits), ``ruckig``
(jerk-limited, waypoint to waypoint, exact), ``topp3`` (jerk-limited path following: a third-order
time parameterisation of the path itself, so every sample is on the path; ``toppra+ruckig`` is its
older name). Every profile ``retime`` returns is certified by ``pipeline.timing.profile.certify`` before it is
returned, with the verdict attached (``profile.certificate``): a profile that fails is an error,
never a result. A profile that would have more than ``max_samples`` samples is refused before they
are made (ProfileSizeError).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import ConfigurationError, TimingError
from ..files.arrays import is_whole_number
from ..files.choices import DEFAULT_DT, DEFAULT_MAX_SAMPLES, DEFAULT_PATH_SHAPE, TIMING_ALIASES, TIMING_METHODS
from ..files.robot_spec import Limits
from .joint_path import JointPath, make_path
from .profile import Profile, certify, scale_limits, scale_schedule
from .schedule import LimitSchedule

METHODS = TIMING_METHODS


def time_path(robot, path_or_waypoints, method: str = "toppra", speed_scale: float = 1.0,
              limits: Limits | None = None, dt: float = DEFAULT_DT, shape: str = DEFAULT_PATH_SHAPE,
              max_samples: int = DEFAULT_MAX_SAMPLES, drake=None, tcp=None, schedule: LimitSchedule | None = None,
              **options) -> Profile:
    """Time a joint path (a JointPath, or waypoints (K, dof) [rad or m]) within the robot's limits, without
    certifying it (``retime`` certifies; a caller joining several timed pieces certifies the whole once).

    ``speed_scale`` in (0, 1] scales qd, qdd, qddd limits by s, s^2, s^3; ``limits`` replaces the
    robot's; ``dt`` [s] is the sample time of the returned profile; ``shape`` (``spline`` or
    ``linear``) builds the path from waypoints. The profile starts and ends at rest. When the
    limits bound joint torques (``tau_max``, robot files with inertias), the torques come from
    Drake's inverse dynamics: toppra limits them, and every method's profile carries them (``tau``).
    ``max_samples``: a profile with more samples is refused (ProfileSizeError) as soon as its
    duration is known, before they are made. ``drake``: the robot's DrakeRobot for the inverse
    dynamics (built here when torques are limited and none is given; pass one to reuse it). ``tcp``: a
    TcpMotion of the robot whose end frame is the TCP: the profile then carries the TCP's samples
    (``profile.tcp``), and the limits' ``tcp_speed_max`` and ``tcp_accel_max`` are met (toppra and topp3:
    as constraints at their grid points, checked densely between them). ``schedule``: a LimitSchedule over
    the path's parameter s in [0, 1] (toppra and topp3 only): on each of its intervals the joint speed
    limits x its ``joint_speed`` and the TCP's speed and acceleration within its ``tcp_speed`` x
    speed_scale and ``tcp_accel`` x speed_scale^2, on top of the limits; the profile carries it mapped
    to time (``profile.schedule``).
    """
    method = TIMING_ALIASES.get(method, method)
    if method not in METHODS:
        raise ConfigurationError(f"unknown timing method {method!r}; choose one of {', '.join(METHODS)}")
    if not np.isfinite(dt) or dt <= 0.0:
        raise ConfigurationError(f"dt must be a positive number of seconds, got {dt}")
    if not is_whole_number(max_samples, 2):
        raise ConfigurationError(f"max_samples must be an integer of at least 2, got {max_samples!r}")
    unscaled = robot.limits if limits is None else limits
    limits = scale_limits(unscaled, speed_scale)
    _check_path_limits(method, limits, tcp, schedule)
    scaled_schedule = scale_schedule(schedule, speed_scale)
    names = tuple(robot.joint_names)
    inverse_dynamics = None
    if limits.tau_max is not None:
        from ..model.chain.drake_model import build_drake_robot

        inverse_dynamics = (drake if drake is not None else build_drake_robot(robot.spec)).inverse_dynamics
    if method == "ruckig":
        from .ruckig_backend import retime_ruckig

        waypoints = path_or_waypoints.waypoints if isinstance(path_or_waypoints, JointPath) else path_or_waypoints
        profile = retime_ruckig(np.asarray(waypoints, dtype=float), limits, dt, names, max_samples=max_samples,
                                **options)
    else:
        path = (path_or_waypoints if isinstance(path_or_waypoints, JointPath)
                else make_path(path_or_waypoints, limits.q_min, limits.q_max, shape))
        if method == "toppra":
            from .toppra_backend import retime_toppra

            profile = retime_toppra(path, limits, dt, names, inverse_dynamics=inverse_dynamics,
                                    max_samples=max_samples, tcp=tcp, schedule=scaled_schedule, **options)
        else:
            from .topp3_backend import retime_topp3

            profile = retime_topp3(path, limits, dt, names, inverse_dynamics=inverse_dynamics,
                                   max_samples=max_samples, tcp=tcp, schedule=scaled_schedule, **options)
    if inverse_dynamics is not None:
        profile = dataclasses.replace(profile, tau=inverse_dynamics(profile.q, profile.qd, profile.qdd))
    if tcp is not None:
        profile = dataclasses.replace(profile, tcp=tcp.samples(profile.q, profile.qd, profile.qdd))
    return dataclasses.replace(profile, speed_scale=float(speed_scale), unscaled_limits=unscaled)


def _check_path_limits(method: str, limits: Limits, tcp, schedule: LimitSchedule | None) -> None:
    """ConfigurationError when a schedule or TCP limits come without what they need: a path-following method
    (toppra or topp3) and, for TCP limits (the limits' or the schedule's), the TCP's kinematics."""
    if method == "ruckig" and schedule is not None:
        raise ConfigurationError("zones and per-move speeds (a LimitSchedule) need a path-following timing: "
                                 "toppra or topp3 (ruckig times waypoint to waypoint, off the path)")
    limits_tcp = limits.tcp_speed_max is not None or limits.tcp_accel_max is not None
    if (limits_tcp or (schedule is not None and schedule.limits_tcp)) and (tcp is None or method == "ruckig"):
        raise ConfigurationError("TCP limits need the TCP's kinematics (tcp=TcpMotion(robot)) and a path-following "
                                 "timing (toppra or topp3; ruckig times waypoint to waypoint, off the path)")


def retime(robot, path_or_waypoints, method: str = "toppra", speed_scale: float = 1.0,
           limits: Limits | None = None, dt: float = DEFAULT_DT, shape: str = DEFAULT_PATH_SHAPE,
           max_samples: int = DEFAULT_MAX_SAMPLES, drake=None, tcp=None, schedule: LimitSchedule | None = None,
           **options) -> Profile:
    """``time_path`` (see there for the arguments) and ``certify``: the certified profile, with the verdict
    attached (``profile.certificate``); TimingError when it fails."""
    profile = time_path(robot, path_or_waypoints, method, speed_scale, limits, dt, shape, max_samples, drake, tcp,
                        schedule, **options)
    report = certify(profile)
    if not report.passed:
        raise TimingError(f"{profile.method} profile failed certification: {report}")
    return dataclasses.replace(profile, certificate=report)


__all__ = ["DEFAULT_MAX_SAMPLES", "METHODS", "retime", "time_path"]
