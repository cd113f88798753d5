"""Time-parameterisation benchmark: our ``retime`` (toppra, topp3, ruckig) beside raw toppra and Drake's Toppra.

Per robot, ``paths`` seeded random paths through ``waypoints`` waypoints (``WAYPOINTS`` = 10 unless asked:
``--waypoints``) drawn uniformly in the middle 80 % of every joint range (each robot draws from its own
generator seeded with ``seed``). The path is our default shape, ``make_path(W, q_min, q_max)`` (monotone: it
never leaves the limits, so no draw is ever rejected; a ``PathError`` would be counted as a redraw). Velocity
and acceleration limits are the robot's (and its jerk limits for the jerk-limited rows), at rest at both ends.

Every method times the SAME geometric path:

* ours: ``retime(robot, path, method="toppra")`` as a user calls it (TOPP-RA compiled on ``GRIDPOINTS``
  and more where the path bends, dense certification, the uniform time stretch, sampling every ``DEFAULT_DT`` and
  ``certify``), timed whole;
* raw toppra at 100 and 1000 grid points: our backend's ``toppra_instance`` (toppra's own joint
  velocity and acceleration constraints, our path through toppra's geometric-path interface in
  units of its length, as our backend hands it to toppra, without our path speed cap) on n uniform
  grid points over the path's whole parameter range, + ``compute_trajectory(0, 0)`` with ``ParametrizeConstAccel``. No knots added,
  no check: toppra as a user calls it;
* Drake's ``Toppra`` at 100 and 1000 grid points (``np.linspace(0, 1, n)``): the path is handed to
  Drake as a ``PiecewisePolynomial`` with breaks at our knots whose pieces are our septic pieces
  (interpolated through 8 Chebyshev points each: the same polynomials up to round-off; the largest
  difference of q, dq/ds and d2q/ds2 on dense samples is reported, ~1e-12 relative). Drake's plant (``build_drake_robot``) is built once per
  robot; ``AddJointVelocityLimit``, ``AddJointAccelerationLimit`` (default kInterpolation),
  ``SolvePathParameterization()``. A ``None`` is a failure; its reason is the message Drake logs;
* the reference: raw toppra at ``REFERENCE_GRIDPOINTS`` = 10,000 grid points. Its duration is the
  dense optimum the gaps are measured to (its own ratios are measured too).

Timing: the wall clock (``time.perf_counter_ns``) of the solve and of producing the trajectory
object (toppra's parametrizer, Drake's s(t)); for ours the whole ``retime`` call, which includes
our certification and sampling. Building the geometric path (ours, and Drake's PiecewisePolynomial
from it) is not timed for anyone. Every method runs once on the robot's first path before timing
(imports, caches), then on each path all methods take turns in an order rotated from path to path,
so that drift of a shared machine's speed hits all of them alike. Failed calls are timed too.

Limit ratios, like with like: every trajectory is evaluated on ``SAMPLES`` = 20,001 evenly spaced
times over its own duration, with the exact chain rule (qd = q'(s) sd, qdd = q'(s) sdd + q''(s) sd^2,
never finite differences): toppra's parametrizer by its own evaluation, Drake's s(t) and its
derivatives composed with the (identical) path, ours by a second, untimed ``retime`` of the same
path with ``dt = duration / (SAMPLES - 1)``: what ours returns when asked for that many samples
(analytic values, certified by ``retime``). Its gap is that dense profile's duration too, so gap and
ratios describe one trajectory. ``retime`` also checks its own output samples and stretches time a
little more if one exceeds, so the dense profile can be a hair slower than the timed one: the
largest relative change is reported (``our_dense_duration_change``, ~1e-8). A path counts as
a violation when a ratio exceeds 1 + ``VIOLATION_TOLERANCE`` (the tolerance of ``certify``). Note
that the reference itself exceeds the limits slightly between its grid points (toppra checks
them only at the grid points), so "the dense optimum" is a hair faster than feasible.

Jerk-limited rows, on the same paths, timed and evaluated like ours (jerk limits too):
``retime(method="topp3")`` (jerk-limited path following) and ``retime(method="ruckig")`` (waypoint
to waypoint, at rest at each). For each: the duration over our toppra's on the same path
(``duration_ratios``), jerk sign reversals per joint per second (``jerk_reversal_rate``: swings
beyond +-10 % of the jerk limit), and for topp3 the path deviation measured both ways: the largest
distance from a profile sample to the path (each sample's nearest path point, found by Newton's
method from the nearest of DEVIATION_POINTS path samples) and from a path point to the nearest
sample (at most half the largest step between samples when the profile covers the path).

Goals (from the issues): our toppra's largest gap <= 0.3 %, zero violations (every row of ours), our
toppra compute time at most raw toppra's at 1000 grid points (median over all paths of the per-path
ratio; raw toppra there exceeds qdd by up to ~5 % between its grid points and has a larger gap); for
topp3: compute time <= 10x raw toppra's at 1000 grid points (median of per-path ratios), duration
<= 1.15x our toppra's (median) and <= 1.3x (max), <= 5 jerk reversals per joint per second, path
deviation <= 1e-6 rad. The same goals hold for any number of waypoints (issue 39: 6, ``--waypoints 6``).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ConfigurationError
from ..files.robot_spec import Limits
from ..model.robot import Robot, load_robot
from ..outputs.versions import version_table
from ..progress import Progress
from ..timing import retime
from ..timing import toppra_backend
from ..timing.joint_path import JointPath, PathError, make_path
from ..timing.profile import CERTIFY_TOLERANCE, jerk_reversal_rate
from ..timing.topp3_backend import MAX_STATIONS, MIN_STATIONS
from ..timing.toppra_backend import GRIDPOINTS, toppra_instance
from .goals import Goal, GoalReport, fmt, goal_lines

ROBOTS = ("gp7", "lrmate200id", "irb1600", "arm6")
WAYPOINTS = 10
MARGIN = 0.1                        # waypoints in the middle 80 % of each joint range
MAX_REDRAWS = 1000                  # rejected draws per path before giving up on the robot
SAMPLES = 20_001                    # evaluation samples per trajectory, the same for every method
VIOLATION_TOLERANCE = CERTIFY_TOLERANCE
REFERENCE_GRIDPOINTS = 10_000
RAW_GRIDPOINTS = (100, 1000)

DRAKE_DEGREE = 7                    # the monotone shape's septic pieces (the spline's cubics fit too)
DEVIATION_POINTS = 200_001          # path samples that seed the nearest-point search,
DEVIATION_SEEDS = 8                 # how many of the nearest seed it,
NEWTON_STEPS = 8                    # and its Newton steps

GAP_GOAL_PCT = 0.3
COMPUTE_GOAL_RATIO = 1.0                    # ours / raw toppra at 1000 grid points
TOPP3_COMPUTE_GOAL_RATIO = 10.0
TOPP3_MEDIAN_RATIO_GOAL = 1.15
TOPP3_MAX_RATIO_GOAL = 1.3
REVERSAL_GOAL = 5.0                 # jerk sign reversals per joint per second
DEVIATION_GOAL = 1e-6               # [rad]

OURS = f"ours: retime toppra ({GRIDPOINTS}+ grid points, denser where the path bends, certified)"
TOPP3 = f"ours: retime topp3 ({MIN_STATIONS}-{MAX_STATIONS} stations, jerk-limited path following)"
RUCKIG = "ours: retime ruckig (jerk-limited, waypoint to waypoint)"
#: ``--methods`` keys -> the rows they add (the reference always runs).
METHOD_KEYS = ("toppra", "raw", "drake", "topp3", "ruckig")
REFERENCE = f"toppra, {REFERENCE_GRIDPOINTS} grid points (reference)"


def toppra_name(gridpoints: int) -> str:
    return f"toppra, {gridpoints} grid points"


def drake_name(gridpoints: int) -> str:
    return f"Drake Toppra, {gridpoints} grid points"


TOPPRA_1000 = toppra_name(1000)
METHOD_NAMES = (OURS, *(toppra_name(n) for n in RAW_GRIDPOINTS), *(drake_name(n) for n in RAW_GRIDPOINTS), TOPP3,
                RUCKIG, REFERENCE)

log = logging.getLogger(__name__)


# -- report values ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class MethodRun:
    """One method on one path. ``duration_s``, ``gap_pct`` (to the reference) and the peak ratios are
    None when the method (or, for the gap, the reference) failed; ``failure`` says why. Jerk-limited
    rows also have ``max_qddd_ratio``, ``reversals_per_s`` (the largest joint's) and, for topp3, the
    path deviation [rad] both ways (profile to path, path to profile)."""

    duration_s: float | None
    gap_pct: float | None
    max_qd_ratio: float | None
    max_qdd_ratio: float | None
    compute_ms: float
    samples: int
    failure: str = ""
    max_qddd_ratio: float | None = None
    reversals_per_s: float | None = None
    deviation_to_path: float | None = None
    deviation_from_path: float | None = None

    @property
    def violation(self) -> bool:
        """A ratio above 1 + VIOLATION_TOLERANCE (False when there is no trajectory: a failure)."""
        ratios = (self.max_qd_ratio, self.max_qdd_ratio, self.max_qddd_ratio)
        return self.max_qd_ratio is not None and max(r for r in ratios if r is not None) > 1.0 + VIOLATION_TOLERANCE


@dataclass(frozen=True)
class PathRecord:
    """One random path: its waypoints (K, dof) [rad] as lists, the draws rejected before it, its
    joint-space length [rad], and every method's run by name."""

    index: int
    redraws: int
    length: float
    waypoints: list
    runs: dict[str, MethodRun]


@dataclass(frozen=True)
class TimingRow:
    """One method on one robot. Compute times [ms] per call, failed calls included; gaps [%] to the
    reference duration over the paths both solved; peak ratios over all solved paths; ``violations``:
    solved paths with a ratio above 1 + VIOLATION_TOLERANCE; ``failures``: paths with no trajectory.
    Jerk-limited rows: duration over our toppra's on the same path (median, max), jerk reversals per
    joint per second (median and max over paths of the largest joint's), and for topp3 the largest
    distance of a sample from the path and of a path point from the nearest sample [rad]."""

    name: str
    ours: bool
    paths: int
    compute_median_ms: float
    compute_max_ms: float
    gap_median_pct: float | None
    gap_max_pct: float | None
    max_qd_ratio: float | None
    max_qdd_ratio: float | None
    violations: int
    failures: int
    first_failure: str = ""
    duration_ratio_median: float | None = None
    duration_ratio_max: float | None = None
    reversals_median_per_s: float | None = None
    reversals_max_per_s: float | None = None
    deviation_max: float | None = None
    coverage_max: float | None = None


@dataclass(frozen=True)
class TimingRobotReport:
    """All rows of one robot, ours first and the reference last.

    ``compute_ratio``: median over paths of ours / raw toppra at 1000 grid points (per-path ratios,
    below 1: ours is faster); ``drake_geometry_error``: largest difference between Drake's
    PiecewisePolynomial and our path on dense samples, for q [rad], dq/ds and d2q/ds2;
    ``our_time_stretch``: largest uniform slow-down our certification applied (1: none; None when
    ours failed on every path); ``our_dense_duration_change``: largest relative change of our
    duration from the timed profile (``DEFAULT_DT`` samples) to the dense one that is measured.
    """

    robot_name: str
    dof: int
    paths: int
    redraws: int
    rows: tuple[TimingRow, ...]
    compute_ratio: float
    compute_ratios: list[float]
    drake_geometry_error: dict[str, float]
    our_time_stretch: float | None
    our_dense_duration_change: float | None
    records: tuple[PathRecord, ...]


@dataclass(frozen=True)
class TimingBenchReport(GoalReport):
    """Result of one timing benchmark run: one TimingRobotReport per robot, the goals over all robots."""

    paths: int
    seed: int
    waypoints: int
    samples: int
    robots: tuple[TimingRobotReport, ...]
    goals: tuple[Goal, ...]
    versions: dict[str, str]

    def format_table(self) -> str:
        """One table per robot (method | compute | gaps | ratios | violations | failures), then the goals."""
        lines = [
            f"Timing benchmark: {self.paths} seeded random paths per robot through {self.waypoints} waypoints "
            f"(middle 80 % of the limits), seed {self.seed}; qd and qdd limits, rest to rest",
            f"gap: duration relative to {REFERENCE}; ratios: peak |qd|/limit and |qdd|/limit on {self.samples} "
            f"samples (exact chain rule); violation: a path with a ratio > 1 + {VIOLATION_TOLERANCE:g}; "
            "compute: median per call, interleaved, failed calls included",
        ]
        for robot in self.robots:
            lines += ["", f"{robot.robot_name} ({robot.dof} dof), {robot.paths} paths "
                          f"({robot.redraws} waypoint draws rejected: the path left the limits)",
                      *_table(robot.rows)]
            jerk_rows = [row for row in robot.rows if row.duration_ratio_median is not None]
            if jerk_rows:
                lines += ["  jerk-limited (same paths):", *_jerk_table(jerk_rows)]
            lines.append(f"  ours / {TOPPRA_1000} compute time: median of per-path ratios {robot.compute_ratio:.3g}x "
                         f"(per path: {', '.join(f'{r:.3g}' for r in robot.compute_ratios)})")
            error = robot.drake_geometry_error
            if error:
                lines.append(f"  Drake's path vs ours, largest difference: q {error['q']:.2g} rad, "
                             f"dq/ds {error['dq_ds']:.2g}, d2q/ds2 {error['d2q_ds2']:.2g}")
            stretch, change = fmt(robot.our_time_stretch, ".6f"), fmt(robot.our_dense_duration_change, ".2g")
            lines.append(f"  ours: largest uniform time stretch from the dense check {stretch}; duration of the "
                         f"{self.samples}-sample profile vs the timed one: {change} (relative)")
            lines += [f"  {row.name}: failed on {row.failures} of {row.paths} paths, first: {row.first_failure}"
                      for row in robot.rows if row.failures]
        lines += goal_lines("Goals over all robots and paths:", self.goals, self.versions)
        return "\n".join(lines)



def _table(rows: tuple[TimingRow, ...]) -> list[str]:
    head = ("method", "compute median ms", "gap median %", "gap max %", "max qd ratio", "max qdd ratio",
            "violations", "failures")
    body = [(r.name, f"{r.compute_median_ms:.1f}", fmt(r.gap_median_pct, "+.3f"), fmt(r.gap_max_pct, "+.3f"),
             fmt(r.max_qd_ratio, ".6f"), fmt(r.max_qdd_ratio, ".6f"), str(r.violations), str(r.failures))
            for r in rows]
    return _aligned(head, body)


def _jerk_table(rows: list[TimingRow]) -> list[str]:
    head = ("method", "x toppra median", "x toppra max", "jerk reversals/s median", "max",
            "sample to path rad", "path to sample rad")
    body = [(r.name, fmt(r.duration_ratio_median, ".3f"), fmt(r.duration_ratio_max, ".3f"),
             fmt(r.reversals_median_per_s, ".2f"), fmt(r.reversals_max_per_s, ".2f"), fmt(r.deviation_max, ".2g"),
             fmt(r.coverage_max, ".2g")) for r in rows]
    return _aligned(head, body)


def _aligned(head: tuple[str, ...], body: list[tuple[str, ...]]) -> list[str]:
    widths = [max(len(row[c]) for row in (head, *body)) for c in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *body)]


# -- the paths --------------------------------------------------------------------------------------
def random_paths(robot: Robot, count: int, rng: np.random.Generator,
                 waypoints: int = WAYPOINTS) -> list[tuple[JointPath, int]]:
    """``count`` paths (default shape) through ``waypoints`` random waypoints in the middle 80 % of the
    ranges, each with the number of draws rejected before it (the path left the limits)."""
    limits = robot.limits
    paths = []
    for _ in range(count):
        for redraws in range(MAX_REDRAWS + 1):
            W = robot.random_configurations(rng, waypoints, margin=MARGIN)
            try:
                path = make_path(W, limits.q_min, limits.q_max)
            except PathError:
                continue
            paths.append((path, redraws))
            break
        else:
            raise ConfigurationError(f"{robot.name}: {MAX_REDRAWS + 1} random draws of {waypoints} waypoints all "
                                     "gave a path that leaves the joint limits")
    return paths


# -- the methods: solve (timed) -> a result; evaluate (untimed) -> duration, qd, qdd on SAMPLES ------
@dataclass(frozen=True)
class Evaluation:
    """A solved trajectory seen at its evaluation samples: duration [s], qd and qdd (n, dof);
    ``time_stretch``: the uniform slow-down our certification applied, ``duration_change``: the
    relative change of duration from the timed profile to the dense one (ours only); jerk-limited rows:
    ``qddd``, ``reversals_per_s`` (largest joint) and for topp3 ``deviation`` (to, from the path) [rad]."""

    duration: float
    qd: np.ndarray
    qdd: np.ndarray
    time_stretch: float | None = None
    duration_change: float | None = None
    qddd: np.ndarray | None = None
    reversals_per_s: float | None = None
    deviation: tuple[float, float] | None = None


@dataclass(frozen=True)
class Method:
    """``solve(path)``: the timed call, a trajectory object or None (failed); ``evaluate(path, result)``:
    untimed, an Evaluation, or a string saying why the result is no trajectory."""

    name: str
    solve: Callable[[JointPath], object]
    evaluate: Callable[[JointPath, object], "Evaluation | str"]
    none_means: str = "returned None"


def ours_method(robot: Robot, timing: str = "toppra", name: str = OURS) -> Method:
    """``retime(robot, path, method=timing)``, timed whole; evaluated by a dense second retime. The
    jerk-limited methods also get their jerk reversals and (topp3) path deviation measured."""
    waypoints_only = timing == "ruckig"

    def solve(path: JointPath):
        return retime(robot, path.waypoints if waypoints_only else path, method=timing)

    def evaluate(path: JointPath, profile) -> Evaluation | str:
        # retime certifies the dense profile itself (and raises if it fails): the ratios below are
        # measured again, by the same formula as every other row's.
        dense = retime(robot, path.waypoints if waypoints_only else path, method=timing,
                       dt=profile.duration / (SAMPLES - 1))
        jerk = timing != "toppra"
        return Evaluation(dense.duration, dense.qd, dense.qdd, getattr(dense.details, "time_stretch", None),
                          dense.duration / profile.duration - 1.0, dense.qddd if jerk else None,
                          float(jerk_reversal_rate(profile).max()) if jerk else None,
                          path_deviation(path, dense.q) if timing == "topp3" else None)

    return Method(name, solve, evaluate)


def path_deviation(path: JointPath, q: np.ndarray) -> tuple[float, float]:
    """(largest distance from a sample q (n, dof) to the path, largest distance from a path point to
    the nearest sample) [rad]. Each sample's nearest path point: Newton's method on
    (q(s) - q) . q'(s) = 0 from each of the DEVIATION_SEEDS nearest of DEVIATION_POINTS path samples
    (near a waypoint where the path turns back, both branches are close), the nearest result kept."""
    from scipy.spatial import cKDTree

    s_dense = np.linspace(0.0, 1.0, DEVIATION_POINTS)
    dense = path(s_dense)
    from_path = float(cKDTree(q).query(dense)[0].max())
    seeds = cKDTree(dense).query(q, k=DEVIATION_SEEDS)[1]                       # (n, seeds)
    targets = np.repeat(q, DEVIATION_SEEDS, axis=0)
    s = s_dense[seeds.ravel()]
    for _ in range(NEWTON_STEPS):
        error, d1, d2 = path(s) - targets, path(s, 1), path(s, 2)
        slope = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", error, d2)
        step = np.einsum("ij,ij->i", error, d1) / np.where(slope > 0.0, slope, np.inf)
        s = np.clip(s - step, 0.0, 1.0)
    distance = np.linalg.norm(path(s) - targets, axis=1).reshape(len(q), DEVIATION_SEEDS).min(axis=1)
    return float(distance.max()), from_path


def toppra_geometry(path: JointPath) -> toppra_backend.ScaledPath:
    """Our path as our toppra backend hands it to toppra (in units of its length), without the path
    speed cap: raw toppra gets the path ours gets, so the rows differ only in what toppra does with it."""
    return toppra_backend.ScaledPath(path, max(path.length, 1e-300), cap=False)


def _reaches_end(path: JointPath, q_end: np.ndarray) -> str:
    error = float(np.abs(np.asarray(q_end) - path(1.0)).max())
    return "" if error <= 1e-9 else f"the trajectory ends {error:.3g} away from the path's end"


def raw_toppra_method(limits: Limits, gridpoints: int, name: str | None = None) -> Method:
    """toppra on ``gridpoints`` uniform grid points, ParametrizeConstAccel, its own evaluation (in the
    path's length units, scaled back)."""

    def solve(path: JointPath):
        geometry = toppra_geometry(path)
        return toppra_instance(geometry, geometry.limits(limits, 1.0),
                               np.linspace(0.0, 1.0, gridpoints)).compute_trajectory(0.0, 0.0)

    def evaluate(path: JointPath, trajectory) -> Evaluation | str:
        duration = float(trajectory.duration)
        if not np.isfinite(duration) or duration <= 0.0:
            return f"no usable trajectory (duration {duration} s)"
        t = np.linspace(0.0, duration, SAMPLES)
        scale = toppra_geometry(path).distance
        return _reaches_end(path, np.asarray(trajectory(duration)) * scale) or Evaluation(
            duration, np.asarray(trajectory(t, 1)) * scale, np.asarray(trajectory(t, 2)) * scale)

    return Method(name or toppra_name(gridpoints), solve, evaluate)


class _DrakeLog(logging.Handler):
    """Collects what Drake logs (pydrake forwards its C++ log to the Python logger ``drake``)."""

    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def drake_path(path: JointPath):
    """Our path as a Drake PiecewisePolynomial with breaks at our knots: each segment's polynomial
    (degree DRAKE_DEGREE, which our pieces do not exceed) interpolated through that many + 1 Chebyshev
    points of it, so it is our path up to round-off (the difference is reported)."""
    from pydrake.polynomial import Polynomial
    from pydrake.trajectories import PiecewisePolynomial

    knots = path.s_waypoints
    count = DRAKE_DEGREE + 1
    t = (1.0 - np.cos(np.pi * (np.arange(count) + 0.5) / count)) / 2.0
    vandermonde = np.vander(t, count, increasing=True)
    pieces = []
    for start, length in zip(knots[:-1], np.diff(knots)):
        coefficients = np.linalg.solve(vandermonde, path(start + length * t)) / length ** np.arange(count)[:, None]
        pieces.append(np.array([[Polynomial(coefficients[:, j])] for j in range(path.dof)], dtype=object))
    return PiecewisePolynomial(pieces, list(knots))


def drake_geometry_error(path: JointPath, polynomial) -> dict[str, float]:
    """Largest difference of q, dq/ds and d2q/ds2 between Drake's polynomial and our path on SAMPLES."""
    s = np.linspace(0.0, 1.0, SAMPLES)
    pieces = (polynomial, polynomial.derivative(1), polynomial.derivative(2))
    return {key: float(np.abs(piece.vector_values(s).T - path(s, order)).max())
            for order, (key, piece) in enumerate(zip(("q", "dq_ds", "d2q_ds2"), pieces))}


def drake_toppra_method(robot: Robot, plant, gridpoints: int, polynomials: dict[int, object]) -> Method:
    """Drake's Toppra on the PiecewisePolynomial of our path (``polynomials[id(path)]``, built untimed)."""
    from pydrake.multibody.optimization import Toppra

    limits = robot.limits
    grid = np.linspace(0.0, 1.0, gridpoints)

    def solve(path: JointPath):
        toppra = Toppra(polynomials[id(path)], plant, grid)
        toppra.AddJointVelocityLimit(-limits.qd_max, limits.qd_max)
        toppra.AddJointAccelerationLimit(-limits.qdd_max, limits.qdd_max)
        return toppra.SolvePathParameterization()

    def evaluate(path: JointPath, s_of_t) -> Evaluation | str:
        t0, t1 = s_of_t.start_time(), s_of_t.end_time()
        t = np.linspace(t0, t1, SAMPLES)
        s = s_of_t.vector_values(t).ravel()
        if abs(s[0]) > 1e-9 or abs(s[-1] - 1.0) > 1e-9:
            return f"s(t) runs from {s[0]:.9g} to {s[-1]:.9g}, not 0 to 1"
        sd = s_of_t.derivative(1).vector_values(t).ravel()
        sdd = s_of_t.derivative(2).vector_values(t).ravel()
        d1, d2 = path(s, 1), path(s, 2)
        return Evaluation(float(t1 - t0), d1 * sd[:, None], d1 * sdd[:, None] + d2 * (sd**2)[:, None])

    return Method(drake_name(gridpoints), solve, evaluate, "SolvePathParameterization returned None")


# -- running ----------------------------------------------------------------------------------------
def _peak_ratios(evaluation: Evaluation, limits: Limits) -> tuple[float, float]:
    return (float((np.abs(evaluation.qd) / limits.qd_max).max()),
            float((np.abs(evaluation.qdd) / limits.qdd_max).max()))


def _run_once(method: Method, path: JointPath) -> tuple[object, float, str]:
    """(result or None, compute [ms], failure reason) of one timed call.

    What Drake logs during the call is collected (outside the timed region) for the failure reason.
    """
    drake_logger, drake_log = logging.getLogger("drake"), _DrakeLog()
    drake_logger.addHandler(drake_log)
    try:
        start = time.perf_counter_ns()
        try:
            result = method.solve(path)
            failure = ""
        except Exception as exc:  # noqa: BLE001 - a failure of a method is a row entry, not fatal
            result, failure = None, f"{type(exc).__name__}: {exc}"
        elapsed = (time.perf_counter_ns() - start) / 1e6
    finally:
        drake_logger.removeHandler(drake_log)
    if result is None and not failure:
        failure = method.none_means + (f" ({'; '.join(drake_log.messages)})" if drake_log.messages else "")
    return result, elapsed, failure


def _row(name: str, runs: list[MethodRun], toppra_runs: list[MethodRun] | None = None) -> TimingRow:
    solved = [r for r in runs if r.duration_s is not None]
    gaps = [r.gap_pct for r in solved if r.gap_pct is not None]
    compute = [r.compute_ms for r in runs]
    failures = [r for r in runs if r.failure]
    ratios = [r.duration_s / t.duration_s for r, t in zip(runs, toppra_runs or ())
              if r.duration_s is not None and t.duration_s is not None]
    reversals = [r.reversals_per_s for r in solved if r.reversals_per_s is not None]
    deviations = [r.deviation_to_path for r in solved if r.deviation_to_path is not None]
    coverage = [r.deviation_from_path for r in solved if r.deviation_from_path is not None]
    jerk = bool(reversals)
    return TimingRow(
        name=name, ours=name == OURS, paths=len(runs),
        compute_median_ms=float(np.median(compute)), compute_max_ms=float(np.max(compute)),
        gap_median_pct=float(np.median(gaps)) if gaps else None, gap_max_pct=float(np.max(gaps)) if gaps else None,
        max_qd_ratio=max((r.max_qd_ratio for r in solved), default=None),
        max_qdd_ratio=max((r.max_qdd_ratio for r in solved), default=None),
        violations=sum(r.violation for r in solved), failures=len(failures),
        first_failure=failures[0].failure if failures else "",
        duration_ratio_median=float(np.median(ratios)) if jerk and ratios else None,
        duration_ratio_max=float(np.max(ratios)) if jerk and ratios else None,
        reversals_median_per_s=float(np.median(reversals)) if jerk else None,
        reversals_max_per_s=float(np.max(reversals)) if jerk else None,
        deviation_max=max(deviations) if deviations else None,
        coverage_max=max(coverage) if coverage else None,
    )


def benchmark_robot(robot: Robot, paths: int, seed: int, methods: tuple[str, ...] = METHOD_KEYS,
                    waypoints: int = WAYPOINTS) -> TimingRobotReport:
    """The chosen ``methods`` (METHOD_KEYS) and the reference on ``paths`` seeded random paths of one
    robot through ``waypoints`` waypoints each, interleaved."""
    from ..model.chain.drake_model import build_drake_robot

    limits = robot.limits
    if limits.qdd_max is None:
        raise ConfigurationError(f"{robot.name}: the timing benchmark needs acceleration limits (qdd_max)")
    unknown = sorted(set(methods) - set(METHOD_KEYS))
    if unknown or "toppra" not in methods:
        raise ConfigurationError(f"timing benchmark methods must include toppra and come from {', '.join(METHOD_KEYS)}, "
                                 f"got {', '.join(methods)}")
    drawn = random_paths(robot, paths, np.random.default_rng(seed), waypoints)
    polynomials, geometry, drake_rows = {}, [], []
    if "drake" in methods:
        plant = build_drake_robot(robot.spec).plant
        polynomials = {id(path): drake_path(path) for path, _ in drawn}
        geometry = [drake_geometry_error(path, polynomials[id(path)]) for path, _ in drawn]
        drake_rows = [drake_toppra_method(robot, plant, n, polynomials) for n in RAW_GRIDPOINTS]
    methods = [ours_method(robot),
               *((raw_toppra_method(limits, n) for n in RAW_GRIDPOINTS) if "raw" in methods else ()),
               *drake_rows,
               *((ours_method(robot, "topp3", TOPP3),) if "topp3" in methods else ()),
               *((ours_method(robot, "ruckig", RUCKIG),) if "ruckig" in methods else ()),
               raw_toppra_method(limits, REFERENCE_GRIDPOINTS, REFERENCE)]
    for method in methods:                                  # warm-up: imports, caches; not counted
        _run_once(method, drawn[0][0])

    count = len(methods)
    outcomes: list[list[tuple[Evaluation | None, float, str]]] = [[None] * paths for _ in range(count)]
    with Progress(paths, f"bench timing {robot.name}") as tick:
        for p, (path, _) in enumerate(drawn):
            tick()
            for k in np.roll(np.arange(count), -p):             # interleaved, order rotated per path
                method = methods[k]
                result, compute_ms, failure = _run_once(method, path)
                evaluation = None
                if result is not None:
                    try:
                        evaluation = method.evaluate(path, result)
                    except Exception as exc:  # noqa: BLE001 - a trajectory that cannot be evaluated is a failure
                        evaluation = f"evaluating the result raised {type(exc).__name__}: {exc}"
                    if isinstance(evaluation, str):
                        failure, evaluation = evaluation, None
                if failure:
                    log.info("%s, path %d: %s failed: %s", robot.name, p, method.name, failure)
                outcomes[k][p] = (evaluation, compute_ms, failure)

    reference = outcomes[-1]
    records, runs_by_method = [], {m.name: [] for m in methods}
    stretches = [e.time_stretch for e, _, _ in outcomes[0] if e is not None]
    changes = [e.duration_change for e, _, _ in outcomes[0] if e is not None]
    for p, (path, redraws) in enumerate(drawn):
        runs = {}
        ref_duration = reference[p][0].duration if reference[p][0] is not None else None
        for method, per_path in zip(methods, outcomes):
            evaluation, compute_ms, failure = per_path[p]
            if evaluation is None:
                run = MethodRun(None, None, None, None, compute_ms, 0, failure or "no trajectory")
            else:
                qd_ratio, qdd_ratio = _peak_ratios(evaluation, limits)
                gap = None if ref_duration is None else 100.0 * (evaluation.duration / ref_duration - 1.0)
                qddd_ratio = (None if evaluation.qddd is None
                              else float((np.abs(evaluation.qddd) / limits.qddd_max).max()))
                to_path, from_path = evaluation.deviation or (None, None)
                run = MethodRun(evaluation.duration, gap, qd_ratio, qdd_ratio, compute_ms, len(evaluation.qd),
                                max_qddd_ratio=qddd_ratio, reversals_per_s=evaluation.reversals_per_s,
                                deviation_to_path=to_path, deviation_from_path=from_path)
            runs[method.name] = run
            runs_by_method[method.name].append(run)
        records.append(PathRecord(p, redraws, path.length, path.waypoints.tolist(), runs))

    peer = runs_by_method.get(TOPPRA_1000) or runs_by_method[REFERENCE]
    ratios = [o.compute_ms / t.compute_ms for o, t in zip(runs_by_method[OURS], peer)]
    return TimingRobotReport(
        robot_name=robot.name, dof=robot.dof, paths=paths, redraws=sum(r for _, r in drawn),
        rows=tuple(_row(m.name, runs_by_method[m.name], runs_by_method[OURS]) for m in methods),
        compute_ratio=float(np.median(ratios)), compute_ratios=ratios,
        drake_geometry_error={key: max(g[key] for g in geometry) for key in geometry[0]} if geometry else {},
        our_time_stretch=max(stretches, default=None),
        our_dense_duration_change=max(changes, key=abs, default=None),
        records=tuple(records),
    )


def evaluate_goals(robots: tuple[TimingRobotReport, ...]) -> tuple[Goal, ...]:
    """The goals over all robots and paths: our gap, our violations, our compute time; topp3's."""
    ours = [record.runs[OURS] for robot in robots for record in robot.records]
    gaps = [run.gap_pct for run in ours if run.gap_pct is not None]
    unmeasured = sum(run.gap_pct is None for run in ours)
    violations = sum(run.violation for run in ours)
    failures = sum(run.duration_s is None for run in ours)
    ratio = _compute_ratio(robots, OURS)
    gap_max = max(gaps, default=None)
    return (*_toppra_goals(gap_max, unmeasured, violations, failures, len(ours), ratio), *_topp3_goals(robots))


def _toppra_goals(gap_max, unmeasured, violations, failures, count, ratio) -> tuple[Goal, ...]:
    return (
        Goal("our largest duration gap to the dense optimum [%]", gap_max,
             f"<= {GAP_GOAL_PCT} %" + (f"; {unmeasured} path(s) without a gap" if unmeasured else ""),
             gap_max is not None and unmeasured == 0 and gap_max <= GAP_GOAL_PCT),
        Goal("our limit violations (paths; failures count too)", float(violations + failures),
             f"= 0 over {count} paths ({failures} failed)", violations + failures == 0),
        Goal(f"our compute time / {TOPPRA_1000} (median of per-path ratios)", ratio,
             f"<= {COMPUTE_GOAL_RATIO:g}", ratio is not None and ratio <= COMPUTE_GOAL_RATIO),
    )


def _compute_ratio(robots: tuple[TimingRobotReport, ...], name: str) -> float | None:
    """The median over all robots' paths of ``name``'s compute time / raw toppra's at 1000 grid points on the
    same path (None when either did not run)."""
    ratios = [record.runs[name].compute_ms / record.runs[TOPPRA_1000].compute_ms
              for robot in robots for record in robot.records if name in record.runs and TOPPRA_1000 in record.runs]
    return float(np.median(ratios)) if ratios else None


def _topp3_goals(robots: tuple[TimingRobotReport, ...]) -> tuple[Goal, ...]:
    """topp3's goals over all robots and paths (none when topp3 did not run)."""
    runs = [(record.runs[TOPP3], record.runs[OURS]) for robot in robots for record in robot.records
            if TOPP3 in record.runs]
    if not runs:
        return ()
    solved = [(r, t) for r, t in runs if r.duration_s is not None and t.duration_s is not None]
    ratios = [r.duration_s / t.duration_s for r, t in solved]
    bad = sum(r.violation for r, _ in runs) + sum(r.duration_s is None for r, _ in runs)
    reversals = max((r.reversals_per_s for r, _ in solved), default=None)
    deviation = max((r.deviation_to_path for r, _ in solved),
                    default=None)
    median, largest = (float(np.median(ratios)), float(np.max(ratios))) if ratios else (None, None)
    compute = _compute_ratio(robots, TOPP3)
    return (
        Goal(f"topp3 compute time / {TOPPRA_1000} (median of per-path ratios)", compute,
             f"<= {TOPP3_COMPUTE_GOAL_RATIO:g}", compute is not None and compute <= TOPP3_COMPUTE_GOAL_RATIO),
        Goal("topp3 duration / our toppra's (median)", median, f"<= {TOPP3_MEDIAN_RATIO_GOAL}",
             median is not None and median <= TOPP3_MEDIAN_RATIO_GOAL),
        Goal("topp3 duration / our toppra's (max)", largest, f"<= {TOPP3_MAX_RATIO_GOAL}",
             largest is not None and largest <= TOPP3_MAX_RATIO_GOAL),
        Goal("topp3 jerk reversals per joint per second (max)", reversals, f"<= {REVERSAL_GOAL:g}",
             reversals is not None and reversals <= REVERSAL_GOAL),
        Goal("topp3 distance of a sample from the path [rad] (max)", deviation, f"<= {DEVIATION_GOAL:g}",
             deviation is not None and deviation <= DEVIATION_GOAL),
        Goal("topp3 violations and failures (paths)", float(bad), f"= 0 over {len(runs)} paths", bad == 0),
    )


def run_timing_benchmark(robots=ROBOTS, paths: int = 5, seed: int = 0,
                         methods: tuple[str, ...] = METHOD_KEYS, waypoints: int = WAYPOINTS) -> TimingBenchReport:
    """Ours (toppra, topp3, ruckig) beside raw toppra (100, 1000 grid points) and Drake's Toppra
    (100, 1000) on each robot.

    ``robots``: preset names or robot files; ``paths``: seeded random paths per robot, through ``waypoints``
    waypoints each (at least 2);
    ``seed``: of the waypoints (each robot draws from its own generator seeded with it); ``methods``:
    which rows run (METHOD_KEYS; toppra always, and the reference).
    """
    if paths < 1:
        raise ConfigurationError(f"paths must be >= 1, got {paths}")
    if waypoints < 2:
        raise ConfigurationError(f"waypoints must be >= 2, got {waypoints}")
    robots = (robots,) if isinstance(robots, str) else tuple(robots)
    if not robots:
        raise ConfigurationError("no robots to benchmark")
    reports = tuple(benchmark_robot(load_robot(name), paths, seed, tuple(methods), waypoints) for name in robots)
    versions = version_table("numpy", "scipy", "toppra", "drake", "ruckig", "copp-py")
    return TimingBenchReport(paths=paths, seed=seed, waypoints=waypoints, samples=SAMPLES, robots=reports,
                             goals=evaluate_goals(reports), versions=versions)
