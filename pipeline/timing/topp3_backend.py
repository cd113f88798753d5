"""Jerk-limited path following: a third-order time parameterisation s(t) of the path itself (TOPP3).

The joint velocity, acceleration and jerk along a path q(s) are, by the chain rule,
``qd = q' sd``, ``qdd = q' sdd + q'' sd^2``, ``qddd = q' sddd + 3 q'' sd sdd + q''' sd^3``. copp-py
(Y. Wang, S. He, S. Lin, C. Hu, copp-py 0.2, MIT licence, https://github.com/TOPP-THU/copp: TOPP3
linearised into a second-order cone programme solved by Clarabel) finds the fastest s(t) within the
velocity, acceleration and jerk limits on a grid of stations: a TOPP2 (reachability analysis)
profile first, then TOPP3 linearised near it (``LINEARIZATION_SHARE``), with a small penalty on the total
variation of the joint accelerations (COPP3: without it the time-optimal jerk chatters between its limits
at the station rate). The profile follows the geometric path exactly: every sample is q(s(t)) on the path.

The SOCP's cost grows with its stations, so they go where they matter (``stations_for``,
``refined_stations``): a TOPP2 on FINE_PER_STATION times as many (copp's reachability analysis, about
1 ms) says where the motion spends its time; half the stations are spread evenly over that time, half
evenly over the waypoint segments, and an interval is split where the jerk the path's bends make at that
TOPP2 speed leaves a straight line between its ends. One COPP3 solve then does, on about half the stations
(it was three, on 401-4001 even stations: 1.1-3.2 s for 10 waypoints, now 0.1-0.2 s; 20 s for 30, now 1.5 s).

Between stations copp's profile has ``b = sdd`` linear in s and ``a = sd^2`` quadratic (``a' = 2 b``);
near a stop ``s - s0`` grows like ``c t^3``. We evaluate exactly that parameterisation ourselves
(so q, qd, qdd and qddd are consistent) and check it densely between stations, and between those samples
too (``hermite.joint_peaks_between``, ``jerk_peak``); where the jerk between stations exceeds the limit by
more than TIGHTEN_EXCESS, the stations next to it get that much tighter a limit and the problem is solved
again (TIGHTEN_ROUNDS); what is left is removed by slowing the whole trajectory uniformly by the smallest
factor k that brings it within the limits (velocity / k, acceleration / k^2, jerk / k^3), and k is reported.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..errors import TimingError
from ..files.choices import DEFAULT_MAX_SAMPLES
from ..files.robot_spec import Limits
from .hermite import joint_peaks_between
from .joint_path import JointPath
from .profile import Profile, TimingDetails
from .ruckig_backend import require_jerk_limits
from .schedule import LimitSchedule
from .tcp import PathLimits
from .toppra_backend import (ScaledPath, sample_times, scaled_inverse_dynamics, stretch_for, time_unit,
                             torque_stretch, with_points)

#: Stations per waypoint segment on average and at least, and the fewest and most stations of a path
#: before ``refined_stations`` splits intervals (the solve time grows about linearly with them). On the
#: benchmark's 10-waypoint paths MIN_STATIONS binds: 217-249 stations after splitting, durations 1.09-1.22x
#: toppra's; 24 a segment gave the same durations in 1.1x the time.
STATIONS_PER_SEGMENT = 20
MIN_STATIONS_PER_SEGMENT = 8
MIN_STATIONS = 201
MAX_STATIONS = 1001
#: Stations of the TOPP2 that places them, per station (at 1000 in all, a 30-waypoint path's intervals were
#: too short to be split and its jerk reached 2.3x the limit between stations), and the share of them spread
#: evenly over its time (the rest evenly over the waypoint segments; 0.3 and 0.7: durations up to 1 % longer) [1].
FINE_PER_STATION = 5
TIME_SHARE = 0.5
#: The share over time puts at most this many times its mean density of stations anywhere (near a stop,
#: where the motion is slowest, it would put them ever closer together: the irb1600's tool path of 36
#: IK samples failed numerically) [1].
MAX_TIME_DENSITY = 8.0
#: How far the jerk of the path's bends at the TOPP2 speed (over the jerk limit) may leave a straight line
#: over a station interval before ``refined_stations`` splits it (without it the dense check found jerks
#: 1.2-3x the limit between stations, near waypoints where a joint turns), and its rounds of splitting [1].
GEOMETRY_ERROR = 0.1
GEOMETRY_ROUNDS = 4
#: Weight of the total variation of the joint accelerations (each over its limit, summed over the
#: stations) against the duration, in units of the mean duration of a waypoint segment without a jerk
#: limit: without it the time-optimal jerk flips between its limits at the station rate. On bench timing's
#: paths (seed 0, 10 a robot, LINEARIZATION_SHARE 0.7, the jerk judged on the dense check's samples only),
#: duration over toppra's at the median and the most jerk reversals a joint-second, 10 waypoints / 6 waypoints:
#: 0.05 1.121x, 4.60 / 1.129x, 4.42; 0.045 1.110x, 4.65 / 1.117x, 4.47; 0.04 1.102x, 5.21 (over the goal of 5) /
#: 1.108x, 4.52.
SMOOTHING_SHARE = 0.045
#: The first COPP3 solve linearises its jerk rows at this share of the TOPP2's a = sd^2 [1]: copp replaces
#: each row's bound, convex in a, by its tangent there, stricter the farther a is from it, and the jerk-limited
#: speed is below the TOPP2's. On the paths above (SMOOTHING_SHARE 0.05) 1.0 gave 1.123x toppra's at the median,
#: 1.218x at most / 1.135x, 1.241x; 0.7 1.121x, 1.214x / 1.129x, 1.214x; on two 6-waypoint GP7 paths 0.7 saved
#: two thirds of what a second solve, linearised at the first one's answer, saves (at twice the cost).
LINEARIZATION_SHARE = 0.7
#: Clarabel's relative and absolute duality gap and its feasibility tolerance in copp's scaled units (its
#: defaults 1e-8 took 10-60 % more iterations for durations within 5e-4) [1]; a = sd^2 is of order
#: 1 there, so an a down to -SOLVER_FEASIBILITY is the round-off of a stop (0), and is set to 0; below it
#: the solution is refused.
SOLVER_GAP = 1e-6
SOLVER_FEASIBILITY = 1e-6
A_ROUNDOFF = SOLVER_FEASIBILITY
#: Rounds of tightening the jerk limit at stations next to intervals whose jerk exceeds it by more
#: than TIGHTEN_EXCESS between stations (each round one more solve; smaller excesses are left to the
#: uniform slow-down) [1].
TIGHTEN_ROUNDS = 1
TIGHTEN_EXCESS = 0.1
#: The wall-clock budget of copp's solves for one path [s]: a tightening round that would start after it is
#: skipped (the uniform slow-down then meets the jerk limit), and a first solve that runs out of it is a
#: TimingError that says what to change (a 30-waypoint path took 43-50 s before this bound).
SOLVE_BUDGET_S = 20.0
#: The largest uniform slow-down of copp's solution the back end accepts [1]: beyond it the solution is
#: not accurate enough between its stations (waypoints very close together), and the path is refused.
MAX_STRETCH = 4.0
#: The station just before a breakpoint, in units of the station interval that ends there (1e-3 of the
#: smallest interval of all left a tool move's jerk 5-35x its limit just before some breakpoints) [1].
BREAKPOINT_GAP = 0.05
#: A station of the spread gives way to a breakpoint or a schedule's bound closer than this share of its spacing [1].
STATION_CLEARANCE = 0.5
#: A station closer than this in s to a schedule's bound gives way to it (a bound 1e-17 from a breakpoint
#: would make an interval of nothing) [1].
MIN_STATION_GAP = 1e-10
#: Samples per station interval in the dense limit check; rounds of checking the output samples (a
#: slow-down moves them), and how much more than the measured excess each slow-down takes [1]
#: (certify allows 1e-6).
CHECK_SAMPLES_PER_INTERVAL = 48
#: How far inside a station interval the dense check's first and last samples of it are, in units of the
#: interval [1]: the jerk jumps at a station (a'' = d2(sd^2)/ds2 and, at the stationary ends, the law of
#: motion do), and each interval's samples see its own motion only.
INTERVAL_EDGE = 1e-9
#: Rounds of sampling again, REFINE_FACTOR times more densely, the station intervals where the jerk may rise
#: above the largest sample between the dense check's samples (``jerk_peak``) [1].
REFINE_ROUNDS = 2
REFINE_FACTOR = 8
OUTPUT_ROUNDS = 5
OUTPUT_MARGIN = 1e-7


@dataclass(frozen=True)
class Topp3Details(TimingDetails):
    """What the TOPP3 back end did: ``stations`` of the grid; ``topp2_s`` [s] the duration without a
    jerk limit on that grid and ``topp3_s`` [s] with it, before the slow-down; ``check_samples`` of the
    dense check, which found peaks ``station_peak_qd_ratio``, ``station_peak_qdd_ratio`` and
    ``station_peak_qddd_ratio`` [1] between stations; ``time_stretch`` [1] the uniform slow-down applied
    (1: none); ``path_deviation`` [rad or m]: 0, every sample is on the path; ``compute_s`` [s];
    ``jerk_exact`` True: qddd is the chain-rule jerk of the parameterisation, not a finite difference."""

    stations: int
    topp2_s: float
    topp3_s: float
    check_samples: int
    station_peak_qd_ratio: float
    station_peak_qdd_ratio: float
    station_peak_qddd_ratio: float
    time_stretch: float
    path_deviation: float
    compute_s: float
    jerk_exact: bool = True


def stations_for(path: JointPath, fine_s: np.ndarray, fine_t: np.ndarray, include=()) -> np.ndarray:
    """The station grid in s: ``station_count`` stations spread TIME_SHARE evenly over the time of a TOPP2 timing
    (``fine_t`` [s] at ``fine_s``: more stations where the motion is slow, near a stop or a sharp bend, at most
    MAX_TIME_DENSITY times their mean density) and the rest evenly over the waypoint segments (the path's pieces
    change over each segment's own length), with at least MIN_STATIONS_PER_SEGMENT in each (a short segment between
    two stops needs room to speed up and slow down); every breakpoint of the path is a station (``_clear_of``) and,
    where d3q/ds3 jumps there (a C2 path), so is a point just before it: each side's value must be limited at a
    station; and the points ``include`` (a schedule's bounds, where the limits change)."""
    knots = path.s_waypoints
    segments = len(knots) - 1
    total = station_count(path)
    by_segment = np.interp(fine_s, knots, np.linspace(0.0, 1.0, segments + 1))
    rate = np.minimum(np.diff(fine_t) / np.diff(fine_s) / fine_t[-1], MAX_TIME_DENSITY) * np.diff(fine_s)
    share = TIME_SHARE * np.concatenate([[0.0], np.cumsum(rate)]) / np.sum(rate) + (1.0 - TIME_SHARE) * by_segment
    spread = np.interp(np.linspace(0.0, 1.0, total + 1), share, fine_s)
    floor = [np.linspace(start, end, MIN_STATIONS_PER_SEGMENT + 1)[:-1] for start, end in zip(knots[:-1], knots[1:])
             if np.count_nonzero((spread >= start) & (spread < end)) < MIN_STATIONS_PER_SEGMENT]
    fixed = np.unique(np.concatenate([path.breakpoints, np.clip(include, 0.0, 1.0)]))
    stations = np.union1d(_clear_of(np.unique(np.concatenate([spread, *floor])), fixed), fixed)
    inner = path.breakpoints[1:-1] if path.continuity < 3 else path.breakpoints[:0]
    before = inner - BREAKPOINT_GAP * (inner - stations[np.searchsorted(stations, inner) - 1])
    return with_points(np.concatenate([stations, before]), include, MIN_STATION_GAP)


def station_count(path: JointPath) -> int:
    """STATIONS_PER_SEGMENT per waypoint segment within [MIN_STATIONS, MAX_STATIONS] (a tool move's joint path
    through dense IK samples counts as one segment)."""
    segments = 1 if path.shape == "samples" else len(path.waypoints) - 1
    return int(np.clip(STATIONS_PER_SEGMENT * segments, MIN_STATIONS, MAX_STATIONS))


def _clear_of(points: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """The sorted ``points`` (in s) without those closer to one of the sorted ``fixed`` points than
    STATION_CLEARANCE x their own spacing (the smaller of the gaps to their neighbours): an interval much
    shorter than its neighbours makes copp's jerk rows, a difference of sdd over the interval, ill-conditioned."""
    gaps = np.diff(points)
    spacing = np.minimum(np.append(gaps, np.inf), np.insert(gaps, 0, np.inf))
    index = np.clip(np.searchsorted(fixed, points), 1, len(fixed) - 1)
    nearest = np.minimum(np.abs(points - fixed[index - 1]), np.abs(points - fixed[index]))
    return points[nearest >= STATION_CLEARANCE * spacing]


def refined_stations(view: ScaledPath, scaled: Limits, s: np.ndarray, fine_s: np.ndarray,
                     fine_a: np.ndarray) -> np.ndarray:
    """The stations s with every interval split in two where the joint jerk that the path's bends alone make at
    the TOPP2 speed (|d3q/ds3| sd^3 / qddd_max, sd^2 = ``fine_a`` (n,) at ``fine_s`` (n,), in ``view``'s and
    ``scaled``'s units) is more than GEOMETRY_ERROR off a straight line between its ends on the fine points
    inside, up to GEOMETRY_ROUNDS times: copp limits the jerk at its stations only, and in between it follows
    the path's shape. Intervals of at most two fine spacings are left alone (the one just before a breakpoint
    of a C2 path would see the jump of d3q/ds3 there as an error)."""
    narrow = 2.0 * float(np.max(np.diff(fine_s)))
    joints = slice(0, view.path.dof)

    def jerk_of_bends(points: np.ndarray) -> np.ndarray:
        speed = np.sqrt(np.maximum(np.interp(points, fine_s, fine_a), 0.0))
        return np.abs(view(points, 3)[:, joints]) * speed[:, None] ** 3 / scaled.qddd_max[joints]

    fine_jerk = jerk_of_bends(fine_s)
    for _ in range(GEOMETRY_ROUNDS):
        station_jerk = jerk_of_bends(s)
        k = np.clip(np.searchsorted(s, fine_s, side="right") - 1, 0, len(s) - 2)
        u = ((fine_s - s[k]) / (s[k + 1] - s[k]))[:, None]
        error = np.abs(fine_jerk - (1.0 - u) * station_jerk[k] - u * station_jerk[k + 1]).max(axis=1)
        wide = np.diff(s)[k] > narrow
        over = np.unique(k[(fine_s > s[k]) & (fine_s < s[k + 1]) & wide & (error > GEOMETRY_ERROR)])
        if over.size == 0:
            break
        s = np.union1d(s, (s[over] + s[over + 1]) / 2.0)
    return s


@dataclass(frozen=True, eq=False)
class PathTiming:
    """copp's third-order profile on stations ``s`` (n,): ``a = sd^2`` (n,), ``b = sdd`` (n,), station
    times ``t`` (n,) [s], and ``stationary`` (start, end) intervals where s moves like c t^3."""

    s: np.ndarray
    a: np.ndarray
    b: np.ndarray
    t: np.ndarray
    stationary: tuple[int, int]

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def at(self, t: np.ndarray, stretch: float = 1.0):
        """s, sd, sdd, sddd at times t [s] of the profile slowed by ``stretch``, all from the one model copp
        integrates: a = sd^2 is the cubic Hermite interpolant in s of the stations' a with slope da/ds = 2 b
        there (so sd = sqrt(a), sdd = a'/2, sddd = a'' sd / 2, and copp's s(t) is its time integral), and
        in the stationary intervals at the ends s moves like c t^3 (``junction_consistent`` makes b meet
        it)."""
        import copp_py as copp

        tau = np.clip(np.asarray(t, dtype=float) / stretch, 0.0, self.duration)
        profile = copp.Profile3rd(self.a, self.b, self.stationary)
        inside = tau < self.duration
        s = np.full(tau.shape, self.s[-1])
        if inside.any():                             # copp wants strictly increasing times
            unique, back = np.unique(tau[inside], return_inverse=True)
            s[inside] = copp.interpolation.t_to_s_topp3_samples(self.s, profile, self.t, unique)[back]
        s = np.clip(s, self.s[0], self.s[-1])
        a, slope, curvature = hermite_a(self.s, self.a, self.b, s)
        sd = np.sqrt(np.maximum(a, 0.0))
        sdd = slope / 2.0
        sddd = curvature / 2.0 * sd
        head, tail = self.stationary
        if head:                                     # s = s0 + c t^3
            c = (self.s[head] - self.s[0]) / self.t[head] ** 3
            near = tau <= self.t[head]
            sd[near], sdd[near], sddd[near] = 3.0 * c * tau[near] ** 2, 6.0 * c * tau[near], 6.0 * c
        if tail:                                     # s = s_end - c (T - t)^3
            c = (self.s[-1] - self.s[-1 - tail]) / (self.duration - self.t[-1 - tail]) ** 3
            near = tau >= self.t[-1 - tail]
            left = self.duration - tau[near]
            sd[near], sdd[near], sddd[near] = 3.0 * c * left**2, -6.0 * c * left, 6.0 * c
        return s, sd / stretch, sdd / stretch**2, sddd / stretch**3

    def interval_times(self, per_interval: int, intervals=slice(None)) -> np.ndarray:
        """Times [s] (intervals, ``per_interval`` + 1) evenly over each of the station intervals ``intervals``
        (indices; all by default) from its start to its end, both INTERVAL_EDGE inside."""
        fractions = INTERVAL_EDGE + (1.0 - 2.0 * INTERVAL_EDGE) * np.arange(per_interval + 1) / per_interval
        return self.t[:-1][intervals, None] + np.diff(self.t)[intervals, None] * fractions

    def dense_times(self, per_interval: int) -> np.ndarray:
        """Times [s] of the dense check: ``interval_times(per_interval)``, then the end of the profile."""
        return np.append(self.interval_times(per_interval).ravel(), self.duration)


def joint_motion(path: JointPath, s, sd, sdd, sddd):
    """q, qd, qdd, qddd (n, dof) of the path at s moving with sd, sdd, sddd (the chain rule)."""
    d1, d2, d3 = path(s, 1), path(s, 2), path(s, 3)
    qd = d1 * sd[:, None]
    qdd = d1 * sdd[:, None] + d2 * (sd**2)[:, None]
    qddd = d1 * sddd[:, None] + 3.0 * d2 * (sd * sdd)[:, None] + d3 * (sd**3)[:, None]
    return path(s), qd, qdd, qddd


def _peak_ratios(qd, qdd, qddd, limits: Limits) -> tuple[float, float, float]:
    return (float((np.abs(qd) / limits.qd_max).max()), float((np.abs(qdd) / limits.qdd_max).max()),
            float((np.abs(qddd) / limits.qddd_max).max()))


def hermite_a(stations: np.ndarray, a: np.ndarray, b: np.ndarray, s: np.ndarray):
    """a, da/ds and d2a/ds2 at s of the cubic Hermite interpolant through the stations' a (n,) with slope
    da/ds = 2 b (n,) there: copp's third-order model of a = sd^2 between stations."""
    k = np.clip(np.searchsorted(stations, s, side="right") - 1, 0, len(stations) - 2)
    width = np.diff(stations)[k]
    u = (s - stations[k]) / width
    a0, a1, m0, m1 = a[k], a[k + 1], 2.0 * b[k] * width, 2.0 * b[k + 1] * width
    value = ((2 * u**3 - 3 * u**2 + 1) * a0 + (u**3 - 2 * u**2 + u) * m0 + (3 * u**2 - 2 * u**3) * a1
             + (u**3 - u**2) * m1)
    slope = ((6 * u**2 - 6 * u) * (a0 - a1) + (3 * u**2 - 4 * u + 1) * m0 + (3 * u**2 - 2 * u) * m1) / width
    curvature = ((12 * u - 6) * (a0 - a1) + (6 * u - 4) * m0 + (6 * u - 2) * m1) / width**2
    return value, slope, curvature


def without_roundoff(a: np.ndarray) -> np.ndarray:
    """a (a copy) with the values in [-A_ROUNDOFF, 0) (round-off of a stop) set to 0; lower ones stay."""
    a = np.array(a, dtype=float)
    a[(a < 0.0) & (a >= -A_ROUNDOFF)] = 0.0
    return a


def junction_consistent(s: np.ndarray, a: np.ndarray, b: np.ndarray, stationary: tuple[int, int]) -> np.ndarray:
    """b (a copy) with the station where each stationary end interval meets the rest given the sdd of
    copp's motion there (s - s0 = c t^3 has sdd = 2 a / (3 (s - s0)); at the end, minus that with s_end - s):
    copp fits that motion to a alone, so the solver's b there would make sdd, and so qdd, jump."""
    b = np.array(b, dtype=float)
    head, tail = stationary
    if head:
        b[head] = 2.0 * a[head] / (3.0 * (s[head] - s[0]))
    if tail:
        b[-1 - tail] = -2.0 * a[-1 - tail] / (3.0 * (s[-1] - s[-1 - tail]))
    return b


def _profile_timing(copp, s: np.ndarray, solved) -> PathTiming:
    """The timing of copp's solution ``solved`` (a Profile3rd) on stations s as one motion: a's round-off
    below 0 removed, b consistent with the stationary ends, a kept positive between stations (copp's
    ``force_positive_a``), then the station times."""
    stationary = tuple(solved.num_stationary)
    a = without_roundoff(solved.a)
    profile = copp.Profile3rd(a, junction_consistent(s, a, solved.b, stationary), stationary)
    profile.force_positive_a(s)
    _, t = copp.interpolation.s_to_t_topp3(s, profile, 0.0)
    timing = PathTiming(s, profile.a, profile.b, np.asarray(t), stationary)
    if not np.all(np.isfinite(timing.t)) or np.any(np.diff(timing.t) <= 0.0):
        raise TimingError(f"jerk-limited path timing (copp TOPP3) returned station times that do not increase "
                          f"({len(s)} stations)")
    return timing


def interval_jerk_ratios(timing: PathTiming, path: JointPath, limits: Limits) -> np.ndarray:
    """The peak |qddd| / qddd_max in each station interval, per joint (n - 1, dof), on
    CHECK_SAMPLES_PER_INTERVAL + 1 samples each (``PathTiming.interval_times``)."""
    t = timing.interval_times(CHECK_SAMPLES_PER_INTERVAL)
    qddd = joint_motion(path, *timing.at(t.ravel()))[3]
    return (np.abs(qddd) / limits.qddd_max).reshape(*t.shape, -1).max(axis=1)


def jerk_peak(timing: PathTiming, path: JointPath, limits: Limits, jerk: np.ndarray, per_interval: int,
              stretch: float) -> float:
    """The largest |qddd| / qddd_max [1] of the profile slowed by ``stretch``, between its samples too, from
    ``jerk`` (samples, dof), its qddd / qddd_max at ``timing.dense_times(per_interval)`` x ``stretch``. Inside a
    station interval the jerk is smooth, and where its second difference over the samples is at most D it rises
    at most D / 8 above the larger of two neighbouring samples (exactly so on a parabola); the intervals where
    that bound exceeds the largest sample are sampled REFINE_FACTOR times more densely, up to REFINE_ROUNDS
    times, and the bound of those still beyond it is the answer. (On the samples alone, the jerk of bench
    timing's third GP7 path at seed 0 reached 1.00002x its limit between them, and its profile of 20,001
    samples failed certify's mean-value test of qdd against qddd by 5e-6.)"""
    peak = float(np.abs(jerk).max())
    intervals = np.arange(len(timing.s) - 1)
    inside = jerk[:-1].reshape(len(intervals), per_interval + 1, -1)
    for done in range(REFINE_ROUNDS + 1):
        bound = (np.abs(inside).max(axis=1) + np.abs(np.diff(inside, 2, axis=1)).max(axis=1) / 8.0).max(axis=1)
        peak = max(peak, float(np.abs(inside).max()))
        beyond = bound > peak
        if not beyond.any() or done == REFINE_ROUNDS:
            return max(peak, float(bound.max()))
        intervals, per_interval = intervals[beyond], per_interval * REFINE_FACTOR
        t = timing.interval_times(per_interval, intervals) * stretch
        qddd = joint_motion(path, *timing.at(t.ravel(), stretch))[3]
        inside = (qddd / limits.qddd_max).reshape(*t.shape, -1)


def _slowed(timing: PathTiming, path: JointPath, t: np.ndarray, limits: PathLimits, torques,
            stretch: float, per_interval: int = 0) -> tuple[float, tuple]:
    """The uniform slow-down (at least ``stretch``) that keeps the motion at times t [s] of the profile
    slowed by ``stretch`` within ``limits`` (joint speeds x the schedule's factor, accelerations, jerks, and
    the TCP's speed and acceleration where limited: copp limits them at its stations, between them this
    slow-down does), torques included when ``torques`` is given; and that motion, (q, qd, qdd, qddd) (n, dof).
    With ``per_interval`` (t: the dense check's times, ``PathTiming.dense_times(per_interval)`` x ``stretch``)
    they are judged between the samples too: the joint speeds and accelerations by the cubic through their
    values and slopes (``hermite.joint_peaks_between``), the jerks by ``jerk_peak``: a bulge between samples is
    found, not sampled."""
    state = timing.at(t, stretch)
    motion = joint_motion(path, *state)
    speed, accel = limits.peaks(state[0], *motion[:3])
    jerk = motion[3] / limits.limits.qddd_max
    peak = float(np.abs(jerk).max())
    if per_interval:
        peaks = joint_peaks_between(state[0], *motion[1:], limits, 1, np.diff(t)[None, :] * stretch)
        speed, accel = max(speed, float(peaks[0][0])), max(accel, float(peaks[1][0]))
        peak = max(peak, jerk_peak(timing, path, limits.limits, jerk, per_interval, stretch))
    slowed = stretch_for((speed, accel, peak), stretch, OUTPUT_MARGIN)
    if torques is not None:
        slowed *= torque_stretch(*joint_motion(path, *timing.at(t, slowed))[:3], limits.limits, torques)
    return slowed, motion


def _copp_robot(copp, view: ScaledPath, scaled: Limits, s: np.ndarray, limits: PathLimits, unit: float,
                torques=None, full: bool = True):
    """A copp Robot of ``view`` on stations s with the joint speed limits x the schedule's factor at each and
    the acceleration limits (``scaled``: in the solver's units); with ``full`` also the jerk limits, the torque
    limits when ``torques`` (``scaled_inverse_dynamics``) is given, and the TCP's rows where limited."""
    n = len(s)
    robot = copp.Robot(view.dof, capacity=n, inverse_dynamics=torques if full else None)
    robot.append_s(s)
    robot.set_q(view(s), view(s, 1), view(s, 2), 0, dddq=view(s, 3))
    qd_max = scaled.qd_max * np.append(limits.at(s)[0][:, None] * np.ones(view.path.dof), np.ones((n, 1)), axis=1)
    robot.add_velocity_limits(qd_max, -qd_max, start_idx_s=0, length=n)
    robot.add_acceleration_limits(scaled.qdd_max, -scaled.qdd_max, start_idx_s=0, length=n)
    if not full:
        return robot
    robot.add_jerk_limits(scaled.qddd_max, -scaled.qddd_max, start_idx_s=0, length=n)
    if torques is not None:
        tau_max = np.append(limits.limits.tau_max, 1.0)
        robot.add_torque_limits(tau_max, -tau_max, start_idx_s=0, length=n)
    if limits.limits_tcp:
        from .tcp_constraint import add_copp_rows

        add_copp_rows(robot.constraints, limits.tcp, view.path, limits, unit, s)
    return robot


def _topp2(copp, robot, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """copp's TOPP2 (reachability analysis) on ``robot``'s stations s: (a = sd^2, station times) in its units."""
    a = copp.solver.topp2_ra.solve(copp.solver.topp2_ra.Problem(robot.constraints, idx_s_interval=(0, len(s) - 1),
                                                                a_boundary=(0.0, 0.0)), copp.solver.topp2_ra.Options())
    _, t = copp.interpolation.s_to_t_topp2(s, a, 0.0)
    return a, np.asarray(t)


def solve_topp3(path: JointPath, limits: PathLimits, inverse_dynamics=None) -> tuple[PathTiming, float]:
    """copp's TOPP2 on FINE_PER_STATION x ``station_count`` stations (where the motion spends its time:
    ``stations_for``, ``refined_stations``), then on the stations, then TOPP3 with a small total-variation penalty
    on the joint accelerations (COPP3, an SOCP) linearised at LINEARIZATION_SHARE of that TOPP2's a = sd^2, then
    (up to TIGHTEN_ROUNDS times, when the jerk between stations exceeds its limit by more than TIGHTEN_EXCESS)
    around its own answer with the jerk limit of every station next to such an interval tightened by that excess,
    with the schedule's bounds among the stations. ``limits`` (a PathLimits): the joint speed limits x the
    schedule's factor at each station; torques are limited too when ``tau_max`` and ``inverse_dynamics(Q, QD, QDD)
    -> TAU`` (batched) are given, and the TCP's speed and acceleration where they are limited
    (``tcp_constraint.add_copp_rows``). copp sees the path in units of its length and time in ``time_unit``s
    (``ScaledPath``, with its path speed caps; torques through ``scaled_inverse_dynamics``), and the timing is
    scaled back exactly. The finer TOPP2 has the joint speed and acceleration limits only (it places the
    stations). The solves share SOLVE_BUDGET_S. Returns (timing, TOPP2 duration [s]); TimingError saying what to
    change when copp fails."""
    import copp_py as copp

    distance = max(path.length, 1e-300)
    unit = time_unit(limits.limits, distance)
    view = ScaledPath(path, distance)
    scaled = view.limits(limits.limits, unit)
    bounds = () if limits.schedule is None else limits.schedule.bounds
    torques = None if inverse_dynamics is None else scaled_inverse_dynamics(inverse_dynamics, view, unit)
    fine = with_points(np.concatenate([np.linspace(0.0, 1.0, FINE_PER_STATION * station_count(path)),
                                       path.breakpoints]), bounds, MIN_STATION_GAP)
    s = fine
    started = time.perf_counter()
    try:
        fine_a, fine_t = _topp2(copp, _copp_robot(copp, view, scaled, fine, limits, unit, full=False), fine)
        s = refined_stations(view, scaled, stations_for(path, fine, fine_t, bounds), fine, fine_a)
        n = len(s)
        robot = _copp_robot(copp, view, scaled, s, limits, unit, torques)
        constraints = robot.constraints

        def real(profile) -> PathTiming:
            timing = _profile_timing(copp, s, profile)
            return PathTiming(s, timing.a * unit**2, timing.b * unit**2, timing.t / unit, timing.stationary)

        def solved(a_linearization, b_linearization=None):
            """One COPP3 solve within what is left of SOLVE_BUDGET_S (a_linearization without round-off)."""
            left = SOLVE_BUDGET_S - (time.perf_counter() - started)
            settings = copp.clarabel.ClarabelSettings(time_limit=max(left, 1e-3), tol_gap_rel=SOLVER_GAP,
                                                      tol_gap_abs=SOLVER_GAP, tol_feas=SOLVER_FEASIBILITY)
            options = copp.solver.copp3_socp.Options(allow_almost_solved=True, allow_insufficient_progress=True,
                                                     clarabel_settings=settings)
            return copp.solver.copp3_socp.solve(copp.solver.copp3_socp.Problem(
                robot, objectives, without_roundoff(a_linearization), b_linearization=b_linearization), options)

        a2, t2 = _topp2(copp, robot, s)
        constraints.amax_substitute(a2, 0)
        weight = SMOOTHING_SHARE * t2[-1] / (len(path.waypoints) - 1)
        objectives = [copp.objective.Time(1.0),
                      copp.objective.TotalVariationTorque(weight, np.append(1.0 / scaled.qdd_max[:-1], 0.0))]
        profile = solved(LINEARIZATION_SHARE * a2)
        jerk_max = np.tile(scaled.qddd_max, (n, 1))
        for _ in range(TIGHTEN_ROUNDS):
            excess = interval_jerk_ratios(real(profile), path, limits.limits)
            station_excess = np.maximum(np.vstack([excess, excess[-1:]]), np.vstack([excess[:1], excess]))
            if station_excess.max() <= 1.0 + TIGHTEN_EXCESS or time.perf_counter() - started >= SOLVE_BUDGET_S:
                break
            jerk_max[:, :-1] /= np.maximum(station_excess, 1.0)
            robot.add_jerk_limits(jerk_max, -jerk_max, start_idx_s=0, length=n)
            try:
                profile = solved(profile.a, profile.b)
            except copp.CoppError:
                break                                # keep the last solution: the slow-down meets the jerk limit
        return real(profile), float(t2[-1]) / unit
    except copp.CoppError as exc:
        spent = time.perf_counter() - started
        why = (f"its solver ran out of its {SOLVE_BUDGET_S:g} s budget" if spent >= SOLVE_BUDGET_S
               else "its solver failed numerically")
        raise TimingError(refusal(path, len(s), why, str(exc))) from exc


def refusal(path: JointPath, stations: int, why: str, solver_message: str = "") -> str:
    """A user-facing reason the jerk-limited timing of ``path`` failed: ``why``, the path's closest waypoints
    (the usual cause), what to change, then the solver's own message's first line."""
    gaps = np.linalg.norm(np.diff(path.waypoints, axis=0), axis=1)
    k = int(np.argmin(gaps))
    text = (f"jerk-limited path timing (topp3) found no profile for this path of {len(path.waypoints)} waypoints "
            f"({stations} stations): {why}. Its closest waypoints are {k + 1} and {k + 2}, {gaps[k]:.3g} apart "
            "[rad or m]; merge or spread waypoints that are very close together, use fewer waypoints, move them off "
            "the joint limits, or choose another timing method (toppra: no jerk limit; ruckig: waypoint to waypoint)")
    first_line = solver_message.strip().splitlines()[0] if solver_message.strip() else ""
    return f"{text} (copp: {first_line})" if first_line else text


def retime_topp3(path: JointPath, limits: Limits, dt: float, joint_names: tuple[str, ...],
                 inverse_dynamics=None, max_samples: int = DEFAULT_MAX_SAMPLES, tcp=None,
                 schedule: LimitSchedule | None = None) -> Profile:
    """Time-optimal jerk-limited profile along ``path`` (C2), at rest at both ends, sampled every
    ``dt`` [s] and at the end; torques limited too with ``inverse_dynamics`` and ``limits.tau_max``,
    the TCP's speed and acceleration with ``tcp``, and the ``schedule``'s joint speeds and TCP limits over
    s (scaled like ``limits``); the profile carries the schedule mapped to its time."""
    require_jerk_limits(limits, "topp3")
    if path.continuity < 2:
        raise TimingError(f"jerk-limited path following needs a C2 path (monotone or spline); the {path.shape} "
                          "path's d2q/ds2 jumps at its corners")
    start = time.perf_counter()
    torques = inverse_dynamics if limits.tau_max is not None else None
    judge = PathLimits(limits, tcp, schedule)
    timing, topp2_s = solve_topp3(path, judge, torques)
    check_t = timing.dense_times(CHECK_SAMPLES_PER_INTERVAL)
    stretch, checked = _slowed(timing, path, check_t, judge, torques, 1.0, CHECK_SAMPLES_PER_INTERVAL)
    peaks = _peak_ratios(*checked[1:], limits)
    if stretch > MAX_STRETCH:
        raise TimingError(refusal(path, len(timing.s), f"its solution would need slowing down {stretch:.3g} times "
                                  f"(at most {MAX_STRETCH:g}) to meet the limits between its stations"))
    t = sample_times(timing.duration * stretch, dt, max_samples)
    output_stretch, (q, qd, qdd, qddd) = _slowed(timing, path, t, judge, torques, stretch)
    for _ in range(OUTPUT_ROUNDS):             # the output samples are judged too: slow a little more
        if output_stretch <= stretch:
            break
        stretch = output_stretch
        t = sample_times(timing.duration * stretch, dt, max_samples)
        output_stretch, (q, qd, qdd, qddd) = _slowed(timing, path, t, judge, torques, stretch)
    details = Topp3Details(
        stations=len(timing.s), topp2_s=topp2_s, topp3_s=timing.duration, check_samples=int(check_t.size),
        station_peak_qd_ratio=peaks[0], station_peak_qdd_ratio=peaks[1], station_peak_qddd_ratio=peaks[2],
        time_stretch=stretch, path_deviation=0.0, compute_s=time.perf_counter() - start)
    mapped = None if schedule is None else schedule.mapped(timing.t[np.searchsorted(timing.s, np.clip(
        schedule.bounds, 0.0, 1.0))] * stretch)
    return Profile(t, q, qd, qdd, qddd, "topp3", limits, joint_names, details, schedule=mapped)
