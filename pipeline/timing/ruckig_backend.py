"""Jerk-limited timing with Ruckig, offline and segment by segment (the cloud API is never used).

``retime_ruckig``: one time-optimal, synchronised Ruckig trajectory per pair of consecutive
waypoints, at rest at each waypoint or passing it with a given velocity. The community edition
sends ``intermediate_positions`` to a cloud service, so we never set them: every segment is its own
``Ruckig(dof).calculate(InputParameter, Trajectory)`` call. Offline Ruckig ignores position limits
(``min_position``/``max_position`` are used only by the cloud; "ErrorPositionalLimits ... only in
Ruckig Pro"), so every segment's exact position extrema (``Trajectory.position_extrema``) are checked
against q_min/q_max instead (a continuous joint's -inf, +inf: Ruckig is never given position limits);
velocity, acceleration and jerk limits hold by construction, and the returned samples are certified.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import TimingError
from ..files.choices import DEFAULT_MAX_SAMPLES, TIMING_LIMITS
from ..files.robot_spec import Limits
from .joint_path import NO_MOTION_DISTANCE, check_waypoints
from .profile import CERTIFY_TOLERANCE, Profile, TimingDetails
from .toppra_backend import check_sample_count, sample_times

#: Velocities and accelerations below this count as rest [rad/s, rad/s^2].
REST_TOLERANCE = 1e-12
#: Target states are kept this far inside Ruckig's admissible set (round-off of its check) [1].
ADMISSIBLE_MARGIN = 1e-6
#: How close Ruckig brings a segment to its target position [rad or m] (measured: up to 1e-8 on moves
#: of 1e-9..1e-5 rad): samples within a segment are that exact, waypoints themselves exactly.
RUCKIG_POSITION_PRECISION = 1e-8
#: Relative shrink of the kinematic limits for the one retry of a segment Ruckig fails on [1].
BOUNDARY_SHRINK = 1e-9


# -- Ruckig segments --------------------------------------------------------------------------

class SegmentSolver:
    """One Ruckig instance with the joint limits; ``solve`` times one segment between two states
    and checks its exact position extrema against the position limits."""

    def __init__(self, limits: Limits):
        import ruckig

        self._ruckig = ruckig
        self.dof = limits.qd_max.size
        self.otg = ruckig.Ruckig(self.dof)
        self.input = ruckig.InputParameter(self.dof)
        self._limits = limits
        self._set_kinematic_limits(1.0)
        slack = CERTIFY_TOLERANCE * (limits.q_max - limits.q_min) / 2.0       # as certify() allows
        self.q_min, self.q_max = limits.q_min - slack, limits.q_max + slack
        self.calls = 0
        self.boundary_retries = 0
        self.compute_s = 0.0

    def _set_kinematic_limits(self, scale: float) -> None:
        limits = self._limits
        self.input.max_velocity = (limits.qd_max * scale).tolist()
        self.input.max_acceleration = (limits.qdd_max * scale).tolist()
        self.input.max_jerk = (limits.qddd_max * scale).tolist()

    def _calculate(self, trajectory) -> str:
        """One Ruckig call into ``trajectory``: "" on success, else why not."""
        ruckig = self._ruckig
        began = time.perf_counter()
        try:
            result = self.otg.calculate(self.input, trajectory)
        except ruckig.RuckigError as error:
            return f"Ruckig rejected it: {str(error).strip()}"
        finally:
            self.calls += 1
            self.compute_s += time.perf_counter() - began
        return "" if result in (ruckig.Result.Working, ruckig.Result.Finished) else f"Ruckig failed: {result.name}"

    def solve(self, start, target, where: str):
        """Time-optimal trajectory from state ``start`` to ``target`` (each (q, qd, qdd)); ``where``
        names the segment in the TimingError raised when Ruckig fails.

        Ruckig 0.19 can fail on exact boundary cases (limits that are exact multiples of each other,
        a duration landing exactly on a profile switch): such a segment is retried once with limits
        smaller by BOUNDARY_SHRINK, counted in ``boundary_retries``.
        """
        inp = self.input
        inp.current_position, inp.current_velocity, inp.current_acceleration = (list(x) for x in start)
        inp.target_position, inp.target_velocity, inp.target_acceleration = (list(x) for x in target)
        trajectory = self._ruckig.Trajectory(self.dof)
        failure = self._calculate(trajectory)
        if failure:
            self.boundary_retries += 1
            self._set_kinematic_limits(1.0 - BOUNDARY_SHRINK)
            try:
                failure = self._calculate(trajectory)
            finally:
                self._set_kinematic_limits(1.0)
        if failure:
            raise TimingError(f"{failure} on {where}")
        for joint, bound in enumerate(trajectory.position_extrema):
            if bound.min < self.q_min[joint] or bound.max > self.q_max[joint]:
                raise TimingError(
                    f"Ruckig's trajectory for {where} leaves the limits of joint {joint + 1} (reaches "
                    f"[{bound.min:.6g}, {bound.max:.6g}], limits [{self.q_min[joint]:.6g}, {self.q_max[joint]:.6g}])")
        return trajectory


def segment_jerk(trajectory, tau: np.ndarray) -> np.ndarray:
    """Jerk (n, dof) [rad/s^3] at times tau [s] of a one-section trajectory, exactly: the constant
    jerk of the phase Ruckig's ``at_time`` integrates from (brake phases first, zero after the end)."""
    columns = []
    for phases in trajectory.profiles[0]:
        brake = phases.brake
        durations, jerks = (phases.t, phases.j) if brake.duration <= 0.0 else (
            [*brake.t, *phases.t], [*brake.j, *phases.j])
        index = np.searchsorted(np.cumsum(durations), tau, side="right")
        columns.append(np.append(jerks, 0.0)[index])
    return np.stack(columns, axis=1)


def sample_segment(trajectory, tau: np.ndarray):
    """q, qd, qdd, qddd (n, dof) at times tau [s] from the segment's start (``at_time``)."""
    q, qd, qdd = (np.array(x) for x in zip(*(trajectory.at_time(float(t)) for t in tau)))
    return q, qd, qdd, segment_jerk(trajectory, tau)


def profile_from_segments(trajectories, dt: float, method: str, limits: Limits, joint_names: tuple[str, ...],
                          details: TimingDetails, max_samples: int = DEFAULT_MAX_SAMPLES) -> Profile:
    """Concatenate segments into one Profile sampled every ``dt`` [s] and at every segment end;
    ProfileSizeError before sampling more than ``max_samples``."""
    durations = np.array([trajectory.duration for trajectory in trajectories])
    ends = np.concatenate([[0.0], np.cumsum(durations)])
    check_sample_count(ends[-1], dt, max_samples, extra=len(trajectories))
    t = np.unique(np.concatenate([sample_times(ends[-1], dt, max_samples), ends]))
    segment = np.clip(np.searchsorted(ends, t, side="right") - 1, 0, len(trajectories) - 1)
    columns = [np.empty((t.size, limits.qd_max.size)) for _ in range(4)]
    bounds = np.searchsorted(segment, np.arange(len(trajectories) + 1))       # t is sorted
    for k, (first, stop) in enumerate(zip(bounds[:-1], bounds[1:])):
        if stop > first:
            tau = np.clip(t[first:stop] - ends[k], 0.0, durations[k])
            for column, values in zip(columns, sample_segment(trajectories[k], tau)):
                column[first:stop] = values
    q, qd, qdd, qddd = columns
    return Profile(t=t, q=q, qd=qd, qdd=qdd, qddd=qddd, method=method, limits=limits,
                   joint_names=joint_names, details=details)


def require_jerk_limits(limits: Limits, method: str) -> None:
    """The jerk-limited ``method`` (ruckig, topp3) needs its TIMING_LIMITS, acceleration and jerk, for every joint."""
    missing = [name for name in TIMING_LIMITS[method] if getattr(limits, name) is None]
    if missing:
        raise TimingError(f"{method} needs {' and '.join(missing)} for every joint (jerk-limited timing); "
                          "add the missing limits to the robot file or pass limits=... with them")


# -- waypoint to waypoint -----------------------------------------------------------------------

def _check_velocities(waypoints: np.ndarray, velocities: np.ndarray, limits: Limits) -> None:
    """Waypoint velocities (K, dof) [rad/s]: the waypoints' shape, finite, within qd_max, zero at the ends."""
    if velocities.shape != waypoints.shape:
        raise TimingError(f"waypoint_velocities must have the waypoints' shape {waypoints.shape}, "
                          f"got {velocities.shape}")
    bad = np.argwhere(~np.isfinite(velocities))
    if bad.size:
        raise TimingError(f"waypoint velocity {bad[0][0]} has a non-finite value for joint {bad[0][1] + 1}")
    too_fast = np.argwhere(np.abs(velocities) > limits.qd_max)
    if too_fast.size:
        k, j = too_fast[0]
        raise TimingError(f"waypoint {k}: velocity of joint {j + 1} = {velocities[k, j]:.6g} exceeds "
                          f"qd_max {limits.qd_max[j]:.6g}")
    if np.ptp(waypoints, axis=0).max() <= NO_MOTION_DISTANCE and np.abs(velocities).max() == 0.0:
        raise TimingError(f"all waypoints are the same configuration (within {NO_MOTION_DISTANCE:g}): there is no "
                          "motion to time")
    if np.abs(velocities[[0, -1]]).max() > REST_TOLERANCE:
        raise TimingError("waypoint_velocities must be zero at the first and last waypoint "
                          "(the profile starts and ends at rest)")


@dataclass(frozen=True)
class RuckigDetails(TimingDetails):
    """What the Ruckig back end did: ``rest_at_waypoints`` (False: passing them with the given
    velocities), ``segment_durations_s`` [s] per waypoint pair, ``ruckig_compute_s_per_segment`` [s],
    ``ruckig_boundary_retries`` (segments retried with limits shrunk by BOUNDARY_SHRINK); ``jerk_exact``:
    qddd is the constant jerk of each Ruckig phase."""

    rest_at_waypoints: bool
    segment_durations_s: tuple[float, ...]
    ruckig_compute_s_per_segment: float
    ruckig_boundary_retries: int
    jerk_exact: bool = True


def retime_ruckig(waypoints: np.ndarray, limits: Limits, dt: float, joint_names: tuple[str, ...],
                  waypoint_velocities=None, max_samples: int = DEFAULT_MAX_SAMPLES) -> Profile:
    """Jerk-limited, synchronised profile through waypoints (K, dof) [rad or m], sampled every ``dt`` [s].

    At rest at every waypoint, or passing waypoint k with ``waypoint_velocities[k]`` [rad/s] (zero
    acceleration there; the first and last rows must be zero). Raises TimingError naming the segment,
    ProfileSizeError (once the segments' durations are known) beyond ``max_samples`` samples.
    """
    require_jerk_limits(limits, "ruckig")
    waypoints = check_waypoints(waypoints, limits.q_min, limits.q_max)
    velocities = np.zeros_like(waypoints) if waypoint_velocities is None else np.asarray(waypoint_velocities, float)
    _check_velocities(waypoints, velocities, limits)
    solver = SegmentSolver(limits)
    zero = np.zeros(waypoints.shape[1])
    states = [(q, v, zero) for q, v in zip(waypoints, velocities)]
    trajectories = [solver.solve(states[k], states[k + 1], f"segment {k} (waypoint {k} to {k + 1})")
                    for k in range(len(states) - 1)]
    details = RuckigDetails(
        rest_at_waypoints=waypoint_velocities is None,
        segment_durations_s=tuple(float(trajectory.duration) for trajectory in trajectories),
        ruckig_compute_s_per_segment=solver.compute_s / solver.calls,
        ruckig_boundary_retries=solver.boundary_retries)
    profile = profile_from_segments(trajectories, dt, "ruckig", limits, joint_names, details, max_samples)
    # Ruckig ends a segment within RUCKIG_POSITION_PRECISION of its target: the last sample is the last
    # waypoint itself, and no sample is left a hair beyond a position limit.
    profile.q[-1] = waypoints[-1]
    np.clip(profile.q, limits.q_min, limits.q_max, out=profile.q)
    return profile


