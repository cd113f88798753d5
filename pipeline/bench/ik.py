"""IK benchmark: our methods beside Robotics Toolbox ``ik_LM`` and raw Drake IK, in the same run.

Per robot, the targets are the FK poses of seeded random in-limit configurations and the seeds are
independent random in-limit configurations. Every method and peer gets the same (target, seed)
pairs; on each target they take turns (the order rotated from target to target) so that drift of a
shared machine's speed hits all of them alike.

Two success rates per row: *reported* (what the method or peer says) and *strict*, judged here by
our own NumPy FK whatever the method says: position error <= 1e-6 m, rotation error <= 1e-6 rad and
every joint inside its limits. Times are wall clock per solve call (``time.perf_counter_ns``),
failed calls included, in µs: the Python call, building the problem where the library needs one,
restarts, and our verification for our methods.

Peers (optional ``bench`` extra for Robotics Toolbox; imported lazily, reported unavailable when
missing):

* Robotics Toolbox ``ETS.ik_LM`` (compiled C++, Chan's damping), on the ETS of the ``DHRobot``
  built from the spec with our joint limits, ``ilimit=30``, ``joint_limits=True``, and
  ``tol = RTB_TOLERANCE``: it stops when ``E = e.e / 2 < tol`` for its 6-vector error ``e``
  (position, angle-axis), so 5e-13 is the largest tolerance that implies our strict test (its
  default 1e-6 allows ~1.4e-3 of error). ``slimit=1`` (one search from the seed) and ``slimit=100``
  (up to 99 random restarts, drawn by its own unseeded C++ generator).
* Drake ``InverseKinematics`` as a user would write it: position constraint (equality) and
  orientation constraint (theta_bound 0) on the end frame, joint limits, SNOPT (else IPOPT) with
  default options, the seed as the initial guess, one solve, its own ``is_success()``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import ConfigurationError
from ..progress import Progress
from ..ik import METHODS as IK_METHODS
from ..ik.result import is_strict, make_target, pose_errors, within_limits
from ..versions import version_table
from ..robot import Robot, load_robot

METHODS = ("analytic", "jacobian", "drake")
ROBOTS = ("gp7", "lrmate200id", "irb1600", "arm6")

RTB_1 = "RTB ik_LM (C++), 1 search"
RTB_100 = "RTB ik_LM (C++), up to 100 searches"
DRAKE_RAW = "Drake IK, SNOPT defaults, 1 solve"
PEERS = (RTB_1, RTB_100, DRAKE_RAW)

RTB_TOLERANCE = 5e-13       # E = |e|^2 / 2 < 5e-13  =>  |e| < 1e-6: position and angle both strict
RTB_ITERATIONS = 30         # ilimit: iterations per search (its default)
WARMUP_TARGETS = 3          # solved by everyone before timing (imports, caches); not counted
VERIFY_CONFIGURATIONS = 10
VERIFY_TOLERANCE = 1e-9


def ours_name(method: str) -> str:
    return f"ours: {method}"


@dataclass(frozen=True)
class IkRow:
    """One method or peer on one robot. Times [µs] per solve call, failed calls included.

    ``reported``: successes the method/peer reported; ``strict``: answers that passed our FK check;
    ``reported_not_strict``: reported successes that failed it; ``errors``: calls that raised
    (counted as failures; ``first_error`` says what happened).
    """

    name: str
    ours: bool
    targets: int
    reported: int
    strict: int
    reported_not_strict: int
    errors: int
    reported_pct: float
    strict_pct: float
    median_us: float
    p95_us: float
    first_error: str = ""


@dataclass(frozen=True)
class IkRobotReport:
    """All rows of one robot, ours first. ``ratio[ours][peer]``: ours median / peer median time
    (above 1: ours takes longer); ``fastest_peer``: the peer with the smallest median time.
    ``unavailable``: methods or peers that could not run, with the reason."""

    robot_name: str
    convention: str
    dof: int
    rows: tuple[IkRow, ...]
    ratio: dict[str, dict[str, float]]
    fastest_peer: str
    unavailable: dict[str, str]


@dataclass(frozen=True)
class IkBenchReport:
    """Result of one IK benchmark run: one IkRobotReport per robot."""

    targets: int
    seed: int
    methods: tuple[str, ...]
    robots: tuple[IkRobotReport, ...]
    versions: dict[str, str]

    def format_table(self) -> str:
        """One table per robot (method | reported % | strict % | median µs | p95 µs), then ratios."""
        lines = [
            f"IK benchmark: {self.targets} targets per robot (FK of seeded random in-limit configurations), "
            f"random in-limit seeds, seed {self.seed}",
            "strict = position <= 1e-6 m, rotation <= 1e-6 rad, joints in limits, judged by our FK; "
            "times per solve call, failures included",
        ]
        for robot in self.robots:
            lines += ["", f"{robot.robot_name} ({robot.convention} DH, {robot.dof} dof)", *_table(robot.rows)]
            if robot.fastest_peer:
                peer_median = next(r.median_us for r in robot.rows if r.name == robot.fastest_peer)
                for name, ratios in robot.ratio.items():
                    lines.append(f"  {name} median / fastest numeric peer median ({robot.fastest_peer}, "
                                 f"{peer_median:.0f} µs) = {ratios[robot.fastest_peer]:.3g}x")
            lines += [f"  unavailable: {name}: {why}" for name, why in robot.unavailable.items()]
            lines += [f"  {row.name}: {row.errors} call(s) raised, first: {row.first_error}"
                      for row in robot.rows if row.errors]
        lines.append("versions: " + ", ".join(f"{k} {v}" for k, v in self.versions.items()))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The report as JSON-serialisable builtins."""
        return dataclasses.asdict(self)


def _table(rows: tuple[IkRow, ...]) -> list[str]:
    head = ("method", "reported %", "strict %", "reported, not strict", "median µs", "p95 µs")
    body = [(r.name, f"{r.reported_pct:.1f}", f"{r.strict_pct:.1f}", str(r.reported_not_strict),
             f"{r.median_us:.0f}", f"{r.p95_us:.0f}") for r in rows]
    widths = [max(len(row[c]) for row in (head, *body)) for c in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *body)]


# -- solvers under test: (X_target, q_seed) -> (reported success, q) -----------------------------
Solve = Callable[[np.ndarray, np.ndarray], tuple[bool, np.ndarray]]


def ours_solver(robot: Robot, method: str) -> Solve:
    """Our ``solve_ik`` through the dispatcher, full pose targets."""
    from ..ik import solve_ik, with_drake_model

    options = with_drake_model(robot, method, {})          # one Drake model, built outside the timing

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        result = solve_ik(robot, X, q_seed=q_seed, method=method, **options)
        return result.success, result.q

    return solve


def build_rtb_ets(robot: Robot):
    """The ETS of the Robotics Toolbox ``DHRobot`` built from the spec, with our joint limits.

    Checked against our FK before use. Raises ImportError when roboticstoolbox is not installed.
    """
    import roboticstoolbox as rtb
    from spatialmath import SE3

    from .kinematics import _rtb_link

    spec = robot.spec
    links = [_rtb_link(rtb, joint, spec.convention == "modified") for joint in spec.joints]
    for link, low, high in zip(links, robot.limits.q_min, robot.limits.q_max):
        link.qlim = [low, high]
    arm = rtb.DHRobot(links, base=SE3(spec.X_BaseD0, check=False), tool=SE3(spec.X_DnE, check=False),
                      name=spec.name)
    ets = arm.ets()
    Q = robot.random_configurations(np.random.default_rng(0), VERIFY_CONFIGURATIONS)
    error = max(float(np.abs(np.asarray(ets.eval(q)) - robot.fk(q)).max()) for q in Q)
    limits_error = float(np.abs(np.asarray(ets.qlim) - np.vstack([robot.limits.q_min, robot.limits.q_max])).max())
    if error > VERIFY_TOLERANCE or limits_error > VERIFY_TOLERANCE:
        raise RuntimeError(f"Robotics Toolbox model of {robot.name} disagrees with ours: FK {error:.3g} m, "
                           f"joint limits {limits_error:.3g}")
    return ets


def rtb_solver(ets, searches: int) -> Solve:
    """``ets.ik_LM`` from the seed, up to ``searches`` searches (its own reported success)."""

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        solution = ets.ik_LM(X, q0=q_seed, ilimit=RTB_ITERATIONS, slimit=searches, tol=RTB_TOLERANCE,
                             joint_limits=True)
        return bool(solution.success), np.asarray(solution.q, dtype=float)

    return solve


def drake_raw_solver(robot: Robot) -> Solve:
    """Drake InverseKinematics as a user writes it: position + orientation, default options, one solve."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.inverse_kinematics import InverseKinematics
    from pydrake.solvers import IpoptSolver, SnoptSolver

    from ..drake_model import build_drake_robot

    drake = build_drake_robot(robot.spec)
    plant, B, E = drake.plant, drake.base_frame, drake.end_frame
    solver = SnoptSolver()
    if not solver.available():
        solver = IpoptSolver()

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        ik = InverseKinematics(plant, with_joint_limits=True)
        p = X[:3, 3]
        ik.AddPositionConstraint(E, np.zeros(3), B, p, p)
        ik.AddOrientationConstraint(B, RotationMatrix(X[:3, :3]), E, RotationMatrix(), 0.0)
        result = solver.Solve(ik.prog(), q_seed, None)
        return result.is_success(), np.asarray(result.GetSolution(ik.q()), dtype=float)

    return solve


def _peer_solvers(robot: Robot) -> tuple[list[tuple[str, Solve]], dict[str, str]]:
    solvers, unavailable = [], {}
    try:
        ets = build_rtb_ets(robot)
    except ImportError as exc:
        for name in (RTB_1, RTB_100):
            unavailable[name] = f"{exc} (install the 'bench' extra)"
    else:
        solvers += [(RTB_1, rtb_solver(ets, 1)), (RTB_100, rtb_solver(ets, 100))]
    try:
        solvers.append((DRAKE_RAW, drake_raw_solver(robot)))
    except ImportError as exc:
        unavailable[DRAKE_RAW] = str(exc)
    return solvers, unavailable


# -- the benchmark --------------------------------------------------------------------------------
def _strict(robot: Robot, q: np.ndarray, target) -> bool:
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.dof,) or not np.isfinite(q).all():
        return False
    return is_strict(*pose_errors(robot.fk(q), target)) and within_limits(q, robot.limits.q_min, robot.limits.q_max)


def _usable(name: str, solve: Solve, robot: Robot, Q_warmup: np.ndarray, seeds: np.ndarray) -> str:
    """"" when ``solve`` runs on the warm-up targets, else why not (NotImplementedError, ImportError...)."""
    try:
        for q_target, q_seed in zip(Q_warmup, seeds):
            solve(robot.fk(q_target), q_seed)
    except (NotImplementedError, ImportError) as exc:
        return f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 - a method that cannot run on this robot is reported, not fatal
        return f"raised on a warm-up target: {type(exc).__name__}: {exc}"
    return ""


def _solve_target(robot, solvers, t, q_target, q_seed, times, reported, strict, errors, first_error) -> None:
    """Every solver on target t, interleaved in an order rotated per target; fills row t of the arrays."""
    clock = time.perf_counter_ns
    X = robot.fk(q_target)
    target = make_target(X)
    for k in np.roll(np.arange(len(solvers)), -t):
        name, solve = solvers[k]
        start = clock()
        try:
            ok, q = solve(X, q_seed)
        except Exception as exc:  # noqa: BLE001 - counted as a failure and reported
            times[k, t] = clock() - start
            errors[k] += 1
            first_error[k] = first_error[k] or f"{type(exc).__name__}: {exc}"
            continue
        times[k, t] = clock() - start
        reported[k, t] = ok
        strict[k, t] = _strict(robot, q, target)


def benchmark_robot(robot: Robot, targets: int, seed: int, methods: tuple[str, ...]) -> IkRobotReport:
    """Run every available method and peer on ``targets`` seeded targets of one robot."""
    rng = np.random.default_rng(seed)
    Q_target = robot.random_configurations(rng, targets)
    Q_seed = robot.random_configurations(rng, targets)
    Q_warmup = robot.random_configurations(rng, 2 * WARMUP_TARGETS)

    candidates = [(ours_name(m), ours_solver(robot, m)) for m in methods]
    peers, unavailable = _peer_solvers(robot)
    solvers: list[tuple[str, Solve]] = []
    for name, solve in candidates + peers:
        why = _usable(name, solve, robot, Q_warmup[:WARMUP_TARGETS], Q_warmup[WARMUP_TARGETS:])
        if why:
            unavailable[name] = why
        else:
            solvers.append((name, solve))

    count = len(solvers)
    times = np.zeros((count, targets))
    reported = np.zeros((count, targets), dtype=bool)
    strict = np.zeros((count, targets), dtype=bool)
    errors = [0] * count
    first_error = [""] * count
    with Progress(targets, f"bench ik {robot.name}") as tick:
        for t in range(targets):
            _solve_target(robot, solvers, t, Q_target[t], Q_seed[t], times, reported, strict, errors, first_error)
            tick()

    rows = []
    for k, (name, _) in enumerate(solvers):
        n_reported, n_strict = int(reported[k].sum()), int(strict[k].sum())
        rows.append(IkRow(
            name=name, ours=name.startswith("ours: "), targets=targets, reported=n_reported, strict=n_strict,
            reported_not_strict=int((reported[k] & ~strict[k]).sum()), errors=errors[k],
            reported_pct=100.0 * n_reported / targets, strict_pct=100.0 * n_strict / targets,
            median_us=float(np.median(times[k])) / 1e3, p95_us=float(np.percentile(times[k], 95)) / 1e3,
            first_error=first_error[k],
        ))
    if "analytic" in methods and ours_name("analytic") not in unavailable:
        rows.append(analytic_batch_row(robot, Q_target, Q_seed))
    ours_rows = [r for r in rows if r.ours]
    peer_rows = [r for r in rows if not r.ours]
    fastest = min(peer_rows, key=lambda r: r.median_us).name if peer_rows else ""
    ratio = {o.name: {p.name: o.median_us / p.median_us for p in peer_rows} for o in ours_rows}
    return IkRobotReport(robot_name=robot.name, convention=robot.spec.convention, dof=robot.dof,
                         rows=tuple(rows), ratio=ratio, fastest_peer=fastest, unavailable=unavailable)


def analytic_batch_row(robot: Robot, Q_target: np.ndarray, Q_seed: np.ndarray) -> IkRow:
    """The closed form solving all targets in one vectorised ``ik_batch`` call (best of 3 runs).

    Its median and p95 are both the run time divided by the number of targets: a batch has no
    per-target times.
    """
    X = robot.fk_batch(Q_target)
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter_ns()
        results = robot.ik_batch(X, Q_seed, method="analytic")
        best = min(best, time.perf_counter_ns() - start)
    per_target_us = best / len(X) / 1e3
    reported = np.array([r.success for r in results])
    strict = np.array([_strict(robot, r.q, make_target(x)) for r, x in zip(results, X)])
    n = len(X)
    return IkRow(name=f"ours: analytic, one batch of {n} (time / target)", ours=True, targets=n,
                 reported=int(reported.sum()), strict=int(strict.sum()),
                 reported_not_strict=int((reported & ~strict).sum()), errors=0,
                 reported_pct=100.0 * reported.mean(), strict_pct=100.0 * strict.mean(),
                 median_us=per_target_us, p95_us=per_target_us)


def run_ik_benchmark(robots=ROBOTS, targets: int = 1000, seed: int = 0, methods=METHODS) -> "IkBenchReport":
    """Our IK methods beside Robotics Toolbox ``ik_LM`` and raw Drake IK on each robot, same targets.

    ``robots``: preset names or robot files; ``targets``: per robot; ``seed``: of the targets and
    seeds (each robot draws from its own generator seeded with it); ``methods``: ours, through
    ``pipeline.ik.solve_ik`` (one that raises NotImplementedError or ImportError is reported unavailable).
    """
    if targets < 1:
        raise ConfigurationError(f"targets must be >= 1, got {targets}")
    if isinstance(robots, str):
        robots = (robots,)
    methods = tuple(methods)
    unknown = [m for m in methods if m not in IK_METHODS]
    if unknown:
        raise ConfigurationError(f"unknown IK method(s) {', '.join(unknown)}; choose from {', '.join(IK_METHODS)}")
    reports = tuple(benchmark_robot(load_robot(name), targets, seed, methods) for name in robots)
    versions = version_table("numpy", "drake", "roboticstoolbox-python")
    return IkBenchReport(targets=targets, seed=seed, methods=methods, robots=reports, versions=versions)
