"""``run_job(job, out_dir)``: the one path from a job to certified output files.

Steps: the output folder is checked first (``staged_output``: nothing is computed for a folder that
cannot be written), then the job is compiled into a program (``pipeline.program.compile.compile_job``: IK,
tool tracks, planned moves), checked against the duration limits, timed and certified once
(``time_program``: a profile that fails is an error, never an output), then every requested output (profile CSV/NPZ, JSON report, profile plot, the 3-D views: a
standalone Meshcat HTML animation and a PNG drawing of the arm, and the profile as a ROS 2
JointTrajectory message in YAML or JSON for a controller, and the program in a controller's own
language: ABB RAPID, FANUC LS, Yaskawa INFORM, KUKA KRL, URScript, ``program_texts``) written into a
staging folder that replaces the output folder whole. Used by the CLI (``python -m pipeline run``), the tests and the
notebooks.
"""

from __future__ import annotations

import functools
import logging
import re
from dataclasses import dataclass, replace
from pathlib import Path

from .cell.clear_motion import ClearanceError
from .errors import CollisionError, ConfigurationError, OutputError, PipelineError, PlanningError, TimingError
from .files.atomic import staged_output
from .files.choices import DEFAULT_MAX_DURATION_S
from .outputs.formats import write_json, write_profile_csv, write_profile_npz
from .outputs.ros2 import write_json_trajectory, write_ros2_yaml
from .outputs.versions import installed_version
from .program.bound import LowerBound, check_duration, lower_bound
from .program.compile import compile_job
from .program.job import Job, load_job
from .program.model import Program, program_arrays
from .program.report import cycle_lines, cycle_report
from .program.timing import time_program
from .timing import DEFAULT_MAX_SAMPLES
from .timing.profile import QUANTITIES, LimitReport, Profile, certify, limits_summary

log = logging.getLogger(__name__)

#: Output kind -> file name inside the output directory.
FILE_NAMES = {"csv": "profile.csv", "npz": "profile.npz", "json": "report.json", "png": "profile.png",
              "html": "view.html", "arm_png": "arm.png", "ros2_yaml": "trajectory.ros2.yaml",
              "json_trajectory": "trajectory.json", "tcp_png": "tcp.png"}
#: Controller program output kind (``pipeline.outputs.controllers.lint.LANGUAGES``) -> the files it writes in the
#: output directory (KRL: the .src with its motions and the .dat with its targets).
PROGRAM_FILES = {"rapid": ("program.mod",), "ls": ("program.ls",), "jbi": ("program.jbi",),
                 "krl": ("program.src", "program.dat"), "urscript": ("program.script",)}
#: Each language's name, as messages and headers give it.
LANGUAGE_TITLES = {"rapid": "ABB RAPID", "ls": "FANUC LS", "jbi": "Yaskawa INFORM", "krl": "KUKA KRL",
                   "urscript": "URScript"}
#: Each language's program names, as a header states them when the job's name had to be changed.
NAME_RULES = {"rapid": "RAPID names are a letter, then letters, digits or _, at most 32, not a reserved word",
              "ls": "FANUC program names are upper case, at most 8 characters",
              "jbi": "Yaskawa job names are upper case, at most 8 characters",
              "krl": "KRL names are a letter, then letters, digits or _, at most 24",
              "urscript": "URScript names are a letter, then letters, digits or _, not a keyword"}
#: The summary says when a stretch was slowed down uniformly by more than this [1].
STRETCH_NOTICE = 1.001
VERSIONED_PACKAGES = ("dh-pipeline", "drake", "toppra", "ruckig", "copp-py", "numpy", "scipy")


@dataclass(frozen=True, eq=False)
class JobOutcome:
    """What a job produced: the certified ``profile``, the ``files`` written, the ``report`` (the JSON
    report's content) and the compiled ``program`` it timed."""

    job: Job
    profile: Profile
    files: tuple[Path, ...]
    report: dict
    program: Program | None = None

    @property
    def limit_report(self) -> LimitReport:
        """The profile's certificate (peak/limit ratios), from ``retime``."""
        return self.profile.certificate

    def summary(self) -> str:
        """A few lines: robot, method, duration, peak/limit ratios, files."""
        scale = self.job.speed_scale
        lines = [f"job {self.job.name}: robot {self.job.robot.name}, {len(self.job.waypoints)} waypoints, "
                 f"timing {self.profile.method}, speed scale {scale:g}",
                 f"duration {self.profile.duration:.4f} s, {len(self.profile.t)} samples every {self.job.dt:g} s",
                 f"peak/limit, limits x speed scale {scale:g}: {_ratios(self.limit_report)} "
                 f"({'PASS' if self.limit_report.passed else 'FAIL'})"]
        if scale != 1.0:
            own = certify(self.profile, self.job.robot.limits)
            lines.append(f"peak/limit, the robot's own limits: {_ratios(own)}")
        if self.limit_report.clearance is not None:
            lines.append(f"cell {self.job.cell.name}: {self.limit_report.clearance}")
        tilt = self.report["timing_details"].get("tilt")
        if tilt is not None:
            lines.append(f"planned moves keep the tool within {tilt['max_deg']:g} deg of the vertical: at most "
                         f"{tilt['worst_deg']:.2f} deg (samples and between them)")
        planned = [(k, move["planned"]) for k, move in enumerate(self.report["program"]["moves"], start=1)
                   if move["planned"] is not None and move["planned"]["planner"] != "direct"]
        lines += [f"move to waypoint {k} planned by {plan['planner']}: {plan['plan_time_s'] * 1e3:.1f} ms search, "
                  f"{plan['simplify_time_s'] * 1e3:.1f} ms shortcutting, path {plan['path_length_before_rad']:.2f} -> "
                  f"{plan['path_length_after_rad']:.2f} rad" for k, plan in planned]
        lines += [f"stretch {s['first']}->{s['last']} slowed down uniformly by {s['timing']['time_stretch']:.4f} "
                  "(the dense check found limits exceeded between grid points)"
                  for s in self.report["timing_details"].get("stretches", [])
                  if (s["timing"] or {}).get("time_stretch", 1.0) > STRETCH_NOTICE]
        lines += cycle_lines(self.report["cycle"])
        for w in self.report.get("written_programs", {}).values():
            lines += written_lines(w, self.profile.duration)
        lines += [f"wrote {path}" for path in self.files]
        return "\n".join(lines)


def _ratios(report: LimitReport) -> str:
    return ", ".join(f"{name} {report.max_ratio(name):.4f}" for name in QUANTITIES if name in report.ratios)


def package_versions() -> dict[str, str | None]:
    """Installed versions of this package and its numerical dependencies (None when absent)."""
    return {name: installed_version(name) for name in VERSIONED_PACKAGES}


def build_report(job: Job, program: Program, profile: Profile, cycle: dict) -> dict:
    """The JSON report: inputs and their hash, methods (``path`` null for ruckig, which times waypoint
    to waypoint), duration, the limits (values and peak/limit ratios, against the limits the profile was
    timed against and against the robot's own, with the speed scale), timing details, the cycle-time
    report (per move, the lower bound), the program (its moves, planned vertices included); in a cell,
    the cell and the clearance certificate."""
    certificate = profile.certificate
    cell = None if job.cell is None else {
        "name": job.cell.name, "file": job.cell.source, "plan": job.plan,
        "clearance": None if certificate is None or certificate.clearance is None else certificate.clearance.to_dict()}
    return {
        "job": job.name,
        "job_file": job.source,
        "description": job.description,
        "robot": {"name": job.robot.name, "file": job.robot.spec.source, "joints": list(job.robot.joint_names)},
        "inputs_sha256": job.inputs_sha256,
        "method": {"ik": job.ik, "timing": job.timing, "path": job.path},
        "speed_scale": job.speed_scale,
        "dt_s": job.dt,
        "duration_s": profile.duration,
        "samples": int(len(profile.t)),
        "waypoints": [w.to_dict() for w in program.waypoints],
        "cycle": cycle,
        "program": program.to_dict(),
        "limits": limits_summary(profile),
        "timing_details": profile.details.to_dict(),
        "cell": cell,
        "versions": package_versions(),
    }


def _title(job: Job, profile: Profile) -> str:
    return f"{job.robot.name}: {job.name}, {profile.method}, speed scale {job.speed_scale:g}, {profile.duration:.3f} s"


def run_job(job: Job, out_dir: str | Path, max_samples: int = DEFAULT_MAX_SAMPLES,
            max_duration_s: float = DEFAULT_MAX_DURATION_S) -> JobOutcome:
    """Run a validated job and write its outputs into ``out_dir``, which is replaced whole on success
    and left as it was on any failure (``staged_output``; checked before any work). A profile of more
    than ``max_samples`` samples is refused (ProfileSizeError) before it is made, and a job whose moves
    take more than ``max_duration_s`` [s] or ``max_samples`` samples at their speed limits before any
    timing (``check_duration``)."""
    with staged_output(out_dir) as staging:
        program, profile, report = reported_program(job, max_samples, max_duration_s)
        written, motion = {}, None
        for language in (k for k in job.outputs if k in PROGRAM_FILES):
            # the certified motion as written is the same for every language: computed once
            motion = motion or written_motion(job, language, program, profile)
            written[language], own = language_written(job, language, program, profile, motion)
            if written[language] is not None:
                report.setdefault("written_programs", {})[language] = written_report(
                    written[language], language, program, profile, own)
        writers = _writers(job, profile, report, program, written)
        for kind in job.outputs:
            writers[kind](staging / output_names(kind)[0])
    files = tuple(Path(out_dir) / name for kind in job.outputs for name in output_names(kind))
    log.info("job %s: %s, %.4f s; wrote %d file(s) to %s", job.name, profile.method, profile.duration,
             len(files), out_dir)
    return JobOutcome(job, profile, files, report, program)


def output_names(kind: str) -> tuple[str, ...]:
    """The file names an output kind writes in the output directory (FILE_NAMES, PROGRAM_FILES)."""
    return PROGRAM_FILES.get(kind) or (FILE_NAMES[kind],)


def timed_program(job: Job, max_samples: int = DEFAULT_MAX_SAMPLES,
                  max_duration_s: float = DEFAULT_MAX_DURATION_S) -> tuple[Program, LowerBound, Profile]:
    """The job's program, its lower bound and its certified profile, in the job's cell if it has one
    (``_compiled_and_timed``: errors name the job file)."""
    return _compiled_and_timed(job, collision_model(job), max_samples, max_duration_s)


def reported_program(job: Job, max_samples: int = DEFAULT_MAX_SAMPLES,
                     max_duration_s: float = DEFAULT_MAX_DURATION_S) -> tuple[Program, Profile, dict]:
    """The job's program, its certified profile and its JSON report (with the cycle-time report): what
    ``run_job`` writes, without writing it."""
    program, bound, profile = timed_program(job, max_samples, max_duration_s)
    return program, profile, build_report(job, program, profile, cycle_report(program, profile, bound))


def program_name(language: str, job_name: str) -> str:
    """A valid program name in ``language`` made from ``job_name`` (``pipeline.outputs.controllers.names.
    legal_name``: _ for other characters, FANUC and Yaskawa upper case, ``P_`` before a reserved word, cut to the
    language's length)."""
    from .outputs.controllers.names import legal_name

    return legal_name(language, job_name)


def check_language_arm(robot, language: str) -> None:
    """OutputError naming the robot and its file unless ``language`` can move ``robot`` (URScript: a Universal
    Robots arm, ``urscript.check_arm``): checked before a job is planned and timed (the writer checks again)."""
    if language == "urscript":
        from .outputs.controllers.urscript import check_arm

        check_arm(robot)


#: URScript's servoj replay period [s] by default: an e-Series controller's (a CB3's is 0.008 s).
SERVO_PERIOD_S = 0.002


#: Languages written as the certified motion (``controller_motion.certified_moves``, issue 36): all five.
CERTIFIED_MOTION_LANGUAGES = ("rapid", "krl", "ls", "jbi", "urscript")


def written_motion(job: Job, language: str, program: Program, profile: Profile):
    """The certified motion as ``language`` writes it (``controller_motion.certified_moves``: a planned move as
    joint targets on the certified path, zones wherever it does not stop, its certificate in the job's cell and
    its cycle time as written), or None for a language not yet written so (CERTIFIED_MOTION_LANGUAGES), a
    profile without its waypoints' passages, or a written motion the timing cannot time (e.g. topp3 out of its
    budget on a long path: logged as a warning; the writer then writes the planner's vertices with exact stops)."""
    if language not in CERTIFIED_MOTION_LANGUAGES or getattr(profile.details, "passages_s", None) is None:
        return None
    from .outputs.controllers.controller_motion import certified_moves

    try:
        return certified_moves(program, profile, collision_model(job))
    except PipelineError as exc:
        log.warning("job %s: the certified motion as written could not be timed, written without it: %s",
                    job.name, exc)
        return None


def language_written(job: Job, language: str, program: Program, profile: Profile, written):
    """(``written`` with, for FANUC and Yaskawa, the certificate of the zones the language writes instead in its
    header ``notes``, that certificate as ``language_zones_certificate`` gives it, or None); (None, None) for None."""
    own = language_zones_certificate(language, program, profile, written, collision_model(job))
    if own is None:
        return written, None
    return replace(written, notes=(f"{LANGUAGE_TITLES[language]} {language_zones_line(language, own)}",)), own


def zone_differences(language: str, program: Program, written) -> list[str]:
    """Per written move, where ``language`` cannot write the certified zone exactly, what it writes instead and the
    difference (FANUC CNT: ``fanuc_ls.cnt_differences``; Yaskawa PL: ``yaskawa_jbi.pl_differences``); RAPID,
    KRL and URScript write the zone in mm or m (none listed)."""
    if written is None:
        return []
    if language == "ls":
        from .outputs.controllers.fanuc_ls import cnt_differences

        return cnt_differences(program, written)
    if language == "jbi":
        from .outputs.controllers.yaskawa_jbi import pl_differences

        return pl_differences(program, written)
    return []


def language_zones_certificate(language: str, program: Program, profile: Profile, written, scene=None):
    """The written program's certificate (``controller_motion.WrittenCertificate.to_dict``) with the zones
    ``language`` writes instead of the certified ones where it cannot write them exactly (FANUC: CNT's n % of its
    reach; Yaskawa: the assumed PL distances), in ``scene``: not passed, with the ``error``, when the motion with
    those zones cannot be timed; None for a language that writes the zones exactly."""
    if written is None or language not in ("ls", "jbi"):
        return None
    from .outputs.controllers.controller_motion import written_program_certificate

    if language == "ls":
        from .outputs.controllers.fanuc_ls import cnt_zones as zones_of
    else:
        from .outputs.controllers.yaskawa_jbi import pl_zones as zones_of
    moves = [replace(w, zone_m=z) for w, z in zip(written.moves, zones_of(program, written))]
    try:
        certificate = written_program_certificate(program, moves, profile, scene)[2]
    except PipelineError as exc:        # e.g. the timing of the path with these zones found no profile
        return {"passed": False, "error": str(exc), "duration_s": None, "min_clearance_m": None}
    return {**certificate.to_dict(), "max_deviation_rad": certificate.max_deviation_rad}


def language_zones_line(language: str, certificate: dict) -> str:
    """One line: the cycle time and certificate (``WrittenCertificate.to_dict``) of the program with the
    language's own zones."""
    clearance = "" if certificate["min_clearance_m"] is None else \
        f", smallest clearance {certificate['min_clearance_m'] * 1e3:.1f} mm"
    what = {"ls": "CNT's modelled zones", "jbi": "the assumed PL distances"}[language]
    if certificate.get("error"):
        return f"with {what}: not certified ({certificate['error']})"
    return (f"with {what}: {certificate['duration_s']:.4f} s, certificate "
            f"{'passed' if certificate['passed'] else 'FAILED'}{clearance}")


def written_lines(report: dict, certified_s: float) -> list[str]:
    """What ``program`` and ``run`` print of a written program (``written_report``): its cycle time as written
    beside the certified one [s], its certificate, then per move the zones changed and the zones the language
    writes instead, and the certificate with those."""
    language = report["language"]
    deviation = report["max_deviation_rad"]
    lines = [f"{LANGUAGE_TITLES[language]} as written: {report['duration_s']:.4f} s (certified {certified_s:.4f} s), "
             f"written-program certificate {'passed' if report['passed'] else 'FAILED'}, {report['exact_stops']} exact "
             "stops" + ("" if deviation is None else f", largest deviation from the certified path {deviation:.4f} rad")]
    lines += [f"  zone changed: {c['change']} (cost {c['cost_s']:+.4f} s)" for c in report["zone_changes"]]
    lines += [f"  zone as written: {d}" for d in report["zone_differences"]]
    if report["language_zones"] is not None:
        lines.append(f"  {LANGUAGE_TITLES[language]} {language_zones_line(language, report['language_zones'])}")
    return lines


def written_report(written, language: str, program: Program, profile: Profile, own=None) -> dict:
    """The written program's certificate for report.json: verdict, smallest clearance, largest deviation, cycle
    time as written beside the certified one, exact stops, per move the zones changed (with their reasons and
    their cost: the written move to that waypoint's duration minus the certified one's [s]) and what the language
    writes instead of a zone it cannot express."""
    certificate = written.certificate
    costs = waypoint_costs(written, profile)
    changes = []
    for change in written.changes:
        found = re.search(r"waypoint (\d+)", change)
        j = int(found.group(1)) if found else None
        changes.append({"change": change, "waypoint": j, "cost_s": costs.get(j, 0.0)})
    return {"language": language, **certificate.to_dict(), "max_deviation_rad": certificate.max_deviation_rad,
            "exact_stops": written.exact_stops, "job_exact_stops": len(program.stops),
            "written_moves": len(written.moves), "zone_changes": changes,
            "zone_differences": zone_differences(language, program, written),
            "language_zones": own}


def waypoint_costs(written, profile: Profile) -> dict[int, float]:
    """Per program waypoint j >= 1, how much longer [s] the written program takes from waypoint j - 1 to j than
    the certified profile (``WrittenTiming.passages_s`` at the last written move of each waypoint against the
    certified ``passages_s``)."""
    passages = getattr(profile.details, "passages_s", None)
    if passages is None:
        return {}
    ends = {}
    for w, t in zip(written.moves, written.timing.passages_s):
        ends[w.source] = float(t)
    costs, before = {}, 0.0
    for j in sorted(k for k in ends if k is not None):
        costs[j] = (ends[j] - before) - (passages[j] - passages[j - 1])
        before = ends[j]
    return costs


def program_texts(job: Job, language: str, program: Program, profile: Profile,
                  name: str | None = None, servo_period: float = SERVO_PERIOD_S,
                  krl_generation: str = "krc2", written=None) -> dict[str, str]:
    """The job's ``program`` in a controller's ``language`` (rapid, ls, jbi, krl, urscript) as program
    ``name`` (None: ``program_name`` of the job's name): file suffix -> text (KRL: .src and .dat). When
    the name differs from the job's, the writer's header says so (the program's name it states becomes
    "job name (written as NAME: the language's rule)", the rule when the name was made from the job's).
    URScript gets the certified ``profile``'s servoj replay every ``servo_period`` [s], KRL is written for the
    controller generation ``krl_generation`` (``krl.GENERATIONS``). Every language writes ``written`` (None: computed
    here, ``written_motion``), the certified motion with its certificate in the header.
    OutputError names the job file (and the waypoint whose move breaks a rule of the language) and what
    the writer refused."""
    name = program_name(language, job.name) if name is None else name
    if name != program.name:
        rule = f": {NAME_RULES[language]}" if name == program_name(language, program.name) else ""
        program = replace(program, name=f"{program.name} (written as {name}{rule})")
    try:
        if written is None:
            written = language_written(job, language, program, profile,
                                       written_motion(job, language, program, profile))[0]
        return _program_texts(language, program, profile, name, servo_period, krl_generation, written)
    except PipelineError as exc:
        move = getattr(exc, "move", None)
        where = job.source if move is None else job.location(("waypoints", move))
        raise OutputError(f"{where}: cannot write the {LANGUAGE_TITLES[language]} program {name}: {exc}") from exc


def _program_texts(language: str, program: Program, profile: Profile, name: str,
                   servo_period: float, krl_generation: str, written=None) -> dict[str, str]:
    from .outputs.controllers.fanuc_ls import write_ls
    from .outputs.controllers.krl import write_krl
    from .outputs.controllers.rapid import write_rapid
    from .outputs.controllers.urscript import write_urscript
    from .outputs.controllers.yaskawa_jbi import write_jbi

    if language == "krl":
        return dict(zip((".src", ".dat"), write_krl(program, name, krl_generation, written)))
    writers = {"rapid": lambda: {".mod": write_rapid(program, name, written)},
               "ls": lambda: {".ls": write_ls(program, name, written=written)},
               "jbi": lambda: {".jbi": write_jbi(program, name, written=written)},
               "urscript": lambda: {".script": write_urscript(program, name, profile, servo_period, written=written)}}
    return writers[language]()


def _write_program(job: Job, language: str, program: Program, profile: Profile, path: Path, written=None) -> None:
    """The program's files at ``path`` (its first file; KRL's .dat beside its .src); ``written``: the certified
    motion as written (None: computed, ``written_motion``)."""
    for suffix, text in program_texts(job, language, program, profile, written=written).items():
        path.with_suffix(suffix).write_text(text, encoding="utf-8")


def collision_model(job: Job):
    """The job's CollisionModel (its cell's robot, as the robot file gives it, and the cell), or None
    for a job without a cell."""
    if job.cell is None:
        return None
    from .cell.collision import CollisionModel   # Drake's checker only for jobs in a cell

    return CollisionModel(job.cell.load_robot(), job.cell)


def _compiled_and_timed(job: Job, scene, max_samples: int,
                        max_duration_s: float) -> tuple[Program, LowerBound, Profile]:
    """The job's program (``compile_job``), its lower bound, checked against the duration limits
    (``check_duration``), and its certified profile (``time_program``). Tool-move errors name the waypoint and its line, clearance
    failures the line of the waypoint the motion is moving to (``move_at``) and the job's time, timing,
    planning and collision errors the job file."""
    program = _staged(job, lambda: compile_job(job, scene))
    bound = lower_bound(program)
    check_duration(job, bound, max_samples, max_duration_s)
    return program, bound, _staged(job, lambda: time_program(program, scene, max_samples))


def _staged(job: Job, stage):
    """``stage()``, its errors named as ``_compiled_and_timed`` says."""
    from .program.tool_moves import ToolMoveError

    try:
        return stage()
    except ToolMoveError as exc:
        raise job.error(("waypoints", exc.move), str(exc)) from exc
    except ClearanceError as exc:
        k = move_at(exc.profile, exc.first, exc.last, exc.report.failed_at_s)
        raise CollisionError(f"{job.location(('waypoints', k))}: on the move to this waypoint (t in job time), "
                             f"{exc}") from exc
    except (TimingError, ConfigurationError, CollisionError, PlanningError) as exc:
        raise type(exc)(f"{job.source}: {exc}") from exc


def move_at(profile: Profile, first: int, last: int | None, t: float | None) -> int:
    """The waypoint the motion is moving to at job time ``t`` [s] (None: the last of the stretch
    ``first`` .. ``last``, None: the job's last), from the profile's passage times
    (``ProgramDetails.passages_s``; the stretch's last waypoint when it has none)."""
    passages = getattr(profile.details, "passages_s", None)
    if passages is None or t is None:
        return last if last is not None else len(passages or [0]) - 1
    after = [k for k, passed in enumerate(passages) if passed >= t]
    return after[0] if after else len(passages) - 1


def _writers(job: Job, profile: Profile, report: dict, program: Program, written: dict | None = None) -> dict:
    """Output kind -> function writing that output at the path it is given."""
    revolute = [j.is_revolute for j in job.robot.spec.joints]
    return {
        "csv": lambda path: write_profile_csv(path, profile, revolute),
        "npz": lambda path: write_profile_npz(path, profile, program_arrays(program)),
        "json": lambda path: write_json(path, report),
        "png": lambda path: _plot(path, job, profile, revolute),
        "html": lambda path: _view_html(path, job, profile, program.tool),
        "arm_png": lambda path: _plot_arm(path, job, profile, program.tool),
        "tcp_png": lambda path: _plot_tcp(path, job, profile),
        "ros2_yaml": lambda path: write_ros2_yaml(path, profile),
        "json_trajectory": lambda path: write_json_trajectory(path, profile),
        **{language: functools.partial(_write_program, job, language, program, profile,
                                       written=(written or {}).get(language)) for language in PROGRAM_FILES},
    }


def _plot(path: Path, job: Job, profile: Profile, revolute: list[bool]) -> None:
    from .outputs.plots import plot_profile   # matplotlib only when a plot is asked for

    plot_profile(path, profile, revolute, _title(job, profile))


def _plot_tcp(path: Path, job: Job, profile: Profile) -> None:
    from .outputs.plots import plot_tcp

    plot_tcp(path, profile, _title(job, profile))


def _view_html(path: Path, job: Job, profile: Profile, tool) -> None:
    from .outputs.views import profile_html   # Drake's Meshcat only when a view is asked for

    Path(path).write_text(profile_html(job.robot, profile, cell=job.cell, tool=tool), encoding="utf-8")


def _plot_arm(path: Path, job: Job, profile: Profile, tool) -> None:
    from .outputs.views import plot_arm_motion

    plot_arm_motion(path, job.robot, profile, _title(job, profile), job.cell, tool)


def run_job_file(path: str | Path, out_dir: str | Path, max_samples: int = DEFAULT_MAX_SAMPLES,
                 max_duration_s: float = DEFAULT_MAX_DURATION_S) -> JobOutcome:
    """Load a job file and run it: ``run_job(load_job(path), out_dir, max_samples, max_duration_s)``."""
    return run_job(load_job(path), out_dir, max_samples, max_duration_s)
