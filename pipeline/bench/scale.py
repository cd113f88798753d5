"""Scaling benchmark: a reachability map on 1 and 2 Dask workers, the cost of a chunk, and the time of
a 1,000,000-pose map.

Problem: ``reachability_map`` of ``robot`` (default the IRB 1600: compiled closed-form IK, every
branch) with ``ORIENTATIONS`` seeded random orientations per voxel, the voxel step chosen so that the
map has about the number of poses asked for (poses = voxels inside the reach bound x orientations;
the actual count is reported).

What is timed (wall clock, ``time.perf_counter``, the whole ``reachability_map`` call: problem, chunks,
IK, assembly):

* rates [poses/s]: one map of about ``measure_poses`` poses in this process (``--workers 1``: no
  cluster), then on a LocalCluster of 1 worker process, then of 2, the same chunks each time; each
  cluster's workers are warmed first (``client.run``: imports, compiled code loaded, one chunk solved
  on every worker). Speed-up: 2 workers over 1 worker, both clusters, so both pay the same transfers.
  The three maps are checked equal (every array, exactly).
* the map of about ``poses`` poses on the 2-worker cluster: its wall time.
* the ceiling: what the machine gives two processes at that moment, 2 x (a fixed in-process map on the
  1-worker cluster's worker) / (the same map on both workers of the 2-worker cluster at once, the
  slower), no Dask between; a shared machine whose other load takes a core shows ~1x here.
* per-chunk overhead [ms]: ``OVERHEAD_TASKS`` tasks that take a chunk's arguments (the problem, the
  voxels and their centres of a real chunk) and return at once, through ``map_chunks`` on the 2
  workers: wall time / tasks; and that as a fraction of a chunk's compute time (CHUNK_POSES poses at
  the 1-worker rate).

Estimate for a 64-core cluster (an estimate, not a measurement): the 1,000,000-pose map's chunks run in
``ceil(chunks / 64)`` rounds, each taking one chunk's poses at the 1-worker rate divided by the
per-worker efficiency measured with 2 workers (speed-up / 2), plus the per-chunk overhead. It assumes
that efficiency holds at 64 workers (no shared memory bandwidth or scheduler limit) and leaves out the
workers' start-up; with chunks of CHUNK_POSES a 1,000,000-pose map has about 50 chunks, so one round
(``chunk_poses`` smaller would spread it over all 64). The same estimate is given for the default map
(25 mm voxels over the whole reach bound), beside its time here at the 2-worker rate.

The UR family beside it (issue 25): the in-process map of about ``measure_poses`` poses of a UR arm
(``ur_robot``, default the UR5 of tests/data where the checkout has it: the compiled closed form of
``pipeline.model.ik.three_parallel``), timed right after the robot's own, its rate against the robot's.

Goals: speed-up with 2 workers >= ``SPEEDUP_GOAL`` = 1.7; the maps identical whatever ran them; the UR
arm's in-process rate >= ``UR_RATE_GOAL`` = 0.25x the robot's (the IRB 1600's by default).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..model.robot import load_robot
from ..outputs.versions import version_table
from ..scale.cluster import local_client, map_chunks
from ..scale.reach import CHUNK_POSES, map_problem, plan_map, reachability_map
from .goals import Goal, GoalReport, goal_lines
from .ik import UR5_FILE

ROBOT = "irb1600"
ORIENTATIONS = 16
#: Poses of the maps whose rates are compared (the 1,000,000-pose map is timed on its own).
MEASURE_POSES = 400_000
#: Trivial tasks timed for the per-chunk overhead; workers of the 64-core estimate.
OVERHEAD_TASKS = 200
CLUSTER_WORKERS = 64
SPEEDUP_GOAL = 1.7
#: The UR arm's in-process map rate over the robot's, at least.
UR_RATE_GOAL = 0.25
#: The UR arm of the run, where the checkout has it.
UR_ROBOT = str(UR5_FILE) if UR5_FILE.is_file() else None


def step_for(robot, poses: int, orientations: int) -> float:
    """The voxel step [m] that gives a map of ``robot`` about ``poses`` poses (voxels in the ball of its
    reach bound x orientations)."""
    radius = robot.spec.reach_bound
    return (4.0 / 3.0 * math.pi * radius ** 3 * orientations / poses) ** (1.0 / 3.0)


def chunk_arguments(problem, voxels: np.ndarray, centres: np.ndarray) -> int:
    """A task that takes a chunk's arguments and does nothing with them (the per-chunk overhead)."""
    return len(voxels)


def _warm(robot, step: float, orientations: int, seed: int) -> int:
    """One small map in this process: imports done, compiled code loaded (a Dask ``client.run`` target)."""
    return reachability_map(robot, step=step, orientations=orientations, seed=seed).poses


def _timed_work(robot, step: float, orientations: int, seed: int) -> float:
    """The wall time of ``_warm``'s map in this process [s] (a ``client.run`` target: the ceiling)."""
    began = time.perf_counter()
    _warm(robot, step, orientations, seed)
    return time.perf_counter() - began


def _timed_map(robot, step: float, orientations: int, seed: int, client):
    began = time.perf_counter()
    reach_map = reachability_map(robot, step=step, orientations=orientations, seed=seed, client=client)
    return reach_map, time.perf_counter() - began


def _same(a, b) -> bool:
    return all(np.array_equal(getattr(a, name), getattr(b, name))
               for name in ("fraction", "manipulability", "branches"))


@dataclass
class ScaleBenchReport(GoalReport):
    robot: str
    orientations: int
    seed: int
    chunk_poses: int
    measure_poses: int
    measure_step_m: float
    rate_in_process: float
    rate_1_worker: float
    rate_2_workers: float
    speedup: float
    ceiling: float
    identical: bool
    map_poses: int
    map_step_m: float
    map_chunks: int
    map_s: float
    overhead_ms: float
    overhead_fraction: float
    overhead_tasks: int
    estimate_64_s: float
    full_poses: int
    full_step_m: float
    full_here_s: float
    full_64_s: float
    ur_robot: str
    ur_rate_in_process: float | None
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        chunk_s = self.chunk_poses / self.rate_1_worker
        lines = [
            f"Scaling benchmark: reachability map of {self.robot}, {self.orientations} orientations per voxel "
            f"(seed {self.seed}), chunks of about {self.chunk_poses:,} poses, Dask LocalCluster on 127.0.0.1",
            f"rates, the same map of {self.measure_poses:,} poses ({self.measure_step_m * 1e3:.1f} mm voxels), "
            "wall clock of the whole call:",
            f"  in this process (--workers 1)  {self.rate_in_process:12,.0f} poses/s",
            f"  1 worker process               {self.rate_1_worker:12,.0f} poses/s",
            f"  2 worker processes             {self.rate_2_workers:12,.0f} poses/s",
            f"  speed-up, 2 workers over 1: {self.speedup:.2f}x; the three maps "
            f"{'identical' if self.identical else 'DIFFER'}",
            f"  what this machine gives 2 processes now: {self.ceiling:.2f}x (the same in-process map on each worker "
            "at once, against on 1 alone, no Dask between: other load on the cores shows here)",
            f"map of {self.map_poses:,} poses ({self.map_step_m * 1e3:.1f} mm voxels, {self.map_chunks} chunks) on 2 "
            f"workers: {self.map_s:.1f} s",
            f"per-chunk overhead: {self.overhead_ms:.2f} ms per task ({self.overhead_tasks} tasks carrying a chunk's "
            f"arguments), {100 * self.overhead_fraction:.2f} % of a chunk's {chunk_s:.2f} s of work",
            f"estimate for {CLUSTER_WORKERS} workers (not measured): {self.estimate_64_s:.2f} s for the "
            f"{self.map_poses:,}-pose map: its {self.map_chunks} chunks in ceil({self.map_chunks} / {CLUSTER_WORKERS}) "
            f"round(s), each a chunk's poses at the 1-worker rate x {min(self.speedup / 2, 1):.2f} (the efficiency "
            "per worker measured with 2, at most 1) plus the per-chunk overhead; start-up of the workers not counted",
            f"the default map ({self.full_step_m * 1e3:g} mm voxels, {self.orientations} orientations): "
            f"{self.full_poses:,} poses, {self.full_here_s:.0f} s here at the 2-worker rate, about "
            f"{self.full_64_s:.0f} s on {CLUSTER_WORKERS} workers (the same estimate)",
        ]
        if self.ur_rate_in_process is not None:
            lines.append(f"the UR family: {self.ur_robot}'s map of about {self.measure_poses:,} poses in this process "
                         f"{self.ur_rate_in_process:12,.0f} poses/s, "
                         f"{self.ur_rate_in_process / self.rate_in_process:.2f}x {self.robot}'s")
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def _in_process_rate(robot, poses: int, orientations: int, seed: int) -> tuple[float, float, object]:
    """(the voxel step [m] of a map of about ``poses`` poses, its rate in this process [poses/s], the map),
    after a warm-up map."""
    step = step_for(robot, poses, orientations)
    _warm(robot, step_for(robot, min(2 * CHUNK_POSES, poses), orientations), orientations, seed)
    reach_map, seconds = _timed_map(robot, step, orientations, seed, None)
    return step, reach_map.poses / seconds, reach_map


def run_scale_benchmark(robot: str | None = None, poses: int = 1_000_000, measure_poses: int | None = None,
                        orientations: int = ORIENTATIONS, seed: int = 0, overhead_tasks: int = OVERHEAD_TASKS,
                        ur_robot: str | None = UR_ROBOT) -> ScaleBenchReport:
    """The benchmark (see the module docstring); ``measure_poses`` defaults to min(poses, MEASURE_POSES);
    ``ur_robot``: the UR arm whose rate is compared (None: none)."""
    arm = load_robot(robot or ROBOT)
    measure_poses = min(poses, MEASURE_POSES) if measure_poses is None else measure_poses
    map_step = step_for(arm, poses, orientations)
    warm_step = step_for(arm, min(2 * CHUNK_POSES, measure_poses), orientations)
    measure_step, serial_rate, serial = _in_process_rate(arm, measure_poses, orientations, seed)
    ur = None if ur_robot is None else load_robot(ur_robot)
    ur_rate = None if ur is None else _in_process_rate(ur, measure_poses, orientations, seed)[1]
    with local_client(1) as client:
        client.run(_warm, arm, warm_step, orientations, seed)
        alone = max(client.run(_timed_work, arm, warm_step, orientations, seed).values())
        one, one_s = _timed_map(arm, measure_step, orientations, seed, client)
    with local_client(2) as client:
        client.run(_warm, arm, warm_step, orientations, seed)
        together = max(client.run(_timed_work, arm, warm_step, orientations, seed).values())
        two, two_s = _timed_map(arm, measure_step, orientations, seed, client)
        big, big_s = _timed_map(arm, map_step, orientations, seed, client)
        problem = map_problem(arm, None, orientations, None, seed, "end")
        voxels = np.arange(CHUNK_POSES // orientations)
        centres = np.zeros((len(voxels), 3))
        began = time.perf_counter()
        map_chunks(chunk_arguments, [(problem, voxels, centres)] * overhead_tasks, client, "bench scale overhead")
        overhead_s = (time.perf_counter() - began) / overhead_tasks
    rate = {0: serial_rate, 1: serial.poses / one_s, 2: serial.poses / two_s}
    speedup = rate[2] / rate[1]
    identical = _same(serial, one) and _same(one, two)
    efficiency = min(speedup / 2.0, 1.0)        # no better than perfect, whatever the noise
    full = plan_map(arm, orientations=orientations, seed=seed)          # the default map: 25 mm voxels

    def on_64(map_poses: int, chunks: int) -> float:
        return math.ceil(chunks / CLUSTER_WORKERS) * (map_poses / chunks / (rate[1] * efficiency) + overhead_s)

    ur_ratio = None if ur_rate is None else ur_rate / rate[0]
    goals = [Goal("speed-up with 2 workers over 1 [x]", speedup, f">= {SPEEDUP_GOAL:g}", speedup >= SPEEDUP_GOAL),
             Goal("maps identical in this process, on 1 and on 2 workers", float(identical), "= 1", identical),
             Goal(f"the UR family's map rate / {arm.name}'s, in this process [x]", ur_ratio,
                  f">= {UR_RATE_GOAL:g}" + ("; not measured: no UR arm in this run" if ur is None else
                                            f" ({ur.name}: {ur_rate:,.0f} poses/s)"),
                  ur_ratio is not None and ur_ratio >= UR_RATE_GOAL)]
    return ScaleBenchReport(
        robot=arm.name, orientations=orientations, seed=seed, chunk_poses=CHUNK_POSES, measure_poses=serial.poses,
        measure_step_m=measure_step, rate_in_process=rate[0], rate_1_worker=rate[1], rate_2_workers=rate[2],
        speedup=speedup, ceiling=2.0 * alone / together, identical=identical, map_poses=big.poses,
        map_step_m=map_step, map_chunks=big.chunks, map_s=big_s, overhead_ms=1e3 * overhead_s,
        overhead_fraction=overhead_s / (CHUNK_POSES / rate[1]), overhead_tasks=overhead_tasks,
        estimate_64_s=on_64(big.poses, big.chunks), full_poses=full.poses, full_step_m=full.grid.step,
        full_here_s=full.poses / rate[2], full_64_s=on_64(full.poses, full.chunk_count),
        ur_robot="" if ur is None else ur.name, ur_rate_in_process=ur_rate, goals=goals,
        versions=version_table("dask", "distributed", "numba", "numpy"))

