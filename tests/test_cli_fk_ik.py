"""``python -m pipeline fk`` and ``ik`` in this process (``pipeline.__main__.main``): fk prints the TCP pose, branch and
Yaskawa configuration our own FK gives, in the robot file's angle unit by default; ik lists every branch (in a cell
with its collision state and closest pair), an unreachable pose is a result; bad joint values are one error line."""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.files.poses import pose_to_quaternion_position, rotation_to_rpy, rpy_position_to_pose
from pipeline.files.robot_spec import load_robot_spec
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.robot import load_robot, robot_with_tool
from pipeline.model.vendors import configurations, format_configuration

Q_DEG = [10.0, 30.0, -20.0, 15.0, -40.0, 25.0]
TOOL = ["--tool", "0", "0", "120", "0", "0", "0"]
#: fk prints 3 decimals of mm and deg, 9 of the quaternion.
MM_DEG_TOL, QUATERNION_TOL = 5e-4, 5e-10


def cli(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _row(out: str, label: str) -> np.ndarray:
    """The numbers of fk's row ``label``."""
    line = next(line for line in out.splitlines() if line.strip().startswith(label))
    return np.array([float(v) for v in line.split(":", 1)[1].split(",")])


def test_fk_prints_our_fk_pose_branch_and_configuration(capsys):
    code, out, err = cli(capsys, "fk", "gp7", *Q_DEG, *TOOL)
    assert code == 0 and err == ""
    robot = robot_with_tool(load_robot("gp7"), rpy_position_to_pose([0, 0, 0], [0, 0, 0.12]))
    q = np.radians(Q_DEG)
    X = robot.fk(q)
    quaternion, position = pose_to_quaternion_position(X)
    assert np.allclose(_row(out, "position [mm]"), position * 1e3, atol=MM_DEG_TOL, rtol=0)
    assert np.allclose(_row(out, "rpy [deg]"), np.degrees(rotation_to_rpy(X[:3, :3])), atol=MM_DEG_TOL, rtol=0)
    assert np.allclose(_row(out, "quaternion [w x y z]"), quaternion, atol=QUATERNION_TOL, rtol=0)
    assert f"branch:                {configuration_labels(robot, q[None])[0]}\n" in out
    assert f"yaskawa configuration: {format_configuration('yaskawa', configurations(robot, q, 'yaskawa'))}\n" in out


def test_fk_reads_the_robot_files_angle_unit_unless_told(capsys, tmp_path):
    with open(load_robot_spec("gp7").source) as file:
        document = yaml.safe_load(file)
    for joint in document["joints"]:
        for key in ("alpha", "theta_offset", "q_min", "q_max", "qd_max", "qdd_max", "qddd_max"):
            joint[key] = float(np.radians(joint[key]))
    document["angle_unit"] = "rad"
    path = tmp_path / "gp7_rad.yaml"
    path.write_text(yaml.safe_dump(document))
    _, in_deg, _ = cli(capsys, "fk", "gp7", *Q_DEG)
    _, in_rad, _ = cli(capsys, "fk", path, *np.radians(Q_DEG))
    _, told, _ = cli(capsys, "fk", "gp7", *np.radians(Q_DEG), "--unit", "rad")
    for label in ("position [mm]", "quaternion [w x y z]"):
        assert np.allclose(_row(in_rad, label), _row(in_deg, label), atol=QUATERNION_TOL, rtol=0)
        assert np.allclose(_row(told, label), _row(in_deg, label), atol=QUATERNION_TOL, rtol=0)
    assert "] rad; TCP" in in_rad and "] deg; TCP" in in_deg


def test_ik_lists_every_branch_with_the_fk_configuration_among_them(capsys):
    robot = robot_with_tool(load_robot("gp7"), rpy_position_to_pose([0, 0, 0], [0, 0, 0.12]))
    X = robot.fk(np.radians(Q_DEG))
    pose = [*(X[:3, 3] * 1e3), *np.degrees(rotation_to_rpy(X[:3, :3]))]
    code, out, err = cli(capsys, "ik", "gp7", *[f"{v:.12g}" for v in pose], *TOOL, "--seed", *Q_DEG)
    assert code == 0 and err == ""
    header, *rows = [re.split(r"\s{2,}", line.strip()) for line in out.splitlines()[3:]]
    assert header == ["#", "branch", "yaskawa", "q [deg]", "variants", "state", "sigma_min", "closest"]
    q = np.radians(Q_DEG)
    branches = {solution.branch for solution in robot.ik(X, method="analytic").solutions}
    assert len(rows) == len(branches) >= 4 and {row[1] for row in rows} == branches    # every branch, once
    number, name, config, values, _, state, _, closest = rows[0]                     # the seed's own first
    assert (number, name, state, closest) == ("1", configuration_labels(robot, q[None])[0], "free", "-")
    assert config == format_configuration("yaskawa", configurations(robot, q, "yaskawa"))
    assert [float(v) for v in values.split()] == pytest.approx(Q_DEG, abs=1e-3)


def test_ik_in_a_cell_shows_the_collision_and_the_closest_pair(capsys):
    code, out, _ = cli(capsys, "ik", "gp7", 700, 0, 450, 0, 90, 0, "--cell", "gp7_shelf_cell", *TOOL)
    assert code == 0 and "in cell gp7_shelf_cell" in out
    rows = [line for line in out.splitlines() if re.match(r"\s+\d+\s", line)]
    assert rows and all("colliding" in row and "tool - board_middle" in row for row in rows)


def test_an_unreachable_pose_is_a_result(capsys):
    code, out, err = cli(capsys, "ik", "gp7", 3000, 0, 0, 0, 0, 0)
    assert code == 0 and err == ""
    assert out.splitlines()[-1].startswith("no branch: no in-limit IK solution of the TCP target at xyz [3000.000")


@pytest.mark.parametrize("args, message", [
    (["fk", "gp7", 0, 0, 0, 0, 0], "error: joint values: gp7 has 6 joints (S, L, U, R, B, T), got 5 value(s)\n"),
    (["fk", "gp7", 0, 0, 0, "x", 0, 0], "error: joint values: joint 4 (R): 'x' is not a number\n"),
    (["fk", "gp7", 0, 0, 0, 0, 200, 0],
     "error: joint values: joint 5 (B) = 200 deg is outside its limits [-135, 135] deg\n"),
    (["fk", "gp7", 0, 0, 0, 0, 0, 400, "--unit", "rad"],
     ("error: joint values: joint 6 (T) = 400 rad is outside its limits [-6.28319, 6.28319] rad (a value beyond a "
      "turn: are these degrees? give --unit deg)\n")),
    (["ik", "gp7", 560, 0, 700, 0, 90, 0, "--seed", 0, 0, 0, 0, 0, 0, 0],
     "error: --seed: gp7 has 6 joints (S, L, U, R, B, T), got 7 value(s)\n"),
    (["ik", "gp7", 560, 0, 700, 0, 90, 0, "--seed", 0, -80, 0, 0, 0, 0],
     "error: --seed: joint 2 (L) = -80 deg is outside its limits [-65, 145] deg\n"),
    (["ik", "irb1600", 700, 0, 450, 0, 90, 0, "--cell", "gp7_shelf_cell"],
     "error: ROBOT 'irb1600' is irb1600, but the cell gp7_shelf_cell holds gp7 (gp7): name the cell's robot\n"),
])
def test_bad_joint_values_are_one_error_line(capsys, args, message):
    code, out, err = cli(capsys, *args)
    assert (code, out, err) == (2, "", message)


def test_a_rad_value_in_degrees_needs_no_hint(capsys):
    code, out, err = cli(capsys, "fk", "gp7", 0.1, 0.5, -0.3, 0, -1.2, 0)       # small degrees: fine
    assert code == 0 and err == "" and out.startswith("gp7 at q = [0.1, 0.5, -0.3, 0, -1.2, 0] deg; TCP")
