"""Planning benchmark: collision-free joint moves in two cells, ours beside OMPL set up by hand.

Problem set, per cell (``gp7_wall_cell``: a table with a wall across it, the demo cell;
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
  planner's margins, else OMPL RRTConnect with Drake's checker and parallel edge checks, then vertex
  reduction and rope shortcutting): the whole call, and its own search and shortcut times;
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
"""

from __future__ import annotations

import importlib.resources
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cell import load_cell
from ..cell_motion import time_clear
from ..collision import EDGE_STEP_RAD, SELF_CLEARANCE_M, CollisionModel
from ..errors import PipelineError
from ..planning import joint_space, path_length, path_vertices, plan_joint_path
from ..progress import Progress
from ..timing import retime
from ..versions import version_table
from .goals import Goal, GoalReport, fmt, goal_lines

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


def cell_file(name: str) -> Path:
    """A demo cell installed with the package (the checkout's models/cells/)."""
    return Path(str(importlib.resources.files("pipeline.models") / "cells" / f"{name}.yaml"))


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


def run_peer(model, q_a, q_b, budget: float) -> Run:
    """OMPL by hand on a pair (see the module docstring), timed, then checked."""
    setup, values = peer_setup(model, q_a, q_b)
    began = time.perf_counter()
    setup.solve(budget)
    search = time.perf_counter() - began
    if not setup.haveExactSolutionPath():
        return Run(False, search, search, reason=f"no exact solution in {budget:g} s")
    raw = path_vertices(setup.getSolutionPath(), values)
    setup.simplifySolution()
    total = time.perf_counter() - began
    return _checked(model, path_vertices(setup.getSolutionPath(), values), total, search, total - search,
                    path_length(raw))


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


def cell_model(name: str) -> CollisionModel:
    cell = load_cell(cell_file(name))
    return CollisionModel(cell.load_robot(), cell)


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


@dataclass
class PlanBenchReport(GoalReport):
    pairs: int
    seed: int
    time_budget_s: float
    cells: list[CellReport]
    job: JobFigures
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        """Per cell a table of both contestants, the whole job, then the goals."""
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
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def plan_goals(cells: list[CellReport], job: JobFigures) -> list[Goal]:
    successes = [c.ours.success for c in cells if c.ours.success is not None]
    first = cells[0]
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
    ]


def run_plan_benchmark(cells=CELLS, pairs: int = 100, seed: int = 0,
                       time_budget: float = TIME_BUDGET_S) -> PlanBenchReport:
    """The benchmark (see the module docstring); ``time_budget`` [s] per planner run."""
    reports, first_model = [], None
    for name in cells:
        report, model = measure_cell(name, pairs, seed, time_budget)
        reports.append(report)
        first_model = first_model or model
    first = reports[0]
    job_pairs = [(np.array(r.start), np.array(r.goal)) for r in first.records if r.kind == "search"][:JOB_PAIRS]
    job = measure_jobs(first_model, first.cell, job_pairs, time_budget)
    versions = version_table("drake", "ompl", "toppra", "numpy")
    return PlanBenchReport(pairs, seed, time_budget, reports, job, plan_goals(reports, job), versions)
