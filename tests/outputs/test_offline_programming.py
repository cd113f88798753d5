"""Offline programming end to end (issue 26, "Must show"): for every preset and a UR5 imported from
tests/data/urdf/ur5.urdf, a demo-style job (a joint target, then pose waypoints reached by a joint move, linear
moves with a zone and a circular move) is compiled, written in the language of the arm's maker (gp7: Yaskawa
INFORM .jbi, lrmate200id: FANUC .ls, irb1600: ABB RAPID, arm6: KUKA KRL, UR5: URScript), and the GP7 in the four
languages other than URScript (written for UR arms only); the demo job files gp7_pick_place (those four) and
irb1600_tool_moves (RAPID) too. Each program is read back by
our reader, and

* every Cartesian target, as the file holds it (the read pose) with the vendor configuration the file gives it
  (read from the text: RAPID confdata, FANUC CONFIG, Yaskawa RCONF, KUKA S and T; it must be the exported joint
  values' own, ``configurations``), is re-solved by ``pipeline.model.vendors.selection``: 100 % land on the
  exported closed-form branch and 2 pi representative, within the format's own rounding carried to the joints by
  ``fanuc_ls.rounding_bound`` (twice the first-order joint motion of a pose off by half a step per written
  number), and the reader's ``config`` of it is the exported branch. One exception is the controller's own rule:
  KUKA evaluates S and T on PTP motions only (KUKA System Software 8 manual, "Status and Turn"; the KRL writer's
  and reader's docstrings), so where S and T name two 2 pi variants of a LIN or CIRC target (here the last LIN of
  gp7_pick_place, axis 6 at 0 deg within +-360 deg), the variant reached is the one nearest the previous target;
* the read job compiled again has the same move kinds, the same branches and targets within that bound.

The format's rounding (``FORMATS``): RAPID 0.001 mm and 1e-6 per quaternion component (a rotation off by at most
2 x 2 x 0.5e-6 rad = 2e-6 rad, below 3 x 1e-4 deg / 2; jointtargets 0.0001 deg); FANUC .ls 0.001 mm and 0.001 deg;
Yaskawa .jbi 0.001 mm and 0.01 deg (every point Cartesian: no pulses per degree in a robot file); KUKA KRL 0.001 mm
and 0.0001 deg; URScript 1e-6 m and 1e-6 rad per rotation vector component (off by at most sqrt(3) x 0.5e-6 rad,
below 3 x 6e-5 deg / 2; joint values 1e-6 rad). URScript has no configuration: a pose is read on the branch
nearest the previous target (the reader's rule), so its check is the round trip alone.

Syntax: every written program parses with the package's lark grammar of its language
(pipeline/outputs/controllers/grammars/*.lark), and every RAPID module also with rapidchecker run as an external tool
(skipped with a reason where it is not installed).
"""

from __future__ import annotations

import datetime as dt
import importlib.util
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from lark import Lark

from pipeline.errors import ConfigurationNotFoundError
from pipeline.files.poses import quaternion_position_to_pose, rotation_to_rpy, rpy_position_to_pose
from pipeline.model.ik import solve_ik_batch
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.ik.result import limit_variants
from pipeline.model.robot import load_robot, robot_with_tool
from pipeline.model.vendors import configurations, parse_configuration, select_solution
from pipeline.model.vendors.configuration import mismatched_field
from pipeline.outputs.controllers.fanuc_ls import program_points, rounding_bound, write_ls
from pipeline.outputs.controllers.krl import write_krl
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_jbi import read_jbi
from pipeline.outputs.controllers.read_krl import read_krl
from pipeline.outputs.controllers.read_ls import read_ls
from pipeline.outputs.controllers.read_rapid import read_rapid
from pipeline.outputs.controllers.read_urscript import read_urscript
from pipeline.outputs.controllers.urscript import write_urscript
from pipeline.outputs.controllers.yaskawa_jbi import job_points, write_jbi
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.runner import collision_model
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR
from .test_rapid import rapidchecker_errors
from .test_urscript import on_a_ur_controller

ROOT = Path(__file__).resolve().parents[2]
JOBS = ROOT / "trajectories" / "jobs"
GRAMMARS = ROOT / "pipeline" / "outputs" / "controllers" / "grammars"
WHEN = dt.datetime(2026, 11, 27, 3, 0, 0)
#: The TCP 100 mm out of the flange [m].
TOOL_MM = [0.0, 0.0, 100.0]


@dataclass(frozen=True)
class Format:
    """A controller language: its writer (program -> text, or KRL's (src, dat)), reader (written, robot ->
    job document), the vendor whose configuration it writes (None: URScript, none), its grammar file, and its
    rounding: positions ``mm_step`` [mm], rotations ``deg_step`` [deg] (or the angle step that bounds its
    rotation's rounding, module docstring), joint values ``joint_step_deg`` [deg]."""

    write: Callable
    read: Callable
    vendor: str | None
    grammar: str
    mm_step: float
    deg_step: float
    joint_step_deg: float


FORMATS = {
    "rapid": Format(lambda program: write_rapid(program, "demo"), lambda text, robot: read_rapid(text, robot),
                    "abb", "rapid.lark", 0.001, 1e-4, 1e-4),
    "ls": Format(lambda program: write_ls(program, "DEMO", WHEN), lambda text, robot: read_ls(text, robot),
                 "fanuc", "fanuc_ls.lark", 0.001, 0.001, 0.001),
    "jbi": Format(lambda program: write_jbi(program, "DEMO", WHEN), lambda text, robot: read_jbi(text, robot),
                  "yaskawa", "yaskawa_jbi.lark", 0.001, 0.01, 0.01),
    "krl": Format(lambda program: write_krl(program, "DEMO"), lambda files, robot: read_krl(*files, robot),
                  "kuka", "krl.lark", 0.001, 1e-4, 1e-4),
    "urscript": Format(lambda program: write_urscript(program, "demo"), lambda text, robot: read_urscript(text, robot),
                       None, "urscript.lark", 0.001, 6e-5, np.degrees(1e-6)),
}
#: The language of each arm's maker (arm6, seed 004's arm of no maker, on a KUKA controller: its axis angles
#: are its joint values).
MAKER = {"gp7": "jbi", "lrmate200id": "ls", "irb1600": "rapid", "arm6": "krl", "ur5": "urscript", "kr6": "krl",
         "irb6640": "rapid", "lrmate200ic": "ls", "gp8": "jbi"}
#: Joint values [deg] the built job starts at and moves around: inside every limit, no axis at 0 or +-180 deg
#: (a configuration field's boundary), the wrist away from its singular set.
SEEDS = {"gp7": [5, 20, -10, 8, -70, 12], "lrmate200id": [10, 20, -10, 5, -60, 10],
         "irb1600": [5, 10, -10, 8, 45, 12], "arm6": [15, 60, -30, 10, 50, 15], "ur5": [30, -100, 100, -90, -90, 30],
         "kr6": [10, -80, 100, 15, 40, 20], "irb6640": [5, 10, -10, 8, 45, 12], "lrmate200ic": [10, 20, -10, 5, -60, 10],
         "gp8": [5, 20, -10, 8, -70, 12]}
#: Arms imported from ROS-Industrial URDFs with their maker's controller section: (file, maker, tip link). The LR
#: Mate 200iC ends at its ``flange`` link (x out of the faceplate), so FANUC's flange (tool0) is turned from our
#: end frame, and its world frame is 330 mm above our base: targets and tool must be written in FANUC's frames.
IMPORTED = {"irb6640": ("abb_irb6640_185_280.urdf", "abb", None), "lrmate200ic": ("fanuc_lrmate200ic.urdf", "fanuc",
                                                                                "flange"),
            "gp8": ("motoman_gp8.urdf", "yaskawa", None)}
#: (case name, robot, job: "built" or a demo file, language).
CASES = [
    *[(f"{robot}_built_{MAKER[robot]}", robot, "built", MAKER[robot]) for robot in SEEDS],
    *[(f"gp7_built_{language}", "gp7", "built", language) for language in FORMATS
      if language not in ("jbi", "urscript")],
    *[(f"gp7_pick_place_{language}", "gp7", "gp7_pick_place", language) for language in FORMATS
      if language != "urscript"],
    ("irb1600_tool_moves_rapid", "irb1600", "irb1600_tool_moves", "rapid"),
]
CASE_IDS = [case[0] for case in CASES]


def built_job(robot: str, reference: str) -> dict:
    """A demo-style job for ``robot`` (named ``reference`` in the job: a preset or a robot file) around its seed:
    the seed as a joint target; a pose 60 mm above the seed's TCP by a joint move; down to it (linear, stop); 80 mm
    along base x (linear, zone 20 mm); a quarter circle of radius 80 mm about the seed's TCP to 80 mm along base y
    (circular); back (linear, stop). The orientation is the seed's throughout (mm, deg)."""
    arm = robot_with_tool(load_robot(reference), rpy_position_to_pose(np.zeros(3), np.array(TOOL_MM) / 1000.0))
    X0 = arm.fk(np.radians(SEEDS[robot]))
    rpy = [float(v) for v in np.degrees(rotation_to_rpy(X0[:3, :3]))]
    centre = X0[:3, 3] * 1000.0

    def at(dx: float, dy: float, dz: float = 0.0) -> list[float]:
        return [float(v) for v in centre + [dx, dy, dz]]

    def pose(dx: float, dy: float, dz: float = 0.0, **move) -> dict:
        return {"xyz": at(dx, dy, dz), "rpy": rpy, **move}

    side = 80.0 * np.sqrt(0.5)
    return {"robot": reference, "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 250, "tcp_accel_max": 1200,
            "tool": {"xyz": TOOL_MM, "rpy": [0, 0, 0]}, "dt": 0.008, "outputs": ["json"],
            "waypoints": [SEEDS[robot], pose(0, 0, 60, move="joint"), pose(0, 0, move="linear"),
                          pose(80, 0, move="linear", zone=20),
                          pose(0, 80, move="circular", via={"xyz": at(side, side)}), pose(0, 0, move="linear")]}


@pytest.fixture(scope="module")
def references(tmp_path_factory) -> dict[str, str]:
    """How a job names each robot: the preset, or for the UR5 the robot file imported from the ROS-Industrial
    URDF with a UR controller section (time to full speed 0.3 s, as the presets assume: a URDF has no acceleration
    limits)."""
    imported = import_urdf(DATA_DIR / "urdf" / "ur5.urdf", time_to_full_speed=0.3, controller="ur")
    path = imported.write(tmp_path_factory.mktemp("ur5") / "ur5.yaml")
    kuka = import_urdf(DATA_DIR / "urdf" / "kuka_kr6r700sixx.urdf", time_to_full_speed=0.3, controller="kuka")
    kr6 = kuka.write(tmp_path_factory.mktemp("kr6") / "kr6.yaml")     # KUKA's zero, $FLANGE x out of the flange
    arms = {name: str(import_urdf(DATA_DIR / "urdf" / urdf, tip=tip, time_to_full_speed=0.3, controller=maker)
                      .write(tmp_path_factory.mktemp(name) / f"{name}.yaml"))
            for name, (urdf, maker, tip) in IMPORTED.items()}
    return {**{robot: robot for robot in SEEDS}, "ur5": str(path), "kr6": str(kr6), **arms}


@pytest.fixture(scope="module")
def written(references) -> dict:
    """Each case's (program, written text or (src, dat))."""
    out = {}
    for name, robot, job, language in CASES:
        if job == "built":
            program = compile_job(parse_job(built_job(robot, references[robot]), source=f"{name}.yaml"))
        else:
            program = compile_job(load_job(JOBS / f"{job}.yaml"))
        out[name] = program, FORMATS[language].write(program)
    return out


def bound(program, q: np.ndarray, form: Format) -> np.ndarray:
    """How far (6,) [rad] a target q (6,) read back may be from the exported one: a pose's rounding carried to
    the joints, or a joint value's half step, whichever is larger."""
    return np.maximum(rounding_bound(program.robot, q, form.mm_step, form.deg_step),
                      np.radians(form.joint_step_deg) / 2.0 + 1e-12)


@pytest.mark.parametrize("name, robot, job, language", CASES, ids=CASE_IDS)
def test_every_cartesian_target_re_solves_on_the_exported_branch(written, references, name, robot, job, language):
    """Each read pose with its written vendor configuration selects the exported joint values (branch and 2 pi
    representative) within the format's rounding; its read ``config`` is the exported branch."""
    program, text = written[name]
    form = FORMATS[language]
    document = form.read(text, references[robot])
    waypoints = document["waypoints"]
    assert len(waypoints) == len(program.targets)
    arm = program.robot                       # a compiled program's robot carries its tool: TCP poses
    labels = configuration_labels(program.robot, program.targets)
    cartesian = [k for k, w in enumerate(waypoints) if isinstance(w, dict) and "xyz" in w]
    assert cartesian, f"{name}: no Cartesian target written"
    written_configs = file_configurations(language, text, program) if form.vendor else {}
    landed = 0
    for k in cartesian:
        q = program.targets[k]
        assert ", ".join(f"{key} {value}" for key, value in waypoints[k]["config"].items()) == labels[k]
        if form.vendor is None:
            landed += 1
            continue
        written = parse_configuration(form.vendor, written_configs[k])
        assert mismatched_field(arm, q, form.vendor, written) is None   # q's own (or, on a boundary, either side)
        X = quaternion_position_to_pose(waypoints[k]["quaternion"], waypoints[k]["xyz"])
        again = re_solved(program, k, X, written_configs[k], form.vendor)
        landed += bool(np.all(np.abs(again - q) <= bound(program, q, form)))
    assert landed == len(cartesian)


def file_configurations(language: str, text, program) -> dict[int, tuple[int, ...]]:
    """The vendor configuration the file gives each Cartesian target k, read from the text by the writer's point
    naming: RAPID ``robtarget p<k>``'s confdata; KRL ``E6POS XP<k>``'s S and T; FANUC ``P[n]``'s CONFIG and Yaskawa
    ``C<n>``'s ///RCONF (the last one before it), n counting the points in the writers' order
    (``fanuc_ls.program_points``, ``yaskawa_jbi.job_points``: the first is 1 / C00000)."""
    if language == "rapid":
        found = re.findall(r"robtarget p(\d+) := \[\[[^\]]*\],\[[^\]]*\],\[([^\]]*)\]", text)
        return {int(k): tuple(int(v) for v in config.split(",")) for k, config in found}
    if language == "krl":
        found = re.findall(r"E6POS XP(\d+)=\{[^}]*\bS (\d+),T (\d+)", text[1])
        return {int(k): (int(status), int(turn)) for k, status, turn in found}
    if language == "ls":
        by_point = {int(n) - 1: parse_configuration("fanuc", config)
                    for n, config in re.findall(r"P\[(\d+)\]\{[^}]*?CONFIG : '([^']*)'", text)}
        return target_points(program_points(program, "fanuc"), by_point)
    by_point, rconf = {}, None
    for line in text.split("//INST")[0].splitlines():
        if line.startswith("///RCONF"):
            rconf = tuple(int(v) for v in line.split()[1].split(",")[:6])
        elif re.match(r"C\d{5}=", line):
            by_point[int(line[1:6])] = rconf
    return target_points(job_points(program), by_point)


def target_points(motions: list, by_point: dict[int, tuple]) -> dict[int, tuple]:
    """Target k's entry of ``by_point`` (keyed by the points' order from 0): the last point of each written move
    (``motions``: ``fanuc_ls.Motion`` in order, the first the start; a planned move's vertices come before its
    end) is target k."""
    out, n, k = {}, -1, 0
    for i, motion in enumerate(motions):
        n += len(motion.points)
        if i + 1 < len(motions) and motions[i + 1].move is motion.move:
            continue
        if n in by_point:
            out[k] = by_point[n]
        k += 1
    return out


def re_solved(program, k: int, X: np.ndarray, config, vendor: str) -> np.ndarray:
    """The joint values (6,) [rad] the controller reaches at target k, pose X (4, 4) [m] as read, with the
    configuration the file gives it (``config``): the one solution ``select_solution`` picks; on KUKA, where
    Status and Turn name two 2 pi variants (Turn is a sign per axis: an axis of more than +-180 deg has two of
    one sign) of a LIN or CIRC target, the controller ignores S and T and follows its path from the previous
    target (module docstring): the variant nearest it."""
    arm = program.robot
    try:
        return select_solution(arm, X, config, vendor)
    except ConfigurationNotFoundError:
        if vendor != "kuka" or not program.moves[k - 1].is_tool_move:
            raise
    Q = solutions_with(arm, X, config, vendor)
    return Q[np.argmin(np.abs(Q - program.targets[k - 1]).max(axis=1))]


def solutions_with(robot, X: np.ndarray, config, vendor: str) -> np.ndarray:
    """Every in-limit closed-form solution and 2 pi variant (K, 6) [rad] of pose X (4, 4) [m] with the vendor
    configuration ``config``."""
    Q = np.array([s.q for s in solve_ik_batch(robot, X[None], method="analytic")[0].solutions]).reshape(-1, 6)
    shifted, valid = limit_variants(Q, robot.revolute_mask, robot.limits.q_min, robot.limits.q_max)
    Q = shifted[valid]
    return Q[(configurations(robot, Q, vendor) == parse_configuration(vendor, config)).all(axis=1)]


@pytest.mark.parametrize("name, robot, job, language", CASES, ids=CASE_IDS)
def test_the_read_job_compiles_to_the_same_moves_targets_and_branches(written, references, name, robot, job,
                                                                       language):
    program, text = written[name]
    form = FORMATS[language]
    again = compile_job(parse_job(form.read(text, references[robot]), source=f"{name} read back"))
    assert [m.kind for m in again.moves] == [m.kind for m in program.moves]
    assert configuration_labels(again.robot, again.targets) == configuration_labels(program.robot, program.targets)
    for q, q_back in zip(program.targets, again.targets, strict=True):
        assert np.all(np.abs(q_back - q) <= bound(program, q, form))


@pytest.fixture(scope="module")
def parsers() -> dict[str, Lark]:
    """The package's LALR parser of each language's grammar."""
    return {language: Lark((GRAMMARS / form.grammar).read_text(), parser="lalr") for language, form in FORMATS.items()}


@pytest.mark.parametrize("name, robot, job, language", CASES, ids=CASE_IDS)
def test_every_written_program_parses_with_the_grammar(written, parsers, name, robot, job, language):
    _, text = written[name]
    for part in (text if language == "krl" else (text,)):
        assert parsers[language].parse(part) is not None


@pytest.mark.slow
@pytest.mark.parametrize("name", [case[0] for case in CASES if case[3] == "rapid"])
def test_rapidchecker_accepts_every_rapid_module(written, tmp_path, name):
    """rapidchecker as an external tool (a subprocess each: about a second, hence slow)."""
    if importlib.util.find_spec("rapidchecker") is None:
        pytest.skip("rapidchecker (pip install rapidchecker) is not installed")
    result = rapidchecker_errors(tmp_path, written[name][1])
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.fixture(scope="module")
def cell_program():
    """gp7_cell_pick_place compiled in its cell: both transfers over the wall are planned joint moves."""
    job = load_job(JOBS / "gp7_cell_pick_place.yaml")
    program = compile_job(job, collision_model(job))
    assert all(len(m.planned.waypoints) > 2 for m in program.moves if m.kind == "joint")
    return program


@pytest.mark.parametrize("language", FORMATS)
def test_a_planned_move_is_written_through_its_vertices_with_exact_stops(cell_program, language):
    """Every language writes a planned joint move as joint moves through the planner's vertices (the straight
    joint segments the planner checked), stopping exactly at each vertex and at both ends of the move: read
    back, the targets are the program's with the vertices between, each within the format's rounding, and none
    of those has a zone. Without the vertices the controller would cut straight through the cell's wall. (URScript,
    written for UR arms only, gets the GP7 as if on a UR controller: ``test_urscript.on_a_ur_controller``.)"""
    program, form = cell_program, FORMATS[language]
    program = on_a_ur_controller(program) if language == "urscript" else program
    document = form.read(form.write(program), "gp7")
    expected, exact = [program.targets[0]], [True]
    for move in program.moves:
        vertices = list(move.planned.waypoints[1:-1]) if move.planned is not None else []
        expected += [*vertices, move.target]
        exact += [True] * len(vertices) + [move.planned is not None]
        if move.planned is not None:
            exact[-len(vertices) - 2] = True                  # the move into a planned move stops too
    waypoints = document["waypoints"]
    assert len(waypoints) == len(expected)
    for k, (w, q, stop) in enumerate(zip(waypoints, expected, exact)):
        w = w if isinstance(w, dict) else {"joints": w}
        if "joints" in w:
            assert np.all(np.abs(np.radians(w["joints"]) - q) <= bound(program, q, form)), k
        else:
            X = quaternion_position_to_pose(w["quaternion"], w["xyz"])
            assert np.linalg.norm(X[:3, 3] - program.robot.fk(q)[:3, 3]) <= 1e-6, k
        if stop:
            assert w.get("zone", 0) == 0, (k, w)
