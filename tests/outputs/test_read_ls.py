"""FANUC .ls reader (pipeline.outputs.controllers.read_ls): the demo jobs written by ``write_ls``, read back into job
documents, validated by ``parse_job`` and compiled again: the same move kinds, the same targets within the
file's rounding (0.001 mm, 0.001 deg carried to the joints by ``fanuc_ls.rounding_bound``), the same branches
and 2 pi representatives, the same via points, speeds (whole % and mm/sec) and zones (the writer's zone
comment, 0.1 mm). A pendant-style copy (spaces for tabs, CR LF, other line numbering, an added comment)
reads the same; CNT without the comment follows the writer's rule; joint positions in the pendant
convention come back as model joint values."""

from __future__ import annotations

import datetime as dt
import re

import numpy as np
import pytest

from pipeline.model.ik.branches import configuration_labels
from pipeline.model.vendors.axes import joint_values
from pipeline.outputs.controllers.fanuc_ls import cnt_value, rounding_bound, write_ls, zone_reach
from pipeline.outputs.controllers.read_ls import ControllerProgramError, read_ls
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

from .test_fanuc_ls import CARTESIAN_JOBS, JOBS

WHEN = dt.datetime(2026, 11, 27, 3, 0, 0)


@pytest.fixture(scope="module")
def programs():
    """The demo jobs compiled (a few tens of ms each)."""
    return {name: compile_job(load_job(JOBS / f"{name}.yaml")) for name in CARTESIAN_JOBS}


def check_round_trip(program, reread, mm_step: float, deg_step: float, zone_step: float, speed_steps) -> None:
    """``reread`` (the program compiled from the read job) has ``program``'s move kinds, targets within the
    rounding bound, branches, vias, speeds within ``speed_steps`` (% / 100, m/s) and zones within
    ``zone_step`` [m]."""
    assert [m.kind for m in reread.moves] == [m.kind for m in program.moves]
    for q, q_back in zip(program.targets, reread.targets):
        assert np.all(np.abs(q_back - q) <= rounding_bound(program.robot, q, mm_step, deg_step))
    assert configuration_labels(program.robot, reread.targets) == configuration_labels(program.robot, program.targets)
    for move, back in zip(program.moves, reread.moves):
        if move.via is not None:
            assert np.abs(back.via - move.via).max() <= mm_step / 2000.0 + 1e-12
        step = speed_steps[0] if move.kind == "joint" else speed_steps[1]
        assert abs(back.speed * reread.speed_scale - move.speed * program.speed_scale) <= step / 2.0 + 1e-12
        assert abs(back.zone - move.zone) <= zone_step / 2.0 + 1e-12


@pytest.mark.parametrize("name", CARTESIAN_JOBS)
def test_round_trip(programs, name):
    program = programs[name]
    document = read_ls(write_ls(program, "DEMO", WHEN), program.robot.name)
    reread = compile_job(parse_job(document))
    check_round_trip(program, reread, 0.001, 0.001, 1e-4, (0.01, 0.001))


def pendant_style(text: str) -> str:
    """``text`` as a pendant or another tool might print it: spaces for tabs, line numbers without padding,
    a comment added to /MN, CR LF line ends."""
    text = text.replace("\t", "    ")
    text = re.sub(r"^ +(\d+):  ", r"\1: ", text, flags=re.MULTILINE)
    text = text.replace("/MN\n", "/MN\n   0:  !taught on the pendant ;\n", 1)
    return text.replace("\n", "\r\n")


@pytest.mark.parametrize("name", CARTESIAN_JOBS)
def test_pendant_style_reads_the_same(programs, name):
    program = programs[name]
    text = write_ls(program, "DEMO", WHEN)
    assert read_ls(pendant_style(text), program.robot.name) == read_ls(text, program.robot.name)


def test_world_frame_undone(programs):
    """The LR Mate's points are written 330 mm lower (FANUC world frame) and read back in our base frame."""
    program = programs["lrmate200id_quaternion_poses"]
    text = write_ls(program, "DEMO", WHEN)
    z_written = float(re.search(r"Z =\s+(-?\d+\.\d+)", text).group(1))
    first = read_ls(text, program.robot.name)["waypoints"][0]
    assert first["xyz"][2] == pytest.approx(z_written / 1000.0 + 0.330, abs=1e-12)
    assert first["xyz"][2] == pytest.approx(program.robot.fk(program.targets[0])[2, 3], abs=5e-7)


def test_cnt_without_comment_follows_the_writer_rule(programs):
    """Without the writer's zone comment, CNT n reads as n / 100 of the writer's reach: the deceleration
    distance at the move's speed when the caller gives the TCP acceleration limit, else half the shorter
    neighbouring move."""
    program = programs["irb1600_tool_moves"]
    text = re.sub(r"^ *\d+:  !zone[^\n]*\n", "", write_ls(program, "DEMO", WHEN), flags=re.MULTILINE)
    assert "!zone" not in text
    with_accel = read_ls(text, program.robot.name, tcp_accel_max=program.tcp_accel_max)["waypoints"]
    without = read_ls(text, program.robot.name)["waypoints"]
    for k, move in enumerate(program.moves):
        if move.zone <= 0.0:
            assert "zone" not in with_accel[k + 1]
            continue
        reach, how = zone_reach(program, k)
        assert how == "decel"
        n = cnt_value(move.zone, reach)
        assert with_accel[k + 1]["zone"] == pytest.approx(n / 100.0 * reach)
        assert move.zone <= with_accel[k + 1]["zone"] + 1e-12 and with_accel[k + 1]["zone"] - move.zone <= reach / 100
        before, after = (program.robot.fk(program.targets[j])[:3, 3] for j in (k, k + 1))
        chords = [np.linalg.norm(after - before)]
        if k + 1 < len(program.moves):
            chords.append(np.linalg.norm(program.moves[k + 1].X_BT[:3, 3] - after))
        assert without[k + 1]["zone"] == pytest.approx(n / 100.0 * min(chords) / 2.0, abs=1e-6)


def test_joint_positions_in_the_pendant_convention(tmp_path):
    """A job in joints is written as J1..J6 as the pendant shows them (J3 = q3 - q2) and read back as q."""
    path = tmp_path / "lrmate_joints.yaml"
    path.write_text("robot: lrmate200id\nangle_unit: deg\nwaypoints:\n  - [0, 0, 0, 0, -90, 0]\n"
                    "  - [30, 20, 10, 40, -60, 100]\n  - {joints: [-20, 10, 30, -150, 45, 170], speed: 40}\n")
    program = compile_job(load_job(path))
    text = write_ls(program, "JOINTS", WHEN)
    assert re.search(r"J3=\s+-10\.000 deg", text)                    # q3 - q2 = 10 - 20
    document = read_ls(text, "lrmate200id")
    assert np.allclose(document["waypoints"][1]["joints"], [30, 20, 10, 40, -60, 100], atol=1e-9)
    assert document["waypoints"][2]["speed"] == 40.0
    reread = compile_job(parse_job(document))
    assert np.abs(np.array(reread.targets) - np.array(program.targets)).max() <= np.radians(0.0005) + 1e-12


def test_joint_values_invert_the_fanuc_coupling():
    from pipeline.model.robot import load_robot

    robot = load_robot("lrmate200id")
    assert np.allclose(np.degrees(joint_values(robot, [0, 10, 5, 0, 0, 0], "fanuc")), [0, 10, 15, 0, 0, 0])


def test_tool_from_the_header_or_the_caller(programs):
    program = programs["gp7_pick_place"]
    text = write_ls(program, "DEMO", WHEN)
    assert read_ls(text, "gp7")["tool"] == {"xyz": [0.0, 0.0, 0.12], "rpy": [0.0, 0.0, 0.0]}
    stripped = text.replace("UT 1 = tool", "UT 1 = TOOL")
    with pytest.raises(ControllerProgramError, match=r"demo.ls:\d+: line \d+: tool 1 .*not in the file"):
        read_ls(stripped, "gp7", source="demo.ls")                 # UT 1's data is on the controller
    assert read_ls(stripped, "gp7", tool=program.tool.X_FT) == read_ls(text, "gp7")


@pytest.mark.parametrize("edit, match", [
    (("UF : 0", "UF : 1"), "P\\[1\\]: UF : 1, but UFRAME_NUM=0"),
    (("J P[2]", "J P[99]"), "P\\[99\\]"),
    (("500mm/sec FINE", "500mm/sec FINE FINE"), r"demo.ls:\d+: line \d+: L P\[3\] .*FINE: a motion option"),
    (("'N U T, 0, 0, 0'", "'N U T, 5, 0, 0'"), "P\\[1\\]"),
])
def test_errors_name_what_is_wrong(programs, edit, match):
    text = write_ls(programs["gp7_pick_place"], "DEMO", WHEN).replace(*edit, 1)
    with pytest.raises(ControllerProgramError, match=match):
        read_ls(text, "gp7", source="demo.ls")
