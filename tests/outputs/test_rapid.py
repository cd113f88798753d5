"""ABB RAPID modules of compiled programs (pipeline.outputs.controllers.rapid, issue 26): the demo jobs for the IRB 1600
(tool moves, joint moves) and the GP7 pick and place (any 6R arm with a spherical wrist gets confdata). Every
robtarget's confdata is the one pipeline.model.vendors computes from the move's joint values; each robtarget's
pose re-solved with its confdata (pipeline.model.vendors.selection) lands on those joint values within the format's
rounding; jointtargets are the joint values; the syntax passes rapidchecker (an independent RAPID grammar)."""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.errors import OutputError
from pipeline.files.poses import quaternion_position_to_pose
from pipeline.model.vendors import select_solution
from pipeline.model.vendors.configuration import mismatched_field
from pipeline.outputs.controllers.rapid import (
    check_identifier,
    joint_move_time,
    via_target,
    write_rapid,
    written_configuration,
)
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job
from pipeline.program.tool_moves import POSITION_TOLERANCE_M
from pipeline.runner import collision_model

JOBS = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
DEMOS = ("irb1600_tool_moves", "irb1600_joint_moves", "gp7_pick_place")
#: Re-solved joint values agree with the exported ones within this [rad]: the pose is rounded to 0.0005 mm and
#: 5e-7 per quaternion component (about 1e-6 rad), which moves the joints by about that over the arm's
#: Jacobian; 1e-4 rad leaves room for the wrist near (not on) its singular set.
RESOLVE_TOLERANCE_RAD = 1e-4
#: A jointtarget is written to 0.0001 deg: half of that, and double round-off [deg].
JOINT_ROUNDING_DEG = 0.5e-4 + 1e-9
#: A via point's joint values come from the program's joint path along its arc, which keeps the TCP within
#: 0.1 mm and 0.1 deg of the arc (pipeline.program.tool_moves), so the via pose re-solves near them [rad].
VIA_TOLERANCE_RAD = 5e-3
NUMBER = r"-?\d+(?:\.\d+)?(?:E\d+)?"
ROBTARGET = re.compile(rf"CONST robtarget (\w+) := \[\[({NUMBER}),({NUMBER}),({NUMBER})\],"
                       rf"\[({NUMBER}),({NUMBER}),({NUMBER}),({NUMBER})\],\[(-?\d+),(-?\d+),(-?\d+),(-?\d+)\],")
JOINTTARGET = re.compile(rf"CONST jointtarget (\w+) := \[\[({NUMBER}(?:,{NUMBER}){{5}})\],")


@pytest.fixture(scope="module")
def written() -> dict:
    """Each demo job's (program, module text)."""
    out = {}
    for name in DEMOS:
        program = compile_job(load_job(JOBS / f"{name}.yaml"))
        out[name] = program, write_rapid(program, name)
    return out


def robtargets(text: str) -> dict[str, tuple[np.ndarray, tuple[int, ...]]]:
    """name -> (pose (4, 4) [m] as the controller reads it, confdata) of every robtarget in the module."""
    out = {}
    for match in ROBTARGET.finditer(text):
        values = [float(v) for v in match.groups()[1:8]]
        quaternion = np.array(values[3:]) / np.linalg.norm(values[3:])
        out[match.group(1)] = (quaternion_position_to_pose(quaternion, np.array(values[:3]) / 1e3),
                               tuple(int(v) for v in match.groups()[8:]))
    return out


def jointtargets(text: str) -> dict[str, np.ndarray]:
    """name -> axis angles (6,) [deg] of every jointtarget in the module."""
    return {m.group(1): np.array([float(v) for v in m.group(2).split(",")]) for m in JOINTTARGET.finditer(text)}


def instructions(text: str) -> list[str]:
    """The instructions of the module's entry routine (``PROC main_<module>()``), one per line, without
    indentation."""
    body = re.split(r"PROC main_\w+\(\)\n", text)[1].split("ENDPROC")[0]
    return [line.strip() for line in body.splitlines()]


@pytest.mark.parametrize("name", DEMOS)
def test_confdata_is_that_of_the_move_joint_values(written, name):
    program, text = written[name]
    targets = robtargets(text)
    for move in program.moves:
        key = f"p{move.end}"
        if key in targets:
            assert mismatched_field(program.robot, move.target, "abb", targets[key][1]) is None   # its own, or
            # the other side of a quadrant boundary the axis sits on by round-off (configuration.mismatched_field)


@pytest.mark.parametrize("name", DEMOS)
def test_robtargets_resolve_to_the_exported_joint_values(written, name):
    program, text = written[name]
    targets = robtargets(text)
    resolved = 0
    for move in program.moves:
        if f"p{move.end}" not in targets:
            continue
        X, conf = targets[f"p{move.end}"]
        np.testing.assert_allclose(X[:3, 3], move.X_BT[:3, 3], atol=0.5e-6 + 1e-12)
        q = select_solution(program.robot, X, conf, "abb")
        assert np.abs(q - move.target).max() <= RESOLVE_TOLERANCE_RAD
        resolved += 1
    assert resolved == sum(1 for m in program.moves if m.is_tool_move or program.waypoints[m.end].method)


@pytest.mark.parametrize("name", ["irb1600_tool_moves", "gp7_pick_place"])
def test_via_points_are_on_the_arc_with_the_track_configuration(written, name):
    program, text = written[name]
    targets = robtargets(text)
    circular = [m for m in program.moves if m.kind == "circular"]
    assert circular
    for move in circular:
        X, conf = targets[f"c{move.end}"]
        np.testing.assert_allclose(X[:3, 3], move.via, atol=0.5e-6 + 1e-12)
        X_track, q_track = via_target(program, move)
        np.testing.assert_allclose(program.robot.fk(q_track)[:3, 3], move.via, atol=POSITION_TOLERANCE_M)
        assert tuple(written_configuration(program.robot, X_track, q_track)) == conf
        q = select_solution(program.robot, X, conf, "abb")
        assert np.abs(q - q_track).max() <= VIA_TOLERANCE_RAD


def test_joint_moves_given_as_joints_are_jointtargets(written):
    program, text = written["irb1600_joint_moves"]
    joints = jointtargets(text)
    for k, q in enumerate(program.targets):
        assert np.abs(joints[f"j{k}"] - np.degrees(q)).max() <= JOINT_ROUNDING_DEG
    moves = [line for line in instructions(text) if line.startswith("Move")]
    assert moves[0] == "MoveAbsJ j0, v100, fine, tool_job;"
    assert all(line.startswith("MoveAbsJ") for line in moves)
    # Passed through without a zone: z0; the last waypoint is a stop.
    assert [line.split(", ")[2] for line in moves[1:]] == ["z0"] * 4 + ["fine"]


def test_joint_move_time_is_the_leading_axis_at_its_fraction(written):
    program, text = written["irb1600_joint_moves"]
    first = next(line for line in instructions(text) if line.startswith("MoveAbsJ j1"))
    seconds = float(re.search(r"\\T:=([\d.]+)", first).group(1))
    step = np.abs(program.targets[1] - program.targets[0]) / program.limits.qd_max
    assert step.max() <= seconds < step.max() + 1e-3
    assert joint_move_time(program, program.targets[0], program.targets[0], 1.0) == 0.0


def test_speeds_zones_and_tool(written):
    text = written["irb1600_tool_moves"][1]
    assert "PERS tooldata tool_job := [TRUE,[[0,0,100],[1,0,0,0]],[1,[0,0,0],[1,0,0,0],0,0,0]];" in text
    assert "CONST speeddata speed_400 := [400,500,5000,1000];" in text
    assert "CONST zonedata zone_40 := [FALSE,40,60,60,6,60,6];" in text
    moves = [line for line in instructions(text) if line.startswith("Move")]
    assert moves[1:] == ["MoveL p1, speed_400, zone_40, tool_job;", "MoveL p2, speed_400, zone_40, tool_job;",
                         "MoveL p3, speed_400, zone_40, tool_job;", "MoveL p4, speed_400, fine, tool_job;",
                         "MoveC c5, p5, speed_400, fine, tool_job;"]
    assert "PLACEHOLDER" in text and "not the certified profile" in text


def test_names_within_rapid_limits(written):
    for _, text in written.values():
        for name in re.findall(r"(?:CONST|PERS) \w+ (\w+) :=", text):
            assert check_identifier(name, "data name") == name
        assert all(len(line) <= 120 for line in text.splitlines())
    for bad in ("1abc", "a" * 33, "with space", "MODULE", "", "tool-1"):
        with pytest.raises(OutputError, match="RAPID module name"):
            write_rapid(written["irb1600_tool_moves"][0], bad)


def rapidchecker_errors(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    """rapidchecker run as an external tool on the module written to tmp_path (its own working directory,
    so no rapidchecker.toml of the repository changes its defaults)."""
    path = tmp_path / "module.mod"
    path.write_text(text)
    return subprocess.run([sys.executable, "-m", "rapidchecker", str(path)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60, check=False)


@pytest.mark.parametrize("name", DEMOS)
def test_rapidchecker_accepts_the_modules(written, tmp_path, name):
    pytest.importorskip("rapidchecker", reason="rapidchecker (pip install rapidchecker) is not installed")
    result = rapidchecker_errors(tmp_path, written[name][1])
    assert result.returncode == 0, result.stdout + result.stderr


def test_rapidchecker_rejects_a_broken_module(written, tmp_path):
    pytest.importorskip("rapidchecker", reason="rapidchecker (pip install rapidchecker) is not installed")
    text = written["irb1600_tool_moves"][1].replace("MoveL p2, speed_400, zone_40, tool_job;",
                                                    "MoveL p2, speed_400 zone_40, tool_job")
    assert rapidchecker_errors(tmp_path, text).returncode != 0


@pytest.fixture(scope="module")
def cell_program():
    """The GP7 cell job compiled with its cell: its joint moves over the wall are planned."""
    job = load_job(JOBS / "gp7_cell_pick_place.yaml")
    return compile_job(job, collision_model(job))


def test_planned_moves_pass_their_vertices_with_exact_stops(cell_program, tmp_path):
    text = write_rapid(cell_program, "gp7_cell")
    joints, moves = jointtargets(text), [line for line in instructions(text) if line.startswith("Move")]
    planned = [m for m in cell_program.moves if m.planned is not None]
    assert planned
    for move in planned:
        vertices = move.planned.waypoints[1:-1]
        assert len(vertices)
        for i, vertex in enumerate(vertices, start=1):
            assert np.abs(joints[f"j{move.end}_{i}"] - np.degrees(vertex)).max() <= JOINT_ROUNDING_DEG
            assert any(line.startswith(f"MoveAbsJ j{move.end}_{i}, vmax\\T:=") and ", fine," in line
                       for line in moves)
        # Into and out of the planned move: exact stops, whatever the job's zones.
        ends = [line for line in moves if re.match(rf"Move\w+ (?:c\d+, )?p({move.end - 1}|{move.end}),", line)]
        assert len(ends) == 2 and all(", fine," in line for line in ends)
    if importlib.util.find_spec("rapidchecker") is not None:
        assert rapidchecker_errors(tmp_path, text).returncode == 0


def test_work_object_when_the_base_is_placed_in_the_cell(cell_program):
    X_WB = np.eye(4)
    X_WB[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    X_WB[:3, 3] = [1.0, 0.5, 0.2]
    program = dataclasses.replace(cell_program, cell=dataclasses.replace(cell_program.cell, X_WB=X_WB))
    text = write_rapid(program, "gp7_cell")
    assert "LOCAL PERS wobjdata wobj_base := [FALSE,TRUE,\"\",[[1000,500,200],[0.707107,0,0,0.707107]]," \
           "[[0,0,0],[1,0,0,0]]];" in text
    moves = [line for line in instructions(text) if line.startswith("Move") and not line.startswith("MoveAbsJ")]
    assert moves and all(line.endswith("tool_job\\WObj:=wobj_base;") for line in moves)
    # The targets stay in the robot's base frame.
    assert robtargets(text).keys() == robtargets(write_rapid(cell_program, "gp7_cell")).keys()
    for name, (X, conf) in robtargets(text).items():
        X0, conf0 = robtargets(write_rapid(cell_program, "gp7_cell"))[name]
        np.testing.assert_array_equal(X, X0)
        assert conf == conf0
