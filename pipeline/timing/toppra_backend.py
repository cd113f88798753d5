"""Time-optimal path timing (TOPP-RA, the algorithm of toppra), certified between its grid points.

On a grid s_0 < ... < s_N the path velocity sd_i at each grid point and a constant path acceleration
u_i on each interval are found by TOPP-RA's two passes (``reachability``: compiled, about 40x faster
than toppra's own stepping in Python on the same grid and constraints, and the same answer). The joint
speeds bound sd^2 at every grid point; the joint accelerations ``q'(s) u + q''(s) sd^2`` (and the torques,
the TCP's acceleration) are limited at both ends of every interval, with the interval's own u, so between
grid points they stray only by the path's curvature within the interval. The grid holds every breakpoint of
the path, however close (``grid_for``), so the path is smooth inside every interval, and is denser where the
path bends (``bending_points``), where that curvature is large and where, on a uniform grid, toppra's
solution strays most and is slowest. We evaluate the constant-acceleration parameterisation exactly
(``s = s_i + sd_i tau + u_i tau^2 / 2``) and check it between grid points (``DenseCheck``: values and
time derivatives at three samples per interval and the cubic through them, which finds a smooth bulge
rather than sampling it); an interval that exceeds a limit by more than REFINE_EXCESS is split and the
grid solved again (up to REFINE_ROUNDS times); whatever excess is left is removed by slowing the whole
trajectory uniformly by the smallest factor k that brings every sample back (velocity / k,
acceleration / k^2), and k is reported. If no grid timing exists, the grid is refined and the solve
retried, and that is reported too. The path and the limits are normalised before the solver sees them
in units of the path's length and the move's natural time (``ScaledPath``, ``time_unit``: a speed scale
of 0.001 or a 1e-8 rad move would otherwise leave it with vanishing limits), and the result is scaled
back exactly.

Limits that change along the path (a ``LimitSchedule`` over s: joint speed factors, TCP speed and
acceleration per interval) constrain each grid point with that point's limits, the schedule's bounds are
grid points (so the time at each is exact), and the dense and output checks judge each sample by the
limits at its s (``tcp.PathLimits``; ``tcp_constraint``).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ..errors import ProfileSizeError, TimingError
from ..files.choices import DEFAULT_MAX_SAMPLES
from ..files.robot_spec import Limits
from .hermite import joint_peaks_between
from .joint_path import JointPath
from .profile import Profile, TimingDetails
from .reachability import canonical_rows, solve_rows
from .schedule import LimitSchedule
from .tcp import PathLimits

#: Grid points of the first solve where the path is straight (more where it bends: on the benchmark paths
#: 2,300-3,600 in all, the duration within 0.14 % of toppra's 10,000-point optimum; see
#: ``python -m pipeline bench timing``), and of the retries.
GRIDPOINTS = 1000
RETRY_GRIDPOINTS = (3000, 6000)
#: Grid points for the joint path of a tool move (through dense IK samples, shape ``samples``): on
#: 0.5 m lines of the GP7 the duration is within 1e-6 of the 2000-point solve's, at a quarter of the time.
SAMPLE_PATH_GRIDPOINTS = 500
#: Grid density floors: uniform points per waypoint segment, and points per smooth piece of the path.
POINTS_PER_SEGMENT = 60
POINTS_PER_PIECE = 8
#: Grid points per bending length of the path (``bending_points``), and the most points per unit of s, in
#: multiples of the grid's count (at a stop, where dq/ds vanishes, the bending length does too).
BEND_DENSITY = 60.0
MAX_DENSITY = 5.0
#: The points the grid adds between the path's breakpoints (``grid_for``) are at least this far apart and from
#: every breakpoint [1]: the solver meets its constraints to round-off, and on a shorter interval the path
#: acceleration u = (x1 - x0) / (2 ds) between two such x is noise.
MIN_GRID_GAP = 1e-7
#: Breakpoints of the path and a schedule's bounds closer than this in s are one grid point, a bound kept [1]:
#: the same point but for round-off (a schedule's bound 1.4e-17 from a breakpoint of the path made a grid
#: interval of nothing, a joint acceleration 2.6e8 times its limit there, and the piece was slowed 40,000
#: times). Farther apart, both are grid points, however close: a path whose waypoints end in steps of 1e-6 rad
#: (a sine's crest, 4,000 waypoints) has breakpoints 5e-8 apart in s, and a grid that dropped them jumped
#: over a reversal of joint 1 at full speed.
SAME_POINT_GAP = 1e-12
#: Caps of the path speed ds/dt, acceleration and jerk in the solvers' units (``ScaledPath``,
#: ``time_unit``: there they are about 1 on ordinary paths): they bind only where every joint nearly
#: stands still, and cost no measurable time there (larger caps leave the solvers ill-conditioned).
PATH_SPEED_CAP = 1e2
PATH_ACCELERATION_CAP = 1e4
PATH_JERK_CAP = 1e6
#: Where the dense check samples each grid interval, in fractions of its duration (the end a hair inside, so
#: that a jump of d2q/ds2 at a breakpoint is seen from both sides; ``DenseCheck``); the TCP's limits (a
#: Jacobian per sample) are checked on the middle samples (its speed and acceleration vary slowly along an
#: interval; the output samples are all checked).
CHECK_FRACTIONS = np.array([0.0, 0.5, 1.0 - 1e-9])
TCP_ROWS = slice(1, None, len(CHECK_FRACTIONS))
#: Slow down by this much more than the measured excess, so the check passes with room [1]; for the
#: output samples, rounds of checking them (a slow-down moves them) and their margin (certify allows 1e-6).
STRETCH_MARGIN = 1e-9
OUTPUT_ROUNDS = 5
OUTPUT_MARGIN = 1e-7
#: Rounds of splitting the grid intervals whose dense check exceeds a limit by more than
#: REFINE_EXCESS (smaller excesses are left to the uniform slow-down), the pieces each is split into,
#: and the largest grid refining may make, in multiples of the first grid.
REFINE_ROUNDS = 3
REFINE_EXCESS = 3e-4
REFINE_SPLIT = 4
REFINE_GROWTH = 4


class ScaledPath:
    """A JointPath as the solvers (toppra, copp) see it: over its own s in [0, 1], in units of
    ``distance`` [rad or m]
    (q / distance: with the path's length as the unit |dq/ds| is about 1 whatever the move's size, so
    a 1e-7 rad move is as well conditioned as a 3 rad one), and, with ``cap``, one more coordinate,
    s itself, whose velocity and acceleration limits (PATH_SPEED_CAP, PATH_ACCELERATION_CAP) bound the
    path speed where every joint nearly stands still (a waypoint where the path turns back, with
    dq/ds -> 0): there the joint limits allow path speeds near infinity and the solvers fail.
    """

    def __init__(self, path: JointPath, distance: float, cap: bool = True):
        self.path, self.distance, self.cap = path, distance, cap

    @property
    def dof(self) -> int:
        return self.path.dof + self.cap

    def __call__(self, s, order: int = 0) -> np.ndarray:
        q = self.path(s, order) / self.distance
        if not self.cap:
            return q
        extra = np.asarray(s, dtype=float) if order == 0 else np.full(np.shape(s), 1.0 if order == 1 else 0.0)
        return np.concatenate([q, extra[..., None]], axis=-1)

    def limits(self, limits: Limits, unit: float) -> Limits:
        """Joint limits for this view, with time in units of 1 / ``unit`` [1/s] (qd / (distance unit),
        qdd / (distance unit^2), qddd / (distance unit^3)), and the caps of the extra coordinate."""

        def scaled(values, order: int, cap: float):
            if values is None:
                return None
            return np.concatenate([values / (self.distance * unit**order), [cap] if self.cap else []])

        return Limits(limits.q_min, limits.q_max, scaled(limits.qd_max, 1, PATH_SPEED_CAP),
                      scaled(limits.qdd_max, 2, PATH_ACCELERATION_CAP), scaled(limits.qddd_max, 3, PATH_JERK_CAP),
                      limits.tau_max)


def grid_for(path: JointPath, count: int, include=()) -> np.ndarray:
    """Grid in s: every breakpoint of the path and the points ``include`` (a schedule's bounds, where the
    limits change), however close (``SAME_POINT_GAP``): inside every interval the path is smooth, so the
    solver's constraints at the interval's ends and the dense check between them see every change of its
    derivatives; each smooth piece split at least ``POINTS_PER_PIECE`` times (into pieces no shorter than
    MIN_GRID_GAP), so every interval is short and the dense check sees every acceleration peak; and
    ``count`` points (at least ``POINTS_PER_SEGMENT`` per waypoint segment), denser where the path bends
    (``bending_points``), those within MIN_GRID_GAP of another point left out."""
    ends = np.concatenate([[0.0], path.breakpoints, [1.0]])
    structural = _apart(with_points(ends, include, SAME_POINT_GAP), SAME_POINT_GAP)
    # A tool move's joint path passes through dense IK samples, not waypoints: no floor per segment.
    segments = 1 if path.shape == "samples" else len(path.waypoints) - 1
    spread = bending_points(path, max(count, POINTS_PER_SEGMENT * segments))
    width = np.diff(structural)
    splits = np.clip(np.floor(width / MIN_GRID_GAP), 1, POINTS_PER_PIECE).astype(int)
    piece = np.repeat(np.arange(len(width)), splits - 1)
    step = np.arange(len(piece)) - np.repeat(np.cumsum(splits - 1) - (splits - 1), splits - 1) + 1
    inside = structural[piece] + width[piece] * step / splits[piece]
    return with_points(spread, with_points(inside, structural, MIN_GRID_GAP), MIN_GRID_GAP)


def _apart(points: np.ndarray, gap: float) -> np.ndarray:
    """Sorted ``points`` without those within ``gap`` after the one before (the last point, the path's end,
    replaces the one before it instead)."""
    close = np.flatnonzero(np.diff(points) < gap)
    return np.delete(points, np.where(close + 2 == len(points), close, close + 1))


def bending_points(path: JointPath, count: int) -> np.ndarray:
    """Points in s from 0 to 1, ``count`` per unit of s where the path is straight and BEND_DENSITY per
    bending length where that is closer (up to MAX_DENSITY x ``count``, never closer than MIN_GRID_GAP): the
    length over which the path's direction or its curvature changes, the shorter of max|dq/ds| / max|d2q/ds2| and
    sqrt(max|dq/ds| / max|d3q/ds3|). The limits are met at both ends of every interval; between them the
    joint accelerations stray by about (ds / bending length)^2 / 8, and the discretised timing is slower
    than the optimum by about ds times the change of the path acceleration."""
    s = np.linspace(0.0, 1.0, count + 1)
    d1 = np.maximum(np.abs(path(s, 1)).max(axis=1), 1e-300)
    bending = np.maximum(np.abs(path(s, 2)).max(axis=1) / d1, np.sqrt(np.abs(path(s, 3)).max(axis=1) / d1))
    density = np.minimum(np.clip(BEND_DENSITY * bending, count, MAX_DENSITY * count), 1.0 / MIN_GRID_GAP)
    cumulative = np.concatenate([[0.0], np.cumsum((density[:-1] + density[1:]) / 2.0 * np.diff(s))])
    return np.interp(np.linspace(0.0, cumulative[-1], int(np.ceil(cumulative[-1])) + 1), cumulative, s)


def with_points(points: np.ndarray, include, gap: float) -> np.ndarray:
    """The sorted union of ``points`` and ``include`` (both in s, clipped to [0, 1]), where every point closer
    than ``gap`` to an included one gives way to it (a schedule's bound must be a point itself)."""
    points = np.unique(points)
    include = np.unique(np.clip(np.asarray(include, dtype=float), 0.0, 1.0))
    if include.size == 0:
        return points
    index = np.searchsorted(include, points)
    nearest = np.minimum(np.abs(points - include[np.maximum(index - 1, 0)]),
                         np.abs(points - include[np.minimum(index, len(include) - 1)]))
    return np.unique(np.concatenate([points[nearest >= gap], include]))


def _toppra_path(path: ScaledPath):
    """The path seen through toppra's geometric-path interface."""
    import toppra

    class Adapter(toppra.interpolator.AbstractGeometricPath):
        def __call__(self, path_positions, order=0):
            return path(path_positions, order)

        @property
        def dof(self):
            return path.dof

        @property
        def path_interval(self):
            return np.array([0.0, 1.0])

        @property
        def waypoints(self):
            return path.path.s_waypoints, path(path.path.s_waypoints)

    return Adapter()


def scaled_inverse_dynamics(inverse_dynamics, path: ScaledPath, unit: float):
    """``f(q, qd, qdd) -> tau`` for one state of ``path``'s coordinates in its units (1-D arrays, the
    path speed cap last) from the batched ``inverse_dynamics(Q, QD, QDD) -> TAU`` [N m or N]: the
    torque in real units, with the velocity and acceleration terms in ``unit``s of time (x unit^2) and
    gravity as it is, so that the solvers' torque rows a u + b sd^2 + c are the real torque [N m]."""
    dof, distance = path.path.dof, path.distance

    def torques(q, qd, qdd):
        q, qd, qdd = (np.asarray(x, dtype=float)[None, :dof] * distance for x in (q, qd, qdd))
        gravity = inverse_dynamics(q, np.zeros_like(q), np.zeros_like(q))[0]
        moving = inverse_dynamics(q, qd, qdd)[0] - gravity
        return np.append(gravity + unit**2 * moving, np.zeros(path.dof - dof))

    return torques


def toppra_instance(path: ScaledPath, limits: Limits, gridpoints: np.ndarray, torques=None, extra=()):
    """A toppra TOPPRA instance with joint velocity and acceleration constraints on the path (``limits``
    as ``path.limits`` gives them), torque constraints when ``torques`` (``scaled_inverse_dynamics``)
    is given with ``limits.tau_max``, and the ``extra`` constraints (the TCP's)."""
    import toppra.algorithm
    import toppra.constraint

    constraints = [
        toppra.constraint.JointVelocityConstraint(np.stack([-limits.qd_max, limits.qd_max], axis=1)),
        toppra.constraint.JointAccelerationConstraint(np.stack([-limits.qdd_max, limits.qdd_max], axis=1)),
    ]
    if torques is not None:
        tau_max = np.append(limits.tau_max, np.ones(path.dof - path.path.dof))
        constraints.append(toppra.constraint.JointTorqueConstraint(
            torques, np.stack([-tau_max, tau_max], axis=1), np.zeros(path.dof)))
    constraints += list(extra)
    return toppra.algorithm.TOPPRA(constraints, _toppra_path(path), gridpoints=gridpoints,
                                   parametrizer="ParametrizeConstAccel")


@dataclass(frozen=True, eq=False)
class GridTiming:
    """A constant-path-acceleration timing: grid ``s`` (N+1,) in the path's parameter, ``sd`` (N+1,),
    ``u`` (N,), times ``t`` (N+1,) [s]."""

    s: np.ndarray
    sd: np.ndarray
    u: np.ndarray
    t: np.ndarray

    @classmethod
    def from_grid(cls, s: np.ndarray, sd: np.ndarray) -> "GridTiming":
        ds = np.diff(s)
        sd = np.maximum(sd, 0.0)
        u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * ds)            # consistent with sd at both ends
        dt = 2.0 * ds / (sd[:-1] + sd[1:])
        return cls(s, sd, u, np.concatenate([[0.0], np.cumsum(dt)]))

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def at(self, path: JointPath, t: np.ndarray, stretch: float = 1.0, jerk: bool = False, position: bool = True):
        """s, q (None without ``position``), qd, qdd (and with ``jerk`` qddd, inside each interval
        d3q/ds3 sd^3 + 3 d2q/ds2 sd u) at times t [s] of the trajectory slowed by ``stretch`` (time x stretch)."""
        tau_total = np.clip(t / stretch, 0.0, self.duration)
        i = np.clip(np.searchsorted(self.t, tau_total, side="right") - 1, 0, len(self.u) - 1)
        tau = tau_total - self.t[i]
        u = self.u[i]
        # Stay inside the interval: at a breakpoint d2q/ds2 may jump, and only its own side is consistent with u.
        s = np.minimum(self.s[i] + self.sd[i] * tau + 0.5 * u * tau**2, np.nextafter(self.s[i + 1], -np.inf))
        sd = self.sd[i] + u * tau
        d1, d2 = path(s, 1), path(s, 2)
        qd = d1 * sd[:, None] / stretch
        qdd = (d1 * u[:, None] + d2 * (sd**2)[:, None]) / stretch**2
        q = path(s) if position else None
        if not jerk:
            return s, q, qd, qdd
        return s, q, qd, qdd, (path(s, 3) * (sd**3)[:, None] + 3.0 * d2 * (sd * u)[:, None]) / stretch**3

    def times_of(self, points: np.ndarray) -> np.ndarray:
        """The times [s] at which the timing passes ``points`` (m,), grid points of its s (a schedule's
        bounds are on every grid)."""
        index = np.searchsorted(self.s, np.clip(points, 0.0, 1.0))
        return self.t[np.minimum(index, len(self.s) - 1)]

    def times_inside(self, fractions: np.ndarray) -> np.ndarray:
        """The times [s] at ``fractions`` (k,) of every grid interval's duration, interval by interval."""
        return (self.t[:-1, None] + np.diff(self.t)[:, None] * fractions).ravel()


def solve_grid_timing(path: ScaledPath, limits: Limits, grid, torques=None, extra=()) -> GridTiming | None:
    """The time-optimal timing on ``grid`` (s values, or a point count for ``grid_for``) as a GridTiming in
    the time unit of ``limits`` (as ``path.limits`` gives them), or None when no timing meets them on it.

    TOPP-RA (``reachability``) with the joint speeds bounding sd^2 at every grid point and the joint
    accelerations limited at both ends of every interval (at s_{i+1} with the interval's own u_i and
    x_i + 2 ds u_i, and d2q/ds2 from the interval's side), so that between grid points they stray only
    by the path's curvature within an interval; torques (``scaled_inverse_dynamics``, by toppra's torque
    constraint) at both ends too, and the ``extra`` constraints (the TCP's, a schedule's joint speeds,
    ``tcp_constraint``) in toppra's canonical form."""
    s = grid_for(path.path, grid) if np.isscalar(grid) else np.asarray(grid, dtype=float)
    d1, d2 = path(s, 1), path(s, 2)
    end1, end2 = d1[1:].copy(), d2[1:].copy()
    jumps = np.flatnonzero(np.isin(s[1:], path.path.breakpoints[1:-1]))       # the interval's side of s_{i+1}
    if jumps.size:
        left = np.nextafter(s[1:][jumps], -np.inf)
        end1[jumps], end2[jumps] = path(left, 1), path(left, 2)
    end1 += 2.0 * np.diff(s)[:, None] * end2
    alpha, beta = [np.hstack([d1[:-1], -d1[:-1], end1, -end1])], [np.hstack([d2[:-1], -d2[:-1], end2, -end2])]
    gamma = [np.tile(limits.qdd_max, (len(end1), 4))]
    with np.errstate(divide="ignore", over="ignore"):       # an axis still (or nearly) there bounds nothing: inf
        x_hi = np.min((limits.qd_max / np.abs(d1)) ** 2, axis=1)
    x_lo = np.zeros_like(x_hi)
    constraints = [(constraint, path) for constraint in extra]
    if torques is not None:
        import toppra.constraint            # its torque rows (inverse dynamics per grid point); toppra imports pyplot

        tau_max = np.append(limits.tau_max, np.ones(path.dof - path.path.dof))
        constraints.append((toppra.constraint.JointTorqueConstraint(
            torques, np.stack([-tau_max, tau_max], axis=1), np.zeros(path.dof),
            discretization_scheme=toppra.constraint.DiscretizationType.Interpolation), _toppra_path(path)))
    for constraint, seen_as in constraints:
        rows, xbound = canonical_rows(constraint, seen_as, s)
        if rows is not None:
            for stacked, row in zip((alpha, beta, gamma), rows):
                stacked.append(row)
        if xbound is not None:
            x_lo, x_hi = np.maximum(x_lo, xbound[:, 0]), np.minimum(x_hi, xbound[:, 1])
    x, _ = solve_rows(s, *(parts[0] if len(parts) == 1 else np.hstack(parts) for parts in (alpha, beta, gamma)),
                      x_lo, x_hi)
    if x is None:
        return None
    return GridTiming.from_grid(s, np.sqrt(np.maximum(x, 0.0)))


def time_unit(limits: Limits, distance: float) -> float:
    """1 / T [1/s] for T the time a move of ``distance`` [rad or m] takes at the median limits, the
    longest of distance / qd, sqrt(distance / qdd) and cbrt(distance / qddd): in units of T and of the
    distance, the limits a solver sees are all >= about 1 and none is tiny, whatever the move's size
    and the speed scale (1e-9 rad at 0.001 x the limits as well as 3 rad at 1)."""
    times = [distance / np.median(limits.qd_max)]
    times += [np.sqrt(distance / np.median(limits.qdd_max))] if limits.qdd_max is not None else []
    times += [np.cbrt(distance / np.median(limits.qddd_max))] if limits.qddd_max is not None else []
    return 1.0 / float(max(times))


@dataclass(frozen=True, eq=False)
class DenseCheck:
    """How far a timing strays from the limits inside its grid intervals: samples at the start, middle and
    end of every interval (``samples``: s, q or None, qd, qdd at them), and between them, for each joint, the
    largest |speed| and |acceleration| ratio of the cubic in time through the ratios and their time
    derivatives (acceleration and jerk) at the samples (``hermite.joint_peaks_between``: exact for a cubic, so a
    smooth bulge between samples is found, not sampled); the TCP's ratios at the middle samples. Per interval the
    largest ratio (``interval_ratios`` (N,) [1]) and over all the peaks (``peaks``: speed, acceleration [1])."""

    samples: tuple
    interval_ratios: np.ndarray
    peaks: tuple[float, float]

    @classmethod
    def of(cls, timing: GridTiming, path: JointPath, limits: PathLimits, positions: bool) -> "DenseCheck":
        """The check of ``timing``; the samples' q only with ``positions`` (the TCP's limits need them)."""
        n = len(timing.u)
        *samples, qddd = timing.at(path, timing.times_inside(CHECK_FRACTIONS), jerk=True,
                                   position=positions or limits.limits_tcp)
        s, _, qd, qdd = samples
        step = np.diff(timing.t)[:, None] * np.diff(CHECK_FRACTIONS)                      # (N, k - 1) [s]
        speed, accel = joint_peaks_between(s, qd, qdd, qddd, limits, n, step)
        if limits.limits_tcp:
            tcp_speed, tcp_accel = limits.sample_ratios(*samples, tcp_rows=TCP_ROWS)
            speed, accel = np.maximum(speed, tcp_speed[TCP_ROWS]), np.maximum(accel, tcp_accel[TCP_ROWS])
        return cls(tuple(samples), np.maximum(speed, accel), (float(speed.max()), float(accel.max())))

    def refined(self, timing: GridTiming) -> np.ndarray | None:
        """``timing``'s grid with every interval that exceeds a limit by more than REFINE_EXCESS split in
        REFINE_SPLIT (None: no interval does)."""
        over = self.interval_ratios > 1.0 + REFINE_EXCESS
        if not over.any():
            return None
        lo, width = timing.s[:-1][over], np.diff(timing.s)[over]
        added = lo[:, None] + width[:, None] * np.arange(1, REFINE_SPLIT) / REFINE_SPLIT
        return np.unique(np.concatenate([timing.s, added.ravel()]))


def _solve_refined(path: JointPath, limits: PathLimits, gridpoints: int, inverse_dynamics=None):
    """(GridTiming [s], retried grid sizes, its DenseCheck) with up to REFINE_ROUNDS of splitting the
    intervals the dense check finds over a limit and solving again (without torques); TimingError when
    no grid has a solution. The solver sees the path in units of its length and time in units of
    ``time_unit``, and the timing is scaled back exactly. A schedule's bounds are on every grid, its joint
    speeds and the TCP's limits constrain each grid point."""
    distance = max(path.length, 1e-300)
    unit = time_unit(limits.limits, distance)
    view = ScaledPath(path, distance)
    scaled = view.limits(limits.limits, unit)
    torques = None if inverse_dynamics is None else scaled_inverse_dynamics(inverse_dynamics, view, unit)
    extra = _extra_constraints(path, view, scaled, limits, unit)
    bounds = () if limits.schedule is None else limits.schedule.bounds

    def real(timing: GridTiming) -> GridTiming:
        return GridTiming(timing.s, timing.sd * unit, timing.u * unit**2, timing.t / unit)

    attempts = [gridpoints, *[g for g in RETRY_GRIDPOINTS if g > gridpoints]]
    for used in attempts:
        timing = solve_grid_timing(view, scaled, grid_for(path, used, bounds), torques, extra)
        if timing is not None:
            break
    else:
        raise TimingError(f"no feasible time parameterisation on {attempts} grid points "
                          f"(path through {len(path.waypoints)} waypoints)")
    timing = real(timing)
    largest = REFINE_GROWTH * len(timing.s)
    check = DenseCheck.of(timing, path, limits, positions=inverse_dynamics is not None)
    for _ in range(REFINE_ROUNDS if inverse_dynamics is None else 0):
        grid = check.refined(timing)
        refined = None if grid is None or len(grid) > largest else solve_grid_timing(view, scaled, grid, extra=extra)
        if refined is None:
            break
        timing = real(refined)
        check = DenseCheck.of(timing, path, limits, positions=inverse_dynamics is not None)
    return timing, tuple(attempts[: attempts.index(used)]), check


def _extra_constraints(path: JointPath, view: ScaledPath, scaled: Limits, limits: PathLimits, unit: float) -> tuple:
    """The constraints beyond the joints' own (``scaled``: their limits in the solver's units): the TCP's
    where ``limits`` limit it, the schedule's joint speeds where it slows them."""
    from .tcp_constraint import TcpConstraint, VaryingSpeedConstraint

    extra = []
    if limits.limits_tcp:
        extra.append(TcpConstraint(limits.tcp, path, limits, unit, view.dof))
    if limits.schedule is not None and np.any(limits.schedule.joint_speed < 1.0):
        extra.append(VaryingSpeedConstraint(scaled.qd_max, limits))
    return tuple(extra)


@dataclass(frozen=True)
class ToppraDetails(TimingDetails):
    """What the toppra back end did: ``gridpoints`` of the solve that succeeded, after the
    ``retried_gridpoints`` that failed; ``optimal_on_grid_s`` [s] its duration; ``check_samples`` of
    the dense check, which found peaks ``grid_peak_qd_ratio`` and ``grid_peak_qdd_ratio`` [1] between grid
    points; ``time_stretch`` [1] the uniform slow-down applied (1: none); ``compute_s`` [s];
    ``jerk_exact`` False: qddd is the finite difference of qdd (jerk is not limited)."""

    gridpoints: int
    retried_gridpoints: tuple[int, ...]
    optimal_on_grid_s: float
    check_samples: int
    grid_peak_qd_ratio: float
    grid_peak_qdd_ratio: float
    time_stretch: float
    compute_s: float
    jerk_exact: bool = False


@dataclass(frozen=True, eq=False)
class ToppraSolution:
    """toppra's grid timing along ``path`` within ``limits`` (a PathLimits), slowed uniformly by ``stretch``
    [1] so that its dense check (``check_samples`` samples, peaks ``grid_peak_ratios`` (qd, qdd) [1]) passes;
    ``solve_s`` [s]."""

    path: JointPath
    limits: PathLimits
    grid: GridTiming
    stretch: float
    retried_gridpoints: tuple[int, ...]
    check_samples: int
    grid_peak_ratios: tuple[float, float]
    solve_s: float

    @property
    def duration(self) -> float:
        """[s]"""
        return self.grid.duration * self.stretch


def solve_toppra(path: JointPath, limits: Limits, gridpoints: int | None = None,
                 inverse_dynamics=None, tcp=None, schedule: LimitSchedule | None = None) -> ToppraSolution:
    """Time-optimal timing along ``path`` within qd_max and qdd_max (and tau_max through
    ``inverse_dynamics(Q, QD, QDD) -> TAU``, batched [N m], when the limits have it; the TCP's speed and
    acceleration limits through ``tcp``, a TcpMotion, when the limits or the schedule have them; the
    ``schedule``'s joint speeds over s, scaled like ``limits``), checked densely between grid points; no
    samples yet. Raises TimingError when toppra fails on every grid."""
    torques = inverse_dynamics if limits.tau_max is not None else None
    if limits.qdd_max is None:
        raise TimingError("toppra needs acceleration limits (qdd_max) for every joint")
    gridpoints = gridpoints or (SAMPLE_PATH_GRIDPOINTS if path.shape == "samples" else GRIDPOINTS)
    start = time.perf_counter()
    if torques is not None:
        q_grid = path(grid_for(path, gridpoints))
        check_holding_torques(q_grid, torques(q_grid, np.zeros_like(q_grid), np.zeros_like(q_grid)), limits)
    judge = PathLimits(limits, tcp, schedule)
    timing, retried, check = _solve_refined(path, judge, gridpoints, torques)
    stretch = stretch_for(check.peaks, 1.0)
    if torques is not None:
        stretch = max(stretch, torque_stretch(*check.samples[1:], limits, torques))
    return ToppraSolution(path, judge, timing, stretch, retried, len(check.samples[0]), check.peaks,
                          time.perf_counter() - start)


def sample_toppra(solution: ToppraSolution, dt: float, joint_names: tuple[str, ...],
                  max_samples: int = DEFAULT_MAX_SAMPLES) -> Profile:
    """The solution sampled every ``dt`` [s] (and at the end); slowed a little more if an output
    sample exceeds a limit. Raises ProfileSizeError before sampling more than ``max_samples``. The
    profile carries the schedule mapped to its time."""
    start = time.perf_counter()
    path, timing, stretch, limits = solution.path, solution.grid, solution.stretch, solution.limits
    t = sample_times(timing.duration * stretch, dt, max_samples)
    s, q, qd, qdd = timing.at(path, t, stretch)
    # The output samples are judged too (certify() reads them): stretch more while one of them exceeds
    # (a slow-down moves the samples, so each round checks the new ones).
    for _ in range(OUTPUT_ROUNDS):
        output_ratios = limits.peaks(s, q, qd, qdd)
        if max(output_ratios) <= 1.0:
            break
        stretch = stretch_for(output_ratios, stretch, OUTPUT_MARGIN)
        t = sample_times(timing.duration * stretch, dt, max_samples)
        s, q, qd, qdd = timing.at(path, t, stretch)
    details = ToppraDetails(
        gridpoints=int(len(timing.s)), retried_gridpoints=solution.retried_gridpoints,
        optimal_on_grid_s=timing.duration, check_samples=solution.check_samples,
        grid_peak_qd_ratio=solution.grid_peak_ratios[0], grid_peak_qdd_ratio=solution.grid_peak_ratios[1],
        time_stretch=stretch, compute_s=solution.solve_s + time.perf_counter() - start)
    timed_limits = dataclasses.replace(limits.limits, qddd_max=None)
    schedule = None if limits.schedule is None else limits.schedule.mapped(timing.times_of(limits.schedule.bounds)
                                                                           * stretch)
    return Profile(t, q, qd, qdd, np.gradient(qdd, t, axis=0), "toppra", timed_limits, joint_names, details,
                   schedule=schedule)


def retime_toppra(path: JointPath, limits: Limits, dt: float, joint_names: tuple[str, ...],
                  gridpoints: int | None = None, inverse_dynamics=None,
                  max_samples: int = DEFAULT_MAX_SAMPLES, tcp=None, schedule: LimitSchedule | None = None) -> Profile:
    """Time-optimal profile along ``path``, at rest at both ends, sampled every ``dt`` [s]:
    ``solve_toppra`` then ``sample_toppra``."""
    return sample_toppra(solve_toppra(path, limits, gridpoints, inverse_dynamics, tcp, schedule), dt, joint_names,
                         max_samples)


def check_holding_torques(q: np.ndarray, static: np.ndarray, limits: Limits) -> None:
    """Raise TimingError if the gravity torque alone at some sample exceeds tau_max."""
    over = np.abs(static) >= limits.tau_max
    if over.any():
        k, j = np.argwhere(over)[0]
        raise TimingError(f"joint {j + 1} needs {abs(static[k, j]):.4g} N m just to hold the path at q = "
                          f"{np.round(q[k], 4).tolist()} rad, over its torque limit {limits.tau_max[j]:.4g} N m")


def torque_stretch(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, limits: Limits, torques) -> float:
    """The time stretch k that keeps every torque sample within tau_max [1].

    Slowing by k scales the velocity-dependent and inertial torques d by 1/k^2 and leaves the
    static (gravity) torque g alone, so k^2 >= d / (tau_max - g) where d > 0, -d / (tau_max + g) where d < 0.
    """
    static = torques(q, np.zeros_like(q), np.zeros_like(q))
    check_holding_torques(q, static, limits)
    dynamic = torques(q, qd, qdd) - static
    room = np.where(dynamic > 0.0, limits.tau_max - static, limits.tau_max + static)
    k_squared = float(np.max(np.abs(dynamic) / room))
    return float(np.sqrt(k_squared)) * (1.0 + STRETCH_MARGIN) if k_squared > 1.0 else 1.0


def stretch_for(ratios, stretch: float, margin: float = STRETCH_MARGIN) -> float:
    """The time stretch that brings peak ratios (velocity, acceleration[, jerk]) measured at
    ``stretch`` down to 1 (at least ``stretch``), ``margin`` [1] more: a slow-down by k divides the
    n-th time derivative by k^n."""
    factor = max(1.0, *(ratio ** (1.0 / order) for order, ratio in enumerate(ratios, start=1)))
    return stretch * factor * (1.0 + margin) if factor > 1.0 else stretch


def check_sample_count(duration: float, dt: float, max_samples: int, what: str = "the profile",
                       extra: int = 0) -> None:
    """Raise ProfileSizeError when ``what``, lasting ``duration`` [s] and sampled every ``dt`` [s] (and
    at ``extra`` more instants), could have more than ``max_samples`` samples: checked before any array
    of that size exists."""
    count = duration / dt + 2.0 + extra            # sample_times' count, at most, and the extra ones
    if not count <= max_samples:
        raise ProfileSizeError(
            f"{what} would last {duration:.6g} s; sampled every dt = {dt:g} s that is {count:,.0f} samples, "
            f"above the limit of {max_samples:,}: raise the limit (--max-samples, or max_samples=...) or "
            "use a larger dt or speed_scale")


def sample_times(duration: float, dt: float, max_samples: int = DEFAULT_MAX_SAMPLES) -> np.ndarray:
    """0, dt, 2 dt, ... and the end time itself [s]; ProfileSizeError beyond ``max_samples``."""
    check_sample_count(duration, dt, max_samples)
    t = np.arange(0.0, duration, dt)
    if t.size == 0:                                # no duration: the one sample at 0
        return np.zeros(1)
    return np.append(t, duration) if duration - t[-1] > 1e-12 else t
