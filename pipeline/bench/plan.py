"""Planning benchmark: collision-free joint moves, ours beside OMPL set up by hand, on random pairs in two
cells and on problem sets that need a search.

Random pairs, per cell (``gp7_wall_cell``: a table with a wall across it, the demo cell;
``gp7_shelf_cell``: a shelf of three boards, a back panel and a post), ``pairs`` start/goal pairs from
one generator seeded with ``seed`` (the same draws in every cell): configurations uniform in the
robot's joint box (``random_configurations``, in limits), a draw kept only when Drake's checker finds
it collision-free (``is_free``: the cell's clearance to obstacles, links apart); draws 2k and 2k + 1
of the kept ones make pair k. A pair is "direct" when its straight joint-space edge is free
(``edge_is_free``, untimed) and "needs a search" otherwise (ours may still search on a direct pair: it
keeps a margin beyond the clearance while planning). Random pairs can be infeasible (a start boxed in
under a board): a pair is proven feasible when a run returned a path the independent check below
confirms (ours with the budget, the peer, or, when both failed, ours again with FEASIBILITY_BUDGET_S).
Success rates, times and ratios are over the proven-feasible pairs; the unproven ones are counted apart.

What is timed (``time.perf_counter``, wall clock, per pair, failed runs included at the time they
took), the two contestants taking turns in an order rotated from pair to pair (machine drift hits both
alike), each once on a pair that needs a search before the timing (imports, caches):

* ours: ``plan_joint_path(model, q_a, q_b, time_budget=2.0)`` (the straight edge when it keeps the
  planner's margins, else a detour, a route through the cell's roadmap or OMPL RRTConnect: see
  ``pipeline.cell.planning``): the whole call, and its own search and shortcut times;
* the peer, what a user writes by hand: OMPL's ``SimpleSetup`` over the same joint box, the state
  validity checker a Python callback on the same Drake checker (``CheckConfigCollisionFree``, the same
  clearance padding), OMPL's default discrete motion validator stepping PEER_STEP_RAD (the validity
  checking resolution as a fraction of the space's maximum extent), ``RRTConnect``, ``solve(2.0)``
  then ``simplifySolution()``: search, simplification and their sum.

Ratios are peer / ours (above 1: ours is faster), medians of per-pair ratios of the whole times over
the pairs both solved.

Checked (untimed), independently of both planners: every returned polyline at CHECK_STEP_RAD joint
steps (Euclidean) with ``CollisionModel.clearance`` (Drake's distance query, not the boolean check the
planners use): every configuration at least the clearance from the obstacles and its links apart. A
path failing it counts as a failure. Reported: the smallest obstacle distance along the paths, path
lengths (Euclidean, joint space) after / before shortcutting.

Whole job, on the first JOB_PAIRS pairs of the first cell that need a search: ``plan_joint_path`` then
``time_clear(model, waypoints, retime, refine=True)`` (toppra through the vertices, the clearance
certificate, refinement while it fails), timed together. Each certified profile is then re-checked
with ``CollisionModel.clearance`` at its samples and at linear interpolations between them at
DENSE_FACTOR x the sample rate; a profile closer than the clearance anywhere there is counted.

Goals: 100 % success on the proven-feasible pairs (every cell); on the first cell, ours (the whole
call) median <= 10 ms and p95 <= 50 ms over its pairs; the whole job under 1 s (the slowest); no
certified profile closer than the clearance.

Problem sets that need a search (``pipeline.bench.plan_sets``: "cubbies", the GP7 reaching into the demo
shelf's cubbies, every ordered pair of its 6 targets; MotionBenchMaker-style scenes and our own rack, machine
door and totes for the GP7 and the IRB 1600, ``count`` queries each, seeded with ``seed``). Per query the two
contestants take turns (ours first on even queries), each at the default planning budget (PLAN_TIME_BUDGET_S),
after a warm-up of both on the set's first query:

* ours: ``plan_joint_path(model, start, goal, seed=JOB_MOVE_SEED)``, the whole call timed (wall clock);
  then, untimed, the query as a programmer writes it (``query_document``: the set's cell, a tool with the
  set's X_FT, a joint move from start to goal, ``plan: collision_free``), ``parse_job``, ``compile_job``
  (which plans the move again) and ``time_program`` (its certificate: limits and the clearance). The
  program's planned vertices must equal the timed call's (the same ends and seed: a deterministic plan);
  the queries where they differ are counted.
* the peer: ``solve_peer`` (OMPL by hand, as on the random pairs) timed, then toppra through a spline of its
  vertices (``time_path(robot, vertices, shape="spline")``, as MoveIt and MPlib users time a plan) and our
  judge (``certify`` with the cell).

Each profile (untimed) is measured: the TCP path (FK of the flange composed with X_FT at the profile's
samples, the sum of |dp|) over the straight TCP distance between start and goal; the duration over the
rest-to-rest bound (``polyline_time`` of [start, goal]: the slowest joint from rest to rest); and an
independent re-check (``recheck_profile``) of every point of the samples subdivided DENSE_FACTOR times
(linear interpolation): ``CollisionModel.clearance`` (Drake's distance query) at every ESTIMATE_STRIDE-th
sample, Drake's checks padded beyond the clearance (SCREENS_M) to find the points nearest the obstacles,
and ``CollisionModel.clearance`` at those: the smallest obstacle distance over all the points, with 1-20 %
of the distance queries (a query costs about 0.6 ms, a padded check 25-50 us: on 6 profiles of the
bookshelf and box sets, every point measured took 1.5-3.6 s a profile, the screened re-check 0.1-1.0 s
for the same smallest distances). A query is solved by a contestant when it found a path within the
budget and its profile passes the re-check; certified when the profile passed our judge.

Per set and contestant: solved %, plan time p50 / p95 / max over every query (failures at the time they
took), TCP path / straight median and max and motion / bound median over the solved, the re-check's
smallest obstacle distance, certified / found, profiles under the clearance in the re-check; the peer /
ours plan-time ratio (median of per-query ratios over the queries both solved).

Goals on every set (issue 38): every query solved, plan time median <= 20 ms and p95 <= 100 ms, TCP path /
straight median <= 1.8, motion / bound median <= 1.8, every path ours found certified and above the clearance
in the re-check; over all sets, no program planning other vertices than the timed call. The broad phase the
planner checks with has its own benchmark (``bench broad-phase``: ``pipeline.bench.broad_phase``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..cell.clear_motion import time_clear
from ..cell.collision import EDGE_STEP_RAD, SELF_CLEARANCE_M, CollisionModel
from ..cell.planning import joint_space, path_length, path_vertices, plan_joint_path, polyline_time
from ..errors import ConfigurationError, PipelineError
from ..files.choices import PLAN_TIME_BUDGET_S
from ..files.poses import rotation_to_rpy
from ..outputs.versions import version_table
from ..program.compile import compile_job
from ..program.timing import time_program
from ..program.job import parse_job
from ..progress import Progress
from ..timing import retime, time_path
from ..timing.profile import Profile, certify
from .goals import Goal, GoalReport, fmt, goal_lines
from . import plan_sets
from .plan_sets import SET_NAMES, cell_model, set_model

CELLS = ("gp7_wall_cell", "gp7_shelf_cell")
#: Each contestant's planning time budget [s]; the budget of the feasibility run when both failed [s].
TIME_BUDGET_S = 2.0
FEASIBILITY_BUDGET_S = 10.0
#: The peer's motion validator step: Drake's edge step [rad].
PEER_STEP_RAD = EDGE_STEP_RAD
#: The independent check's joint-space step along a returned polyline [rad].
CHECK_STEP_RAD = 0.005
#: Pairs timed as a whole job; the profile re-check's samples per profile sample interval.
JOB_PAIRS = 20
DENSE_FACTOR = 10
MEDIAN_GOAL_MS, P95_GOAL_MS, JOB_GOAL_S = 10.0, 50.0, 1.0
#: The paddings beyond the clearance [m] of the re-check's screens (``nearest_points``); the stride of the
#: profile samples it measures first.
SCREENS_M = (0.0025, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.03, 0.045, 0.065, 0.1, 0.15, 0.22, 0.32)
ESTIMATE_STRIDE = 10
#: The seed ``compile_job`` gives the move to waypoint 1 (``seed=k``): the timed call plans with it too.
JOB_MOVE_SEED = 1
#: Every set's goals (issue 38): solved [1], plan time median and p95 [ms], TCP path / straight and motion /
#: rest-to-rest bound medians [1]; the plan time a query counts as solved in time for the table [s].
SOLVED_GOAL, SET_MEDIAN_MS, SET_P95_MS, SET_TCP_GOAL, SET_TIME_GOAL = 1.0, 20.0, 100.0, 1.8, 1.8
SOLVE_TIME_S = 1.0


# -- the independent check --------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    """The independent check of configurations: ``ok`` (all at least the clearance from the obstacles,
    links apart), the smallest obstacle and link-link distances [m] (inf: none in reach)."""

    ok: bool
    obstacle_m: float
    self_m: float

    def why(self) -> str:
        return (f"the independent check found {self.obstacle_m * 1e3:.2f} mm to an obstacle, links "
                f"{self.self_m * 1e3:.2f} mm apart")


def check_configurations(model, Q: np.ndarray) -> Check:
    """``CollisionModel.clearance`` at every configuration of Q (k, dof)."""
    distances = [model.clearance(q) for q in Q]
    obstacle = min(c.obstacle for c in distances)
    self_ = min(c.self for c in distances)
    return Check(bool(obstacle >= model.clearance_m and self_ >= SELF_CLEARANCE_M), float(obstacle), float(self_))


def dense_polyline(vertices: np.ndarray, step: float) -> np.ndarray:
    """The polyline through ``vertices`` (k, dof) at joint-space steps of at most ``step`` [rad]."""
    points = [vertices[:1]]
    for a, b in zip(vertices[:-1], vertices[1:]):
        count = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        points.append(a + np.linspace(0.0, 1.0, count + 1)[1:, None] * (b - a))
    return np.vstack(points)


def subdivided(Q: np.ndarray, factor: int) -> np.ndarray:
    """Q (n, dof) with ``factor - 1`` evenly spaced linear interpolations inserted between neighbours."""
    f = np.arange(factor) / factor
    inner = Q[:-1, None, :] + f[None, :, None] * (Q[1:] - Q[:-1])[:, None, :]
    return np.vstack([inner.reshape(-1, Q.shape[1]), Q[-1:]])


def verify(model, vertices: np.ndarray) -> Check:
    """The independent check of a returned polyline at CHECK_STEP_RAD steps."""
    return check_configurations(model, dense_polyline(vertices, CHECK_STEP_RAD))


# -- the contestants --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Run:
    """One planner on one pair: ``ok`` (a path the independent check confirms), the whole time, the
    search and shortcut times [s], lengths before / after shortcutting [rad], the smallest obstacle
    distance along the path [m] (the check's), and why it failed ("" when ok)."""

    ok: bool
    total_s: float
    search_s: float | None = None
    simplify_s: float | None = None
    length_before: float | None = None
    length_after: float | None = None
    min_distance_m: float | None = None
    reason: str = ""


def _checked(model, vertices: np.ndarray, total, search, simplify, length_before) -> Run:
    check = verify(model, vertices)
    return Run(check.ok, total, search, simplify, length_before, path_length(vertices), check.obstacle_m,
               "" if check.ok else check.why())


def run_ours(model, q_a, q_b, budget: float) -> Run:
    """``plan_joint_path`` on a pair, timed, then checked."""
    began = time.perf_counter()
    try:
        plan = plan_joint_path(model, q_a, q_b, time_budget=budget)
    except PipelineError as exc:
        return Run(False, time.perf_counter() - began, reason=str(exc))
    total = time.perf_counter() - began
    return _checked(model, plan.waypoints, total, plan.plan_time_s, plan.simplify_time_s, plan.length_before)


def peer_setup(model, q_a, q_b):
    """(OMPL's ``SimpleSetup`` as a user sets it up by hand, a function state -> joint values): the joint
    box, a validity callback on the model's Drake checker (its clearance), OMPL's motion validator at
    PEER_STEP_RAD, RRTConnect, start and goal (see the module docstring)."""
    from ompl import geometric as og, util as ou

    ou.setLogLevel(ou.LOG_WARN)
    checker = model.checker
    space, values, start, goal = joint_space(model.robot, q_a, q_b)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda state: bool(checker.CheckConfigCollisionFree(values(state))))
    setup.getSpaceInformation().setStateValidityCheckingResolution(PEER_STEP_RAD / space.getMaximumExtent())
    setup.setStartAndGoalStates(start, goal)
    setup.setPlanner(og.RRTConnect(setup.getSpaceInformation()))
    return setup, values


@dataclass(frozen=True, eq=False)
class PeerPath:
    """The peer's answer on a pair: its raw and simplified vertices (k, dof) [rad] (None: no exact
    solution), its search time and its whole time (search + simplification) [s]."""

    raw: np.ndarray | None
    vertices: np.ndarray | None
    search_s: float
    total_s: float


def solve_peer(model, q_a, q_b, budget: float) -> PeerPath:
    """OMPL by hand on a pair (see the module docstring), timed."""
    setup, values = peer_setup(model, q_a, q_b)
    began = time.perf_counter()
    setup.solve(budget)
    search = time.perf_counter() - began
    if not setup.haveExactSolutionPath():
        return PeerPath(None, None, search, search)
    raw = path_vertices(setup.getSolutionPath(), values)
    setup.simplifySolution()
    total = time.perf_counter() - began
    return PeerPath(raw, path_vertices(setup.getSolutionPath(), values), search, total)


def run_peer(model, q_a, q_b, budget: float) -> Run:
    """OMPL by hand on a pair, timed (``solve_peer``), then checked."""
    peer = solve_peer(model, q_a, q_b, budget)
    if peer.vertices is None:
        return Run(False, peer.total_s, peer.search_s, reason=f"no exact solution in {budget:g} s")
    return _checked(model, peer.vertices, peer.total_s, peer.search_s, peer.total_s - peer.search_s,
                    path_length(peer.raw))


# -- the problem set --------------------------------------------------------------------------------
def problem_set(model, pairs: int, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """``pairs`` pairs of collision-free in-limit configurations (see the module docstring)."""
    free = []
    while len(free) < 2 * pairs:
        free += [q for q in model.robot.random_configurations(rng, 4 * pairs) if model.is_free(q)]
    return [(free[2 * k], free[2 * k + 1]) for k in range(pairs)]


@dataclass(frozen=True)
class PairRecord:
    """One pair: its index, start and goal [rad], ``kind`` ("direct" | "search"), ``feasible``
    (proven), ``ours_first`` (the order of the turn), ours and the peer's runs."""

    index: int
    start: list[float]
    goal: list[float]
    kind: str
    feasible: bool
    ours_first: bool
    ours: Run
    peer: Run


def measure_pair(model, k: int, q_a, q_b, budget: float) -> PairRecord:
    """Both contestants on pair k (ours first on even k), then feasibility."""
    kind = "direct" if model.edge_is_free(q_a, q_b) else "search"
    ours_first = k % 2 == 0
    if ours_first:
        ours = run_ours(model, q_a, q_b, budget)
        peer = run_peer(model, q_a, q_b, budget)
    else:
        peer = run_peer(model, q_a, q_b, budget)
        ours = run_ours(model, q_a, q_b, budget)
    feasible = ours.ok or peer.ok or run_ours(model, q_a, q_b, FEASIBILITY_BUDGET_S).ok
    return PairRecord(k, q_a.tolist(), q_b.tolist(), kind, feasible, ours_first, ours, peer)


# -- figures ----------------------------------------------------------------------------------------
def _stats(values: list[float]) -> tuple[float | None, float | None]:
    """(median, p95) of the values, or (None, None) for none."""
    if not values:
        return None, None
    return float(np.median(values)), float(np.percentile(values, 95))


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


@dataclass(frozen=True)
class PlannerFigures:
    """One contestant in one cell, over the proven-feasible pairs: ``success`` [1]; whole times [ms]
    median / p95 over all of them and over those that need a search (failed runs included); median
    search and shortcut times on the search pairs it solved [ms]; ``shortening``: median length after /
    before shortcutting on them [1]; ``min_distance_mm``: the smallest obstacle distance along its
    confirmed paths; ``failures``: "pair k: why" on feasible pairs."""

    success: float | None
    median_ms: float | None
    p95_ms: float | None
    search_pairs_median_ms: float | None
    search_pairs_p95_ms: float | None
    search_median_ms: float | None
    simplify_median_ms: float | None
    shortening: float | None
    min_distance_mm: float | None
    failures: list[str]


def planner_figures(records: list[PairRecord], which: str) -> PlannerFigures:
    """The figures of ``which`` ("ours" | "peer") over the feasible records."""
    runs = [(r, getattr(r, which)) for r in records if r.feasible]
    solved = [run for _, run in runs if run.ok]
    solved_search = [run for r, run in runs if r.kind == "search" and run.ok]
    return PlannerFigures(
        float(np.mean([run.ok for _, run in runs])) if runs else None,
        *_stats([1e3 * run.total_s for _, run in runs]),
        *_stats([1e3 * run.total_s for r, run in runs if r.kind == "search"]),
        _median([1e3 * run.search_s for run in solved_search]),
        _median([1e3 * run.simplify_s for run in solved_search]),
        _median([run.length_after / run.length_before for run in solved_search if run.length_before > 0]),
        1e3 * min(run.min_distance_m for run in solved) if solved else None,
        [f"pair {r.index} ({r.kind}): {run.reason}" for r, run in runs if not run.ok])


def _ratio(records: list[PairRecord], kinds: tuple[str, ...]) -> float | None:
    """Median over the feasible pairs of these kinds both solved of peer / ours whole time."""
    return _median([r.peer.total_s / r.ours.total_s for r in records
                    if r.feasible and r.kind in kinds and r.ours.ok and r.peer.ok])


@dataclass
class CellReport:
    """One cell: pair counts, each contestant's figures, peer / ours ratios (all feasible pairs, the
    search pairs) and every pair's record."""

    cell: str
    pairs: int
    direct: int
    search: int
    feasible: int
    unproven: list[int]
    ours: PlannerFigures
    peer: PlannerFigures
    ratio_all: float | None
    ratio_search: float | None
    records: list[PairRecord] = field(repr=False)


def cell_report(name: str, records: list[PairRecord]) -> CellReport:
    search = sum(r.kind == "search" for r in records)
    return CellReport(name, len(records), len(records) - search, search, sum(r.feasible for r in records),
                      [r.index for r in records if not r.feasible], planner_figures(records, "ours"),
                      planner_figures(records, "peer"), _ratio(records, ("direct", "search")),
                      _ratio(records, ("search",)), records)


def measure_cell(name: str, pairs: int, seed: int, budget: float) -> tuple[CellReport, CollisionModel]:
    """The cell's problem set, the warm-up, and every pair measured."""
    model = cell_model(name)
    problems = problem_set(model, pairs, np.random.default_rng(seed))
    warm = next((p for p in problems if not model.edge_is_free(*p)), problems[0])
    run_ours(model, *warm, budget)              # ours first: OMPL's generator takes our seed
    run_peer(model, *warm, budget)
    records = []
    with Progress(pairs, f"bench plan {name}") as tick:
        for k, (q_a, q_b) in enumerate(problems):
            records.append(measure_pair(model, k, q_a, q_b, budget))
            tick()
    return cell_report(name, records), model


# -- the whole job ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class JobFigures:
    """Plan + timing + certificate on ``runs`` pairs of ``cell``: times [s] (failures included),
    profiles ``certified``, those the dense re-check finds closer than the clearance
    (``under_clearance``), the smallest obstacle distance it found [mm], and the failures."""

    cell: str
    runs: int
    median_s: float | None
    p95_s: float | None
    max_s: float | None
    certified: int
    under_clearance: int
    min_distance_mm: float | None
    failures: list[str]


def measure_jobs(model, name: str, pairs: list[tuple[np.ndarray, np.ndarray]], budget: float) -> JobFigures:
    """Each pair planned, timed and certified (timed), then the profile re-checked (untimed)."""
    robot, times, checks, failures = model.robot, [], [], []
    for k, (q_a, q_b) in enumerate(pairs):
        began = time.perf_counter()
        try:
            plan = plan_joint_path(model, q_a, q_b, time_budget=budget)
            profile, _ = time_clear(model, plan.waypoints, lambda vertices: retime(robot, vertices), refine=True)
        except PipelineError as exc:
            times.append(time.perf_counter() - began)
            failures.append(f"job {k}: {exc}")
            continue
        times.append(time.perf_counter() - began)
        checks.append(check_configurations(model, subdivided(profile.q, DENSE_FACTOR)))
    median, p95 = _stats(times)
    return JobFigures(name, len(times), median, p95, max(times, default=None), len(checks),
                      sum(not c.ok for c in checks), 1e3 * min(c.obstacle_m for c in checks) if checks else None,
                      failures)


# -- problem sets that need a search (pipeline.bench.plan_sets) ---------------------------------------
@dataclass(frozen=True)
class Recheck:
    """The independent re-check of a profile (``recheck_profile``): ``ok`` (every point at least the
    clearance from the obstacles, links apart), the smallest obstacle distance over all its points and the
    smallest link-link distance among those it measured [m], the points it checked (``dense``), the
    padding beyond the clearance of the screen that found the points nearest the obstacles (``screen_m``,
    ``nearest_points``; 0: the clearance; None: none did) and the points it measured (``measured``)."""

    ok: bool
    obstacle_m: float
    self_m: float
    dense: int
    screen_m: float | None
    measured: int


def _refused(checker, points: list) -> list:
    return [q for q in points if not checker.CheckConfigCollisionFree(q)]


def nearest_points(model, points: list, within_m: float) -> tuple[list, float | None]:
    """(the points nearest the obstacles, the padding beyond the clearance [m] of the screen that found
    them; None: none found) by Drake's checks padded by 0 (the model's own) and each of SCREENS_M
    (``CollisionModel.padded_checker``, links apart), given that some point is ``within_m`` [m] of an
    obstacle: the narrowest screen wider than that on every point, then narrower ones on the points refused
    while they refuse any. The points a screen accepted are farther than its padding from every obstacle."""
    ladder = [(0.0, model.checker), *[(extra, model.padded_checker(extra, SELF_CLEARANCE_M)) for extra in SCREENS_M]]
    wider = [k for k, (extra, _) in enumerate(ladder) if model.clearance_m + extra > within_m]
    if not wider:
        return [], None
    k = wider[0]
    refused = _refused(ladder[k][1], points)
    while k > 0 and (finer := _refused(ladder[k - 1][1], refused)):
        k, refused = k - 1, finer
    return refused, ladder[k][0] if refused else None


def recheck_profile(model, Q: np.ndarray) -> Recheck:
    """Profile samples Q (n, dof) re-checked at every point of ``subdivided(Q, DENSE_FACTOR)`` (the samples
    and DENSE_FACTOR - 1 linear interpolations between neighbours): ``CollisionModel.clearance`` (Drake's
    distance query) at every ESTIMATE_STRIDE-th sample, then at the points nearest the obstacles
    (``nearest_points`` within the smallest distance those found), so the smallest distance measured is
    the smallest over all the points; when none is within the widest screen, at every sample."""
    coarse = [model.clearance(q) for q in Q[::ESTIMATE_STRIDE]]
    near, screen_m = nearest_points(model, list(subdivided(Q, DENSE_FACTOR)), min(c.obstacle for c in coarse))
    measured = coarse + [model.clearance(q) for q in (near if near else Q)]
    obstacle, self_ = min(c.obstacle for c in measured), min(c.self for c in measured)
    ok = obstacle >= model.clearance_m and self_ >= SELF_CLEARANCE_M
    return Recheck(bool(ok), float(obstacle), float(self_), (len(Q) - 1) * DENSE_FACTOR + 1, screen_m, len(measured))


def tcp_positions(robot, X_FT: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """(n, 3) TCP positions [m] in the robot's base frame at Q (n, dof): the flange's FK composed with X_FT."""
    X_BF = robot.fk_batch(np.ascontiguousarray(Q))
    return X_BF[:, :3, :3] @ X_FT[:3, 3] + X_BF[:, :3, 3]


@dataclass(frozen=True)
class Motion:
    """One contestant on one query: ``found`` (a path within the budget), ``plan_s`` [s] (the planner's
    whole time, wall clock, failures included at the time they took), ``profiled`` (a profile was made),
    ``certified`` (it passed our judge, clearance included), the re-check's verdict ``rechecked`` and
    smallest obstacle distance ``min_distance_m`` [m], ``tcp_ratio`` (TCP path along the profile / straight
    distance [1]), ``time_ratio`` (duration / rest-to-rest bound [1]), ``duration_s`` [s], ``vertices``
    (of the path), and why it failed ("" when solved)."""

    found: bool
    plan_s: float
    profiled: bool = False
    certified: bool = False
    rechecked: bool = False
    min_distance_m: float | None = None
    tcp_ratio: float | None = None
    time_ratio: float | None = None
    duration_s: float | None = None
    vertices: int | None = None
    reason: str = ""

    @property
    def solved(self) -> bool:
        """A path found within the budget whose profile the independent re-check confirms."""
        return self.found and self.rechecked


def judged_motion(model, X_FT: np.ndarray, start, goal, plan_s: float, vertices: int, profile: Profile,
                  certified: bool) -> Motion:
    """A found path's profile measured (see ``Motion``) and re-checked (``recheck_profile``)."""
    check = recheck_profile(model, profile.q)
    P = tcp_positions(model.robot, X_FT, profile.q)
    straight = float(np.linalg.norm(P[-1] - P[0]))
    travel = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
    bound = polyline_time(model.robot.limits, np.array([start, goal]))
    reason = "" if check.ok else (f"the re-check found {check.obstacle_m * 1e3:.2f} mm to an obstacle, links "
                                  f"{check.self_m * 1e3:.2f} mm apart")
    return Motion(True, plan_s, True, certified, check.ok, check.obstacle_m,
                  travel / straight if straight > 0.0 else None, profile.duration / bound if bound > 0.0 else None,
                  profile.duration, vertices, reason)


def query_document(problems, query, budget: float) -> dict:
    """The query as a job a programmer writes [m, rad]: the set's cell and tool (X_FT), a joint move
    from ``query.start`` to ``query.goal`` planned collision-free within ``budget`` [s]."""
    return {"description": f"bench plan: {problems.name} query {query.index}", "cell": problems.cell,
            "length_unit": "m", "angle_unit": "rad",
            "tool": {"xyz": problems.X_FT[:3, 3].tolist(), "rpy": rotation_to_rpy(problems.X_FT[:3, :3]).tolist()},
            "plan": "collision_free", "plan_time_budget": budget,
            "waypoints": [query.start.tolist(), query.goal.tolist()]}


def ours_on_query(model, problems, query, budget: float) -> tuple[Motion, bool | None]:
    """Ours on a query: ``plan_joint_path`` timed (seed JOB_MOVE_SEED), then the query as a program
    (``query_document``, ``compile_job``, ``time_program``: untimed) whose planned move is measured;
    (the motion, whether the program's planned vertices equal the timed call's; None: nothing to compare)."""
    began = time.perf_counter()
    try:
        plan = plan_joint_path(model, query.start, query.goal, time_budget=budget, seed=JOB_MOVE_SEED)
    except PipelineError as exc:
        return Motion(False, time.perf_counter() - began, reason=f"plan_joint_path: {exc}"), None
    plan_s = time.perf_counter() - began
    name = f"{problems.name}_{query.index:03d}"
    try:
        job = parse_job(query_document(problems, query, budget), source=f"<bench plan {name}>", name=name)
        program = compile_job(job, model)
    except PipelineError as exc:
        return Motion(True, plan_s, vertices=len(plan.waypoints), reason=f"compile_job: {exc}"), None
    planned = program.moves[-1].planned
    same = bool(np.array_equal(planned.waypoints, plan.waypoints))
    try:
        profile = time_program(program, model)
    except PipelineError as exc:
        return Motion(True, plan_s, vertices=len(planned.waypoints), reason=f"time_program: {exc}"), same
    return judged_motion(model, problems.X_FT, query.start, query.goal, plan_s, len(planned.waypoints), profile,
                         profile.certificate.passed), same


def peer_on_query(model, problems, query, budget: float) -> Motion:
    """The peer on a query: ``solve_peer`` timed, then toppra through a spline of its vertices
    (``time_path``, untimed) and our judge (``certify`` with the cell)."""
    peer = solve_peer(model, query.start, query.goal, budget)
    if peer.vertices is None:
        return Motion(False, peer.total_s, reason=f"no exact solution in {budget:g} s")
    try:
        profile = time_path(model.robot, peer.vertices, shape="spline")
    except PipelineError as exc:
        return Motion(True, peer.total_s, vertices=len(peer.vertices), reason=f"toppra: {exc}")
    return judged_motion(model, problems.X_FT, query.start, query.goal, peer.total_s, len(peer.vertices), profile,
                         certify(profile, scene=model).passed)


@dataclass(frozen=True)
class QueryRecord:
    """One query of a set: its index, ``search`` (its straight joint edge is not free), ``ours_first``
    (the order of the turn), both motions and ``same_vertices`` (the program planned the vertices the
    timed call returned; None: not compared)."""

    index: int
    search: bool
    ours_first: bool
    ours: Motion
    peer: Motion
    same_vertices: bool | None


def measure_query(model, problems, query, budget: float) -> QueryRecord:
    """Both contestants on a query (ours first on even indices)."""
    ours_first = query.index % 2 == 0
    if ours_first:
        ours, same = ours_on_query(model, problems, query, budget)
        peer = peer_on_query(model, problems, query, budget)
    else:
        peer = peer_on_query(model, problems, query, budget)
        ours, same = ours_on_query(model, problems, query, budget)
    return QueryRecord(query.index, not model.edge_is_free(query.start, query.goal), ours_first, ours, peer, same)


@dataclass(frozen=True)
class SetFigures:
    """One contestant on one set: ``solved`` and ``solved_in_time`` (solved with a plan time <= SOLVE_TIME_S)
    fractions [1]; plan time p50 / p95 / max over every query [ms]; TCP path / straight median and max,
    motion / bound median over the solved [1]; ``min_distance_mm``: the re-check's smallest obstacle
    distance over the found paths' profiles; ``found``, ``certified`` and ``under_clearance`` (profiles the
    re-check found closer than the clearance) counts; ``failures``: "query k: why"."""

    solved: float | None
    solved_in_time: float | None
    p50_ms: float | None
    p95_ms: float | None
    max_ms: float | None
    tcp_median: float | None
    tcp_max: float | None
    time_median: float | None
    min_distance_mm: float | None
    found: int
    certified: int
    under_clearance: int
    failures: list[str]


def set_figures(records: list[QueryRecord], which: str) -> SetFigures:
    """The figures of ``which`` ("ours" | "peer") over a set's records."""
    motions = [(r.index, getattr(r, which)) for r in records]
    solved = [m for _, m in motions if m.solved]
    profiled = [m for _, m in motions if m.profiled]
    times = [1e3 * m.plan_s for _, m in motions]
    tcp = [m.tcp_ratio for m in solved if m.tcp_ratio is not None]
    return SetFigures(
        float(np.mean([m.solved for _, m in motions])) if motions else None,
        float(np.mean([m.solved and m.plan_s <= SOLVE_TIME_S for _, m in motions])) if motions else None,
        *_stats(times), max(times, default=None), _median(tcp), max(tcp, default=None),
        _median([m.time_ratio for m in solved if m.time_ratio is not None]),
        1e3 * min(m.min_distance_m for m in profiled) if profiled else None,
        sum(m.found for _, m in motions), sum(m.certified for m in profiled), sum(not m.rechecked for m in profiled),
        [f"query {k}: {m.reason}" for k, m in motions if not m.solved])


@dataclass
class SetReport:
    """One problem set: its name, cell, queries, those that need a search, each contestant's figures, the
    peer / ours plan-time ratio (median of per-query ratios over the queries both solved), the queries
    whose program planned other vertices than the timed call (``mismatches``) and every query's record."""

    name: str
    cell: str
    queries: int
    search: int
    ours: SetFigures
    peer: SetFigures
    ratio: float | None
    mismatches: list[int]
    records: list[QueryRecord] = field(repr=False)


def set_report(name: str, cell: str, records: list[QueryRecord]) -> SetReport:
    return SetReport(name, cell, len(records), sum(r.search for r in records), set_figures(records, "ours"),
                     set_figures(records, "peer"),
                     _median([r.peer.plan_s / r.ours.plan_s for r in records
                              if r.ours.solved and r.peer.solved and r.ours.plan_s > 0.0]),
                     [r.index for r in records if r.same_vertices is False], records)


def measure_set(name: str, count: int, seed: int, budget: float = PLAN_TIME_BUDGET_S) -> SetReport:
    """A problem set (``plan_sets.problem_set``), a warm-up of both contestants and the program on its
    first query (imports, caches, compilation), then every query measured."""

    model = set_model(name)
    problems = plan_sets.problem_set(name, model, count=count, seed=seed)
    ours_on_query(model, problems, problems.queries[0], budget)
    peer_on_query(model, problems, problems.queries[0], budget)
    records = []
    with Progress(len(problems.queries), f"bench plan {name}") as tick:
        for query in problems.queries:
            records.append(measure_query(model, problems, query, budget))
            tick()
    return set_report(name, problems.cell, records)


# -- the report -------------------------------------------------------------------------------------
def _table(head: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    widths = [max(len(row[i]) for row in (head, *rows)) for i in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *rows)]


def _planner_row(label: str, f: PlannerFigures) -> tuple[str, ...]:
    return (label, fmt(None if f.success is None else 100 * f.success, ".0f") + " %",
            f"{fmt(f.median_ms, '.1f')} / {fmt(f.p95_ms, '.1f')}",
            f"{fmt(f.search_pairs_median_ms, '.1f')} / {fmt(f.search_pairs_p95_ms, '.1f')}",
            f"{fmt(f.search_median_ms, '.1f')} + {fmt(f.simplify_median_ms, '.1f')}",
            fmt(f.shortening, ".2f"), fmt(f.min_distance_mm, ".1f"))


def _set_row(label: str, f: SetFigures) -> tuple[str, ...]:
    return (label, fmt(None if f.solved is None else 100 * f.solved, ".0f") + " %",
            f"{fmt(f.p50_ms, '.1f')} / {fmt(f.p95_ms, '.1f')} / {fmt(f.max_ms, '.1f')}",
            f"{fmt(f.tcp_median, '.2f')} / {fmt(f.tcp_max, '.2f')}", fmt(f.time_median, ".2f"),
            fmt(f.min_distance_mm, ".1f"), f"{f.certified} / {f.found}", str(f.under_clearance))


def _set_lines(sets: list[SetReport]) -> list[str]:
    """Per problem set a table of both contestants, the ratio, the determinism check and the failures."""
    if not sets:
        return []
    lines = ["", f"Problem sets that need a search (pipeline.bench.plan_sets), default budget "
                 f"{PLAN_TIME_BUDGET_S:g} s; ours: plan_joint_path timed, then the query as a program (compile_job, "
                 "time_program); peer: as above, then toppra through a spline of its vertices, certify",
             f"solved: found and the profile re-checked (its smallest distance to the obstacles at {DENSE_FACTOR}x "
             "the sample rate by CollisionModel.clearance at the points Drake's padded checks find nearest); TCP: "
             "TCP path / straight distance; motion: duration / rest-to-rest bound"]
    head = ("", "solved", "plan ms p50 / p95 / max", "TCP med / max", "motion med", "closest mm",
            "certified / found", "under clearance")
    for c in sets:
        lines += ["", f"{c.name} ({c.cell}): {c.queries} queries, {c.search} need a search"]
        lines += _table(head, [_set_row("ours", c.ours), _set_row("peer", c.peer)])
        lines.append(f"  peer / ours plan time (median of per-query ratios; > 1: ours is faster) "
                     f"{fmt(c.ratio, '.2f')}; the program planned other vertices than the timed call on "
                     f"{len(c.mismatches)} queries{': ' + ', '.join(map(str, c.mismatches)) if c.mismatches else ''}")
        lines += [f"  {who} failed: {why}" for who, f in (("ours", c.ours), ("peer", c.peer)) for why in f.failures]
    return lines


@dataclass
class PlanBenchReport(GoalReport):
    pairs: int
    seed: int
    time_budget_s: float
    cells: list[CellReport]
    job: JobFigures
    count: int
    sets: list[SetReport]
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        """Per cell a table of both contestants, the whole job, per problem set a table, then the goals."""
        lines = [
            f"Planning benchmark: {self.pairs} seeded random pairs of collision-free configurations per cell "
            f"(seed {self.seed}), budget {self.time_budget_s:g} s each",
            "ours: plan_joint_path; peer: OMPL SimpleSetup + Python validity callback on the same Drake checker, "
            f"motion validator at {PEER_STEP_RAD:g} rad, RRTConnect, simplifySolution; turns rotated per pair",
            "times: wall clock per pair [ms], median / p95 over the proven-feasible pairs (failed runs included); "
            "search + shortcut: medians on the solved search pairs",
            f"every path checked with CollisionModel.clearance at {CHECK_STEP_RAD:g} rad steps; len: length after / "
            "before shortcutting (search pairs, median); closest: smallest obstacle distance along the paths",
        ]
        head = ("", "success", "all pairs ms", "search pairs ms", "search + shortcut ms", "len", "closest mm")
        for c in self.cells:
            unproven = f" (pairs {', '.join(map(str, c.unproven))})" if c.unproven else ""
            lines += ["", f"{c.cell}: {c.pairs} pairs, {c.direct} direct, {c.search} need a search; {c.feasible} "
                          f"proven feasible, {len(c.unproven)} unproven{unproven}"]
            lines += _table(head, [_planner_row("ours", c.ours), _planner_row("peer", c.peer)])
            lines.append(f"  peer / ours time (median of per-pair ratios; > 1: ours is faster): all pairs "
                         f"{fmt(c.ratio_all, '.2f')}, search pairs {fmt(c.ratio_search, '.2f')}")
            lines += [f"  {who} failed: {why}" for who, f in (("ours", c.ours), ("peer", c.peer)) for why in f.failures]
        j = self.job
        lines += ["", f"whole job (plan_joint_path + time_clear: toppra, clearance certificate, refinement), "
                      f"{j.runs} search pairs of {j.cell}: median {fmt(j.median_s, '.3f')} s, p95 "
                      f"{fmt(j.p95_s, '.3f')} s, max {fmt(j.max_s, '.3f')} s; {j.certified} certified, "
                      f"{j.under_clearance} closer than the clearance at {DENSE_FACTOR}x the sample rate (closest "
                      f"{fmt(j.min_distance_mm, '.1f')} mm)"]
        lines += [f"  {failure}" for failure in j.failures]
        lines += _set_lines(self.sets)
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def plan_goals(cells: list[CellReport], job: JobFigures, sets: list[SetReport]) -> list[Goal]:
    """The random pairs' goals, each set's (``set_goals``) and the determinism of the programs' plans."""
    successes = [c.ours.success for c in cells if c.ours.success is not None]
    first = cells[0]
    mismatches = sum(len(s.mismatches) for s in sets)
    return [
        Goal("ours: success on the proven-feasible pairs, worst cell [1]", min(successes, default=None), "= 1",
             bool(successes) and min(successes) == 1.0),
        Goal(f"ours on {first.cell}: median over all pairs [ms]", first.ours.median_ms, f"<= {MEDIAN_GOAL_MS:g}",
             first.ours.median_ms is not None and first.ours.median_ms <= MEDIAN_GOAL_MS),
        Goal(f"ours on {first.cell}: p95 over all pairs [ms]", first.ours.p95_ms, f"<= {P95_GOAL_MS:g}",
             first.ours.p95_ms is not None and first.ours.p95_ms <= P95_GOAL_MS),
        Goal("whole job (plan, timing, certificate), slowest [s]", job.max_s, f"< {JOB_GOAL_S:g}",
             job.max_s is not None and job.max_s < JOB_GOAL_S),
        Goal(f"certified profiles closer than the clearance at {DENSE_FACTOR}x the sample rate",
             float(job.under_clearance), "= 0", job.under_clearance == 0),
        *[goal for s in sets for goal in set_goals(s)],
        *([Goal("problem sets: queries whose program planned other vertices than the timed call", float(mismatches),
                "= 0", mismatches == 0)] if sets else []),
    ]


def _at_most(value: float | None, bound: float) -> bool:
    return value is not None and value <= bound


def set_goals(s: SetReport) -> list[Goal]:
    """Every set's goals (issue 38): every query solved, plan time median and p95, TCP path / straight and
    motion / rest-to-rest bound medians, every found path certified and above the clearance in the re-check."""
    f = s.ours
    unproven = f.found - sum(r.ours.certified and r.ours.rechecked for r in s.records)
    return [Goal(f"{s.name}: ours solved [1]", f.solved, f"= {SOLVED_GOAL:g}", f.solved == SOLVED_GOAL),
            Goal(f"{s.name}: ours plan time median [ms]", f.p50_ms, f"<= {SET_MEDIAN_MS:g}",
                 _at_most(f.p50_ms, SET_MEDIAN_MS)),
            Goal(f"{s.name}: ours plan time p95 [ms]", f.p95_ms, f"<= {SET_P95_MS:g}", _at_most(f.p95_ms, SET_P95_MS)),
            Goal(f"{s.name}: ours TCP path / straight, median [1]", f.tcp_median, f"<= {SET_TCP_GOAL:g}",
                 _at_most(f.tcp_median, SET_TCP_GOAL)),
            Goal(f"{s.name}: ours motion / rest-to-rest bound, median [1]", f.time_median, f"<= {SET_TIME_GOAL:g}",
                 _at_most(f.time_median, SET_TIME_GOAL)),
            Goal(f"{s.name}: ours found paths not certified or under the clearance at {DENSE_FACTOR}x",
                 float(unproven), "= 0", unproven == 0)]


def set_names(sets: tuple[str, ...] | None) -> tuple[str, ...]:
    """The problem sets asked for (None: every one of ``plan_sets.SET_NAMES``); ConfigurationError naming
    an unknown one and the known."""

    if sets is None:
        return SET_NAMES
    unknown = [name for name in sets if name not in SET_NAMES]
    if unknown:
        raise ConfigurationError(f"unknown problem set {unknown[0]!r}; choose from {', '.join(SET_NAMES)}")
    return tuple(sets)


def run_plan_benchmark(cells=CELLS, pairs: int = 100, seed: int = 0, time_budget: float = TIME_BUDGET_S,
                       sets: tuple[str, ...] | None = None, count: int = 100) -> PlanBenchReport:
    """The benchmark (see the module docstring); ``time_budget`` [s] per planner run on the random pairs;
    ``sets`` (None: all) of ``count`` queries each (seeded with ``seed``), at the default budget."""
    names = set_names(sets)
    reports, first_model = [], None
    for name in cells:
        report, model = measure_cell(name, pairs, seed, time_budget)
        reports.append(report)
        first_model = first_model or model
    first = reports[0]
    job_pairs = [(np.array(r.start), np.array(r.goal)) for r in first.records if r.kind == "search"][:JOB_PAIRS]
    job = measure_jobs(first_model, first.cell, job_pairs, time_budget)
    set_reports = [measure_set(name, count, seed) for name in names]
    versions = version_table("drake", "ompl", "toppra", "numpy")
    return PlanBenchReport(pairs, seed, time_budget, reports, job, count, set_reports,
                           plan_goals(reports, job, set_reports), versions)
