"""Written-program benchmark: what a controller program costs against the certified motion, and its round trip.

Problem set: every demo job of a six-axis arm (trajectories/jobs/), then ``programs`` of ``bench cycle``'s seeded
pick-and-place programs per cell (``cycle.drawn_programs``: the GP7 wall and shelf cells, the IRB 1600 wall cell).
For each program and each language of a six-axis arm (RAPID, KRL, LS, JBI; URScript for a UR arm):

* the certified profile (``runner.timed_program``): its duration and its exact stops (``program.stops``);
* the program as written (``runner.written_motion``: ``controller_motion.certified_moves``): its cycle time as
  written (the time-optimal motion along the path the controller may take, zones as written), the verdict of its
  certificate, its largest joint-space deviation from the certified path and its exact stops; for LS and JBI the
  cycle time and verdict with the zones the language writes instead (CNT, PL: ``runner.language_zones_certificate``);
* the round trip: the writer's text (``runner.program_texts``) read back (``read_program.read_program_text``), in
  the same cell and without planning, compiled and timed as any job (``runner.timed_program``): certified (limits
  and clearance), its duration over the certified one, and whether it stops exactly where the original stops (the
  same joint values within STOP_RAD, in order).

Goals (issue 36), over every program and language: round trip certified, within ROUND_TRIP_GOAL of the certified
duration (both ways), the same stops; the written program's certificate passed.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import PipelineError
from ..outputs.controllers.read_program import read_program_text
from ..outputs.versions import version_table
from ..program.job import load_job, parse_job
from ..progress import Progress
from ..runner import PROGRAM_FILES, language_written, program_texts, timed_program, written_motion
from .cycle import CELLS, DEMO_JOB_DIR, drawn_programs
from .goals import Goal, GoalReport, fmt, goal_lines

#: The languages of a six-axis arm of another maker; URScript only for a Universal Robots arm.
LANGUAGES = ("rapid", "krl", "ls", "jbi")
#: Round trip within this factor of the certified duration, either way [1].
ROUND_TRIP_GOAL = 1.15
#: Two stops are the same where their joint values differ by less than this [rad] (the files round to 0.0001 deg
#: or 0.001 mm; a pose read back is solved again).
STOP_RAD = 1e-3


@dataclass(frozen=True)
class WrittenRecord:
    """One program in one language: the certified duration [s] and exact stops (the start counted, everywhere);
    as written: cycle time [s], certificate verdict, largest deviation [rad], exact stops, and with the language's own zones (LS, JBI) the cycle
    time [s] and verdict; the round trip's duration [s], verdict, exact stops and whether they are the original's;
    ``error``: what failed (empty when nothing did)."""

    program: str
    language: str
    certified_s: float
    job_stops: int
    written_s: float | None = None
    written_passed: bool = False
    deviation_rad: float | None = None
    written_stops: int | None = None
    own_zones_s: float | None = None
    own_zones_passed: bool | None = None
    read_back_s: float | None = None
    read_back_passed: bool = False
    read_back_stops: int | None = None
    same_stops: bool = False
    error: str = ""

    @property
    def ratio(self) -> float | None:
        """Round trip duration over the certified one [1]."""
        return None if self.read_back_s is None else self.read_back_s / self.certified_s

    @property
    def passed(self) -> bool:
        ratio = self.ratio
        return (self.written_passed and self.read_back_passed and self.same_stops and ratio is not None
                and 1.0 / ROUND_TRIP_GOAL <= ratio <= ROUND_TRIP_GOAL)


def _stops(program) -> np.ndarray:
    return program.targets[list(program.stops)]


def _robot_reference(robot) -> str:
    """How a job names ``robot``: its robot file when it has one, else its (preset) name."""
    source = getattr(robot.spec, "source", None)
    return str(Path(source).resolve()) if source and Path(source).is_file() else robot.name


def read_back(job, language: str, texts: dict[str, str]):
    """The job ``texts`` (a writer's, suffix -> text) read back as by ``read-program``, in ``job``'s cell, without
    planning."""
    main = PROGRAM_FILES[language][0]
    suffix = Path(main).suffix
    robot = _robot_reference(job.robot)
    document = read_program_text(language, texts[suffix], robot, f"<{language}>", texts.get(".dat"))
    document["robot"] = robot
    if job.cell is not None:
        document["cell"] = str(Path(job.cell.source).resolve())
    return parse_job(document, source=f"<{job.name} read back from {language}>", name=job.name)


def measure(job, language: str, program, profile, written) -> WrittenRecord:
    """One program in ``language``: as written and round trip (module docstring)."""
    record = WrittenRecord(job.name, language, profile.duration, len(program.stops))
    if written is None:
        return dataclasses.replace(record, error="not written as the certified motion")
    certificate = written.certificate
    record = dataclasses.replace(record, written_s=certificate.duration_s, written_passed=certificate.passed,
                                 deviation_rad=certificate.max_deviation_rad, written_stops=1 + written.exact_stops)
    written, own = language_written(job, language, program, profile, written)
    if own is not None:
        record = dataclasses.replace(record, own_zones_s=own["duration_s"], own_zones_passed=own["passed"])
    try:
        texts = program_texts(job, language, program, profile, written=written)
        read = read_back(job, language, texts)
        read_program, _, read_profile = timed_program(read)
    except PipelineError as exc:
        return dataclasses.replace(record, error=f"round trip: {type(exc).__name__}: {exc}")
    a, b = _stops(program), _stops(read_program)
    same = a.shape == b.shape and bool(np.all(np.abs(a - b) <= STOP_RAD))
    passed = read_profile.certificate.passed
    return dataclasses.replace(record, read_back_s=read_profile.duration, read_back_passed=passed,
                               read_back_stops=len(read_program.stops), same_stops=same)


def languages_for(robot) -> tuple[str, ...]:
    """The languages that fit ``robot``: URScript for a Universal Robots arm (a robot file with controller maker
    ur), else LANGUAGES."""
    from ..model.vendors.controller import controller_of

    return ("urscript",) if getattr(controller_of(robot), "maker", None) == "ur" else LANGUAGES


def measure_job(job, languages: tuple[str, ...] | None = None) -> list[WrittenRecord]:
    """Every language on one job (None: ``languages_for`` its robot): its certified profile once, then as written
    and round trip per language."""
    languages = languages_for(job.robot) if languages is None else languages
    try:
        program, _, profile = timed_program(job)
    except PipelineError as exc:
        return [WrittenRecord(job.name, language, float("nan"), 0, error=f"{type(exc).__name__}: {exc}")
                for language in languages]
    written = written_motion(job, languages[0], program, profile)      # the same for every language
    return [measure(job, language, program, profile, written) for language in languages]


def demo_jobs() -> list:
    """The demo jobs of a six-axis arm, loaded (trajectories/jobs/)."""
    jobs = [load_job(path) for path in sorted(DEMO_JOB_DIR.glob("*.yaml"))]
    return [job for job in jobs if job.robot.dof == 6]


@dataclass
class WrittenBenchReport(GoalReport):
    programs: int
    seed: int
    records: list[WrittenRecord]
    goals: list[Goal]
    versions: dict
    compute_s: float

    def format_table(self) -> str:
        """One row per program and language, then the goals."""
        lines = [
            f"Written-program benchmark: the demo jobs and {self.programs} bench cycle programs per cell (seed "
            f"{self.seed}), in {', '.join(LANGUAGES)}",
            "certified: the certified profile [s]; as written: the cycle time of the program as the controller model "
            "has it [s] / certified, its certificate, largest deviation from the certified path [rad]; LS/JBI own "
            "zones: with CNT / PL as written; round trip: program -> read-program -> run in the same cell without "
            "planning [s] / certified, certified; stops: exact stops job / written / read back (= the same joint "
            "values)",
            "",
        ]
        head = ("program", "lang", "certified", "as written", "cert.", "deviation", "own zones", "round trip",
                "cert.", "stops")
        rows = []
        for r in self.records:
            if r.written_s is None:
                rows.append((r.program, r.language, fmt(r.certified_s, ".3f"), r.error[:60], "", "", "", "", "", ""))
                continue
            own = "" if r.own_zones_s is None else f"{r.own_zones_s / r.certified_s:.3f}x " + \
                ("ok" if r.own_zones_passed else "FAIL")
            trip = r.error[:40] if r.read_back_s is None else f"{r.read_back_s:.3f} = {r.ratio:.3f}x"
            rows.append((r.program, r.language, f"{r.certified_s:.3f}",
                         f"{r.written_s:.3f} = {r.written_s / r.certified_s:.3f}x",
                         "ok" if r.written_passed else "FAIL", fmt(r.deviation_rad, ".4f"), own, trip,
                         "ok" if r.read_back_passed else "FAIL",
                         f"{r.job_stops}/{r.written_stops}/{fmt(r.read_back_stops, 'd')}"
                         + ("" if r.same_stops else " DIFFER")))
        widths = [max(len(row[i]) for row in (head, *rows)) for i in range(len(head))]
        lines += ["  " + "  ".join(v.ljust(w) for v, w in zip(row, widths)) for row in (head, *rows)]
        lines.append(f"compute time {self.compute_s:.1f} s")
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def written_goals(records: list[WrittenRecord]) -> list[Goal]:
    """The goals of issue 36 over every record (module docstring)."""
    ratios = [r.ratio for r in records if r.ratio is not None]
    worst = max(ratios, key=lambda x: max(x, 1.0 / x), default=None)
    return [
        Goal("written programs: certificate passed [1]", float(np.mean([r.written_passed for r in records])),
             "= 1", all(r.written_passed for r in records)),
        Goal("round trips: certified [1]", float(np.mean([r.read_back_passed for r in records])), "= 1",
             all(r.read_back_passed for r in records)),
        Goal("round trips: furthest duration / certified", worst, f"within {ROUND_TRIP_GOAL:g}x either way",
             len(ratios) == len(records) and all(1.0 / ROUND_TRIP_GOAL <= x <= ROUND_TRIP_GOAL for x in ratios)),
        Goal("round trips: the same exact stops [1]", float(np.mean([r.same_stops for r in records])), "= 1",
             all(r.same_stops for r in records)),
    ]


def run_written_benchmark(cells=CELLS, programs: int = 5, seed: int = 0,
                          languages: tuple[str, ...] | None = None) -> WrittenBenchReport:
    """The benchmark (module docstring): the demo jobs, then ``programs`` drawn programs per cell, in ``languages``
    (None: those that fit each robot)."""
    began = time.perf_counter()
    jobs = demo_jobs()
    for cell in cells:
        drawn, _ = drawn_programs(cell, programs, np.random.default_rng(seed))
        jobs += [parse_job(d.job, source=f"<bench cycle {d.name}>", name=d.name) for d in drawn]
    records = []
    with Progress(len(jobs), "bench written") as tick:
        for job in jobs:
            records += measure_job(job, languages)
            tick()
    return WrittenBenchReport(programs, seed, records, written_goals(records),
                              version_table("drake", "ompl", "toppra", "numpy"), time.perf_counter() - began)
