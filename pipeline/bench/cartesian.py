"""Cartesian benchmark: certified straight-line TCP moves, ours end to end beside Robotics Toolbox's path.

Per robot (the robot's end frame is the TCP, no tool), ``moves`` seeded random straight-line moves of
``MOVE_LENGTH_M`` = 0.5 m (each robot draws from its own generator seeded with ``seed``): a random
in-limit configuration ``q0`` ``MARGIN`` = 15 % of every range inside the limits, ``X0 = fk(q0)``, a
direction ``d`` uniform on the unit sphere (a normalised 3-D normal draw), and ``X1`` = X0 moved by
0.5 m along d with the same orientation. A draw is kept only when our whole pipeline (below) runs on
it; a ToolMoveError (out of reach, branch change, singularity) or TimingError (no certified timing)
rejects it and a new draw is made, up to ``MAX_DRAWS`` per move (the rejections are counted by reason
and reported).

What is timed (``time.perf_counter``, wall clock, per move, failed calls included):

* ours, end to end, as a user calls it: ``ToolPath(X0, [ToolMove("linear", X1)])``,
  ``joint_path_along(robot, tool_path, q0, tcp_speed_max=V)`` (IK at adaptive samples, the joint
  path checked to deviate <= 0.1 mm / 0.1 deg from the ideal pose between the samples: the "IK"
  part), then ``retime(robot, along.path, method="toppra", limits=<the robot's with tcp_speed_max=V,
  tcp_accel_max=A>, tcp=TcpMotion(robot), dt=DT)`` (time-optimal timing under the joint and TCP limits,
  the dense check, sampling, and ``certify``: the "timing + certification" part). The profile returned
  is certified (``profile.certificate.passed``; a failure is counted);
* the peer, Robotics Toolbox (optional ``bench`` extra; imported lazily, reported unavailable when
  missing), for the PATH PART ONLY: ``rtb.ctraj(SE3(X0), SE3(X1), n)`` (its default trapezoidal
  spacing, orientation by quaternion interpolation) with n = the number of IK samples our joint path
  has on that move (the same density), then ``ETS.ikine_LM`` (its Python Levenberg-Marquardt) on each
  pose, seeded by the previous solution (the first by ``q0``), with ``tol = RTB_TOLERANCE`` (its error
  then implies our strict 1e-6 m / 1e-6 rad; the default 1e-6 allows ~1.4 mm), ``ilimit=RTB_ITERATIONS``,
  ``joint_limits=True``, its other options default (up to 100 searches, restarts seeded with
  ``RTB_SEED``). The ETS is the ``DHRobot`` built from the spec by ``pipeline.bench.ik.build_rtb_ets``
  (checked against our FK), built once per robot outside the timing. The peer does no timing and no
  certification: its result is joint samples that a user would still have to time (and check).

Every contestant runs once on the first move before timing (imports, caches); then on each move they
take turns in an order rotated from move to move, so that drift of a shared machine's speed hits both
alike. Ratios are medians of per-move ratios, peer / ours (above 1: ours is faster); the peer is
compared both with our total and with our IK part alone (the like-for-like part).

What is measured (untimed):

* achieved TCP speed: the straight part is the part of the line where a TCP held only to V and A
  would cruise at V (its progress along d in [V^2 / (2 A), L - V^2 / (2 A)], 0.1 to 0.4 m); per move, the
  fraction of the profile's samples there with ``profile.tcp.speed >= 0.99 V``, and the peak
  ``profile.tcp.speed / V`` over the whole move;
* distance of the TCP from the segment X0 -> X1 [mm] (point to segment), independently of the
  pipeline's own check: our FK (``fk_batch``) of the profile's q samples, and of the joint path at
  ``DENSE_SAMPLES`` evenly spaced path parameters; beside it the path's own ``max_position_error``;
* the peer: whether every pose was solved (its own reported success), the largest position error of
  its solutions (our FK), and the largest distance from the segment of the joint-space linear
  interpolation between its consecutive solutions (our FK at the midpoints): what a user gets from
  the peer's samples if the controller interpolates them linearly in joint space.

Goals: a certified 0.5 m move in under ``TIME_GOAL_MS`` = 50 ms (median total time, per robot: the
largest shown), and the TCP at >= 99 % of its speed limit on the straight part (every move's peak
TCP speed >= 0.99 V).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ConfigurationError, TimingError
from ..model.robot import Robot, load_robot
from ..outputs.versions import version_table
from ..progress import Progress
from .goals import Goal, GoalReport, fmt, goal_lines

ROBOTS = ("gp7", "irb1600")
MOVE_LENGTH_M = 0.5
#: q0 is drawn this fraction of every joint range inside the limits [1].
MARGIN = 0.15
#: Draws per move (rejected ones included) before giving up on the robot.
MAX_DRAWS = 1000
#: The TCP limits of every move: speed V [m/s] and acceleration A [m/s^2]; profile sample time [s].
TCP_SPEED = 1.0
TCP_ACCEL = 5.0
DT = 0.004
#: A sample at >= SPEED_FRACTION x V counts as "at the speed limit" [1].
SPEED_FRACTION = 0.99
#: Evenly spaced path parameters at which our joint path's distance from the line is measured.
DENSE_SAMPLES = 10_001
#: Seed of Robotics Toolbox ikine_LM's random restarts (its tolerance and iterations: pipeline.bench.ik's).
RTB_SEED = 0
TIME_GOAL_MS = 50.0

OURS = "ours: ToolPath + joint_path_along + retime toppra (certified)"
PEER = "RTB ctraj + ikine_LM (path only: no timing, no certification)"


# -- report values ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class OursRun:
    """Ours on one move: times [ms] of the IK part (ToolPath + joint_path_along), of timing +
    certification (retime) and their total; ``certified``: the profile's certificate passed;
    ``failure``: why there is no profile (then the measures are None). ``samples``: IK samples of the
    joint path; ``profile_samples``; ``duration_s``; ``cruise_fraction``: of the straight part's
    samples, those at >= 0.99 V; ``peak_speed_ratio``: peak TCP speed / V; distances from the segment
    [mm]: at the profile's samples, on the joint path at DENSE_SAMPLES, and the path's own
    ``max_position_error``."""

    ik_ms: float
    timing_ms: float
    total_ms: float
    certified: bool
    samples: int
    failure: str = ""
    profile_samples: int | None = None
    duration_s: float | None = None
    cruise_fraction: float | None = None
    peak_speed_ratio: float | None = None
    line_deviation_mm: float | None = None
    dense_line_deviation_mm: float | None = None
    path_position_error_mm: float | None = None


@dataclass(frozen=True)
class PeerRun:
    """The peer on one move: time [ms]; ``solved`` of ``poses`` (its reported successes); ``success``:
    all solved; ``pose_error_mm``: the largest position error of its solutions (our FK);
    ``midpoint_deviation_mm``: the largest distance from the segment of our FK at the midpoints of
    consecutive solutions (None unless every pose was solved); ``failure``: what raised."""

    time_ms: float
    poses: int
    solved: int
    success: bool
    pose_error_mm: float | None = None
    midpoint_deviation_mm: float | None = None
    failure: str = ""


@dataclass(frozen=True)
class MoveRecord:
    """One move: ``q0`` [rad] and the unit ``direction`` as lists, the draws rejected before it, ours
    and the peer's run (None when the peer is unavailable)."""

    index: int
    redraws: int
    q0: list
    direction: list
    ours: OursRun
    peer: PeerRun | None


@dataclass(frozen=True)
class CartesianRobotReport:
    """One robot: ``moves``, ``redraws`` (by reason: the exception's class), ours' times [ms] (median
    and p95 of the IK part, of timing + certification and of the total), ``certified`` and ``failures``,
    TCP speed (median and smallest per-move cruise fraction, median peak ratio, moves whose peak >=
    0.99, smallest peak), distances from the line [mm] (largest and median over moves of each move's
    largest); the peer's time, ratios (median of per-move peer / ours, total and IK part), moves it
    solved whole and its distances (likewise);
    ``unavailable``: the peer, with the reason, when it could not run."""

    robot_name: str
    dof: int
    moves: int
    redraws: int
    redraw_reasons: dict[str, int]
    ik_median_ms: float
    ik_p95_ms: float
    timing_median_ms: float
    timing_p95_ms: float
    total_median_ms: float
    total_p95_ms: float
    certified: int
    failures: int
    cruise_fraction_median: float | None
    cruise_fraction_min: float | None
    peak_ratio_median: float | None
    peak_ratio_min: float | None
    peak_at_limit: int
    line_deviation_max_mm: float | None
    line_deviation_median_mm: float | None
    dense_line_deviation_max_mm: float | None
    dense_line_deviation_median_mm: float | None
    path_position_error_max_mm: float | None
    path_position_error_median_mm: float | None
    peer_median_ms: float | None
    peer_p95_ms: float | None
    peer_ratio_total: float | None
    peer_ratio_ik: float | None
    peer_successes: int | None
    peer_pose_error_max_mm: float | None
    peer_pose_error_median_mm: float | None
    peer_midpoint_deviation_max_mm: float | None
    peer_midpoint_deviation_median_mm: float | None
    peer_first_failure: str
    unavailable: dict[str, str]
    records: tuple[MoveRecord, ...]


@dataclass(frozen=True)
class CartesianBenchReport(GoalReport):
    """Result of one Cartesian benchmark run: one CartesianRobotReport per robot, the goals over all."""

    moves: int
    seed: int
    move_length_m: float
    tcp_speed_max: float
    tcp_accel_max: float
    dt: float
    robots: tuple[CartesianRobotReport, ...]
    goals: tuple[Goal, ...]
    versions: dict[str, str]

    def format_table(self) -> str:
        """Per robot a time table (ours split, the peer) and a quality table, then the goals."""
        V, A = self.tcp_speed_max, self.tcp_accel_max
        ramp = V * V / (2.0 * A)
        lines = [
            f"Cartesian benchmark: {self.moves} seeded random {self.move_length_m:g} m straight-line TCP moves per "
            f"robot (same orientation, q0 {100 * MARGIN:.0f} % inside the limits), seed {self.seed}; "
            f"V = {V:g} m/s, A = {A:g} m/s^2, dt = {self.dt:g} s",
            "ours: timed end to end (IK along the line + toppra timing + certification); the peer computes joint "
            "samples along the line only (no timing, no certification); times per move, interleaved",
            f"straight part: {ramp:g} to {self.move_length_m - ramp:g} m along the line; distance: TCP (our FK) to "
            "the segment X0 -> X1",
        ]
        for robot in self.robots:
            reasons = ", ".join(f"{n} {k}" for k, n in robot.redraw_reasons.items())
            lines += ["", f"{robot.robot_name} ({robot.dof} dof), {robot.moves} moves ({robot.redraws} draw(s) "
                          f"rejected{': ' + reasons if reasons else ''})", *_time_table(robot)]
            if robot.peer_ratio_total is not None:
                lines.append(f"  peer / ours time (median of per-move ratios; > 1: ours is faster): "
                             f"vs our total {robot.peer_ratio_total:.3g}x, vs our IK part {robot.peer_ratio_ik:.3g}x")
            lines += _quality_table(robot, self.moves)
            lines.append(f"  ours: TCP speed on the straight part: samples >= {SPEED_FRACTION:g} V median "
                         f"{_pct(robot.cruise_fraction_median)} (smallest {_pct(robot.cruise_fraction_min)}); peak / V "
                         f"median {fmt(robot.peak_ratio_median, '.4f')} (smallest {fmt(robot.peak_ratio_min, '.4f')}),"
                         f" peak >= {SPEED_FRACTION:g} on {robot.peak_at_limit} of {robot.moves} moves "
                         f"({100.0 * robot.peak_at_limit / robot.moves:.0f} %)")
            lines += [f"  unavailable: {name}: {why}" for name, why in robot.unavailable.items()]
            if robot.failures:
                first = next(r.ours.failure for r in robot.records if r.ours.failure)
                lines.append(f"  ours failed on {robot.failures} of {robot.moves} moves, first: {first}")
            if robot.peer_first_failure:
                lines.append(f"  peer, first failure: {robot.peer_first_failure}")
        lines += goal_lines("Goals over all robots and moves:", self.goals, self.versions)
        return "\n".join(lines)



def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100.0 * value:.1f} %"


def _aligned(head: tuple[str, ...], body: list[tuple[str, ...]]) -> list[str]:
    widths = [max(len(row[c]) for row in (head, *body)) for c in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *body)]


def _time_table(robot: CartesianRobotReport) -> list[str]:
    head = ("time per move", "median ms", "p95 ms")
    body = [("ours: IK along the line (ToolPath + joint_path_along)", f"{robot.ik_median_ms:.1f}",
             f"{robot.ik_p95_ms:.1f}"),
            ("ours: timing + certification (retime toppra, TCP limits)", f"{robot.timing_median_ms:.1f}",
             f"{robot.timing_p95_ms:.1f}"),
            ("ours: total (certified profile)", f"{robot.total_median_ms:.1f}", f"{robot.total_p95_ms:.1f}")]
    if robot.peer_median_ms is not None:
        body.append((PEER, f"{robot.peer_median_ms:.1f}", f"{robot.peer_p95_ms:.1f}"))
    return _aligned(head, body)


def _quality_table(robot: CartesianRobotReport, moves: int) -> list[str]:
    head = ("TCP distance from the segment X0 -> X1", "moves OK", "max mm", "median of per-move max mm")
    body = [("ours: at the profile's samples", f"{robot.certified}/{moves} certified",
             fmt(robot.line_deviation_max_mm, ".4f"), fmt(robot.line_deviation_median_mm, ".4f")),
            (f"ours: on the joint path, {DENSE_SAMPLES} points", "",
             fmt(robot.dense_line_deviation_max_mm, ".4f"), fmt(robot.dense_line_deviation_median_mm, ".4f")),
            ("ours: joint_path_along's own check (max_position_error, to the ideal pose)", "",
             fmt(robot.path_position_error_max_mm, ".4f"), fmt(robot.path_position_error_median_mm, ".4f"))]
    if robot.peer_successes is not None:
        body += [("peer: its IK solutions (position error to the ctraj poses)", f"{robot.peer_successes}/{moves} all solved",
                  fmt(robot.peer_pose_error_max_mm, ".4f"), fmt(robot.peer_pose_error_median_mm, ".4f")),
                 ("peer: joint-space linear interpolation (midpoints of its solutions)", "",
                  fmt(robot.peer_midpoint_deviation_max_mm, ".4f"), fmt(robot.peer_midpoint_deviation_median_mm, ".4f"))]
    return _aligned(head, body)


# -- geometry ---------------------------------------------------------------------------------------
def segment_distance(points: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Distance [m] of points (n, 3) from the segment p0 -> p1 (the nearest point of the segment)."""
    axis = p1 - p0
    u = np.clip((points - p0) @ axis / float(axis @ axis), 0.0, 1.0)
    return np.linalg.norm(points - (p0 + u[:, None] * axis), axis=1)


@dataclass(frozen=True)
class Move:
    """One drawn move: start configuration, start and end pose, direction, rejected draws before it,
    and the number of IK samples our joint path has on it (the peer's density)."""

    q0: np.ndarray
    X0: np.ndarray
    X1: np.ndarray
    direction: np.ndarray
    redraws: int
    samples: int


# -- ours -------------------------------------------------------------------------------------------
def run_ours(robot: Robot, X0: np.ndarray, X1: np.ndarray, q0: np.ndarray):
    """Our pipeline on one move: (along, profile, IK seconds, timing seconds). Raises what it raises."""
    from ..timing.tcp import TcpMotion
    from ..timing import retime
    from ..program.tool_moves import joint_path_along
    from ..program.tool_path import ToolMove, ToolPath

    clock = time.perf_counter
    start = clock()
    along = joint_path_along(robot, ToolPath(X0, [ToolMove("linear", X1)]), q0, tcp_speed_max=TCP_SPEED)
    middle = clock()
    limits = dataclasses.replace(robot.limits, tcp_speed_max=TCP_SPEED, tcp_accel_max=TCP_ACCEL)
    profile = retime(robot, along.path, method="toppra", limits=limits, tcp=TcpMotion(robot), dt=DT)
    return along, profile, middle - start, clock() - middle


def draw_moves(robot: Robot, count: int, rng: np.random.Generator) -> tuple[list[Move], dict[str, int]]:
    """``count`` moves our pipeline can run (untimed trial runs), and the rejected draws by reason."""
    from ..program.tool_moves import ToolMoveError

    moves, reasons = [], {}
    with Progress(count, f"bench cartesian {robot.name}: drawing moves") as tick:
        for _ in range(count):
            for redraws in range(MAX_DRAWS):
                q0 = robot.random_configurations(rng, 1, margin=MARGIN)[0]
                direction = rng.normal(size=3)
                direction /= np.linalg.norm(direction)
                X0 = robot.fk(q0)
                X1 = X0.copy()
                X1[:3, 3] += MOVE_LENGTH_M * direction
                try:
                    along, _, _, _ = run_ours(robot, X0, X1, q0)
                except (ToolMoveError, TimingError) as exc:
                    reasons[type(exc).__name__] = reasons.get(type(exc).__name__, 0) + 1
                    continue
                moves.append(Move(q0, X0, X1, direction, redraws, len(along.sigma)))
                break
            else:
                raise ConfigurationError(f"{robot.name}: {MAX_DRAWS} random draws of a {MOVE_LENGTH_M:g} m straight "
                                         "move in a row were all rejected (out of reach, branch change, singularity "
                                         "or no certified timing)")
            tick()
    return moves, reasons


def measure_ours(robot: Robot, move: Move, outcome) -> OursRun:
    """The untimed measures of our run: certification, TCP speed, distances from the line."""
    along, profile, ik_s, timing_s = outcome
    ik_ms, timing_ms = 1e3 * ik_s, 1e3 * timing_s
    certified = profile.certificate is not None and bool(profile.certificate.passed)
    p0, p1 = move.X0[:3, 3], move.X1[:3, 3]
    positions = robot.fk_batch(profile.q)[:, :3, 3]
    progress = (positions - p0) @ move.direction
    ramp = TCP_SPEED**2 / (2.0 * TCP_ACCEL)
    cruise = (progress >= ramp) & (progress <= MOVE_LENGTH_M - ramp)
    speed = np.asarray(profile.tcp.speed)
    dense = robot.fk_batch(along.path(np.linspace(0.0, 1.0, DENSE_SAMPLES)))[:, :3, 3]
    return OursRun(
        ik_ms=ik_ms, timing_ms=timing_ms, total_ms=ik_ms + timing_ms, certified=certified, samples=len(along.sigma),
        failure="" if certified else f"certificate failed: {profile.certificate}",
        profile_samples=len(profile.t), duration_s=profile.duration,
        cruise_fraction=float(np.mean(speed[cruise] >= SPEED_FRACTION * TCP_SPEED)) if cruise.any() else None,
        peak_speed_ratio=float(speed.max() / TCP_SPEED),
        line_deviation_mm=1e3 * float(segment_distance(positions, p0, p1).max()),
        dense_line_deviation_mm=1e3 * float(segment_distance(dense, p0, p1).max()),
        path_position_error_mm=1e3 * float(along.max_position_error),
    )


# -- the peer ---------------------------------------------------------------------------------------
PeerSolve = Callable[[Move], tuple[np.ndarray, np.ndarray, object]]


def rtb_path_solver(robot: Robot) -> PeerSolve:
    """Robotics Toolbox ``ctraj`` + ``ikine_LM`` seeded by the previous solution: (Q (n, dof), solved (n,),
    the ctraj poses). Raises ImportError when roboticstoolbox is not installed."""
    import roboticstoolbox as rtb
    from spatialmath import SE3

    from .ik import RTB_ITERATIONS, RTB_TOLERANCE, build_rtb_ets

    ets = build_rtb_ets(robot)

    def solve(move: Move) -> tuple[np.ndarray, np.ndarray, object]:
        poses = rtb.ctraj(SE3(move.X0, check=False), SE3(move.X1, check=False), move.samples)
        Q, solved, seed = np.empty((len(poses), robot.dof)), np.zeros(len(poses), dtype=bool), move.q0
        for k, pose in enumerate(poses):
            solution = ets.ikine_LM(pose, q0=seed, ilimit=RTB_ITERATIONS, tol=RTB_TOLERANCE, joint_limits=True,
                                    seed=RTB_SEED)
            Q[k], solved[k] = solution.q, bool(solution.success)
            if solved[k]:
                seed = Q[k]
        return Q, solved, poses

    return solve


def measure_peer(robot: Robot, move: Move, Q: np.ndarray, solved: np.ndarray, targets: np.ndarray,
                 elapsed_s: float) -> PeerRun:
    """Its success, its solutions' position error (to its targets (n, 3) [m]) and the distance of its
    joint-space midpoints from the segment."""
    p0, p1 = move.X0[:3, 3], move.X1[:3, 3]
    success = bool(solved.all())
    pose_error = midpoint = None
    if solved.any():
        reached = robot.fk_batch(Q[solved])[:, :3, 3]
        pose_error = 1e3 * float(np.linalg.norm(reached - targets[solved], axis=1).max())
    if success:
        middles = robot.fk_batch((Q[:-1] + Q[1:]) / 2.0)[:, :3, 3]
        midpoint = 1e3 * float(segment_distance(middles, p0, p1).max())
    return PeerRun(time_ms=1e3 * elapsed_s, poses=len(Q), solved=int(solved.sum()), success=success,
                   pose_error_mm=pose_error, midpoint_deviation_mm=midpoint)


# -- running ----------------------------------------------------------------------------------------
def _ours_contestant(robot: Robot, move: Move) -> OursRun:
    start = time.perf_counter()
    try:
        outcome = run_ours(robot, move.X0, move.X1, move.q0)
    except Exception as exc:  # noqa: BLE001 - a failure is counted and reported, not fatal
        elapsed = 1e3 * (time.perf_counter() - start)   # the split is unknown: all of it counts as IK
        return OursRun(elapsed, 0.0, elapsed, False, 0, f"{type(exc).__name__}: {exc}")
    return measure_ours(robot, move, outcome)


def _peer_contestant(robot: Robot, solve: PeerSolve, move: Move) -> PeerRun:
    start = time.perf_counter()
    try:
        Q, solved, poses = solve(move)
    except Exception as exc:  # noqa: BLE001 - a failure is counted and reported, not fatal
        return PeerRun(1e3 * (time.perf_counter() - start), move.samples, 0, False,
                       failure=f"{type(exc).__name__}: {exc}")
    elapsed = time.perf_counter() - start
    return measure_peer(robot, move, Q, solved, np.asarray(poses.t, dtype=float).reshape(-1, 3), elapsed)


def _median(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else None


def _p95(values) -> float:
    return float(np.percentile(values, 95))


def benchmark_robot(robot: Robot, moves: int, seed: int) -> CartesianRobotReport:
    """Ours and the peer on ``moves`` seeded random feasible straight-line moves of one robot, interleaved."""
    drawn, reasons = draw_moves(robot, moves, np.random.default_rng(seed))
    unavailable, peer = {}, None
    try:
        peer = rtb_path_solver(robot)
    except ImportError as exc:
        unavailable[PEER] = f"{exc} (install the 'bench' extra)"
    contestants = [lambda move: _ours_contestant(robot, move)]
    if peer is not None:
        contestants.append(lambda move: _peer_contestant(robot, peer, move))
    for contestant in contestants:                              # warm-up: imports, caches; not counted
        contestant(drawn[0])

    runs: list[list] = [[None] * moves for _ in contestants]
    with Progress(moves, f"bench cartesian {robot.name}") as tick:
        for m, move in enumerate(drawn):
            for k in np.roll(np.arange(len(contestants)), -m):     # interleaved, order rotated per move
                runs[k][m] = contestants[k](move)
            tick()
    ours: list[OursRun] = runs[0]
    peers: list[PeerRun] | None = runs[1] if peer is not None else None
    records = tuple(MoveRecord(m, move.redraws, move.q0.tolist(), move.direction.tolist(), ours[m],
                               peers[m] if peers else None) for m, move in enumerate(drawn))

    ok = [r for r in ours if not r.failure]
    peak = [r.peak_speed_ratio for r in ok]
    cruise = [r.cruise_fraction for r in ok if r.cruise_fraction is not None]
    peer_values: dict = dict(peer_median_ms=None, peer_p95_ms=None, peer_ratio_total=None, peer_ratio_ik=None,
                             peer_successes=None, peer_pose_error_max_mm=None, peer_pose_error_median_mm=None,
                             peer_midpoint_deviation_max_mm=None,
                             peer_midpoint_deviation_median_mm=None, peer_first_failure="")
    if peers:
        times = [p.time_ms for p in peers]
        midpoints = [p.midpoint_deviation_mm for p in peers if p.midpoint_deviation_mm is not None]
        errors = [p.pose_error_mm for p in peers if p.pose_error_mm is not None]
        failed = [p for p in peers if p.failure or not p.success]
        peer_values.update(
            peer_median_ms=float(np.median(times)), peer_p95_ms=_p95(times),
            peer_ratio_total=float(np.median([p.time_ms / o.total_ms for p, o in zip(peers, ours)])),
            peer_ratio_ik=float(np.median([p.time_ms / o.ik_ms for p, o in zip(peers, ours)])),
            peer_successes=sum(p.success for p in peers),
            peer_pose_error_max_mm=max(errors, default=None), peer_pose_error_median_mm=_median(errors),
            peer_midpoint_deviation_max_mm=max(midpoints, default=None),
            peer_midpoint_deviation_median_mm=_median(midpoints),
            peer_first_failure=(failed[0].failure or f"solved {failed[0].solved} of {failed[0].poses} poses")
            if failed else "")
    return CartesianRobotReport(
        robot_name=robot.name, dof=robot.dof, moves=moves, redraws=sum(m.redraws for m in drawn),
        redraw_reasons=dict(sorted(reasons.items())),
        ik_median_ms=float(np.median([r.ik_ms for r in ours])), ik_p95_ms=_p95([r.ik_ms for r in ours]),
        timing_median_ms=float(np.median([r.timing_ms for r in ours])), timing_p95_ms=_p95([r.timing_ms for r in ours]),
        total_median_ms=float(np.median([r.total_ms for r in ours])), total_p95_ms=_p95([r.total_ms for r in ours]),
        certified=sum(r.certified for r in ours), failures=sum(bool(r.failure) for r in ours),
        cruise_fraction_median=_median(cruise), cruise_fraction_min=min(cruise, default=None),
        peak_ratio_median=_median(peak), peak_ratio_min=min(peak, default=None),
        peak_at_limit=sum(p >= SPEED_FRACTION for p in peak),
        line_deviation_max_mm=max((r.line_deviation_mm for r in ok), default=None),
        line_deviation_median_mm=_median(r.line_deviation_mm for r in ok),
        dense_line_deviation_max_mm=max((r.dense_line_deviation_mm for r in ok), default=None),
        dense_line_deviation_median_mm=_median(r.dense_line_deviation_mm for r in ok),
        path_position_error_max_mm=max((r.path_position_error_mm for r in ok), default=None),
        path_position_error_median_mm=_median(r.path_position_error_mm for r in ok),
        **peer_values, unavailable=unavailable, records=records,
    )


def evaluate_goals(robots: tuple[CartesianRobotReport, ...]) -> tuple[Goal, ...]:
    """The two goals over all robots and moves (a failed move fails both)."""
    failures = sum(robot.failures for robot in robots)
    count = sum(robot.moves for robot in robots)
    slowest = max(robot.total_median_ms for robot in robots)
    peaks = [r.ours.peak_speed_ratio for robot in robots for r in robot.records if not r.ours.failure]
    smallest = min(peaks, default=None)
    below = sum(p < SPEED_FRACTION for p in peaks)
    return (
        Goal(f"certified {MOVE_LENGTH_M:g} m move under {TIME_GOAL_MS:g} ms: median total time per robot [ms], the "
             "largest", slowest, f"< {TIME_GOAL_MS:g} ms, every move certified ({failures} of {count} failed)",
             slowest < TIME_GOAL_MS and failures == 0),
        Goal(f"TCP at >= {100 * SPEED_FRACTION:.0f} % of its speed limit on the straight part: peak TCP speed / V, "
             "smallest over moves", smallest,
             f">= {SPEED_FRACTION:g} on every move ({below} of {count} below, {failures} failed)",
             smallest is not None and below == 0 and failures == 0),
    )


def run_cartesian_benchmark(robots=ROBOTS, moves: int = 20, seed: int = 0) -> CartesianBenchReport:
    """Ours (straight-line TCP move -> IK along it -> certified toppra profile) beside Robotics
    Toolbox's ctraj + ikine_LM (path only) on each robot, the same moves.

    ``robots``: preset names or robot files; ``moves``: seeded random feasible 0.5 m moves per robot;
    ``seed``: of the moves (each robot draws from its own generator seeded with it).
    """
    if moves < 1:
        raise ConfigurationError(f"moves must be >= 1, got {moves}")
    robots = (robots,) if isinstance(robots, str) else tuple(robots)
    if not robots:
        raise ConfigurationError("no robots to benchmark")
    reports = tuple(benchmark_robot(load_robot(name), moves, seed) for name in robots)
    versions = version_table("numpy", "scipy", "toppra", "roboticstoolbox-python", "spatialmath-python")
    return CartesianBenchReport(moves=moves, seed=seed, move_length_m=MOVE_LENGTH_M, tcp_speed_max=TCP_SPEED,
                                tcp_accel_max=TCP_ACCEL, dt=DT, robots=reports, goals=evaluate_goals(reports),
                                versions=versions)
