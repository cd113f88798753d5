"""Yaskawa INFORM writer (pipeline.outputs.controllers.yaskawa_jbi): the demo jobs written, parsed by a grammar
of the subset
(pipeline/outputs/controllers/grammars/yaskawa_jbi.lark), each RCONF equal to the configuration of the point's
joints, and each target re-solved with its RCONF landing on the exported joint values within what the
file's rounding (0.001 mm, 0.01 deg) allows (``fanuc_ls.rounding_bound``: half a step on every written
number, carried to the joints through the inverse Jacobian, doubled)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from lark import Lark

from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.vendors import configurations, select_solution
from pipeline.model.vendors.configuration import mismatched_field
from pipeline.outputs.controllers.fanuc_ls import COMMENT_CHARS, controller_frame, rounding_bound
from pipeline.outputs.controllers.yaskawa_jbi import PL_MM, UNUSED_RCONF, job_points, pl_level, write_jbi
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job

from .test_fanuc_ls import CARTESIAN_JOBS, GRAMMARS, JOBS

WHEN = dt.datetime(2026, 11, 27, 3, 0)


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    """The demo jobs compiled (a few tens of ms each), and a GP7 job given in joints."""
    joints = tmp_path_factory.mktemp("jobs") / "gp7_joints.yaml"
    joints.write_text("robot: gp7\nangle_unit: deg\nwaypoints:\n  - [0, 0, 0, 0, -90, 0]\n"
                      "  - [30, 20, 10, 40, -60, 100]\n  - [-20, 10, 30, -185, 45, 250]\n")
    compiled = {name: compile_job(load_job(JOBS / f"{name}.yaml")) for name in (*CARTESIAN_JOBS, "irb1600_joint_moves")}
    return {**compiled, "gp7_joints": compile_job(load_job(joints))}


@pytest.fixture(scope="module")
def jbi_parser():
    return Lark((GRAMMARS / "yaskawa_jbi.lark").read_text(), parser="lalr")


def written_points(parser, text: str) -> list[dict]:
    """The Cxxxxx points in order: {"name", "rconf" (the ///RCONF fields in force), "xyz" [mm], "angles" [deg]}."""
    points, rconf = [], None
    for node in next(parser.parse(text).find_data("pos")).children:
        if node.data not in ("rconf", "point"):
            continue
        if node.data == "rconf":
            rconf = tuple(int(t) for t in node.children)
            continue
        values = np.array([float(t) for t in node.children[1:]])
        points.append({"name": str(node.children[0]), "rconf": rconf, "xyz": values[:3], "angles": values[3:]})
    return points


def flat_points(program):
    return [point for motion in job_points(program) for point in motion.points]


@pytest.mark.parametrize("job", [*CARTESIAN_JOBS, "gp7_joints"])
def test_every_written_job_parses_with_the_grammar(programs, jbi_parser, job):
    text = write_jbi(programs[job], "JOB1", WHEN)
    points = written_points(jbi_parser, text)
    assert [p["name"] for p in points] == [f"C{k:05d}" for k in range(len(flat_points(programs[job])))]
    assert f"///NPOS {len(points)},0,0,0,0,0\n" in text
    assert text.startswith("/JOB\n//NAME JOB1\n//POS\n") and text.endswith("NOP\n" + text.split("NOP\n", 1)[1])
    assert text.endswith("END\n")


@pytest.mark.parametrize("job", [*CARTESIAN_JOBS, "gp7_joints"])
def test_rconf_is_the_joints_configuration_and_resolving_lands_on_the_exported_joints(programs, jbi_parser, job):
    """Joint waypoints too: without pulses per degree they are Cartesian data with RCONF."""
    program = programs[job]
    robot = program.robot
    X_B_base, _ = controller_frame(robot, "yaskawa")
    written = written_points(jbi_parser, write_jbi(program, "JOB1", WHEN))
    for entry, point in zip(written, flat_points(program), strict=True):
        assert entry["rconf"] == (*configurations(robot, point.q, "yaskawa"), *[0] * UNUSED_RCONF)
        X = X_B_base @ rpy_position_to_pose(np.radians(entry["angles"]), entry["xyz"] / 1000.0)
        q = select_solution(robot, X, entry["rconf"][:6], "yaskawa")
        tolerance = rounding_bound(robot, point.q, 0.001, 0.01)
        assert np.all(np.abs(q - point.q) <= tolerance), (entry["name"], np.degrees(q - point.q), np.degrees(tolerance))


def test_an_axis_at_exactly_180_deg_is_written_on_the_side_its_rounded_pose_selects(programs, jbi_parser):
    """irb1600_joint_moves has axis 6 at exactly 180 deg, on RCONF's "T >= 180" boundary (the last digit
    decides the side): C00002 is written, with an RCONF that describes its joint values (either side of the
    boundary) and that, with the rounded pose, brings the controller back to 180 deg, not to -180 deg."""
    program = programs["irb1600_joint_moves"]
    robot = program.robot
    X_B_base, _ = controller_frame(robot, "yaskawa")
    entry = written_points(jbi_parser, write_jbi(program, "IRB", WHEN))[2]
    q_target = flat_points(program)[2].q
    assert (entry["name"], np.degrees(q_target[5])) == ("C00002", pytest.approx(180.0))
    assert mismatched_field(robot, q_target, "yaskawa", entry["rconf"][:6]) is None
    X = X_B_base @ rpy_position_to_pose(np.radians(entry["angles"]), entry["xyz"] / 1000.0)
    q = select_solution(robot, X, entry["rconf"][:6], "yaskawa")
    assert np.all(np.abs(q - q_target) <= rounding_bound(robot, q_target, 0.001, 0.01)), np.degrees(q - q_target)


def test_gp7_targets_are_in_the_robot_frame_330_mm_above_the_mounting_face(programs, jbi_parser):
    first = written_points(jbi_parser, write_jbi(programs["gp7_pick_place"], "GP7", WHEN))[0]
    np.testing.assert_allclose(first["xyz"], [560.0, 0.0, 150.0], atol=1e-3)       # job: (560, 0, 480) mm
    np.testing.assert_allclose(first["angles"], [180.0, 0.0, 0.0], atol=1e-2)


def instructions(text: str) -> list[str]:
    return text.split("NOP\n", 1)[1].split("\nEND")[0].splitlines()


def test_moves_speeds_and_position_levels_of_the_gp7_job(programs):
    lines = [line for line in instructions(write_jbi(programs["gp7_pick_place"], "GP7", WHEN))
             if not line.startswith("'")]
    assert lines == ["MOVJ C00000 VJ=100.00", "MOVJ C00001 VJ=100.00", "MOVL C00002 V=500.0",
                     "MOVC C00003 V=500.0 PL=3",      # the retreat: the arc's first point, reached on a line, its zone
                     "MOVC C00004 V=500.0", "MOVC C00005 V=500.0 PL=3",
                     "MOVL C00006 V=500.0", "MOVL C00007 V=500.0 PL=3", "MOVL C00008 V=500.0"]


def test_a_line_into_an_arc_is_the_arcs_first_point(programs, jbi_parser):
    points = written_points(jbi_parser, write_jbi(programs["gp7_pick_place"], "GP7", WHEN))
    assert len(points) == 9
    assert points[3]["xyz"] == pytest.approx([500.0, 350.0, 0.0])                 # the retreat's end (z 330 - 330)
    assert points[4]["xyz"] == pytest.approx([700.0, 0.0, 50.0])                  # the via point


def test_an_arc_after_a_joint_move_repeats_its_start_and_stops_there():
    """INFORM reaches an arc's first MOVC point on a line: after a joint move the arc's start is written again (a
    zero-length first segment), and the joint move's zone is dropped (reported per move)."""
    from pipeline.program.job import parse_job

    job = parse_job({"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tool": {"xyz": [0, 0, 120]},
                     "tcp_speed_max": 500, "start": [0, 0, 0, 0, -90, 0],
                     "waypoints": [{"xyz": [560, 0, 480], "rpy": [180, 0, 0]},
                                   {"xyz": [500, 350, 330], "rpy": [180, 0, 35], "move": "joint", "zone": 40},
                                   {"xyz": [500, -350, 330], "rpy": [180, 0, -35], "move": "circular",
                                    "via": {"xyz": [700, 0, 380]}}]}, source="arc.yaml", name="arc")
    lines = [line for line in instructions(write_jbi(compile_job(job), "ARC", WHEN)) if not line.startswith("'")]
    assert lines == ["MOVJ C00000 VJ=100.00", "MOVJ C00001 VJ=100.00", "MOVC C00002 V=500.0", "MOVC C00003 V=500.0",
                     "MOVC C00004 V=500.0"]


@pytest.mark.parametrize("zone_mm, level", [(0.0, 0), (5.0, 0), (12.5, 1), (24.9, 1), (60.0, 3), (1600.0, 8),
                                            (5000.0, 8)])
def test_pl_is_the_largest_level_within_the_zone(zone_mm, level):
    assert pl_level(zone_mm / 1000.0) == level
    assert level == 0 or PL_MM[level - 1] <= zone_mm


def test_the_controllers_own_pl_distances_can_be_given(programs):
    lines = instructions(write_jbi(programs["gp7_pick_place"], "GP7", WHEN, pl_mm=(5, 10, 20, 40, 60, 80, 100, 120)))
    assert "MOVC C00005 V=500.0 PL=5" in lines
    with pytest.raises(ConfigurationError, match="8 increasing distances"):
        write_jbi(programs["gp7_pick_place"], "GP7", WHEN, pl_mm=(1, 2, 3))


def test_comments_fit_32_characters(programs):
    text = write_jbi(programs["gp7_pick_place"], "GP7", WHEN)
    comments = [line[1:] for line in instructions(text) if line.startswith("'")]
    assert comments and all(len(c) <= COMMENT_CHARS for c in comments)
    assert len(text.split("///COMM ", 1)[1].split("\n")[0]) <= COMMENT_CHARS


def test_joint_speed_is_a_percentage_with_two_decimals(programs):
    assert "MOVJ C00001 VJ=70.00" in instructions(write_jbi(programs["lrmate200id_quaternion_poses"], "LRM", WHEN))


@pytest.mark.parametrize("name", ["job", "TOOLONGNAME", "1ABC", "", None])
def test_a_name_the_controller_refuses_is_an_error(programs, name):
    with pytest.raises(ConfigurationError, match="1 to 8 characters"):
        write_jbi(programs["gp7_pick_place"], name, WHEN)


def test_an_axis_at_180_deg_is_refused_naming_the_rconf_bit(tmp_path):
    """The IRB 1600's axis 4 at -180 deg (a pick of bench cycle's IRB 1600 wall cell): RCONF's R >= 180 bit is the same
    for -180 and +180 deg, and the rounded pose selects +180: refused, saying why (not "near-singular")."""
    from pipeline.program.job import parse_job

    job = parse_job({"robot": "irb1600", "angle_unit": "deg",
                     "waypoints": [[16.9988, 1.4212, 47.612, -180.0, -40.9668, 8.7988], [30, 10, 20, 170, -40, 10]]},
                    source="axis4.yaml", name="axis4")
    with pytest.raises(ConfigurationError, match=r"C00000: .*axis 4 is at \+-180 deg, where RCONF's >= 180 bit is "
                                                 r"the same for -180 and \+180 deg"):
        write_jbi(compile_job(job), "AXIS4")
