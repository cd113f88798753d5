"""Jerk-limited path following: a third-order time parameterisation s(t) of the path itself (TOPP3).

The joint velocity, acceleration and jerk along a path q(s) are, by the chain rule,
``qd = q' sd``, ``qdd = q' sdd + q'' sd^2``, ``qddd = q' sddd + 3 q'' sd sdd + q''' sd^3``. copp-py
(Y. Wang, S. He, S. Lin, C. Hu, copp-py 0.2, MIT licence, https://github.com/TOPP-THU/copp: TOPP3
linearised into a second-order cone programme solved by Clarabel) finds the fastest s(t) within the
velocity, acceleration and jerk limits on a grid of stations: a TOPP2 (reachability analysis)
profile first, then TOPP3 linearised around it, with a small penalty on the total variation of the
joint accelerations (COPP3: without it the time-optimal jerk chatters between its limits at the
station rate), then again around its own answer. The profile follows the geometric path exactly:
every sample is q(s(t)) on the path.

Between stations copp's profile has ``b = sdd`` linear in s and ``a = sd^2`` quadratic (``a' = 2 b``);
near a stop ``s - s0`` grows like ``c t^3``. We evaluate exactly that parameterisation ourselves
(so q, qd, qdd and qddd are consistent) and check it densely between stations; stations next to an
interval whose jerk exceeds the limit get that much tighter a limit and the problem is solved again
(TIGHTEN_ROUNDS); what is left is removed by slowing the whole trajectory uniformly by the smallest
factor k that brings every sample within the limits (velocity / k, acceleration / k^2, jerk / k^3),
and k is reported.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..choices import DEFAULT_MAX_SAMPLES
from ..errors import TimingError
from ..path import JointPath
from ..profile import Profile, TimingDetails
from ..robot_spec import Limits
from ..schedule import LimitSchedule
from ..tcp import PathLimits
from .ruckig_backend import require_jerk_limits
from .toppra_backend import (ScaledPath, sample_times, scaled_inverse_dynamics, stretch_for, time_unit,
                             torque_stretch, with_points)

#: Stations per waypoint segment on average and at least, and the fewest and most stations of a path
#: (the solve time grows about linearly with them: 0.3-2 s for a 10-waypoint path, ~15 s for 60
#: waypoints, 2 cores). Paths of few segments get at least MIN_STATIONS: at 201 the 4-segment LR Mate
#: demo needed three rounds of jerk tightening and its jerk reversed 7.2 times a second; at 401 none
#: and 6.1, in a third of the time.
STATIONS_PER_SEGMENT = 60
MIN_STATIONS_PER_SEGMENT = 16
MIN_STATIONS = 401
MAX_STATIONS = 4001
#: Weight of the total variation of the joint accelerations (each over its limit, summed over the
#: stations) against the duration, in units of the mean duration of a waypoint segment without a jerk
#: limit: without it the time-optimal jerk flips between its limits at the station rate.
SMOOTHING_SHARE = 0.05
#: Rounds of tightening the jerk limit at stations next to intervals whose jerk exceeds it by more
#: than TIGHTEN_EXCESS between stations (each round one more solve) [1].
TIGHTEN_ROUNDS = 3
TIGHTEN_EXCESS = 2e-3
#: The wall-clock budget of copp's solves for one path [s]: a tightening round that would start after it is
#: skipped (the uniform slow-down then meets the jerk limit), and a first solve that runs out of it is a
#: TimingError that says what to change (a 30-waypoint path took 43-50 s before this bound).
SOLVE_BUDGET_S = 20.0
#: The largest uniform slow-down of copp's solution the back end accepts [1]: beyond it the solution is
#: not accurate enough between its stations (waypoints very close together), and the path is refused.
MAX_STRETCH = 4.0
#: copp's solutions meet their constraints to Clarabel's feasibility tolerance (1e-8) in copp's scaled
#: units, where a = sd^2 is of order 1: an a down to -this is the round-off of a stop (0), and is set to 0;
#: below it the solution is refused [1].
A_ROUNDOFF = 1e-8
#: The station just before a breakpoint, in units of the smallest station spacing [1].
BREAKPOINT_GAP = 1e-3
#: A station closer than this in s to a schedule's bound gives way to it (a bound 1e-17 from a breakpoint
#: would make an interval of nothing) [1].
MIN_STATION_GAP = 1e-10
#: Samples per station interval in the dense limit check; rounds of checking the output samples (a
#: slow-down moves them), and how much more than the measured excess each slow-down takes [1]
#: (certify allows 1e-6).
CHECK_SAMPLES_PER_INTERVAL = 48
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


def stations_for(path: JointPath, include=()) -> np.ndarray:
    """The station grid in s: STATIONS_PER_SEGMENT per waypoint segment on average (within
    [MIN_STATIONS, MAX_STATIONS] in all), spread over the segments by their length but at least
    MIN_STATIONS_PER_SEGMENT in each (a short segment between two stops needs room to speed up and
    slow down), evenly within each; every breakpoint of the path is a station and, where d3q/ds3 jumps
    there (a C2 path), so is a point just before it: each side's value must be limited at a station; and
    the points ``include`` (a schedule's bounds, where the limits change)."""
    knots = path.s_waypoints
    segments = len(knots) - 1
    total = int(np.clip(STATIONS_PER_SEGMENT * segments, MIN_STATIONS, MAX_STATIONS))
    counts = np.maximum(np.round(total * np.diff(knots)).astype(int), MIN_STATIONS_PER_SEGMENT)
    stations = [np.linspace(start, end, count + 1)[:-1] for start, end, count in zip(knots[:-1], knots[1:], counts)]
    spacing = float(np.min(np.diff(knots) / counts))
    inner = path.breakpoints[1:-1]
    before = inner - BREAKPOINT_GAP * spacing if path.continuity < 3 else inner[:0]
    return with_points(np.concatenate([*stations, path.breakpoints, before, [1.0]]), include, MIN_STATION_GAP)


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

    def dense_times(self, per_interval: int) -> np.ndarray:
        fractions = np.arange(per_interval) / per_interval
        return np.append((self.t[:-1, None] + np.diff(self.t)[:, None] * fractions).ravel(), self.duration)


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
    CHECK_SAMPLES_PER_INTERVAL + 1 samples each."""
    fractions = np.arange(CHECK_SAMPLES_PER_INTERVAL + 1) / CHECK_SAMPLES_PER_INTERVAL
    t = (timing.t[:-1, None] + np.diff(timing.t)[:, None] * fractions).ravel()
    qddd = joint_motion(path, *timing.at(np.minimum(t, timing.duration)))[3]
    return (np.abs(qddd) / limits.qddd_max).reshape(len(timing.s) - 1, fractions.size, -1).max(axis=1)


def _slowed(timing: PathTiming, path: JointPath, t: np.ndarray, limits: PathLimits, torques,
            stretch: float) -> float:
    """The uniform slow-down (at least ``stretch``) that keeps the motion at times t [s] of the profile
    slowed by ``stretch`` within ``limits`` (joint speeds x the schedule's factor, accelerations, jerks, and
    the TCP's speed and acceleration where limited: copp limits them at its stations, between them this
    slow-down does), torques included when ``torques`` is given."""
    state = timing.at(t, stretch)
    q, qd, qdd, qddd = joint_motion(path, *state)
    speed, accel = limits.peaks(state[0], q, qd, qdd)
    slowed = stretch_for((speed, accel, float((np.abs(qddd) / limits.limits.qddd_max).max())), stretch,
                         OUTPUT_MARGIN)
    if torques is not None:
        slowed *= torque_stretch(*joint_motion(path, *timing.at(t, slowed))[:3], limits.limits, torques)
    return slowed


def solve_topp3(path: JointPath, limits: PathLimits, inverse_dynamics=None) -> tuple[PathTiming, float]:
    """copp's TOPP2, then TOPP3 with a small total-variation penalty on the joint accelerations (COPP3,
    an SOCP) linearised around it, then (up to TIGHTEN_ROUNDS times) around its own answer with the
    jerk limit of every station next to an interval whose jerk exceeds it between stations tightened
    by that excess, on ``stations_for(path)`` with the schedule's bounds. ``limits`` (a PathLimits): the joint
    speed limits x the schedule's factor at each station; torques are limited too when ``tau_max`` and
    ``inverse_dynamics(Q, QD, QDD) -> TAU`` (batched) are given, and the TCP's speed and acceleration
    where they are limited (``tcp_constraint.add_copp_rows``). copp sees the path in units of its
    length and time in ``time_unit``s (``ScaledPath``, with its path speed caps; torques through
    ``scaled_inverse_dynamics``), and the timing is scaled back exactly. The solves share SOLVE_BUDGET_S.
    Returns (timing, TOPP2 duration [s]); TimingError saying what to change when copp fails."""
    import copp_py as copp

    distance = max(path.length, 1e-300)
    unit = time_unit(limits.limits, distance)
    view = ScaledPath(path, distance)
    scaled = view.limits(limits.limits, unit)
    s = stations_for(path, () if limits.schedule is None else limits.schedule.bounds)
    n = len(s)
    robot = copp.Robot(view.dof, capacity=n, inverse_dynamics=None if inverse_dynamics is None else
                       scaled_inverse_dynamics(inverse_dynamics, view, unit))
    robot.append_s(s)
    robot.set_q(view(s), view(s, 1), view(s, 2), 0, dddq=view(s, 3))
    qd_max = scaled.qd_max * np.append(limits.at(s)[0][:, None] * np.ones(path.dof), np.ones((n, 1)), axis=1)
    robot.add_velocity_limits(qd_max, -qd_max, start_idx_s=0, length=n)
    robot.add_acceleration_limits(scaled.qdd_max, -scaled.qdd_max, start_idx_s=0, length=n)
    robot.add_jerk_limits(scaled.qddd_max, -scaled.qddd_max, start_idx_s=0, length=n)
    if inverse_dynamics is not None:
        tau_max = np.append(limits.limits.tau_max, 1.0)
        robot.add_torque_limits(tau_max, -tau_max, start_idx_s=0, length=n)
    if limits.limits_tcp:
        from .tcp_constraint import add_copp_rows

        add_copp_rows(robot.constraints, limits.tcp, path, limits, unit, s)

    def real(profile) -> PathTiming:
        timing = _profile_timing(copp, s, profile)
        return PathTiming(s, timing.a * unit**2, timing.b * unit**2, timing.t / unit, timing.stationary)

    constraints = robot.constraints
    started = time.perf_counter()

    def solved(a_linearization, b_linearization=None):
        """One COPP3 solve within what is left of SOLVE_BUDGET_S (a_linearization without round-off)."""
        left = SOLVE_BUDGET_S - (time.perf_counter() - started)
        options = copp.solver.copp3_socp.Options(
            allow_almost_solved=True, allow_insufficient_progress=True,
            clarabel_settings=copp.clarabel.ClarabelSettings(time_limit=max(left, 1e-3)))
        return copp.solver.copp3_socp.solve(copp.solver.copp3_socp.Problem(
            robot, objectives, without_roundoff(a_linearization), b_linearization=b_linearization), options)

    try:
        a2 = copp.solver.topp2_ra.solve(copp.solver.topp2_ra.Problem(constraints, idx_s_interval=(0, n - 1),
                                                                     a_boundary=(0.0, 0.0)),
                                        copp.solver.topp2_ra.Options())
        topp2_s, _ = copp.interpolation.s_to_t_topp2(s, a2, 0.0)
        constraints.amax_substitute(a2, 0)
        weight = SMOOTHING_SHARE * topp2_s / (len(path.waypoints) - 1)
        objectives = [copp.objective.Time(1.0),
                      copp.objective.TotalVariationTorque(weight, np.append(1.0 / scaled.qdd_max[:-1], 0.0))]
        profile = solved(a2)
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
        return real(profile), float(topp2_s) / unit
    except copp.CoppError as exc:
        spent = time.perf_counter() - started
        why = (f"its solver ran out of its {SOLVE_BUDGET_S:g} s budget" if spent >= SOLVE_BUDGET_S
               else "its solver failed numerically")
        raise TimingError(refusal(path, n, why, str(exc))) from exc


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
    peaks = _peak_ratios(*joint_motion(path, *timing.at(check_t))[1:], limits)
    stretch = _slowed(timing, path, check_t, judge, torques, 1.0)
    if stretch > MAX_STRETCH:
        raise TimingError(refusal(path, len(timing.s), f"its solution would need slowing down {stretch:.3g} times "
                                  f"(at most {MAX_STRETCH:g}) to meet the limits between its stations"))
    t = sample_times(timing.duration * stretch, dt, max_samples)
    for _ in range(OUTPUT_ROUNDS):             # the output samples are judged too: slow a little more
        output_stretch = _slowed(timing, path, t, judge, torques, stretch)
        if output_stretch <= stretch:
            break
        stretch = output_stretch
        t = sample_times(timing.duration * stretch, dt, max_samples)
    q, qd, qdd, qddd = joint_motion(path, *timing.at(t, stretch))
    details = Topp3Details(
        stations=len(timing.s), topp2_s=topp2_s, topp3_s=timing.duration, check_samples=int(check_t.size),
        station_peak_qd_ratio=peaks[0], station_peak_qdd_ratio=peaks[1], station_peak_qddd_ratio=peaks[2],
        time_stretch=stretch, path_deviation=0.0, compute_s=time.perf_counter() - start)
    mapped = None if schedule is None else schedule.mapped(timing.t[np.searchsorted(timing.s, np.clip(
        schedule.bounds, 0.0, 1.0))] * stretch)
    return Profile(t, q, qd, qdd, qddd, "topp3", limits, joint_names, details, schedule=mapped)
