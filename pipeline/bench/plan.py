"""Planning benchmark: collision-free joint moves in the demo cells, ours beside OMPL set up by hand.

Problem set, per cell (``gp7_wall_cell``: a table with a wall across it; ``gp7_shelf_cell``: a shelf
of three boards and a post), ``pairs`` start/goal pairs drawn from one generator seeded with ``seed``:
in-limit configurations uniform in the joint box (``random_configurations``), a draw kept only when
Drake's checker finds it collision-free (the clearance kept to obstacles, links apart). Each pair is
"direct" when the straight joint-space edge keeps the planner's margins (``plan_joint_path`` returns it
unplanned) and "search" otherwise. Random pairs can be infeasible (a start boxed in under a board):
a pair counts as proven feasible when any run returned a path that the independent check below
confirms (ours with a 2 s budget, the peer, or ours again with FEASIBILITY_BUDGET_S); success rates
are over the proven-feasible pairs and the unproven ones are counted apart.

What is timed (``time.perf_counter``, wall clock, per pair, failures included), the two contestants
taking turns in an order rotated from pair to pair:

* ours: ``plan_joint_path(model, q_a, q_b, time_budget=2.0)`` (the direct edge, else OMPL RRTConnect
  with Drake's checker and parallel edge checks under the planning margins, then vertex reduction and
  rope shortcutting): search, shortcutting and the whole call;
* the peer, what a user writes by hand: OMPL's ``SimpleSetup`` over the same joint box, the state
  validity checker a Python callback on the same Drake checker (``CheckConfigCollisionFree``, same
  clearance), OMPL's default discrete motion validator at a resolution of PEER_STEP_RAD,
  ``RRTConnect``, ``solve(2.0)`` then ``simplifySolution()``.

Checked (untimed), independently of both planners: every returned polyline at CHECK_STEP_RAD steps
with Drake's checker (the clearance to obstacles, links apart), and the smallest obstacle distance
along it (``CollisionModel.clearance`` at PEER_STEP_RAD steps). Path lengths are Euclidean in joint space.

Whole job, on up to JOB_PAIRS search pairs of the first cell: ``plan_joint_path`` then ``time_clear``
(toppra through the vertices, the clearance certificate, refinement), timed together; each certified
profile is then re-checked at 10x its sample rate (linear interpolation) with Drake's checker, and a
profile found closer than the clearance there is counted.

Goals: 100 % success on the feasible set; ours search + shortcut median <= 10 ms and p95 <= 50 ms on
the demo cell; the whole job under 1 s; zero certified profiles under the clearance.
"""

from __future__ import annotations

import importlib.resources
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cell import load_cell
from ..cell_motion import time_clear
from ..collision import CollisionModel
from ..errors import PipelineError
from ..planning import joint_space, path_length, plan_joint_path
from ..timing import retime
from ..versions import installed_version
from .goals import Goal, GoalReport, fmt, goal_lines

CELLS = ("gp7_wall_cell", "gp7_shelf_cell")
TIME_BUDGET_S = 2.0
FEASIBILITY_BUDGET_S = 10.0
PEER_STEP_RAD = 0.02
CHECK_STEP_RAD = 0.005
JOB_PAIRS = 20
DENSE_FACTOR = 10
MEDIAN_GOAL_MS, P95_GOAL_MS, JOB_GOAL_S = 10.0, 50.0, 1.0


def cell_file(name: str) -> Path:
    """A demo cell installed with the package (the checkout's models/cells/)."""
    return Path(str(importlib.resources.files("pipeline.models") / "cells" / f"{name}.yaml"))


@dataclass(frozen=True)
class Run:
    """One planner on one pair: ``ok`` (a path the independent check confirms), times [s], lengths
    [rad], the smallest obstacle distance along the path [m], and why it failed."""

    ok: bool
    total_s: float
    search_s: float = float("nan")
    simplify_s: float = float("nan")
    length_before: float = float("nan")
    length_after: float = float("nan")
    min_distance_m: float = float("nan")
    reason: str = ""


def _dense(vertices: np.ndarray, step: float) -> np.ndarray:
    """The polyline through ``vertices`` at joint-space steps of at most ``step`` [rad]."""
    points = [vertices[:1]]
    for a, b in zip(vertices[:-1], vertices[1:]):
        count = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        points.append(a + np.linspace(0.0, 1.0, count + 1)[1:, None] * (b - a))
    return np.vstack(points)


def verify(model, vertices: np.ndarray) -> tuple[bool, float]:
    """(every configuration at CHECK_STEP_RAD steps is free, the smallest obstacle distance at
    PEER_STEP_RAD steps [m])."""
    free = all(model.is_free(q) for q in _dense(vertices, CHECK_STEP_RAD))
    distance = min(model.clearance(q).obstacle for q in _dense(vertices, PEER_STEP_RAD))
    return free, float(distance)


def run_ours(model, q_a, q_b, budget: float, seed: int) -> tuple[Run, str]:
    """Our planner on a pair -> (Run, "direct" | planner name | "")."""
    began = time.perf_counter()
    try:
        plan = plan_joint_path(model, q_a, q_b, time_budget=budget, seed=seed)
    except PipelineError as exc:
        return Run(False, time.perf_counter() - began, reason=str(exc)), ""
    total = time.perf_counter() - began
    free, distance = verify(model, plan.waypoints)
    return Run(free, total, plan.plan_time_s, plan.simplify_time_s, plan.length_before, plan.length_after, distance,
               "" if free else "the independent check found a collision"), plan.planner


def run_peer(model, q_a, q_b, budget: float) -> Run:
    """OMPL by hand: SimpleSetup, a Python validity callback on Drake's checker, RRTConnect, simplify."""
    from ompl import geometric as og, util as ou

    ou.setLogLevel(ou.LOG_WARN)
    checker = model.checker
    space, values, start, goal = joint_space(model.robot, q_a, q_b)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda state: bool(checker.CheckConfigCollisionFree(values(state))))
    setup.getSpaceInformation().setStateValidityCheckingResolution(PEER_STEP_RAD / space.getMaximumExtent())
    setup.setStartAndGoalStates(start, goal)
    setup.setPlanner(og.RRTConnect(setup.getSpaceInformation()))
    began = time.perf_counter()
    setup.solve(budget)
    search = time.perf_counter() - began
    if not setup.haveExactSolutionPath():
        return Run(False, search, search, reason="no exact solution")
    path = setup.getSolutionPath()
    raw = np.array([values(path.getState(k)) for k in range(path.getStateCount())])
    setup.simplifySolution()
    total = time.perf_counter() - began
    path = setup.getSolutionPath()
    vertices = np.array([values(path.getState(k)) for k in range(path.getStateCount())])
    free, distance = verify(model, vertices)
    return Run(free, total, search, total - search, path_length(raw), path_length(vertices), distance,
               "" if free else "the independent check found a collision")


def problem_set(model, pairs: int, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """``pairs`` pairs of collision-free in-limit configurations (see the module docstring)."""
    free = []
    while len(free) < 2 * pairs:
        free += [q for q in model.robot.random_configurations(rng, 4 * pairs) if model.is_free(q)]
    return [(free[2 * k], free[2 * k + 1]) for k in range(pairs)]


def _stats(values: list[float]) -> tuple[float | None, float | None]:
    """(median, p95) of the values, or (None, None) for none."""
    if not values:
        return None, None
    return float(np.median(values)), float(np.percentile(values, 95))


@dataclass
class CellReport:
    """One cell's figures (times in ms, lengths in rad, distances in mm)."""

    cell: str
    pairs: int
    search_pairs: int
    feasible: int
    unproven: int
    ours_success: float | None
    peer_success: float | None
    ours_median_ms: float | None
    ours_p95_ms: float | None
    ours_search_median_ms: float | None
    ours_search_p95_ms: float | None
    peer_median_ms: float | None
    peer_p95_ms: float | None
    peer_search_median_ms: float | None
    peer_search_p95_ms: float | None
    ratio_peer_ours: float | None
    ours_shortening: float | None
    peer_shortening: float | None
    ours_min_distance_mm: float | None
    peer_min_distance_mm: float | None
    failures: list[str] = field(default_factory=list)


def _cell_report(name: str, runs: list[tuple[Run, Run, str]], feasible: list[bool]) -> CellReport:
    ok = [k for k, f in enumerate(feasible) if f]
    search = [k for k in ok if runs[k][2] != "direct"]

    def times(which: int, keys) -> list[float]:
        return [1e3 * runs[k][which].total_s for k in keys if runs[k][which].ok]

    def success(which: int) -> float | None:
        return None if not ok else float(np.mean([runs[k][which].ok for k in ok]))

    def shortening(which: int) -> float | None:
        values = [runs[k][which].length_after / runs[k][which].length_before for k in search if runs[k][which].ok]
        return float(np.median(values)) if values else None

    def closest(which: int) -> float | None:
        values = [runs[k][which].min_distance_m for k in ok if runs[k][which].ok]
        return 1e3 * min(values) if values else None

    ratios = [runs[k][1].total_s / runs[k][0].total_s for k in ok if runs[k][0].ok and runs[k][1].ok]
    return CellReport(name, len(runs), len([k for k, r in enumerate(runs) if r[2] != "direct"]), len(ok),
                      len(runs) - len(ok), success(0), success(1), *_stats(times(0, ok)), *_stats(times(0, search)),
                      *_stats(times(1, ok)), *_stats(times(1, search)),
                      float(np.median(ratios)) if ratios else None, shortening(0), shortening(1), closest(0),
                      closest(1), [f"pair {k}: {runs[k][0].reason}" for k in ok if not runs[k][0].ok])


def job_times(model, pairs: list[tuple[np.ndarray, np.ndarray]]) -> tuple[list[float], int, int]:
    """(plan + timing + certificate times [s], certified profiles, those closer than the clearance at
    DENSE_FACTOR x the sample rate) on the pairs."""
    robot, times, certified, under = model.robot, [], 0, 0
    for k, (q_a, q_b) in enumerate(pairs):
        began = time.perf_counter()
        try:
            plan = plan_joint_path(model, q_a, q_b, seed=k)
            profile, _ = time_clear(model, plan.waypoints, lambda vertices: retime(robot, vertices), refine=True)
        except PipelineError:
            times.append(time.perf_counter() - began)
            continue
        times.append(time.perf_counter() - began)
        certified += 1
        t = np.linspace(profile.t[0], profile.t[-1], DENSE_FACTOR * (len(profile.t) - 1) + 1)
        Q = np.column_stack([np.interp(t, profile.t, column) for column in profile.q.T])
        under += not all(model.is_free(q) for q in Q)
    return times, certified, under


@dataclass
class PlanBenchReport(GoalReport):
    cells: list[CellReport]
    job_median_s: float | None
    job_p95_s: float | None
    job_max_s: float | None
    job_runs: int
    certified: int
    certified_under_clearance: int
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        head = ("cell", "pairs", "search", "feasible", "unproven", "ok ours", "ok peer", "ours ms med/p95",
                "search-only ours", "peer ms med/p95", "search-only peer", "peer/ours", "len ours", "len peer",
                "min mm ours", "min mm peer")
        rows = [(c.cell, str(c.pairs), str(c.search_pairs), str(c.feasible), str(c.unproven),
                 fmt(c.ours_success, ".0%"), fmt(c.peer_success, ".0%"),
                 f"{fmt(c.ours_median_ms, '.2f')}/{fmt(c.ours_p95_ms, '.2f')}",
                 f"{fmt(c.ours_search_median_ms, '.2f')}/{fmt(c.ours_search_p95_ms, '.2f')}",
                 f"{fmt(c.peer_median_ms, '.2f')}/{fmt(c.peer_p95_ms, '.2f')}",
                 f"{fmt(c.peer_search_median_ms, '.2f')}/{fmt(c.peer_search_p95_ms, '.2f')}",
                 fmt(c.ratio_peer_ours, ".2f"), fmt(c.ours_shortening, ".2f"), fmt(c.peer_shortening, ".2f"),
                 fmt(c.ours_min_distance_mm, ".1f"), fmt(c.peer_min_distance_mm, ".1f")) for c in self.cells]
        widths = [max(len(r[i]) for r in (head, *rows)) for i in range(len(head))]
        lines = ["Collision-free joint moves (ours: plan_joint_path; peer: OMPL SimpleSetup + Drake checker callback, "
                 "RRTConnect, simplifySolution); times per pair, wall clock; len = path length after/before "
                 "shortcutting (search pairs); min = smallest obstacle distance along the paths"]
        lines += ["  ".join(v.rjust(w) for v, w in zip(r, widths)) for r in (head, *rows)]
        for c in self.cells:
            lines += [f"  {c.cell}: {failure}" for failure in c.failures]
        lines.append(f"whole job (plan + toppra + clearance certificate), {self.job_runs} search pairs of "
                     f"{self.cells[0].cell}: median {fmt(self.job_median_s, '.3f')} s, p95 {fmt(self.job_p95_s, '.3f')} "
                     f"s, max {fmt(self.job_max_s, '.3f')} s; {self.certified} certified, "
                     f"{self.certified_under_clearance} closer than the clearance at {DENSE_FACTOR}x the sample rate")
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def run_plan_benchmark(cells=CELLS, pairs: int = 100, seed: int = 0) -> PlanBenchReport:
    """The benchmark (see the module docstring)."""
    reports, job_pairs, first_model = [], [], None
    for name in cells:
        cell = load_cell(cell_file(name))
        model = CollisionModel(cell.load_robot(), cell)
        first_model = first_model or model
        problems = problem_set(model, pairs, np.random.default_rng(seed))
        run_ours(model, *problems[0], TIME_BUDGET_S, 0)           # warm-up: imports, caches
        run_peer(model, *problems[0], TIME_BUDGET_S)
        runs, feasible = [], []
        for k, (q_a, q_b) in enumerate(problems):
            if k % 2 == 0:
                ours, kind = run_ours(model, q_a, q_b, TIME_BUDGET_S, k)
                peer = run_peer(model, q_a, q_b, TIME_BUDGET_S)
            else:
                peer = run_peer(model, q_a, q_b, TIME_BUDGET_S)
                ours, kind = run_ours(model, q_a, q_b, TIME_BUDGET_S, k)
            proven = ours.ok or peer.ok or run_ours(model, q_a, q_b, FEASIBILITY_BUDGET_S, k)[0].ok
            runs.append((ours, peer, kind))
            feasible.append(proven)
            if name == cells[0] and kind not in ("direct", "") and len(job_pairs) < JOB_PAIRS:
                job_pairs.append((q_a, q_b))
        reports.append(_cell_report(name, runs, feasible))
    times, certified, under = job_times(first_model, job_pairs)
    median, p95 = _stats(times)
    demo = reports[0]
    goals = [
        Goal("success on the proven-feasible pairs, worst cell [1]",
             min((r.ours_success for r in reports if r.ours_success is not None), default=None), ">= 1",
             all(r.ours_success == 1.0 for r in reports if r.ours_success is not None)),
        Goal(f"{demo.cell}: search + shortcut median over all pairs [ms]", demo.ours_median_ms,
             f"<= {MEDIAN_GOAL_MS:g}", demo.ours_median_ms is not None and demo.ours_median_ms <= MEDIAN_GOAL_MS),
        Goal(f"{demo.cell}: search + shortcut p95 over all pairs [ms]", demo.ours_p95_ms, f"<= {P95_GOAL_MS:g}",
             demo.ours_p95_ms is not None and demo.ours_p95_ms <= P95_GOAL_MS),
        Goal("whole job (plan, timing, certificate), slowest [s]", max(times, default=None), f"< {JOB_GOAL_S:g}",
             bool(times) and max(times) < JOB_GOAL_S),
        Goal("certified profiles closer than the clearance at 10x the sample rate", float(under), "= 0", under == 0),
    ]
    versions = {name: installed_version(name) for name in ("dh-pipeline", "drake", "ompl", "toppra", "numpy")}
    return PlanBenchReport(reports, median, p95, max(times, default=None), len(times), certified, under, goals,
                           versions)
