"""Whole-job benchmark: a demo cell job from its file to its certified profile, in a fresh process.

Per job (default: every demo job with a cell, ``trajectories/jobs``), one warm-up process first (it fills
Numba's disk cache, as any first use on a machine does), then ``repeats`` fresh Python processes, each of
which imports the package, reads the job and times one ``run_job`` (``time.perf_counter``; the first call
in its process: the cached kernels load, the Drake plant and the collision model are built, moves are
planned, timed and certified):

* ``computed``: the job with its data outputs only (profile CSV and NPZ, the JSON report): everything a
  controller or a script needs;
* ``with figures``: the job with the outputs its file lists (the PNG figures and the 3-D HTML view too),
  in another fresh process;
* ``process``: the wall time of ``python -m pipeline run JOB`` as a user types it (interpreter start and
  imports included).

The goal (issue 25): ``computed`` under 1 s of wall time (median of the repeats) for every demo cell job.
There is no peer: the bound is absolute, on this machine kind.

With the demo jobs (no ``jobs`` given), long joint jobs (issue 39): arm6 on a linear path through LONG_WAYPOINTS
joint waypoints of one period of a sine of 1 rad on J1 (the other joints still; written to 1e-6 rad, so the
steps shrink to 1e-6 rad at the crests), each file written to a temporary folder and timed in ``long_repeats``
fresh processes (after one warm-up) from reading the file (``load_job``) to the certified profile and its data
outputs (``run_job``). The goals: the longest job in under LONG_GOAL_S of wall time, and its time at most
LONG_RATIO_GOAL x the time of the job with a quarter of its waypoints (medians): a job's cost linear in its
waypoints.

The first IK call (issue 39): in ``first_ik_repeats`` fresh processes, each with a new, empty
``NUMBA_CACHE_DIR`` (``cold``: the IK kernels come from the extension built at install,
``pipeline.model.ik.prebuilt``, and whatever else the call uses compiles, as on a fresh install), then again
with the cache that process filled (``warm``), then with another empty cache and the prebuilt kernels switched
off (``just in time``: every kernel the call uses compiles, as before the extension), the wall time of
``import pipeline`` and of ``load_robot(FIRST_IK_ROBOT)`` then one ``robot.ik`` of FIRST_IK_POSE (the closed form;
the first call). The goal: the cold call (load_robot and robot.ik) within FIRST_IK_GOAL_S (median), on a quiet
machine.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigurationError
from ..model.ik import prebuilt
from ..outputs.versions import version_table
from .goals import Goal, GoalReport, goal_lines

JOBS_DIR = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
DATA_OUTPUTS = ("csv", "npz", "json")
COMPUTED_GOAL_S = 1.0
#: The long joint jobs' waypoint counts (the last 4x the first, to 1 waypoint: the same sine sampled 4x as
#: densely), the goal for the last [s] and for its time over the first's [1].
LONG_WAYPOINTS = (2_501, 10_001)
LONG_GOAL_S = 60.0
LONG_RATIO_GOAL = 5.0
#: The first IK call's robot and pose X_BE (4, 4) [m] (reachable, away from singularities), its goal [s].
FIRST_IK_ROBOT = "gp7"
FIRST_IK_POSE = ((0.0, 0.0, 1.0, 0.5), (0.0, 1.0, 0.0, 0.1), (-1.0, 0.0, 0.0, 0.4), (0.0, 0.0, 0.0, 1.0))
FIRST_IK_GOAL_S = 5.0

#: What a fresh process runs: read the job (data outputs only when asked), time one run_job, print JSON: the
#: wall times [s] of reading the job (``read_s``) and of run_job (``seconds``), the CPU time of both (``cpu_s``),
#: the profile's duration [s].
_ONE_RUN = """
import dataclasses, json, sys, tempfile, time
from pathlib import Path
from pipeline.program.job import load_job
from pipeline.runner import run_job
start, cpu = time.perf_counter(), time.process_time()
job = load_job(Path(sys.argv[1]))
read = time.perf_counter() - start
if sys.argv[2] == "data":
    job = dataclasses.replace(job, outputs=tuple(k for k in job.outputs if k in {data}))
with tempfile.TemporaryDirectory() as folder:
    start = time.perf_counter()
    outcome = run_job(job, Path(folder) / "out")
    print(json.dumps({{"read_s": read, "seconds": time.perf_counter() - start, "cpu_s": time.process_time() - cpu,
                      "duration_s": outcome.profile.duration}}))
""".format(data=repr(set(DATA_OUTPUTS)))

#: What a fresh process runs for the first IK call: import, load the robot (argv[1]), one robot.ik of the pose
#: (argv[2], JSON); prints the wall times [s] of the import (``import_s``) and of load_robot + robot.ik
#: (``first_ik_s``), whether it succeeded, and whether the prebuilt IK kernels were used ("used", or why not).
_FIRST_IK = """
import json, sys, time
start = time.perf_counter()
import numpy as np
from pipeline import load_robot
imported = time.perf_counter()
result = load_robot(sys.argv[1]).ik(np.array(json.loads(sys.argv[2])))
seconds = time.perf_counter() - imported
from pipeline.model.ik.prebuilt import prebuilt_status
print(json.dumps({"import_s": imported - start, "first_ik_s": seconds, "success": bool(result.success),
                  "prebuilt": prebuilt_status().reason or "used"}))
"""


@dataclass(frozen=True)
class JobTiming:
    """One job's wall times [s] over ``repeats`` fresh processes: ``computed`` (data outputs only),
    ``with_figures`` (the file's outputs), ``process`` (``python -m pipeline run``), each a list; the
    profile's ``duration_s`` [s]."""

    job: str
    repeats: int
    computed: list[float]
    with_figures: list[float]
    process: list[float]
    duration_s: float


@dataclass(frozen=True)
class LongJobTiming:
    """A long joint job (``LONG_WAYPOINTS``) over ``repeats`` fresh processes, each a list: the wall times [s] of
    reading its file (``read``) and of ``run_job`` with the data outputs (``computed``: compiled, timed,
    certified, written), the process's CPU time for both (``cpu`` [s]); the profile's ``duration_s`` [s]."""

    waypoints: int
    repeats: int
    read: list[float]
    computed: list[float]
    cpu: list[float]
    duration_s: float

    @property
    def total(self) -> list[float]:
        """Per repeat, read + computed [s]."""
        return [read + computed for read, computed in zip(self.read, self.computed)]


@dataclass(frozen=True)
class FirstIkTiming:
    """The first IK call of ``robot`` in ``repeats`` fresh processes with an empty Numba cache (``cold``), then
    with the cache each filled (``warm``), then with another empty cache and no prebuilt kernels (``jit``): per
    process, the wall times [s] of the import (``*_import``) and of load_robot + the first robot.ik (``cold``,
    ``warm``, ``jit``); ``prebuilt``: "used" when the cold calls used the prebuilt IK kernels, else why not."""

    robot: str
    repeats: int
    cold_import: list[float]
    cold: list[float]
    warm_import: list[float]
    warm: list[float]
    jit_import: list[float]
    jit: list[float]
    prebuilt: str


@dataclass(frozen=True)
class JobBenchReport(GoalReport):
    jobs: tuple[JobTiming, ...]
    goals: tuple[Goal, ...]
    versions: dict[str, str]
    long_jobs: tuple[LongJobTiming, ...] = ()
    first_ik: FirstIkTiming | None = None

    def format_table(self) -> str:
        lines = ["whole demo cell jobs, fresh process each, Numba cache warm (median / max of the repeats, wall s)",
                 f"  {'job':<24} {'computed':>16} {'with figures':>16} {'process':>16}  profile s"]
        for job in self.jobs:
            cells = [f"{np.median(v):.3f} / {max(v):.3f}" for v in (job.computed, job.with_figures, job.process)]
            lines.append(f"  {job.job:<24} {cells[0]:>16} {cells[1]:>16} {cells[2]:>16}  {job.duration_s:.4f}")
        if self.long_jobs:
            lines += ["", "long joint jobs: arm6, a sine on J1, linear path, data outputs (median / max, s)",
                      f"  {'waypoints':>9} {'read':>16} {'computed':>16} {'read + computed':>16} {'CPU':>16}  profile s"]
            for job in self.long_jobs:
                cells = [f"{np.median(v):.2f} / {max(v):.2f}" for v in (job.read, job.computed, job.total, job.cpu)]
                lines.append(f"  {job.waypoints:>9,} {cells[0]:>16} {cells[1]:>16} {cells[2]:>16} {cells[3]:>16}  "
                             f"{job.duration_s:.4f}")
        if self.first_ik is not None:
            timing = self.first_ik
            lines += ["", (f"first IK call: load_robot({timing.robot!r}) and one robot.ik, fresh process each "
                           f"(median / max, wall s); prebuilt IK kernels: {timing.prebuilt}"),
                      f"  {'Numba cache':<32} {'import':>16} {'load + ik':>16}"]
            for label, imports, calls in (("empty", timing.cold_import, timing.cold),
                                          ("warm (loads)", timing.warm_import, timing.warm),
                                          ("empty, just in time (compiles)", timing.jit_import, timing.jit)):
                lines.append(f"  {label:<32} {np.median(imports):>7.2f} / {max(imports):<6.2f} "
                             f"{np.median(calls):>7.2f} / {max(calls):<6.2f}")
        return "\n".join(lines + goal_lines("Goals:", self.goals, self.versions))


def cell_jobs() -> tuple[Path, ...]:
    """The demo jobs that work in a cell."""
    return tuple(path for path in sorted(JOBS_DIR.glob("*.yaml")) if "\ncell:" in path.read_text())


def _one_run(job_file: Path, outputs: str) -> dict:
    run = subprocess.run([sys.executable, "-c", _ONE_RUN, str(job_file), outputs], capture_output=True, text=True,
                         check=False)
    if run.returncode != 0:
        raise ConfigurationError(f"{job_file.name} failed in a fresh process: {run.stderr.strip()[-2000:]}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def _process_seconds(job_file: Path) -> float:
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        run = subprocess.run([sys.executable, "-m", "pipeline", "run", str(job_file), "--out", str(Path(folder) / "o")],
                             capture_output=True, text=True, check=False)
        seconds = time.perf_counter() - start
    if run.returncode != 0:
        raise ConfigurationError(f"python -m pipeline run {job_file.name} failed: {run.stderr.strip()[-2000:]}")
    return seconds


def time_job(job_file: Path, repeats: int) -> JobTiming:
    """``job_file``'s wall times in fresh processes after one warm-up run."""
    warm = _one_run(job_file, "all")
    computed, figures, process = [], [], []
    for _ in range(repeats):
        computed.append(_one_run(job_file, "data")["seconds"])
        figures.append(_one_run(job_file, "all")["seconds"])
        process.append(_process_seconds(job_file))
    return JobTiming(job_file.stem, repeats, computed, figures, process, warm["duration_s"])


def long_job_text(count: int) -> str:
    """A job file (YAML): arm6 through ``count`` joint waypoints [rad] of one period of a sine of 1 rad on J1,
    the other joints still, each rounded to 1e-6 rad; linear path, toppra, the data outputs."""
    waypoints = np.tile([0.0, 0.5, 0.5, 0.0, 0.5, 0.0], (count, 1))
    waypoints[:, 0] = np.round(np.sin(2.0 * np.pi * np.linspace(0.0, 1.0, count)), 6)
    rows = ["- [" + ",".join(np.format_float_positional(v, precision=6, trim="-") for v in q) + "]" for q in waypoints]
    header = ["robot: arm6", "angle_unit: rad", "path: linear", "timing: toppra", "dt: 0.004",
              f"outputs: [{', '.join(DATA_OUTPUTS)}]", "waypoints:"]
    return "\n".join(header + rows) + "\n"


def time_long_jobs(repeats: int) -> tuple[LongJobTiming, ...]:
    """The long joint jobs (``long_job_text`` of each of LONG_WAYPOINTS) timed in ``repeats`` fresh processes
    each, after one warm-up run of the first."""
    timings = []
    with tempfile.TemporaryDirectory() as folder:
        files = [Path(folder) / f"sine_{count}.yaml" for count in LONG_WAYPOINTS]
        for path, count in zip(files, LONG_WAYPOINTS):
            path.write_text(long_job_text(count))
        _one_run(files[0], "data")
        for path, count in zip(files, LONG_WAYPOINTS):
            runs = [_one_run(path, "data") for _ in range(repeats)]
            timings.append(LongJobTiming(count, repeats, [r["read_s"] for r in runs], [r["seconds"] for r in runs],
                                         [r["cpu_s"] for r in runs], runs[0]["duration_s"]))
    return tuple(timings)


def _first_ik_run(env: dict[str, str]) -> dict:
    run = subprocess.run([sys.executable, "-c", _FIRST_IK, FIRST_IK_ROBOT, json.dumps(FIRST_IK_POSE)], env=env,
                         capture_output=True, text=True, check=False)
    answer = json.loads(run.stdout.strip().splitlines()[-1]) if run.returncode == 0 else {"success": False}
    if not answer["success"]:
        raise ConfigurationError(f"the first IK call failed in a fresh process: {run.stderr.strip()[-2000:]}")
    return answer


def time_first_ik(repeats: int) -> FirstIkTiming:
    """The first IK call (``_FIRST_IK``) in ``repeats`` fresh processes, each on a new, empty Numba cache
    directory, then once more on the cache it filled, then on another empty one without the prebuilt kernels
    (the directories removed after)."""
    runs = []
    for _ in range(repeats):
        with (tempfile.TemporaryDirectory(prefix="numba-cache-") as cache,
              tempfile.TemporaryDirectory(prefix="numba-cache-") as jit_cache):
            env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PIPELINE_PROGRESS": "0"}
            jit_env = {**env, "NUMBA_CACHE_DIR": jit_cache, prebuilt.SWITCH: "0"}
            runs.append((_first_ik_run(env), _first_ik_run(env), _first_ik_run(jit_env)))
    cold, warm, jit = zip(*runs)
    return FirstIkTiming(FIRST_IK_ROBOT, repeats, [r["import_s"] for r in cold], [r["first_ik_s"] for r in cold],
                         [r["import_s"] for r in warm], [r["first_ik_s"] for r in warm],
                         [r["import_s"] for r in jit], [r["first_ik_s"] for r in jit], cold[0]["prebuilt"])


def first_ik_goal(timing: FirstIkTiming) -> Goal:
    """The first IK call with an empty Numba cache (load_robot + robot.ik, median) within FIRST_IK_GOAL_S."""
    cold = float(np.median(timing.cold))
    return Goal(f"the first IK call (load_robot({timing.robot!r}), robot.ik) in a fresh process, empty Numba cache "
                f"(prebuilt IK kernels: {timing.prebuilt}) [s] (median)", cold,
                f"<= {FIRST_IK_GOAL_S:g} s on a quiet machine", cold <= FIRST_IK_GOAL_S)


def run_job_benchmark(jobs=None, repeats: int = 5, long_repeats: int = 3,
                      first_ik_repeats: int = 3) -> JobBenchReport:
    """Every demo cell job (or the job files ``jobs``) timed whole in ``repeats`` fresh processes each; without
    ``jobs``, also the long joint jobs in ``long_repeats`` fresh processes each (``time_long_jobs``) and the first
    IK call in ``first_ik_repeats`` fresh processes each with an empty and a warm Numba cache (``time_first_ik``;
    0: not measured)."""
    files = cell_jobs() if jobs is None else tuple(Path(job) for job in jobs)
    if not files:
        raise ConfigurationError("no job files to benchmark")
    timings = tuple(time_job(path, repeats) for path in files)
    slowest = max(float(np.median(t.computed)) for t in timings)
    goals = [Goal("a whole demo cell job computed in a fresh process, warm cache [s] (median; the slowest job)",
                  slowest, f"< {COMPUTED_GOAL_S:g} s", slowest < COMPUTED_GOAL_S)]
    long_jobs = () if jobs is not None else time_long_jobs(long_repeats)
    if long_jobs:
        short, longest = (float(np.median(job.total)) for job in (long_jobs[0], long_jobs[-1]))
        ratio = longest / short
        goals += [Goal(f"a {long_jobs[-1].waypoints:,}-waypoint joint job read, run and certified in a fresh process "
                       "[s] (median)", longest, f"< {LONG_GOAL_S:g} s", longest < LONG_GOAL_S),
                  Goal(f"its time over the {long_jobs[0].waypoints:,}-waypoint job's [1] (medians)", ratio,
                       f"<= {LONG_RATIO_GOAL:g}", ratio <= LONG_RATIO_GOAL)]
    first_ik = time_first_ik(first_ik_repeats) if jobs is None and first_ik_repeats > 0 else None
    if first_ik is not None:
        goals.append(first_ik_goal(first_ik))
    return JobBenchReport(timings, tuple(goals), version_table("numpy", "scipy", "drake", "numba"), long_jobs,
                          first_ik)
