"""FANUC .ls writer (pipeline.outputs.controllers.fanuc_ls): the demo jobs written, parsed by a grammar of the
subset (pipeline/outputs/controllers/grammars/fanuc_ls.lark), each CONFIG equal to the configuration of the move's joints, and
each Cartesian target re-solved with its written CONFIG landing on the exported joint values within what
the file's rounding (0.001 mm, 0.001 deg) allows (``fanuc_ls.rounding_bound``: half a step on every written
number, carried to the joints through the inverse Jacobian, doubled)."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import pytest
from lark import Lark

from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.vendors import axis_angles, configurations, format_configuration, select_solution
from pipeline.model.vendors.pendant import fanuc_pendant_to_serial
from pipeline.outputs.controllers.fanuc_ls import (
    COMMENT_CHARS,
    cnt_value,
    controller_frame,
    program_points,
    rounding_bound,
    write_ls,
)
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job

JOBS = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
GRAMMARS = Path(__file__).resolve().parents[2] / "pipeline" / "outputs" / "controllers" / "grammars"
WHEN = dt.datetime(2026, 11, 27, 3, 0, 0)
CARTESIAN_JOBS = ("lrmate200id_quaternion_poses", "gp7_pick_place", "irb1600_tool_moves")


@pytest.fixture(scope="module")
def programs():
    """The demo jobs compiled (a few tens of ms each)."""
    return {name: compile_job(load_job(JOBS / f"{name}.yaml")) for name in (*CARTESIAN_JOBS, "irb1600_joint_moves")}


@pytest.fixture(scope="module")
def ls_parser():
    return Lark((GRAMMARS / "fanuc_ls.lark").read_text(), parser="lalr")


def written_positions(parser, text: str) -> dict[int, dict]:
    """P index -> {"config": text, "xyz": [mm], "wpr": [deg]} or {"joints": [deg]}, from the parse tree."""
    out = {}
    for position in parser.parse(text).find_data("position"):
        index = int(str(position.children[0])[2:-1])
        values = {str(v.children[0]): float(v.children[1]) for v in position.find_data("value")}
        config = next(position.find_data("config"), None)
        if config is None:
            out[index] = {"joints": np.array([values[f"J{i}"] for i in range(1, 7)])}
            continue
        flip, up, front, *turns = (str(t) for t in config.children)
        out[index] = {"config": f"{flip} {up} {front}, {', '.join(turns)}",
                      "xyz": np.array([values[a] for a in "XYZ"]), "wpr": np.array([values[a] for a in "WPR"])}
    return out


def flat_points(program):
    return [point for motion in program_points(program, "fanuc") for point in motion.points]


@pytest.mark.parametrize("job", [*CARTESIAN_JOBS, "irb1600_joint_moves"])
def test_every_written_program_parses_with_the_grammar(programs, ls_parser, job):
    text = write_ls(programs[job], "PROG1", WHEN)
    assert len(written_positions(ls_parser, text)) == len(flat_points(programs[job]))
    assert text.startswith("/PROG  PROG1\n/ATTR") and text.endswith("/END\n")


@pytest.mark.parametrize("job", CARTESIAN_JOBS)
def test_config_is_the_joints_configuration_and_resolving_lands_on_the_exported_joints(programs, ls_parser, job):
    program = programs[job]
    robot = program.robot
    X_B_base, _ = controller_frame(robot, "fanuc")
    written = written_positions(ls_parser, write_ls(program, "PROG1", WHEN))
    for index, point in enumerate(flat_points(program), start=1):
        entry = written[index]
        assert entry["config"] == format_configuration("fanuc", configurations(robot, point.q, "fanuc"))
        X = X_B_base @ rpy_position_to_pose(np.radians(entry["wpr"]), entry["xyz"] / 1000.0)
        q = select_solution(robot, X, entry["config"], "fanuc")
        tolerance = rounding_bound(robot, point.q, 0.001, 0.001)
        assert np.all(np.abs(q - point.q) <= tolerance), (index, np.degrees(q - point.q), np.degrees(tolerance))
        assert tolerance.max() < np.radians(0.01)       # the bound is tight enough to tell branches apart


def test_lr_mate_targets_are_in_fanucs_world_frame_330_mm_above_the_mounting_face(programs, ls_parser):
    program = programs["lrmate200id_quaternion_poses"]
    written = written_positions(ls_parser, write_ls(program, "LRM", WHEN))
    np.testing.assert_allclose(written[1]["xyz"], [400.0, 0.0, 170.0], atol=1e-3)   # job: (0.40, 0, 0.50) m


def test_joint_waypoints_are_written_in_the_pendants_joint_convention(tmp_path, ls_parser):
    """A LR Mate job given in joints: J3 is written as q3 - q2, and reads back to q within 0.001 deg."""
    path = tmp_path / "lrmate_joints.yaml"
    path.write_text("robot: lrmate200id\nangle_unit: deg\nwaypoints:\n  - [0, 0, 0, 0, -90, 0]\n"
                    "  - [10, 20, 30, 40, -60, 50]\n")
    program = compile_job(load_job(path))
    written = written_positions(ls_parser, write_ls(program, "JOINTS", WHEN))
    assert written[2]["joints"][2] == pytest.approx(10.0)
    for index, point in enumerate(flat_points(program), start=1):
        joints = written[index]["joints"]
        np.testing.assert_allclose(joints, axis_angles(program.robot, point.q, "fanuc"), atol=5e-4)
        np.testing.assert_allclose(fanuc_pendant_to_serial(joints), point.q, atol=np.radians(1e-3))


def test_fine_where_the_zone_is_0_and_cnt_with_the_zone_in_mm_beside_it(programs):
    program = programs["gp7_pick_place"]
    lines = [line.split(":", 1)[1].strip() for line in write_ls(program, "GP7", WHEN).split("/MN\n")[1]
             .split("/POS")[0].splitlines() if not line.strip().startswith(":")]
    motions = [k for k, line in enumerate(lines) if line[0] in "JLC"]
    assert len(motions) == len(program.moves) + 1
    zones = [0.0] + [move.zone for move in program.moves]
    for k, zone in zip(motions, zones):
        if zone == 0.0:
            assert lines[k].endswith("FINE ;") or lines[k].startswith("C ")
        else:
            assert lines[k - 1].startswith(f"!zone {zone * 1000:.1f}mm CNT")
    assert "L P[3] 500mm/sec FINE ;" in lines                       # the pick: a stop
    assert "L P[4] 500mm/sec CNT100 ;" in lines                     # 60 mm zone, 50 mm deceleration at 500 mm/s


@pytest.mark.parametrize("zone, reach, cnt", [(0.06, 0.05, 100), (0.01, 0.05, 20), (1e-4, 1.0, 1), (0.02, 0.0, 100)])
def test_cnt_is_the_zone_as_a_percentage_of_the_reach(zone, reach, cnt):
    assert cnt_value(zone, reach) == cnt


def test_speeds_in_percent_and_mm_per_sec(programs):
    assert "J P[2] 70% FINE ;" in write_ls(programs["lrmate200id_quaternion_poses"], "LRM", WHEN)   # speed_scale 0.7
    assert "400mm/sec" in write_ls(programs["irb1600_tool_moves"], "IRB", WHEN)


def test_header_comment_lines_fit_the_pendant_and_name_the_loader_option(programs):
    text = write_ls(programs["gp7_pick_place"], "GP7", WHEN)
    comments = [line.split(":", 1)[1].strip()[1:-1].strip() for line in text.splitlines() if ":  !" in line]
    assert comments and all(len(c) <= COMMENT_CHARS for c in comments)
    assert "ASCII Program Loader" in " ".join(comments)


@pytest.mark.parametrize("name", ["prog", "TOOLONGNAME", "1ABC", "", "A-B", None])
def test_a_name_the_controller_refuses_is_an_error(programs, name):
    with pytest.raises(ConfigurationError, match="1 to 8 characters"):
        write_ls(programs["gp7_pick_place"], name, WHEN)
