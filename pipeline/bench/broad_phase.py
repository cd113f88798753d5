"""Broad-phase benchmark: the compiled conservative check (``pipeline.cell.broad_phase``) beside Drake's checker.

Per demo cell (``models/cells``: the GP7's and the IRB 1600's) and per checker (``plain``: the cell's clearance,
links apart; ``planner``: the planner's padded checker, PLANNING_MARGIN_M beyond the clearance and
SELF_PLANNING_MARGIN_M between links), ``count`` random configurations in the joint limits
(``random_configurations``, seeded with ``seed`` and the cell's place in the list) are checked by both:

* ours: ``BroadPhase.verdicts`` on chunks of CHUNK configurations (one compiled call each: certainly free, certainly
  colliding or maybe);
* Drake: ``CheckConfigCollisionFree`` on each configuration of the same chunk, in a Python loop;

timed with ``time.perf_counter`` (wall clock), chunk by chunk in turns (drift of the machine hits both alike),
after one warm-up chunk of both. Reported: configurations per second of each, their ratio, the configurations
Drake finds free, the false frees (ours free where Drake's checker is not: must be 0), the false hits (ours
certainly colliding where Drake's checker finds it free: must be 0), the fraction of Drake's free configurations
ours calls free and of its colliding ones ours calls a hit (the rest go to Drake in the planner).

Goals: no false free, no false hit; ours >= RATE_GOAL x Drake's rate; >= FREE_FRACTION_GOAL of Drake's free
configurations called free, per cell and checker.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..cell.broad_phase import FREE, HIT
from ..cell.cell_file import cell_names
from ..cell.collision import SELF_CLEARANCE_M
from ..cell.planning import PLANNING_MARGIN_M, SELF_PLANNING_MARGIN_M
from ..outputs.versions import version_table
from .goals import Goal, GoalReport, goal_lines
from .plan_sets import cell_model

#: The checkers compared: name -> (extra_m, self_m) of ``CollisionModel.broad_phase``.
CHECKERS = {"plain": (0.0, SELF_CLEARANCE_M), "planner": (PLANNING_MARGIN_M, SELF_PLANNING_MARGIN_M)}
#: Configurations per compiled call and per turn of the timing.
CHUNK = 10_000
RATE_GOAL = 20.0
FREE_FRACTION_GOAL = 0.9


@dataclass(frozen=True)
class BroadPhaseRow:
    """One cell and checker: rates [configurations/s], their ratio, Drake's free fraction, ours' false frees and
    false hits, the fraction of Drake's free configurations ours calls free and of its colliding ones a hit."""

    cell: str
    checker: str
    configurations: int
    ours_rate: float
    drake_rate: float
    ratio: float
    drake_free: float
    false_free: int
    free_found: float
    false_hit: int
    hits_found: float


def measure_broad_phase(name: str, count: int, seed: int = 0, stream: int = 0) -> list[BroadPhaseRow]:
    """The rows of demo cell ``name`` (one per CHECKERS entry) on ``count`` random configurations drawn from
    ``np.random.default_rng((seed, stream))``."""
    model = cell_model(name)
    Q = model.robot.random_configurations(np.random.default_rng((seed, stream)), count)
    rows = []
    for checker_name, (extra_m, self_m) in CHECKERS.items():
        broad = model.broad_phase(extra_m, self_m)
        drake = broad.checker
        broad.verdicts(Q[:CHUNK])                              # warm-up: the kernels load, the caches fill
        for q in Q[:min(CHUNK, 200)]:
            drake.CheckConfigCollisionFree(q)
        ours_s = drake_s = 0.0
        ours, theirs = np.empty(count, dtype=np.int8), np.empty(count, dtype=bool)
        for start in range(0, count, CHUNK):
            chunk = Q[start:start + CHUNK]
            began = time.perf_counter()
            ours[start:start + len(chunk)] = broad.verdicts(chunk)
            ours_s += time.perf_counter() - began
            began = time.perf_counter()
            theirs[start:start + len(chunk)] = [drake.CheckConfigCollisionFree(q) for q in chunk]
            drake_s += time.perf_counter() - began
        free, hit = ours == FREE, ours == HIT
        frees, collisions = int(theirs.sum()), int((~theirs).sum())
        rows.append(BroadPhaseRow(name, checker_name, count, count / ours_s, count / drake_s,
                                  drake_s / ours_s, frees / count, int((free & ~theirs).sum()),
                                  float((free & theirs).sum() / frees) if frees else 1.0, int((hit & theirs).sum()),
                                  float((hit & ~theirs).sum() / collisions) if collisions else 1.0))
    return rows


@dataclass
class BroadPhaseBenchReport(GoalReport):
    count: int
    seed: int
    rows: list[BroadPhaseRow]
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        lines = [f"Broad-phase benchmark: {self.count:,} random configurations per cell (seed {self.seed}), "
                 "ours (BroadPhase.verdicts, compiled, batched) beside Drake's CheckConfigCollisionFree loop",
                 f"{'cell':24s} {'checker':8s} {'ours [1/s]':>12s} {'Drake [1/s]':>12s} {'ratio':>7s} "
                 f"{'Drake free':>10s} {'false free':>10s} {'found free':>10s} {'false hit':>9s} {'found hit':>9s}"]
        lines += [f"{r.cell:24s} {r.checker:8s} {r.ours_rate:12,.0f} {r.drake_rate:12,.0f} {r.ratio:6.1f}x "
                  f"{100 * r.drake_free:9.1f}% {r.false_free:10d} {100 * r.free_found:9.2f}% {r.false_hit:9d} "
                  f"{100 * r.hits_found:8.2f}%" for r in self.rows]
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def run_broad_phase_benchmark(cells: tuple[str, ...] | None = None, count: int = 1_000_000,
                              seed: int = 0) -> BroadPhaseBenchReport:
    """The benchmark (see the module docstring) on ``cells`` (None: every demo cell)."""
    names = tuple(cell_names()) if cells is None else tuple(cells)
    rows = [row for k, name in enumerate(names) for row in measure_broad_phase(name, count, seed, k)]
    false_free, false_hit = sum(r.false_free for r in rows), sum(r.false_hit for r in rows)
    slowest = min(rows, key=lambda r: r.ratio)
    least = min(rows, key=lambda r: r.free_found)
    goals = [Goal("false frees over all cells and checkers", false_free, "= 0", false_free == 0),
             Goal("false hits over all cells and checkers", false_hit, "= 0", false_hit == 0),
             Goal(f"rate ratio ours / Drake, the lowest ({slowest.cell}, {slowest.checker}) [x]", slowest.ratio,
                  f">= {RATE_GOAL:g}", slowest.ratio >= RATE_GOAL),
             Goal(f"Drake-free configurations ours calls free, the lowest ({least.cell}, {least.checker})",
                  least.free_found, f">= {FREE_FRACTION_GOAL:g}", least.free_found >= FREE_FRACTION_GOAL)]
    return BroadPhaseBenchReport(count, seed, rows, goals, version_table("drake", "numba", "numpy"))
