"""Command line: ``python -m pipeline VERB ...``, VERB one of
{run,program,read-program,check-program,show,fk,ik,check,check-cell,bench,build-kernels,export,import-urdf,batch,
reach,ui}.
The only place that configures logging.

Every failure is one line on stderr: ``error: ...`` and exit status 2 for bad input or an output that
cannot be written (a PipelineError), ``internal error: ...`` and exit status 1 for a bug (``-v``
prints its traceback), exit status 130 when interrupted. ``check`` above tolerance, ``check-program`` on a program
that would collide or leave a limit, and ``batch`` with a failed job (a row of its summary) exit with status 1 too.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import re
import signal
import sys
import threading
import traceback
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from .errors import ConfigurationError, FileFormatError, OutputError, PipelineError
from .files.atomic import WRITTEN_BY, prepare_file_target, staged_output, write_text_atomic
from .files.choices import DEFAULT_MAX_DURATION_S
from .files.robot_spec import CONTROLLER_MAKERS, preset_names
from .model.chain.singularity import compute_singularity
from .model.robot import load_robot
from .timing import DEFAULT_MAX_SAMPLES


def _robots(name: str):
    names = preset_names() if name == "all" else [name]
    return [load_robot(n) for n in names]


def cmd_show(args) -> int:
    """Print the DH table, the end-frame pose and the singularity measures at q = 0."""
    robot = load_robot(args.robot)
    q = np.zeros(robot.dof)
    with np.printoptions(precision=6, suppress=True):
        print(robot)
        print(f"\nX_BE at q = 0 (end frame in base frame, metres):\n{robot.fk(q)}")
        print(f"\nJacobian at q = 0 (rows vx vy vz wx wy wz):\n{robot.jacobian(q)}")
    print(f"\nSingularity at q = 0: {compute_singularity(robot.jacobian(q))}")
    return 0


def cmd_fk(args) -> int:
    """Print the TCP pose at joint values (the robot file's angle unit unless --unit; prismatic joints in mm):
    position [mm], rpy [deg], quaternion [w x y z], our branch name and the maker's configuration text."""
    from .files.poses import pose_to_quaternion_position, rotation_to_rpy
    from .ui.branches import branch_names

    robot = load_robot(args.robot)
    unit = args.unit or robot.spec.angle_unit or "deg"
    q = _joint_values(robot, args.q, unit, "joint values")
    robot, tool = _with_tool(robot, args.tool)
    X = robot.fk(q)
    quaternion, position = pose_to_quaternion_position(X)
    (name,), vendor, (text,) = branch_names(robot, q[None])
    rows = {"position [mm]": _numbers(position * 1e3),
            "rpy [deg]": _numbers(np.degrees(rotation_to_rpy(X[:3, :3]))),
            "quaternion [w x y z]": _numbers(quaternion, 9),
            "branch": name or f"none ({robot.name} has no named branches)",
            f"{vendor or 'controller'} configuration":
                text or f"none (no maker whose configuration data applies to {robot.name})"}
    print(f"{robot.name} at q = [{', '.join(args.q)}] {unit}; TCP: {tool}")
    width = max(map(len, rows)) + 1
    for label, value in rows.items():
        print(f"  {label + ':':<{width}} {value}")
    return 0


def cmd_ik(args) -> int:
    """Print every IK branch of a TCP pose (mm, deg; base frame): its name, the maker's configuration, joint
    values [deg], state, sigma_min and, in a cell, the closest pair. An unreachable pose is a result (exit 0)."""
    from .files.poses import rpy_position_to_pose
    from .ui.branches import target_branches

    robot, scene, where = load_robot(args.robot), None, ""
    if args.cell:
        from .cell.cell_file import load_cell
        from .cell.collision import CollisionModel

        cell = load_cell(args.cell)
        robot_F = cell.load_robot()
        if robot_F.name != robot.name:
            raise ConfigurationError(f"ROBOT {args.robot!r} is {robot.name}, but the cell {cell.name} holds "
                                     f"{robot_F.name} ({cell.robot}): name the cell's robot")
        robot, scene = robot_F, CollisionModel(robot_F, cell)
        where = f" in cell {cell.name} (clearance {cell.clearance * 1e3:g} mm)"
    seed = None if args.seed is None else _joint_values(robot, args.seed, "deg", "--seed")
    robot, tool = _with_tool(robot, args.tool)
    pose = [getattr(args, name) for name in POSE_NAMES]
    if not all(isinstance(value, float) for value in pose):
        raise ConfigurationError(f"the TCP pose is six numbers {' '.join(n.upper() for n in POSE_NAMES)} [mm, deg], "
                                 f"got {pose}")
    X_BT = rpy_position_to_pose(np.radians(pose[3:]), np.array(pose[:3]) * 1e-3)
    print(f"{robot.name}{where}; TCP: {tool}")
    print(target_branches(robot, X_BT, seed, scene).describe())
    return 0


def _joint_values(robot, texts: list[str], unit: str, what: str) -> np.ndarray:
    """Joint values typed on the command line (revolute joints in ``unit``, prismatic ones in mm) -> q [rad or
    m]; ConfigurationError for a wrong count, a non-number or a value outside the joint's limits (naming the
    joint, its limits and, for rad values only degrees would explain, the unit)."""
    from .files.units import ANGLE_UNITS, LENGTH_UNITS

    names = robot.joint_names
    if len(texts) != robot.dof:
        raise ConfigurationError(f"{what}: {robot.name} has {robot.dof} joints ({', '.join(names)}), got "
                                 f"{len(texts)} value(s)")
    revolute = robot.revolute_mask
    scales = np.where(revolute, ANGLE_UNITS[unit], LENGTH_UNITS["mm"])
    limits = robot.limits
    q = np.empty(robot.dof)
    for j, text in enumerate(texts):
        try:
            q[j] = float(text) * scales[j]
        except ValueError:
            raise ConfigurationError(f"{what}: joint {j + 1} ({names[j]}): {text!r} is not a number") from None
        shown = unit if revolute[j] else "mm"
        if not limits.q_min[j] <= q[j] <= limits.q_max[j]:
            hint = (" (a value beyond a turn: are these degrees? give --unit deg)"
                    if unit == "rad" and revolute[j] and abs(q[j]) > 2.0 * np.pi else "")
            raise ConfigurationError(f"{what}: joint {j + 1} ({names[j]}) = {text} {shown} is outside its limits "
                                     f"[{limits.q_min[j] / scales[j]:.6g}, {limits.q_max[j] / scales[j]:.6g}] "
                                     f"{shown}{hint}")
    return q


def _with_tool(robot, tool: list[float] | None):
    """(the robot whose end frame is the TCP of ``--tool X Y Z R P Y`` [mm, deg] in the flange, words for the
    TCP); without --tool the flange (the robot file's end frame)."""
    from .model.robot import robot_with_tool

    if tool is None:
        return robot, "the flange (no --tool)"
    words = f"--tool xyz [{_numbers(tool[:3])}] mm, rpy [{_numbers(tool[3:])}] deg"
    return robot_with_tool(robot, _pose_option(tool, "--tool")), words


def _program_arguments(args) -> tuple[Path, str, Path | None]:
    """(the program file, its language by suffix, the --out file checked) of read-program and check-program, the
    robot loaded first (its file's own errors name that file, not the program)."""
    from .outputs.controllers.read_program import READ_SUFFIXES

    path = Path(args.file)
    language = READ_SUFFIXES.get(path.suffix.lower())
    if language is None:
        raise _program_error(path, f"unknown program file type {path.suffix!r}: the readers take "
                             f"{', '.join(READ_SUFFIXES)} (KRL: the .src, with its .dat beside it)")
    out = Path(args.out) if args.out else None
    if out is not None:
        prepare_file_target(out, args.force)
    load_robot(args.robot)
    return path, language, out


def _selected(args) -> dict:
    """``--tool`` and ``--frame`` of read-program and check-program: the tool X_FT and the user frame X_BU (4, 4)
    [m] a program selects by number without their data."""
    return {"tool": _pose_option(args.tool, "--tool"), "frame": _pose_option(args.frame, "--frame")}


def _pose_option(values: list[float] | None, option: str) -> np.ndarray | None:
    """``--tool`` or ``--frame X Y Z R P Y`` [mm, deg] -> its pose (4, 4) [m] (None without it)."""
    from .files.poses import check_pose, rpy_position_to_pose

    if values is None:
        return None
    return check_pose(rpy_position_to_pose(np.radians(values[3:]), np.array(values[:3]) * 1e-3), option)


def _numbers(values, decimals: int = 3) -> str:
    """Numbers with ``decimals`` decimals, without "-0.000"."""
    return ", ".join(f"{v:.{decimals}f}" for v in np.round(np.asarray(values, dtype=float), decimals) + 0.0)


def cmd_check(args) -> int:
    """Jacobian check (analytic vs Drake vs finite differences); non-zero exit above tolerance. With
    ``--out`` the JSON reports of the whole run replace that folder together."""
    from .model.jacobian_check import check_robot

    passed = True
    with staged_output(args.out) if args.out else nullcontext() as staging:
        for robot in _robots(args.robot):
            report = check_robot(robot, samples=args.samples, seed=args.seed)
            print(report.format(), end="\n\n")
            passed &= report.passed
            if staging is not None:
                (staging / f"{robot.name}_jacobian_check.json").write_text(json.dumps(report.to_dict(), indent=2))
    print("all checks passed" if passed else "CHECK FAILED: errors above tolerance")
    return 0 if passed else 1


def cmd_export(args) -> int:
    """Write a robot as URDF (ROS-Industrial frame names base_link and tool0)."""
    from .urdf import write_urdf

    robot = load_robot(args.robot)
    path = write_urdf(robot, args.urdf, args.force)
    print(f"wrote {path}: {robot.name}, {robot.dof} joints ({', '.join(robot.joint_names)}), base_link -> tool0")
    return 0


def cmd_import_urdf(args) -> int:
    """Turn a URDF serial chain into a robot file (DH extracted from the joint axes) and report it."""
    from .urdf import import_urdf

    prepare_file_target(args.out, args.force)
    imported = import_urdf(args.urdf, base=args.base, tip=args.tip, convention=args.convention, name=args.name,
                           time_to_full_speed=args.time_to_full_speed, controller=args.controller)
    imported.write(args.out, args.force)
    chain = imported.chain
    print(imported.robot)
    print(f"\nwrote {args.out}: chain {chain.base} -> {chain.tip} of {args.urdf}; FK of the robot file against the "
          f"URDF's on random configurations: largest difference {imported.max_fk_error_m:.2g} m")
    for line in imported.document.get("assumptions", []):
        print(f"note: {line}")
    return 0


def cmd_check_cell(args) -> int:
    """Print a cell, its collision model, the robot's clearance at a pose (--q, default q = 0) and the pair in
    collision there, if any; exit 1 when that pose collides or comes closer than the clearance."""
    from .cell.cell_file import load_cell
    from .cell.collision import CollisionModel

    cell = load_cell(args.cell)
    robot = cell.load_robot()
    model = CollisionModel(robot, cell)
    q = np.zeros(robot.dof) if args.q is None else _joint_values(robot, args.q, args.unit, "--q")
    pose = "q = 0" if args.q is None else f"q = [{', '.join(args.q)}] {args.unit}"
    clearance = model.clearance(q)
    print(cell)
    print(model.describe())
    closest = ("no obstacle within reach" if clearance.obstacle_pair is None else
               f"{clearance.obstacle * 1e3:.1f} mm ({clearance.obstacle_pair[0]} - {clearance.obstacle_pair[1]})")
    links = ("no link pair within reach" if clearance.self_pair is None else
             f"{clearance.self * 1e3:.1f} mm ({clearance.self_pair[0]} - {clearance.self_pair[1]})")
    print(f"at {pose}: closest obstacle {closest}; closest links {links}")
    if model.is_free(q):
        print(f"{pose} is collision-free with {cell.clearance * 1e3:g} mm clearance")
        return 0
    print(f"COLLISION at {pose}: {model.why_not_free(q)}")
    return 1


def _names(text: str | None, default: tuple[str, ...]) -> tuple[str, ...]:
    """A comma-separated list, or the default."""
    return tuple(n.strip() for n in text.split(",") if n.strip()) if text else default


def cmd_run(args) -> int:
    """Run a job file: IK for pose waypoints, path, timing, certification, output files."""
    from .runner import run_job_file

    outcome = run_job_file(args.job, args.out, max_samples=args.max_samples, max_duration_s=args.max_duration)
    print(outcome.summary())
    return 0


#: A controller program's file suffixes by language (the first: the file --out may name; KRL's .dat beside it).
PROGRAM_SUFFIXES = {"rapid": (".mod",), "ls": (".ls",), "jbi": (".jbi",), "krl": (".src", ".dat"),
                    "urscript": (".script",)}


def cmd_program(args) -> int:
    """Compile and time a job, then write its program in a controller's language (``runner.program_texts``):
    into a file named by --out, or as NAME.<suffix> in the folder --out (default: here). Every target is
    checked before any work; each file is written atomically."""
    from .program.job import load_job
    from .runner import (LANGUAGE_TITLES, SERVO_PERIOD_S, check_language_arm, language_written, program_name,
                         program_texts, timed_program, written_lines, written_motion, written_report)

    from .outputs.controllers.krl import KRC2
    from .outputs.controllers.urscript import check_servo_period

    if args.servo_period is not None and args.lang != "urscript":
        raise OutputError(f"--servo-period is the period of URScript's servoj replay; {args.lang} has none")
    period = check_servo_period(SERVO_PERIOD_S if args.servo_period is None else args.servo_period)
    if args.krl_generation is not None and args.lang != "krl":
        raise OutputError(f"--krl-generation is the KUKA controller generation of a KRL program; {args.lang} has none")
    job = load_job(args.job)
    check_language_arm(job.robot, args.lang)
    name, targets = _program_targets(args.lang, program_name(args.lang, job.name), Path(args.out or "."))
    for path in targets.values():
        prepare_file_target(path, args.force, job.name, _keep_both(args.lang, name, path))
    program, _, profile = timed_program(job, args.max_samples, args.max_duration)
    written, own = language_written(job, args.lang, program, profile, written_motion(job, args.lang, program, profile))
    texts = program_texts(job, args.lang, program, profile, name, period, args.krl_generation or KRC2, written)
    print(f"job {job.name}: {LANGUAGE_TITLES[args.lang]} program {name}, {len(program.moves)} moves; the certified "
          f"profile takes {profile.duration:.4f} s (the controller plans its own for native moves)")
    if written is not None:
        print("\n".join(written_lines(written_report(written, args.lang, program, profile, own), profile.duration)))
    for suffix, text in texts.items():
        print(f"wrote {write_text_atomic(targets[suffix], text, args.force)}")
    return 0


def _keep_both(language: str, name: str, path: Path) -> str:
    """How to keep another job's program at ``path`` and write this one too: another folder, or a job name
    that gives a program name still free in that folder (e.g. GP7_PIC2 for GP7_PICK)."""
    from .runner import program_name

    example = ""
    for n in range(2, 100):
        free = program_name(language, f"{name[:len(name) - len(str(n))]}{n}")
        if not path.with_name(free + path.suffix).exists():
            example = f" (free here: {free}, e.g. from a job file named {free.lower()}.yaml)"
            break
    return (f"to keep both, write this one into another folder (--out DIR) or rename the job so that its program "
            f"name differs{example}")


def _program_targets(language: str, name: str, out: Path) -> tuple[str, dict[str, Path]]:
    """(the program's name, suffix -> file): ``out`` with the language's suffix is the file (KRL: its .dat
    beside it, and the name its stem: KRL wants a program's files named as its DEF), anything else a folder
    for NAME.<suffix>. OutputError for another language's suffix or a KRL file stem that is no KRL name."""
    suffixes = PROGRAM_SUFFIXES[language]
    if out.is_dir() or out.suffix.lower() not in {s for group in PROGRAM_SUFFIXES.values() for s in group}:
        return name, {suffix: out / f"{name}{suffix}" for suffix in suffixes}
    if out.suffix.lower() != suffixes[0]:
        raise OutputError(f"{out}: a {language} program is a {suffixes[0]} file; give such a file or a folder")
    if language == "krl":
        from .runner import program_name

        if program_name("krl", out.stem) != out.stem:
            raise OutputError(f"{out}: a KRL program's files are named as its DEF, and {out.stem!r} is not a KRL "
                              "name (a letter, then letters, digits or _, at most 24); give a folder or another name")
        name = out.stem
    return name, {suffix: out.with_suffix(suffix) for suffix in suffixes}


def cmd_read_program(args) -> int:
    """Read a controller program back into a job document (``pipeline.outputs.controllers.read_*``), in the
    program's own units, check it as a job, and write it as YAML to --out (atomically) or print it."""
    import yaml

    from .outputs.controllers.read_units import in_program_units, units_line
    from .program.job import parse_job
    from .runner import LANGUAGE_TITLES

    path, language, out = _program_arguments(args)

    document = in_program_units(_read_program(language, path, args.robot, _selected(args)), language)
    document["robot"] = _robot_reference(args.robot, out)
    job = parse_job(document, source=str(path), name=(out or path).stem, base_dir=out.parent if out else ".")
    header = (f"# {job.name}: the {LANGUAGE_TITLES[language]} program {path} read back by dh-pipeline read-program\n"
              f"{units_line(language)}\n")
    text = header + yaml.safe_dump(document, sort_keys=False, default_flow_style=None, width=120)
    if out is None:
        print(text, end="")
        return 0
    write_text_atomic(out, text, args.force)
    print(f"read {path}: {len(document['waypoints'])} waypoints for {args.robot}; wrote {out}")
    return 0


def cmd_check_program(args) -> int:
    """Check an existing controller program in a cell (``pipeline.outputs.controllers.check_program``): read it,
    solve its targets with its configuration data, time it as written, certify limits and clearance; print the
    cycle time per move and what fails (exit 1), and write the report as JSON to --out when given."""
    from .outputs.controllers.check_program import check_program
    from .program.compile import compile_job
    from .program.job import parse_job
    from .runner import collision_model

    path, language, out = _program_arguments(args)
    document = _read_program(language, path, args.robot, _selected(args))
    document.update(robot=args.robot, allow_branch_change=True)     # the program's own configurations, as written
    if args.cell:
        document["cell"] = args.cell
    job = parse_job(document, source=str(path), name=path.stem)
    program = compile_job(job)                 # no planning, targets where the program puts them
    check = check_program(program, collision_model(job))
    cell = f" in {job.cell.name}" if job.cell is not None else " (no cell: clearance not checked)"
    print(f"check-program {path}: {job.robot.name}{cell}, {len(program.moves)} moves, as the controller runs it")
    print("\n".join(check.lines()))
    if out is not None:
        write_text_atomic(out, json.dumps(check.to_dict(), indent=1) + "\n", args.force)
        print(f"wrote {out}")
    return 0 if check.passed else 1


def _robot_reference(robot: str, out: Path | None) -> str:
    """The job's ``robot``: a preset name as given; a robot file relative to the job file written (its
    relative paths start there), as given when the job is printed."""
    if out is None or Path(robot).suffix not in (".yaml", ".yml"):
        return robot
    return os.path.relpath(os.path.abspath(robot), os.path.abspath(out.parent))


def _program_error(path: Path, problem: str, field: str = "file", line: int | None = None) -> FileFormatError:
    from .outputs.controllers.read_ls import ControllerProgramError

    return ControllerProgramError(str(path), field, problem, line=line)


#: The largest controller program read [bytes]: every program the writers make (a URScript servoj replay is at
#: most ``urscript.MAX_REPLAY_LINES`` lines), and a bound on the parse time (some 2 s a MiB).
MAX_PROGRAM_BYTES = 8 * 1024 * 1024


def _read_text(path: Path) -> str:
    """The program file's UTF-8 text (a byte-order mark allowed): a regular file of at most MAX_PROGRAM_BYTES,
    or the one-line error naming it."""
    from .files.schema import decode_text, read_file_bytes

    def fail(_, problem):
        raise _program_error(path, problem)

    return decode_text(read_file_bytes(path, fail, MAX_PROGRAM_BYTES), fail)


def _read_program(language: str, path: Path, robot: str, selected: dict | None = None) -> dict:
    """The job document of the program at ``path`` in ``language``, with the timing settings its header marks
    (``settings_mark.with_written_settings``); ``selected``: the ``tool`` and ``frame`` (4, 4) [m] the program selects
    by number without their data (``--tool``, ``--frame``); every reader error names ``path``."""
    from .outputs.controllers.read_program import read_program_text

    text = _read_text(path)
    dat = _dat_file(path) if language == "krl" else None
    try:
        return read_program_text(language, text, robot, str(path), dat and _read_text(dat), str(dat),
                                 **(selected or {}))
    except FileFormatError as exc:
        if exc.source in (str(path), str(dat)):
            raise
        raise _program_error(path, exc.problem, exc.field, exc.line) from exc
    except PipelineError as exc:         # e.g. a pose no joint solution of the written configuration reaches
        raise _program_error(path, str(exc)) from exc


def _dat_file(src: Path) -> Path | None:
    """The .dat beside a KRL .src (.dat or .DAT), or None: a .src alone (as offline tools write it: a name it uses
    without declaring is then the reader's error)."""
    for suffix in (".dat", ".DAT"):
        if src.with_suffix(suffix).is_file():
            return src.with_suffix(suffix)
    return None


def cmd_batch(args) -> int:
    """Run job files (or folders of them) on Dask workers into DIR/<job name>/, with summary.csv and
    summary.json; exit 1 when a job failed (its row says why)."""
    from .scale import dask_client
    from .scale.batch import SUMMARY_CSV, SUMMARY_JSON, job_files, run_jobs, write_batch

    files = job_files(args.jobs)
    with staged_output(args.out) as staging, dask_client(args.workers, args.scheduler) as client:
        outcome = run_jobs(files, client, args.max_samples)
        write_batch(staging, outcome)
    print(outcome.summary())
    print(f"wrote {args.out}/{SUMMARY_CSV}, {args.out}/{SUMMARY_JSON} and a folder per job that ran")
    return 1 if outcome.failed else 0


def cmd_reach(args) -> int:
    """A reachability map of a robot (or of the robot in a cell) on Dask workers: NPZ, PNG slices,
    Meshcat HTML and a JSON summary in DIR."""
    from .scale import dask_client
    from .scale.reach import plan_map
    from .scale.result import FILES

    plan = plan_map(_robot_or_cell(args.robot), step=args.step * 1e-3, orientations=args.orientations,
                    tool_axis_cone=args.tool_axis_cone, seed=args.seed, point=args.point)
    with staged_output(args.out) as staging, dask_client(args.workers, args.scheduler) as client:
        reach_map = plan.run(client)
        reach_map.write_into(staging)
    print(reach_map.describe())
    print("wrote " + ", ".join(f"{args.out}/{name}" for name in FILES.values()))
    return 0


def cmd_ui(args) -> int:
    """Serve the local web page until Ctrl-C (or, with --screenshot, take its picture and stop)."""
    from .ui.page import open_page

    if args.screenshot:
        prepare_file_target(args.screenshot, args.force)
    page = open_page(args.source, args.host, args.port)
    url = f"http://{page.host}:{page.port}"
    try:
        if args.screenshot:
            from .ui.screenshot import take_screenshot

            page.show_for_screenshot()
            print(f"wrote {take_screenshot(url, args.screenshot, args.force)}")
            return 0
        print(f"the page of {page.source.title}: open {url} in a browser (Ctrl-C stops it)")
        threading.Event().wait()
    except KeyboardInterrupt:
        print("stopped")
    finally:
        page.stop()
    return 0


def _robot_or_cell(name_or_path: str):
    """A demo cell's name -> its file; anything else (a preset, a robot or cell file) as given."""
    from .cell.cell_file import cell_names, resolve_cell_path

    return resolve_cell_path(name_or_path) if name_or_path in cell_names() else name_or_path


def cmd_build_kernels(args) -> int:
    """Build the IK kernels ahead of time (``make`` does it at install) and compile the planner's broad phase and
    the kernels a planned and timed move uses into Numba's cache; exit 1 with the reason when the IK kernels cannot
    be built."""
    from .cell.clear_motion import compile_motion_kernels
    from .cell.collision import compile_broad_phase
    from .model.ik.prebuilt import main as build_prebuilt

    status = build_prebuilt()
    seconds = compile_broad_phase()
    print(f"broad phase kernels compiled into Numba's cache in {seconds:.0f} s")
    seconds = compile_motion_kernels()
    print(f"kinematics and timing kernels compiled into Numba's cache in {seconds:.0f} s")
    return status


def cmd_bench(args) -> int:
    """Benchmarks beside the peers measured in the same run."""
    if args.out:
        prepare_file_target(args.out, args.force)
    if args.suite == "timing":
        from .bench.timing import METHOD_KEYS, ROBOTS, run_timing_benchmark

        report = run_timing_benchmark(_names(args.robots, ROBOTS), paths=args.paths, seed=args.seed,
                                      methods=_names(args.methods, METHOD_KEYS), waypoints=args.waypoints)
    elif args.suite == "ik":
        from .bench.ik import METHODS, ROBOTS, run_ik_benchmark

        report = run_ik_benchmark(_names(args.robots, ROBOTS), targets=args.targets, seed=args.seed,
                                  methods=_names(args.methods, METHODS))
    elif args.suite == "plan":
        from .bench.plan import run_plan_benchmark

        report = run_plan_benchmark(pairs=args.pairs, seed=args.seed, count=args.count or 100,
                                    sets=None if args.sets is None else _names(args.sets, ()))
    elif args.suite == "broad-phase":
        from .bench.broad_phase import run_broad_phase_benchmark

        report = run_broad_phase_benchmark(None if args.cells is None else _names(args.cells, ()),
                                           count=args.count or 1_000_000, seed=args.seed)
    elif args.suite == "cycle":
        from .bench.cycle import CELLS, run_cycle_benchmark

        report = run_cycle_benchmark(_names(args.cells, CELLS), programs=args.programs or 20, seed=args.seed)
    elif args.suite == "written":
        from .bench.cycle import CELLS
        from .bench.written import run_written_benchmark

        report = run_written_benchmark(_names(args.cells, CELLS), programs=args.programs or 5, seed=args.seed)
    elif args.suite == "scale":
        from .bench.scale import run_scale_benchmark

        report = run_scale_benchmark(robot=args.robot, poses=args.poses, seed=args.seed)
    elif args.suite == "job":
        from .bench.job import run_job_benchmark

        report = run_job_benchmark(None if args.jobs is None else _names(args.jobs, ()), repeats=args.repeats)
    elif args.suite == "ui":
        from .bench.ui import run_ui_benchmark

        report = run_ui_benchmark(seed=args.seed, browser=args.browser)
    elif args.suite == "cartesian":
        from .bench.cartesian import ROBOTS, run_cartesian_benchmark

        report = run_cartesian_benchmark(_names(args.robots, ROBOTS), moves=args.moves, seed=args.seed)
    else:
        from .bench.kinematics import run_kinematics_benchmark

        report = run_kinematics_benchmark(args.robot or "gp7", batch=args.batch, single_calls=args.calls,
                                          seed=args.seed)
    print(report.format_table())
    if args.out:
        write_text_atomic(args.out, json.dumps({"written_by": WRITTEN_BY, **report.to_dict()}, indent=2), args.force)
    return 0


def _count(minimum: int, maximum: int | None = None):
    """An argparse type: an integer of at least ``minimum`` (and at most ``maximum``)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum or (maximum is not None and value > maximum):
            bound = f"at least {minimum}" if maximum is None else f"in [{minimum}, {maximum:,}]"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {value}")
        return value

    return parse


POSITIVE, NON_NEGATIVE = _count(1), _count(0)
#: Most random configurations of ``check`` (about 1.5 ms each: some 2.5 minutes).
MAX_CHECK_SAMPLES = 100_000


def _positive_number(unit: str):
    """An argparse type: a positive finite number of ``unit`` (millimetres, seconds)."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number of {unit}") from None
        if not 0 < value < float("inf"):
            raise argparse.ArgumentTypeError(f"must be a positive number of {unit}, got {text}")
        return value

    return parse


_millimetres, _seconds = _positive_number("millimetres"), _positive_number("seconds")


#: A pose on the command line: position [mm], roll, pitch, yaw [deg].
POSE_NAMES = ("x", "y", "z", "roll", "pitch", "yaw")


def _add_force_option(parser) -> None:
    """--force: replace an existing output file the package did not write (never a folder or special file)."""
    parser.add_argument("--force", action="store_true", help="replace an existing file at the output path even "
                        "if dh-pipeline did not write it (without: such a file is refused, naming it)")


def _add_tool_option(parser) -> None:
    """--tool X Y Z R P Y: the TCP in the flange frame [mm, deg]."""
    parser.add_argument("--tool", nargs=6, type=float, metavar=tuple(name.upper() for name in POSE_NAMES),
                        help="the TCP in the flange frame: position [mm], roll, pitch, yaw [deg] (default: the "
                             "flange)")


def _add_selected_options(parser) -> None:
    """--tool and --frame: what a program selects by number (UTOOL_NUM, ///TOOL n, TOOL_DATA[n]; UFRAME_NUM,
    ///FRAME USER n, BASE_DATA[n]) when the file does not hold its data."""
    names = tuple(name.upper() for name in POSE_NAMES)
    parser.add_argument("--tool", nargs=6, type=float, metavar=names,
                        help="the tool the program selects by number: the TCP in the flange frame, position [mm], "
                             "roll, pitch, yaw [deg] (tool 0 is the flange)")
    parser.add_argument("--frame", nargs=6, type=float, metavar=names,
                        help="the user frame (base) the program selects by number, in the robot's base frame: "
                             "position [mm], roll, pitch, yaw [deg] (frame 0 is the robot's base)")


def _add_dask_options(parser) -> None:
    """--workers N | --scheduler ADDRESS, checked together by ``scale.dask_client``."""
    parser.add_argument("--workers", type=POSITIVE, metavar="N",
                        help="worker processes of a Dask LocalCluster on this machine (default: one per core; "
                             "1: everything in this process, no cluster)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (instead of --workers)")


#: The top parser's text for users (the module docstring is for developers); {prog} is the command.
_DESCRIPTION = """\
From a Denavit-Hartenberg table to certified, collision-free, time-optimal joint profiles.

A robot is a YAML file with its DH table and joint limits, or a preset. A job file names the robot,
its waypoints (joint values or tool poses) and how to time them; "run" solves the inverse kinematics,
times the path within the limits, certifies every sample and writes the profile (CSV, NPZ), a JSON
report, plots and a 3-D view. A job may run in a work cell, where moves are planned around the
obstacles and the clearance is certified too.

  preset robots: {presets}
  demo cells:    {cells}"""

_EPILOG = """\
examples:
  {prog} show gp7
  {prog} run trajectories/jobs/gp7_pick_place.yaml --out out/gp7
  {prog} check-cell gp7_wall_cell

"{prog} VERB --help" shows a verb's options and examples. Exit status: 0 done; 2 bad input, one line
"error: ..." naming the file, line and field, nothing written; 1 an internal error (-v prints its
traceback), a check above tolerance, a program check-program finds colliding or beyond a limit, or a batch
with a failed job; 130 interrupted."""


def _verb(sub, prog: str, name: str, summary: str, description: str, examples: list[str]) -> argparse.ArgumentParser:
    """A subcommand with a one-line summary (in the verb list), a description and examples (in its --help)."""
    lines = "\n".join(f"  {prog} {name} {example}" for example in examples)
    return sub.add_parser(name, help=summary, description=description, epilog=f"examples:\n{lines}",
                          formatter_class=argparse.RawDescriptionHelpFormatter)


class _Parser(argparse.ArgumentParser):
    """argparse reporting a usage mistake as one line and exit status 2, like every other bad input."""

    def error(self, message: str):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def build_parser(prog: str = "python -m pipeline") -> argparse.ArgumentParser:
    from .cell.cell_file import cell_names

    parser = _Parser(prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter,
                     description=_DESCRIPTION.format(presets=", ".join(preset_names()), cells=", ".join(cell_names())),
                     epilog=_EPILOG.format(prog=prog))
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="log debug messages; print the traceback of an internal error")
    sub = parser.add_subparsers(dest="command", required=True, title="verbs (each with its own --help)")

    run = _verb(sub, prog, "run", "run a job file (IK, path, timing, certification) and write its outputs",
                "Run a job file: inverse kinematics for its pose waypoints, a path through them, timing within\n"
                "the robot's limits, a certificate on every sample (and the clearance in a cell), then the\n"
                "outputs the job lists (profile.csv/.npz, report.json, plots, view.html) in --out. Nothing is\n"
                "written when anything fails.",
                ["trajectories/jobs/gp7_pick_place.yaml --out out/gp7",
                 "my_job.yaml --out out/my_job --max-samples 2000000"])
    run.add_argument("job", help="job file, e.g. trajectories/jobs/gp7_pick_place.yaml")
    run.add_argument("--out", required=True, help="output folder, replaced whole (profile CSV/NPZ, JSON report, "
                                                   "plots, 3-D view); only a new, empty or earlier output folder")
    run.add_argument("--max-samples", type=POSITIVE, default=DEFAULT_MAX_SAMPLES, metavar="N",
                     help=f"refuse profiles of more samples (default {DEFAULT_MAX_SAMPLES:,})")
    run.add_argument("--max-duration", type=_seconds, default=DEFAULT_MAX_DURATION_S, metavar="SECONDS",
                     help="refuse, before timing, a job whose moves take longer at their speed limits "
                          f"(default {DEFAULT_MAX_DURATION_S:g})")
    run.set_defaults(func=cmd_run)

    languages = list(PROGRAM_SUFFIXES)
    program = _verb(sub, prog, "program", "compile and time a job, then write it in a robot controller's language "
                    f"({', '.join(languages)})",
                    "Compile and time a job as run does (a job that fails is never written), then write its program\n"
                    "in a controller's own language: ABB RAPID (.mod), FANUC LS (.ls), Yaskawa INFORM (.jbi),\n"
                    "KUKA KRL (.src + .dat), URScript (.script, with the certified profile's servoj replay; for a\n"
                    "Universal Robots arm only: a robot file with controller: {maker: ur}). The\n"
                    "program's name is the job's, made valid for the language (the file's header says so when\n"
                    "it changed). The controller plans its own velocity profile for native moves.",
                    ["trajectories/jobs/gp7_pick_place.yaml --lang jbi --out out/controller",
                     "trajectories/jobs/irb1600_tool_moves.yaml --lang rapid --out irb1600_tool_moves.mod",
                     "my_ur5_job.yaml --lang urscript --servo-period 0.008 --out out/cb3"])
    program.add_argument("job", help="job file, e.g. trajectories/jobs/gp7_pick_place.yaml")
    program.add_argument("--lang", required=True, choices=languages, help="the controller's language")
    program.add_argument("--out", metavar="FILE_OR_DIR", help="a file with the language's suffix (KRL: the .src, "
                         "its .dat beside it), or a folder for NAME.<suffix> (default: the current folder)")
    _add_force_option(program)
    program.add_argument("--krl-generation", choices=("krc2", "kss8"),
                         help="krl: the KUKA controller generation: krc2 (default; KR C2 / KSS 5, PTP zones as C_PTP, "
                              "what a plain KRL parser accepts) or kss8 (KR C4, PTP zones as C_DIS)")
    program.add_argument("--servo-period", type=_seconds, metavar="SECONDS",
                         help="urscript: the controller period of the servoj replay (default 0.002, e-Series; "
                              "0.008 on a CB3)")
    program.add_argument("--max-samples", type=POSITIVE, default=DEFAULT_MAX_SAMPLES, metavar="N",
                         help=f"refuse profiles of more samples (default {DEFAULT_MAX_SAMPLES:,})")
    program.add_argument("--max-duration", type=_seconds, default=DEFAULT_MAX_DURATION_S, metavar="SECONDS",
                         help=f"refuse a job whose moves take longer (default {DEFAULT_MAX_DURATION_S:g})")
    program.set_defaults(func=cmd_program)

    read = _verb(sub, prog, "read-program", "read a controller program (.mod .ls .jbi .src .script) back into a job "
                 "file", "Read a controller program of the subset the writers emit (also as a pendant writes it)\n"
                 "back into a job: targets with their configuration as our IK branch, move kinds, speeds, zones,\n"
                 "the tool. The language comes from the suffix (KRL: the .src, its .dat beside it). The job is\n"
                 "checked before it is written (YAML, to --out or printed).",
                 ["out/controller/GP7_PICK.jbi --robot gp7 --out gp7_read.yaml"])
    read.add_argument("file", help="the program: .mod (RAPID), .ls (FANUC), .jbi (Yaskawa), .src (KRL), .script (UR)")
    read.add_argument("--robot", required=True, help="preset name or robot file path of the arm the program runs on")
    read.add_argument("--out", metavar="JOB.yaml", help="the job file to write (default: print it)")
    _add_selected_options(read)
    _add_force_option(read)
    read.set_defaults(func=cmd_read_program)

    checked = _verb(sub, prog, "check-program", "check an existing controller program in a cell: reach, limits, "
                    "collisions, cycle time as written",
                    "Read a controller program (as read-program does), solve every target with its configuration\n"
                    "data, and time it as the controller runs it (joint interpolation, lines, arcs, corners inside\n"
                    "its zones, stops where it has none, its waits): the cycle time per move, the joint and TCP\n"
                    "limits and, in a cell, the clearance with the closest pair. Exit 1 when it would collide or\n"
                    "leave a limit (naming the move, the pair and the time).",
                    ["out/controller/GP7_PICK.jbi --robot gp7 --cell gp7_wall_cell",
                     "pick.mod --robot irb1600 --cell my_cell.yaml --out check.json"])
    checked.add_argument("file", help="the program: .mod (RAPID), .ls (FANUC), .jbi (Yaskawa), .src (KRL), "
                         ".script (UR)")
    checked.add_argument("--robot", required=True, help="preset name or robot file path of the arm it runs on")
    checked.add_argument("--cell", help="cell name or cell file to check it in (default: none, no clearance)")
    checked.add_argument("--out", metavar="REPORT.json", help="also write the check as JSON")
    _add_selected_options(checked)
    _add_force_option(checked)
    checked.set_defaults(func=cmd_check_program)

    show = _verb(sub, prog, "show", "print a robot's DH table, FK and Jacobian at q = 0",
                 "Print a robot's DH table with its units and limits, the end frame's pose, the Jacobian and the\n"
                 "singularity measures at q = 0.", ["gp7", "models/arm6.yaml"])
    show.add_argument("robot", help="preset name or robot file path")
    show.set_defaults(func=cmd_show)

    fk = _verb(sub, prog, "fk", "print the TCP pose (mm, deg, quaternion), branch and controller configuration at "
               "joint values", "Forward kinematics at the joint values given (the robot file's angle unit unless\n"
               "--unit; prismatic joints in mm): the TCP's position, roll-pitch-yaw and quaternion in the base\n"
               "frame, our IK branch name and the maker's controller configuration (gp7: Yaskawa RCONF).",
               ["gp7 0 0 0 0 -90 0", "gp7 10 30 -20 15 -40 25 --tool 0 0 120 0 0 0",
                "irb1600 0.1 0.5 -0.3 0 -1.2 0 --unit rad"])
    fk.add_argument("robot", help="preset name or robot file path")
    fk.add_argument("q", nargs="+", metavar="Q", help="one value per joint")
    fk.add_argument("--unit", choices=["deg", "rad"], help="angle unit of the values (default: the robot file's)")
    _add_tool_option(fk)
    fk.set_defaults(func=cmd_fk)

    ik = _verb(sub, prog, "ik", "print every IK branch of a TCP pose: name, controller configuration, joint values, "
               "collision and singularity state",
               "Inverse kinematics of a TCP pose in the robot's base frame (X Y Z in mm, roll pitch yaw in deg\n"
               "about the fixed axes): every in-limit branch (the closed form; the numeric IK from --seed for\n"
               "arms without one) with our branch name, the maker's controller configuration, its joint\n"
               "values [deg] nearest --seed, free, colliding (in --cell, with the closest pair) or near a\n"
               "singularity (with the smallest singular value). An unreachable pose prints why (exit 0).",
               ["gp7 560 0 700 0 90 0 --tool 0 0 120 0 0 0",
                "gp7 700 0 450 0 90 0 --cell gp7_shelf_cell --tool 0 0 120 0 0 0"])
    ik.add_argument("robot", help="preset name or robot file path (with --cell: the cell's robot)")
    for name, words in zip(POSE_NAMES, ("TCP position in the base frame [mm]",) * 3 +
                           ("TCP roll, pitch, yaw about the base frame's fixed x, y, z axes [deg]",) * 3):
        ik.add_argument(name, type=float, metavar=name.upper(), help=words if name in ("x", "roll") else "")
    ik.add_argument("--cell", help=f"a demo cell ({', '.join(cell_names())}) or a cell file: collision states, "
                    "closest pairs, the cell's tool shapes")
    _add_tool_option(ik)
    ik.add_argument("--seed", nargs="+", metavar="Q", help="reference joint values [deg; mm] each branch is shown "
                    "nearest to (default: the middle of the joint ranges)")
    ik.set_defaults(func=cmd_ik)

    check = _verb(sub, prog, "check", "check Drake's FK/Jacobian against the analytic one and finite differences",
                  "Compare Drake's forward kinematics and Jacobian with the analytic (NumPy) ones and both with\n"
                  "central finite differences on random in-limit configurations; exit 1 above tolerance.",
                  ["gp7", "all --samples 50 --out out/check"])
    check.add_argument("robot", help="preset name, robot file path, or 'all'")
    check.add_argument("--samples", type=_count(1, MAX_CHECK_SAMPLES), default=200,
                       help=f"random in-limit configurations (default 200, at most {MAX_CHECK_SAMPLES:,})")
    check.add_argument("--seed", type=NON_NEGATIVE, default=0)
    check.add_argument("--out", help="folder for the JSON reports, replaced whole")
    check.set_defaults(func=cmd_check)

    export = _verb(sub, prog, "export", "write a robot as URDF (base_link ... tool0) for ROS, MoveIt and Drake",
                   "Write a robot as URDF with ROS-Industrial frame names (base_link, link_1 .., tool0), its\n"
                   "joint limits, shapes and inertias.", ["gp7 --urdf gp7.urdf"])
    export.add_argument("robot", help="preset name or robot file path")
    export.add_argument("--urdf", required=True, metavar="FILE", help="the URDF file to write")
    _add_force_option(export)
    export.set_defaults(func=cmd_export)

    urdf_in = _verb(sub, prog, "import-urdf", "turn a URDF serial chain into a robot file (DH table from the axes)",
                    "Turn the serial chain of a URDF (from --base to --tip) into a robot file: a DH table from\n"
                    "the joint axes, limits, inertias and provenance; its forward kinematics is checked against\n"
                    "the URDF's before anything is written.",
                    ["irb1600.urdf --out irb1600.yaml", "ur5.urdf --out ur5.yaml --tip tool0 --convention modified",
                     "kr6r700sixx.urdf --out kr6.yaml --controller kuka"])
    urdf_in.add_argument("urdf", help="the URDF file (xacro must be expanded first)")
    urdf_in.add_argument("--out", required=True, metavar="ROBOT.yaml", help="the robot file to write")
    _add_force_option(urdf_in)
    urdf_in.add_argument("--base", metavar="LINK", help="the chain's first link (default base_link, else the root)")
    urdf_in.add_argument("--tip", metavar="LINK", help="the chain's last link (default tool0, else the end of the "
                         "moving joints)")
    urdf_in.add_argument("--convention", choices=["standard", "modified"], default="standard",
                         help="DH convention of the robot file (default standard)")
    urdf_in.add_argument("--name", help="the robot's name (default the URDF's)")
    urdf_in.add_argument("--time-to-full-speed", type=_seconds, metavar="SECONDS",
                         help="fill in the acceleration limits a URDF lacks: qdd_max = qd_max / SECONDS per joint "
                              "(e.g. 0.25; recorded in the file's provenance)")
    urdf_in.add_argument("--controller", choices=list(CONTROLLER_MAKERS), metavar="MAKER",
                         help="give the robot file a controller section for this maker's controller (abb, fanuc, "
                              "yaskawa, kuka, ur) from the conventions of ROS-Industrial's descriptions: axis map, "
                              "base and flange frames, elbow-up pose (models/README.md)")
    urdf_in.set_defaults(func=cmd_import_urdf)

    check_cell = _verb(sub, prog, "check-cell", "print a cell, its collision model and the robot's clearance at "
                       "a pose (exit 1 when it collides)",
                       "Print a work cell (its robot, base pose, obstacles, clearance), the pairs the collision\n"
                       "model does not check, and the robot's distance to the obstacles at q = 0 or at the pose\n"
                       "--q (a home pose); exit 1 when that pose collides or comes closer than the clearance.",
                       ["gp7_wall_cell", "my_cell.yaml --q 0 -30 30 0 60 0"])
    check_cell.add_argument("cell", help=f"a demo cell ({', '.join(cell_names())}) or a cell file")
    check_cell.add_argument("--q", nargs="+", metavar="Q", help="the pose to check: joint values (--unit; "
                            "prismatic joints in mm), default q = 0")
    check_cell.add_argument("--unit", choices=("deg", "rad"), default="deg", help="unit of --q (default deg)")
    check_cell.set_defaults(func=cmd_check_cell)

    bench = _verb(sub, prog, "bench", "benchmarks beside the peers, in the same run",
                  "Time one part of the pipeline beside the libraries it is compared with, in the same run (the\n"
                  "peers of the kinematics and IK suites come with the bench extra: pip install -e .[bench]).",
                  ["kinematics --robot gp7", "timing --robots gp7 --paths 2 --out timing.json"])
    bench.add_argument("suite", choices=["kinematics", "ik", "timing", "cartesian", "plan", "cycle", "written", "scale",
                                         "job", "ui", "broad-phase"])
    bench.add_argument("--robot", default=None, help="kinematics: the robot (default gp7); scale: default irb1600")
    bench.add_argument("--robots", help="ik, timing: comma-separated robots (default gp7,lrmate200id,irb1600,arm6); "
                       "cartesian: default gp7,irb1600")
    bench.add_argument("--paths", type=POSITIVE, default=5, help="timing: seeded random paths per robot")
    bench.add_argument("--waypoints", type=POSITIVE, default=10, metavar="N",
                       help="timing only: waypoints of each random path (default 10, at least 2)")
    bench.add_argument("--moves", type=POSITIVE, default=20, metavar="N",
                       help="cartesian only: seeded random 0.5 m straight-line moves per robot (default 20)")
    bench.add_argument("--methods", help="ik: comma-separated methods of ours (default analytic,jacobian,drake); "
                       "timing: rows to run (default toppra,raw,drake,topp3,ruckig; toppra always)")
    bench.add_argument("--pairs", type=POSITIVE, default=100, metavar="N",
                       help="plan only: seeded random start/goal pairs per cell (default 100)")
    bench.add_argument("--sets", metavar="NAMES", help="plan only: comma-separated problem sets that need a search "
                       "(default: all; cubbies, gp7_box, ...: pipeline.bench.plan_sets.SET_NAMES)")
    bench.add_argument("--count", type=POSITIVE, default=None, metavar="N",
                       help="plan: queries per problem set (default 100; cubbies has its 30 always); broad-phase: "
                       "random configurations per cell (default 1,000,000)")
    bench.add_argument("--programs", type=POSITIVE, default=None, metavar="N",
                       help="cycle, written: seeded random pick-and-place programs per cell (default 20; written: 5)")
    bench.add_argument("--cells", help="broad-phase: comma-separated demo cells (default: all); "
                       "cycle, written: comma-separated demo cells (default gp7_wall_cell,"
                       "gp7_shelf_cell,irb1600_wall_cell)")
    bench.add_argument("--jobs", help="job only: comma-separated job files (default: the demo jobs with a cell)")
    bench.add_argument("--repeats", type=POSITIVE, default=5, metavar="N",
                       help="job only: fresh processes per job and measurement (default 5)")
    bench.add_argument("--targets", type=POSITIVE, default=1000, help="ik: targets per robot (default 1000)")
    bench.add_argument("--poses", type=POSITIVE, default=1_000_000, metavar="N",
                       help="scale only: poses of the timed map (default 1,000,000)")
    bench.add_argument("--batch", type=POSITIVE, default=100_000, help="kinematics: configurations in the batch timing")
    bench.add_argument("--calls", type=POSITIVE, default=2000, help="kinematics: single calls timed per implementation")
    bench.add_argument("--browser", action="store_true", help="ui: drag again with headless Chromium connected")
    bench.add_argument("--seed", type=NON_NEGATIVE, default=0)
    bench.add_argument("--out", help="JSON file for the results")
    _add_force_option(bench)
    bench.set_defaults(func=cmd_bench)

    build_kernels = _verb(sub, prog, "build-kernels", "build the IK kernels as machine code for this CPU, so "
                          "that no first IK call compiles (make does it at install)",
                          "Compile the IK kernels (both closed forms, single and batch, and damped least squares)\n"
                          "ahead of time for this CPU into pipeline/model/ik/ (about a minute; needs a C compiler),\n"
                          "and the planner's broad phase into Numba's cache (else its first use compiles, 20-40 s).\n"
                          "A process uses them while its sources, versions and CPU match the build; otherwise IK\n"
                          "compiles just in time (about 15 s on the first call). DH_PIPELINE_PREBUILT=0 switches\n"
                          "them off.", [""])
    build_kernels.set_defaults(func=cmd_build_kernels)

    batch = _verb(sub, prog, "batch", "run many job files on Dask workers, each into DIR/<job name>/, with "
                  "summary.csv and summary.json (exit 1 when a job failed)",
                  "Run job files (or every *.yaml in the folders given) as run does, on Dask workers, each into\n"
                  "DIR/<job name>/, with summary.csv and summary.json: a row per job, a failed one with its\n"
                  "error. The outputs are the same with 1 worker or many.",
                  ["trajectories/jobs --out out/batch", "a.yaml b.yaml --out out/batch --workers 1"])
    batch.add_argument("jobs", nargs="+", metavar="JOB", help="job files, or folders of *.yaml job files")
    batch.add_argument("--out", required=True, metavar="DIR", help="output folder, replaced whole when the batch is "
                       "done; only a new, empty or earlier output folder")
    batch.add_argument("--max-samples", type=POSITIVE, default=DEFAULT_MAX_SAMPLES, metavar="N",
                       help=f"refuse profiles of more samples (default {DEFAULT_MAX_SAMPLES:,})")
    _add_dask_options(batch)
    batch.set_defaults(func=cmd_batch)

    reach = _verb(sub, prog, "reach", "a reachability map over a voxel grid (fraction of tool orientations "
                  "reached, manipulability, IK branches) on Dask workers",
                  "Map where a robot (or the robot in a cell) reaches: at every voxel centre the fraction of\n"
                  "the tool orientations with an in-limit (and, in a cell, collision-free) IK answer, the best\n"
                  "manipulability and the IK branches; map.npz, slices.png, map.html and summary.json in DIR.",
                  ["irb1600 --out out/reach --step 50 --point wrist",
                   "gp7_wall_cell --out out/cell_reach --tool-axis-cone 30"])
    reach.add_argument("robot", metavar="ROBOT|CELL", help="preset name, robot file, demo cell or cell file")
    reach.add_argument("--out", required=True, metavar="DIR", help="output folder (map.npz, slices.png, map.html, "
                       "summary.json), replaced whole")
    reach.add_argument("--step", type=_millimetres, default=25.0, metavar="MM", help="voxel size in mm (default 25)")
    reach.add_argument("--orientations", type=POSITIVE, metavar="N",
                       help="tool orientations per voxel, uniform over all rotations (default 16); with "
                            "--tool-axis-cone: tool axes in the cone")
    reach.add_argument("--tool-axis-cone", type=float, metavar="DEG",
                       help="tool axes within DEG of straight down (any roll) instead of all orientations")
    reach.add_argument("--point", default="end", metavar="end|wrist",
                       help="the point mapped: the end frame (default) or the wrist centre (where datasheets "
                            "measure reach)")
    reach.add_argument("--seed", type=NON_NEGATIVE, default=0, help="seed of the orientations (default 0)")
    _add_dask_options(reach)
    reach.set_defaults(func=cmd_reach)

    ui = _verb(sub, prog, "ui", "a local web page: jog and drag the tool, every IK branch, build, plan and time, save",
               "Serve a page on this machine (127.0.0.1 unless --host says otherwise): the arm with its joint\n"
               "sliders and TCP pose, a draggable TCP target with every IK branch drawn as a ghost arm (name,\n"
               "controller configuration, collision state and closest pair, near-singular), a program of joint,\n"
               "linear and circular moves with speeds and zones, plan and time with the certificate, plots and a\n"
               "replay, and the program saved as a job file that run reproduces sample for sample.",
               ["gp7", "gp7_shelf_cell --port 8081", "trajectories/jobs/gp7_cell_pick_place.yaml",
                "gp7_shelf_cell --screenshot page.png"])
    ui.add_argument("source", nargs="?", help="a preset or robot file, a demo cell or cell file, or a job file "
                    "(default gp7)")
    ui.add_argument("--port", type=NON_NEGATIVE, default=8080, help="the port (default 8080; the next free one if "
                    "taken; 0: any)")
    ui.add_argument("--host", default="127.0.0.1", help="the interface to serve on (default 127.0.0.1: this machine "
                    "only; another exposes the page to the network)")
    ui.add_argument("--screenshot", metavar="FILE.png", help="take a headless Chromium picture of the page (a job's "
                    "program planned and timed, the target's branches shown) and stop")
    _add_force_option(ui)
    ui.set_defaults(func=cmd_ui)
    return parser


def _one_line(text: str) -> str:
    """``text`` with its line breaks (and the spaces around them) turned into single spaces."""
    return re.sub(r"\s*\n\s*", " ", text.strip())


def main(argv: list[str] | None = None, prog: str = "python -m pipeline") -> int:
    args = build_parser(prog).parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    # toppra logs its own failures (INFO, WARNING) before ours is raised: without -v only our error line.
    logging.getLogger("toppra").setLevel(logging.DEBUG if args.verbose else logging.ERROR)
    # Dask's own loggers (read when ``distributed`` is first imported, here and in its worker processes):
    # its routine INFO lines only with -v.
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "info" if args.verbose else "warning")
    try:
        return args.func(args)
    except PipelineError as exc:
        print(f"error: {_one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted: no output written", file=sys.stderr)
        return 130
    except BrokenPipeError:             # the reader of our output left (``... | head``): stop quietly, as on SIGPIPE
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except Exception as exc:            # a bug: one line, the traceback only when asked for
        if args.verbose:
            traceback.print_exc()
        print(f"internal error: {type(exc).__name__}: {_one_line(str(exc))} (run with -v for the traceback)",
              file=sys.stderr)
        return 1


def console_script() -> int:
    """The ``dh-pipeline`` command (pyproject's [project.scripts]): ``main`` under that name."""
    return main(prog="dh-pipeline")


if __name__ == "__main__":
    sys.exit(main())
