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
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigurationError
from ..outputs.versions import version_table
from .goals import Goal, GoalReport, goal_lines

JOBS_DIR = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
DATA_OUTPUTS = ("csv", "npz", "json")
COMPUTED_GOAL_S = 1.0

#: What a fresh process runs: read the job (data outputs only when asked), time one run_job, print JSON.
_ONE_RUN = """
import dataclasses, json, sys, tempfile, time
from pathlib import Path
from pipeline.program.job import load_job
from pipeline.runner import run_job
job = load_job(Path(sys.argv[1]))
if sys.argv[2] == "data":
    job = dataclasses.replace(job, outputs=tuple(k for k in job.outputs if k in {data}))
with tempfile.TemporaryDirectory() as folder:
    start = time.perf_counter()
    outcome = run_job(job, Path(folder) / "out")
    print(json.dumps({{"seconds": time.perf_counter() - start, "duration_s": outcome.profile.duration}}))
""".format(data=repr(set(DATA_OUTPUTS)))


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
class JobBenchReport(GoalReport):
    jobs: tuple[JobTiming, ...]
    goals: tuple[Goal, ...]
    versions: dict[str, str]

    def format_table(self) -> str:
        lines = ["whole demo cell jobs, fresh process each, Numba cache warm (median / max of the repeats, wall s)",
                 f"  {'job':<24} {'computed':>16} {'with figures':>16} {'process':>16}  profile s"]
        for job in self.jobs:
            cells = [f"{np.median(v):.3f} / {max(v):.3f}" for v in (job.computed, job.with_figures, job.process)]
            lines.append(f"  {job.job:<24} {cells[0]:>16} {cells[1]:>16} {cells[2]:>16}  {job.duration_s:.4f}")
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


def run_job_benchmark(jobs=None, repeats: int = 5) -> JobBenchReport:
    """Every demo cell job (or the job files ``jobs``) timed whole in ``repeats`` fresh processes each."""
    files = cell_jobs() if jobs is None else tuple(Path(job) for job in jobs)
    if not files:
        raise ConfigurationError("no job files to benchmark")
    timings = tuple(time_job(path, repeats) for path in files)
    slowest = max(float(np.median(t.computed)) for t in timings)
    goals = (Goal("a whole demo cell job computed in a fresh process, warm cache [s] (median; the slowest job)",
                  slowest, f"< {COMPUTED_GOAL_S:g} s", slowest < COMPUTED_GOAL_S),)
    return JobBenchReport(timings, goals, version_table("numpy", "scipy", "drake", "numba"))
