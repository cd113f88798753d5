"""``run_batch(jobs, out_dir, client=None)``: many job files run as ``python -m pipeline run`` runs one.

Every job file (a folder stands for the ``*.yaml`` / ``*.yml`` files in it, sorted) is read and checked
here; each job is then run by ``runner.run_job`` in a task of its own (a Dask worker, or this process
without a client) into a temporary folder on that machine, and its files come back as bytes, so a
cluster needs no shared disk. ``out_dir`` is replaced whole (``pipeline.files.atomic.staged_output``): ``<job name>/``
per job that succeeded (exactly what ``run`` writes), ``summary.csv`` and ``summary.json``.

A job that fails (a file that does not read, an unreachable pose, a timing or collision error, even
a bug) is a row with its status, the class of its error and the message, never a lost run. The CSV
holds only what the jobs produced, so it is byte for byte the same whatever ran it; ``summary.json``
has the same rows plus each job's compute time and the run's (wall clock, workers).
"""

from __future__ import annotations

import csv
import io as text_io
import logging
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import PipelineError, ScaleInputError
from ..files.atomic import staged_output
from ..outputs.formats import write_json
from ..program.job import load_job, resolve_job_path
from ..runner import run_job
from ..timing import DEFAULT_MAX_SAMPLES
from ..timing.profile import QUANTITIES
from .cluster import map_chunks, worker_count

log = logging.getLogger(__name__)

JOB_SUFFIXES = (".yaml", ".yml")
SUMMARY_CSV, SUMMARY_JSON = "summary.csv", "summary.json"
#: The columns of summary.csv: per quantity of ``profile.QUANTITIES`` its largest peak/limit ratio
#: (empty where the job has no such limit); ``clearance_m``: the smallest robot-obstacle distance of the
#: clearance certificate (empty outside a cell).
COLUMNS = ("job", "file", "status", "error_type", "error", "duration_s", "samples",
           *(f"max_ratio_{name}" for name in QUANTITIES), "clearance_m", "clearance_pair")
OK, FAILED, INTERNAL = "ok", "failed", "internal error"


def job_files(paths) -> list[Path]:
    """The job files that ``paths`` (files, folders or demo job names) stand for, in order; ScaleInputError for a
    path that does not exist, when there are none, or when two have the same name (their output folders
    would collide)."""
    files: list[Path] = []
    for path in (resolve_job_path(p) for p in paths):
        if not path.exists():
            raise ScaleInputError("jobs", "no such job file or folder", str(path))
        files += sorted(p for p in path.iterdir() if p.suffix in JOB_SUFFIXES) if path.is_dir() else [path]
    if not files:
        raise ScaleInputError("jobs", "no job files: give job files, or folders holding *.yaml job files",
                              [str(p) for p in paths])
    seen: dict[str, Path] = {}
    for path in files:
        if path.stem in seen:
            raise ScaleInputError("jobs", f"two jobs named {path.stem!r} ({seen[path.stem]} and {path}) would write "
                                  "the same output folder; rename one")
        seen[path.stem] = path
    return files


@dataclass(frozen=True)
class JobRun:
    """One job's row of the summary (``COLUMNS``), its files (path inside ``<job name>/`` -> bytes) and
    how long it took where it ran [s]."""

    row: dict
    files: dict = field(repr=False, default_factory=dict)
    compute_s: float = 0.0


def _row(name: str, source: str, status: str, error: BaseException | None = None, outcome=None) -> dict:
    row = dict.fromkeys(COLUMNS, "")
    row.update(job=name, file=source, status=status)
    if error is not None:
        row.update(error_type=type(error).__name__, error=" ".join(str(error).split()))
    if outcome is not None:
        report = outcome.limit_report
        row.update(duration_s=outcome.profile.duration, samples=len(outcome.profile.t),
                   **{f"max_ratio_{name}": report.max_ratio(name) for name in QUANTITIES if name in report.ratios})
        if report.clearance is not None:
            row.update(clearance_m=report.clearance.min_distance_m,
                       clearance_pair=" - ".join(report.clearance.pair or ()))
    return row


def run_one(job, max_samples: int = DEFAULT_MAX_SAMPLES) -> JobRun:
    """Run one validated job and return its row and files (a Dask task), in this process: its plans are
    the same as its own ``python -m pipeline run`` gives (``pipeline.cell.planning`` seeds OMPL per plan, and
    a cell's roadmap answers a query alike whatever ran before)."""
    return run_here(job, max_samples)


def run_here(job, max_samples: int = DEFAULT_MAX_SAMPLES) -> JobRun:
    """Run one validated job in this process into a temporary folder; its row and files."""
    began = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="dh-pipeline-batch-") as folder:
        out = Path(folder) / job.name
        try:
            outcome = run_job(job, out, max_samples)
        except PipelineError as exc:
            return JobRun(_row(job.name, job.source, FAILED, exc), compute_s=time.perf_counter() - began)
        except Exception as exc:            # a bug in one job must not lose the others: it is a row too
            log.exception("job %s: internal error", job.name)
            return JobRun(_row(job.name, job.source, INTERNAL, exc), compute_s=time.perf_counter() - began)
        files = {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    return JobRun(_row(job.name, job.source, OK, outcome=outcome), files, time.perf_counter() - began)


@dataclass(frozen=True)
class BatchOutcome:
    """What a batch produced: one JobRun per job file, in order, the wall clock [s] and the workers
    that ran it."""

    runs: tuple[JobRun, ...]
    wall_s: float
    workers: int

    @property
    def failed(self) -> list[dict]:
        return [run.row for run in self.runs if run.row["status"] != OK]

    def summary(self) -> str:
        lines = [f"batch of {len(self.runs)} jobs on {self.workers} worker(s): {len(self.runs) - len(self.failed)} ok, "
                 f"{len(self.failed)} failed, {self.wall_s:.1f} s"]
        return "\n".join(lines + [f"  {row['job']}: {row['status']}: {row['error_type']}: {row['error']}"
                                  for row in self.failed])


def summary_csv(runs) -> str:
    """The rows as CSV text (``COLUMNS``; floats as Python writes them, exactly)."""
    text = text_io.StringIO()
    writer = csv.DictWriter(text, COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(run.row for run in runs)
    return text.getvalue()


def write_batch(folder: str | Path, outcome: BatchOutcome) -> None:
    """Every ok job's files under ``folder/<job name>/``, and the two summaries."""
    folder = Path(folder)
    for run in outcome.runs:
        for name, data in run.files.items():
            path = folder / run.row["job"] / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
    (folder / SUMMARY_CSV).write_text(summary_csv(outcome.runs))
    write_json(folder / SUMMARY_JSON, {
        "jobs": [{**run.row, "compute_s": run.compute_s} for run in outcome.runs],
        "ok": len(outcome.runs) - len(outcome.failed), "failed": len(outcome.failed),
        "run": {"wall_s": outcome.wall_s, "workers": outcome.workers}})


def run_jobs(files, client=None, max_samples: int = DEFAULT_MAX_SAMPLES) -> BatchOutcome:
    """Read job files (``job_files``' list) here and run them on the Dask ``client``'s workers, or one
    after the other in this process without one; a file that does not read is a failed row at once."""
    began = time.perf_counter()
    runs: list[JobRun | None] = []
    loaded = []
    for path in files:
        try:
            loaded.append(load_job(path))
            runs.append(None)
        except PipelineError as exc:
            runs.append(JobRun(_row(Path(path).stem, str(path), FAILED, exc)))
    done = iter(map_chunks(run_one, [(job, max_samples) for job in loaded], client, f"batch of {len(loaded)} jobs"))
    runs = [run if run is not None else next(done) for run in runs]
    return BatchOutcome(tuple(runs), time.perf_counter() - began, worker_count(client))


def run_batch(jobs, out_dir, client=None, max_samples: int = DEFAULT_MAX_SAMPLES) -> BatchOutcome:
    """Run job files (paths of files or folders) into ``out_dir``, replaced whole when the batch is
    done (checked before any work): ``run_jobs`` then ``write_batch``. See the module docstring."""
    files = job_files([jobs] if isinstance(jobs, (str, Path)) else list(jobs))
    with staged_output(out_dir) as staging:
        outcome = run_jobs(files, client, max_samples)
        write_batch(staging, outcome)
    return outcome
