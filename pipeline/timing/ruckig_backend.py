"""Jerk-limited timing with Ruckig, offline and segment by segment (the cloud API is never used).

``retime_ruckig``: one time-optimal, synchronised Ruckig trajectory per pair of consecutive
waypoints, at rest at each waypoint or passing it with a given velocity. The community edition
sends ``intermediate_positions`` to a cloud service, so we never set them: every segment is its own
``Ruckig(dof).calculate(InputParameter, Trajectory)`` call. Offline Ruckig ignores position limits
(``min_position``/``max_position`` are used only by the cloud; "ErrorPositionalLimits ... only in
Ruckig Pro"), so every segment's exact position extrema (``Trajectory.position_extrema``) are checked
against q_min/q_max instead; velocity, acceleration and jerk limits hold by construction, and the
returned samples are certified.

``retime_toppra_ruckig``: jerk-limited AND within ``path_tolerance`` of the geometric path, which
no open library does. toppra's time-optimal profile switches acceleration instantly, so Ruckig
cannot follow its states (measured: Ruckig through toppra's own states takes 1.6-26x longer and
leaves the path by radians). We therefore build a jerk-aware guide along the path first:

1. toppra's joint-space speed along the path |qd(t)| [rad/s] is averaged over a window of
   max(qdd_max / qddd_max) (a moving average of width w turns an acceleration step into a ramp of
   duration w), which starts and ends at rest;
2. the guide q(t) = path(s(sigma(t))) (sigma: joint-space arc length) is checked against qd, qdd,
   qddd (finite differences over the guide's step, set by the tolerance) on its samples; where it
   exceeds them, time is locally stretched by a smooth factor (a few rounds), and any remainder by
   one uniform factor.

Ruckig is then given guide states (position on the path, velocity, acceleration) at waypoints
along the path, one segment at a time. The deviation of every segment from the path (distance
from DEVIATION_SAMPLES Ruckig samples to a fine polyline of the path near that segment, plus the
polyline's own chord error) is measured, and segments above the tolerance are halved until all pass
or the budget is spent; then the guide is slowed and the whole tried again. Measured on random
paths: 1.0-1.3x toppra's duration on splines; on ``linear`` paths more (1.1-1.7x at 1e-3 rad,
1.4-3.3x at 1e-5 rad), because d2q/ds2 jumps at every blend end, which a jerk limit can only follow
by slowing down or cutting the corner within the tolerance.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.ndimage import maximum_filter1d, uniform_filter1d

from ..choices import DEFAULT_MAX_SAMPLES
from ..errors import TimingError
from ..path import JointPath, check_waypoints
from ..profile import CERTIFY_TOLERANCE, Profile, TimingDetails
from ..robot_spec import Limits
from .toppra_backend import check_sample_count, sample_toppra, sample_times, solve_toppra

#: Velocities and accelerations below this count as rest [rad/s, rad/s^2].
REST_TOLERANCE = 1e-12
#: Target states are kept this far inside Ruckig's admissible set (round-off of its check) [1].
ADMISSIBLE_MARGIN = 1e-6
#: The guide's sample step h [s] is also the time over which its finite-difference jerk sees an
#: acceleration jump (a linear path's blend ends): sqrt(GUIDE_STEP_GAIN tolerance / max qdd_max), so
#: that Ruckig smoothing such a jump stays within the tolerance (measured on 10-waypoint linear paths:
#: 8 ms keeps 1e-3 rad, fails 40 % at 1e-4; 4 ms keeps 1e-4, fails 40 % at 1e-5), within these bounds.
GUIDE_STEP_GAIN = 2.0
GUIDE_STEP_BOUNDS = (5e-4, 8e-3)
#: Rounds of local time stretching of the guide before the uniform remainder.
WARP_ROUNDS = 4
#: The polyline that stands for the path in the deviation check: at least this many points, about
#: this far apart [rad], and more when its chord error exceeds this fraction of the tolerance.
PATH_TABLE_POINTS = 20001
PATH_TABLE_SPACING = 1e-3
CHORD_ERROR_SHARE = 0.1
MAX_PATH_TABLE_POINTS = 2_000_001
#: Guide time between the first waypoints [s]; segments above the tolerance are halved.
INITIAL_SPACING = 0.1
#: Refinement rounds, and uniform slow-downs of the guide (x SLOWDOWN each) when a pass fails.
MAX_ROUNDS = 10
MAX_SLOWDOWNS = 3
SLOWDOWN = 1.1
#: Ruckig samples per segment in the deviation check.
DEVIATION_SAMPLES = 24
DEFAULT_PATH_TOLERANCE = 1e-3   # [rad]
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
    """Ruckig needs acceleration and jerk limits for every joint."""
    missing = [name for name in ("qdd_max", "qddd_max") if getattr(limits, name) is None]
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
    if np.ptp(waypoints, axis=0).max() == 0.0 and np.abs(velocities).max() == 0.0:
        raise TimingError("all waypoints are the same configuration: there is no motion to time")
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
    return profile_from_segments(trajectories, dt, "ruckig", limits, joint_names, details, max_samples)


# -- along the path: the guide ------------------------------------------------------------------

class PathTable:
    """The path sampled at ``points`` uniform values of s: arc length ``sigma`` [rad], points ``q``,
    the map sigma -> s, and ``chord_error``: the largest distance of the path from its polyline [rad]."""

    @classmethod
    def for_tolerance(cls, path: JointPath, tolerance: float) -> "PathTable":
        """A table about PATH_TABLE_SPACING fine, refined once (chord error ~ 1 / points^2) so that
        its chord error is at most CHORD_ERROR_SHARE of ``tolerance`` [rad] where the cap allows."""
        points = int(np.clip(path.length / PATH_TABLE_SPACING, PATH_TABLE_POINTS, MAX_PATH_TABLE_POINTS))
        table = cls(path, points)
        refine = np.sqrt(table.chord_error / (CHORD_ERROR_SHARE * tolerance))
        if refine > 1.0 and points < MAX_PATH_TABLE_POINTS:
            table = cls(path, int(min(np.ceil(points * refine * 1.1), MAX_PATH_TABLE_POINTS)))
        return table

    def __init__(self, path: JointPath, points: int):
        s = np.linspace(0.0, 1.0, points)
        self.path = path
        self.q = path(s)
        self.sigma = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(self.q, axis=0), axis=1))])
        self.length = float(self.sigma[-1])
        self._q_squared = (self.q**2).sum(axis=1)
        self._s_of_sigma = CubicSpline(self.sigma, s)
        middle = path((s[1:] + s[:-1]) / 2.0)
        self.chord_error = float(np.linalg.norm(middle - (self.q[1:] + self.q[:-1]) / 2.0, axis=1).max())

    def at(self, sigma: np.ndarray) -> np.ndarray:
        """Path points (n, dof) at arc lengths sigma [rad]."""
        return self.path(np.clip(self._s_of_sigma(np.clip(sigma, 0.0, self.length)), 0.0, 1.0))

    def distance(self, points: np.ndarray, sigma_lo: float, sigma_hi: float) -> float:
        """Largest distance [rad] of ``points`` (n, dof) from the path between arc lengths sigma_lo and
        sigma_hi: to the two polyline chords at the nearest table point, plus the chord error. Fewer
        candidates only raise a minimum, so this bounds the distance from the whole path from above."""
        lo = max(int(np.searchsorted(self.sigma, sigma_lo)) - 1, 0)
        hi = min(int(np.searchsorted(self.sigma, sigma_hi)) + 1, len(self.sigma) - 1)
        squared = self._q_squared[lo:hi + 1, None] - 2.0 * (self.q[lo:hi + 1] @ points.T)
        nearest = lo + np.argmin(squared, axis=0)
        chords = np.clip(np.stack([nearest - 1, nearest], axis=1), 0, len(self.q) - 2)    # (n, 2)
        start, chord = self.q[chords], self.q[chords + 1] - self.q[chords]
        offset = points[:, None, :] - start
        along = np.clip((offset * chord).sum(axis=2) / np.maximum((chord**2).sum(axis=2), 1e-300), 0.0, 1.0)
        gap = np.linalg.norm(offset - along[..., None] * chord, axis=2).min(axis=1)
        return float(gap.max()) + self.chord_error


@dataclass(frozen=True, eq=False)
class Guide:
    """A time-scaling of the path, uniformly sampled: times ``t`` (n,) [s], arc length ``sigma``,
    positions on the path ``q``, ``qd``, ``qdd`` (n, dof); ``stretch`` the uniform factor applied."""

    t: np.ndarray
    sigma: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    stretch: float
    warp_rounds: int

    def slowed(self, factor: float) -> "Guide":
        """The same motion ``factor`` times slower."""
        return Guide(self.t * factor, self.sigma, self.q, self.qd / factor, self.qdd / factor**2,
                     self.stretch * factor, self.warp_rounds)


def time_scale_needed(qd, qdd, qddd, limits: Limits) -> np.ndarray:
    """Per sample, the slow-down that brings qd, qdd, qddd within the limits (1 = at a limit)."""
    return np.maximum.reduce([np.abs(qd) / limits.qd_max, np.sqrt(np.abs(qdd) / limits.qdd_max),
                              np.cbrt(np.abs(qddd) / limits.qddd_max)]).max(axis=1)


def _derivatives(q: np.ndarray, step: float):
    qd = np.gradient(q, step, axis=0)
    qdd = np.gradient(qd, step, axis=0)
    return qd, qdd, np.gradient(qdd, step, axis=0)


def guide_step(limits: Limits, tolerance: float) -> float:
    """The guide's sample step [s] for a path tolerance [rad] (see GUIDE_STEP_GAIN)."""
    return float(np.clip(np.sqrt(GUIDE_STEP_GAIN * tolerance / np.max(limits.qdd_max)), *GUIDE_STEP_BOUNDS))


def _uniform(duration: float, step: float) -> np.ndarray:
    """Uniform times from 0 to ``duration`` [s], about ``step`` apart."""
    return np.linspace(0.0, duration, max(int(np.ceil(duration / step)), 2) + 1)


def _smoothed_arc_length(reference: Profile, table: PathTable, window: float, step: float):
    """Arc length [rad] at uniform times about ``step`` apart of toppra's speed averaged over
    ``window`` [s], and the exact step [s]."""
    t = _uniform(reference.duration, step)
    step = float(t[1])
    samples = max(int(round(window / step)), 1)
    speed = np.interp(t, reference.t, np.linalg.norm(reference.qd, axis=1))
    speed = np.convolve(speed, np.ones(samples) / samples)       # zero outside: at rest at both ends
    sigma = np.concatenate([[0.0], np.cumsum((speed[1:] + speed[:-1]) / 2.0)])
    return sigma * (table.length / sigma[-1]), step


def _warp(sigma: np.ndarray, step: float, needed: np.ndarray, window: float):
    """Arc length at uniform times after stretching time by a smooth factor >= ``needed`` (n,)
    that varies over ``window`` [s], and the new step [s]."""
    samples = max(int(round(window / step)), 1)
    factor = maximum_filter1d(np.maximum(needed, 1.0), size=2 * samples + 1, mode="nearest")
    factor = uniform_filter1d(uniform_filter1d(factor, samples, mode="nearest"), samples, mode="nearest")
    tau = np.concatenate([[0.0], np.cumsum((factor[1:] + factor[:-1]) / 2.0 * step)])
    t = _uniform(tau[-1], step)
    return CubicSpline(tau, sigma)(t), float(t[1])


def build_guide(reference: Profile, table: PathTable, limits: Limits, step: float) -> Guide:
    """A time-scaling of the path near toppra's, within qd, qdd and qddd on its samples about ``step``
    [s] apart (see the module doc)."""
    window = float(np.max(limits.qdd_max / limits.qddd_max))
    sigma, step = _smoothed_arc_length(reference, table, window, step)
    for rounds in range(WARP_ROUNDS + 1):
        q = table.at(sigma)
        qd, qdd, qddd = _derivatives(q, step)
        needed = time_scale_needed(qd, qdd, qddd, limits)
        if needed.max() <= 1.0 or rounds == WARP_ROUNDS:
            break
        sigma, step = _warp(sigma, step, needed, window)
    guide = Guide(np.arange(len(sigma)) * step, sigma, q, qd, qdd, 1.0, rounds)
    return guide.slowed(max(float(needed.max()), 1.0))


# -- along the path: Ruckig through guide states ------------------------------------------------

def admissible_scale(qd: np.ndarray, qdd: np.ndarray, limits: Limits) -> float:
    """Largest c <= 1 for which the state (qd c, qdd c^2) is one Ruckig accepts: |qdd| <= qdd_max and
    |qd| + qdd^2 / (2 qddd_max) <= qd_max (the velocity reached while the acceleration ramps to 0)."""
    reach = np.abs(qd) + qdd**2 / (2.0 * limits.qddd_max)
    c_velocity = limits.qd_max / np.maximum(reach, 1e-300)
    c_acceleration = np.sqrt(limits.qdd_max / np.maximum(np.abs(qdd), 1e-300))
    return min(1.0, float(c_velocity.min()), float(c_acceleration.min())) * (1.0 - ADMISSIBLE_MARGIN)


def _guide_state(guide: Guide, k: int, limits: Limits):
    """(q, qd, qdd) at guide sample k: at rest at both ends, else scaled into Ruckig's admissible set."""
    if k in (0, len(guide.t) - 1):
        zero = np.zeros_like(guide.q[k])
        return guide.q[k], zero, zero
    c = admissible_scale(guide.qd[k], guide.qdd[k], limits)
    return guide.q[k], guide.qd[k] * c, guide.qdd[k] * c**2


def _segment(guide: Guide, table: PathTable, solver: SegmentSolver, limits: Limits, a: int, b: int):
    """Ruckig from guide sample a to b, and its largest distance from the path [rad]."""
    where = (f"the path segment from arc length {guide.sigma[a]:.6g} to {guide.sigma[b]:.6g} rad "
             f"(guide times {guide.t[a]:.4f} to {guide.t[b]:.4f} s)")
    trajectory = solver.solve(_guide_state(guide, a, limits), _guide_state(guide, b, limits), where)
    tau = np.linspace(0.0, trajectory.duration, DEVIATION_SAMPLES)
    points = np.array([trajectory.at_time(float(t))[0] for t in tau])
    span = guide.sigma[b] - guide.sigma[a]
    return trajectory, table.distance(points, guide.sigma[a] - span, guide.sigma[b] + span)


@dataclass(frozen=True, eq=False)
class PathFollowing:
    """Ruckig segments that follow the path: ``trajectories``, ``deviation`` [rad], ``rounds``,
    ``waypoints`` (guide sample indices, (K,))."""

    trajectories: list
    deviation: float
    rounds: int
    waypoints: np.ndarray


def follow_guide(guide: Guide, table: PathTable, solver: SegmentSolver, limits: Limits,
                 tolerance: float, max_rounds: int) -> PathFollowing:
    """Ruckig between guide samples INITIAL_SPACING apart; every segment farther than ``tolerance``
    [rad] from the path is halved, for up to ``max_rounds`` rounds. Raises TimingError if that fails."""
    last = len(guide.t) - 1
    spacing = max(int(round(INITIAL_SPACING / guide.t[1])), 1)
    marks = np.unique(np.append(np.arange(0, last, spacing), last))
    solved = {}
    for rounds in range(1, max_rounds + 1):
        pairs = list(zip(marks[:-1].tolist(), marks[1:].tolist()))
        for a, b in pairs:
            if (a, b) not in solved:
                solved[a, b] = _segment(guide, table, solver, limits, a, b)
        deviations = np.array([solved[pair][1] for pair in pairs])
        if deviations.max() <= tolerance:
            return PathFollowing([solved[pair][0] for pair in pairs], float(deviations.max()), rounds, marks)
        splits = [(a + b) // 2 for (a, b), deviation in zip(pairs, deviations)
                  if deviation > tolerance and b - a > 1]
        if not splits:
            break
        marks = np.union1d(marks, splits)
    raise TimingError(f"toppra+ruckig reached a path deviation of {deviations.max():.3g} rad, above the "
                      f"tolerance {tolerance:.3g} rad, after {rounds} rounds with {len(marks)} waypoints "
                      f"({int((deviations > tolerance).sum())} segments still above it); raise path_tolerance")


@dataclass(frozen=True)
class ToppraRuckigDetails(TimingDetails):
    """What toppra+ruckig did: ``path_tolerance``, the reached ``path_deviation`` and the deviation
    check's ``path_chord_error`` [rad]; ``toppra_duration_s`` [s] and ``duration_ratio_to_toppra`` [1];
    refinement ``rounds`` and the Ruckig ``waypoints`` they ended with; the guide's ``guide_duration_s``,
    ``guide_step_s``, ``guide_smoothing_window_s`` [s], ``guide_warp_rounds`` and ``guide_uniform_stretch``
    [1]; ``slowdowns`` of the guide; ``ruckig_segments_solved``, ``ruckig_compute_s_per_segment`` [s],
    ``ruckig_boundary_retries``; ``compute_s`` [s]; ``jerk_exact``: qddd is Ruckig's own jerk."""

    path_tolerance: float
    path_deviation: float
    path_chord_error: float
    toppra_duration_s: float
    duration_ratio_to_toppra: float
    rounds: int
    waypoints: int
    guide_duration_s: float
    guide_step_s: float
    guide_smoothing_window_s: float
    guide_warp_rounds: int
    guide_uniform_stretch: float
    slowdowns: int
    ruckig_segments_solved: int
    ruckig_compute_s_per_segment: float
    ruckig_boundary_retries: int
    compute_s: float
    jerk_exact: bool = True


def retime_toppra_ruckig(path: JointPath, limits: Limits, dt: float, joint_names: tuple[str, ...],
                         path_tolerance: float = DEFAULT_PATH_TOLERANCE, max_rounds: int = MAX_ROUNDS,
                         max_samples: int = DEFAULT_MAX_SAMPLES) -> Profile:
    """Jerk-limited profile within ``path_tolerance`` [rad] of ``path``, at rest at both ends, sampled
    every ``dt`` [s] and at every segment end (see the module doc). Raises TimingError when Ruckig
    fails or the tolerance is not met within ``max_rounds`` refinements (after MAX_SLOWDOWNS retries);
    ProfileSizeError, as soon as toppra's duration is known, when the profile or the guide would
    have more than ``max_samples`` samples."""
    require_jerk_limits(limits, "toppra+ruckig")
    if not np.isfinite(path_tolerance) or path_tolerance <= 0.0:
        raise TimingError(f"path_tolerance must be a positive number of radians, got {path_tolerance}")
    began = time.perf_counter()
    step = guide_step(limits, path_tolerance)
    solution = solve_toppra(path, limits)
    check_sample_count(solution.duration, dt, max_samples, "the profile (no shorter than toppra's)")
    check_sample_count(solution.duration, step, max_samples, "the toppra+ruckig guide")
    reference = sample_toppra(solution, limits, step, joint_names, max_samples)
    table = PathTable.for_tolerance(path, path_tolerance)
    guide = build_guide(reference, table, limits, step)
    solver = SegmentSolver(limits)
    for slowdowns in range(MAX_SLOWDOWNS + 1):
        try:
            following = follow_guide(guide, table, solver, limits, path_tolerance, max_rounds)
            break
        except TimingError as error:
            if slowdowns == MAX_SLOWDOWNS:
                raise TimingError(f"{error} (also with the guide slowed {slowdowns} times by {SLOWDOWN})") from error
            guide = guide.slowed(SLOWDOWN)
    duration = float(sum(trajectory.duration for trajectory in following.trajectories))
    details = ToppraRuckigDetails(
        path_tolerance=path_tolerance, path_deviation=following.deviation, path_chord_error=table.chord_error,
        toppra_duration_s=reference.duration, duration_ratio_to_toppra=duration / reference.duration,
        rounds=following.rounds, waypoints=int(len(following.waypoints)),
        guide_duration_s=float(guide.t[-1]), guide_step_s=step,
        guide_smoothing_window_s=float(np.max(limits.qdd_max / limits.qddd_max)),
        guide_warp_rounds=guide.warp_rounds, guide_uniform_stretch=guide.stretch, slowdowns=slowdowns,
        ruckig_segments_solved=solver.calls, ruckig_compute_s_per_segment=solver.compute_s / solver.calls,
        ruckig_boundary_retries=solver.boundary_retries, compute_s=time.perf_counter() - began)
    return profile_from_segments(following.trajectories, dt, "toppra+ruckig", limits, joint_names, details,
                                 max_samples)
