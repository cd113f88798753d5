"""Continuous joints (``continuous: true``): no position limits, q_min = -inf and q_max = +inf in
``Limits``, and every consumer of the limits takes that as "no limit": robot files, random
configurations, timing and its certificate, the robot file and URDF written back, the Drake plant, the
planning box and a job's JSON report. Robots are preset copies with continuous rows, written to tmp_path."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline import load_robot
from pipeline.cell.planning import joint_space, planning_box
from pipeline.errors import InvalidValueError, MissingFieldError, RobotFileError
from pipeline.files.robot_spec import PRESETS
from pipeline.files.robot_writer import robot_document, robot_file_text, write_robot_file
from pipeline.model.chain.drake_model import build_plant
from pipeline.runner import run_job_file
from pipeline.timing import retime
from pipeline.urdf import import_urdf, urdf_text, write_urdf

#: (preset, 1-based joints made continuous): a spherical wrist's 4 and 6, and a base (rotary table).
ROBOTS = {"arm6_wrist": ("arm6", (4, 6)), "gp7_base": ("gp7", (1,))}


def preset_document(preset: str) -> dict:
    return yaml.safe_load((PRESETS / f"{preset}.yaml").read_text())


def write_doc(tmp_path: Path, document: dict, name: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


def continuous_file(tmp_path: Path, key: str) -> Path:
    """A preset's robot file with the rows of ROBOTS[key] made continuous (their q_min, q_max dropped)."""
    preset, joints = ROBOTS[key]
    document = preset_document(preset)
    document["name"] = key
    for j in joints:
        row = document["joints"][j - 1]
        del row["q_min"], row["q_max"]
        row["continuous"] = True
    return write_doc(tmp_path, document, key)


@pytest.fixture(params=sorted(ROBOTS))
def pair(request, tmp_path):
    """(the continuous robot, its preset, the 0-based continuous joints)."""
    preset, joints = ROBOTS[request.param]
    return load_robot(continuous_file(tmp_path, request.param)), load_robot(preset), [j - 1 for j in joints]


# -- loading and kinematics --------------------------------------------------------------------------
def test_continuous_rows_load_without_position_limits(pair):
    robot, _, joints = pair
    limits = robot.limits
    assert list(np.flatnonzero(limits.continuous)) == joints
    assert np.all(limits.q_min[joints] == -np.inf) and np.all(limits.q_max[joints] == np.inf)
    assert np.isfinite(np.delete(limits.q_min, joints)).all() and np.isfinite(np.delete(limits.q_max, joints)).all()
    assert [j.is_continuous for j in robot.spec.joints] == list(limits.continuous)
    assert np.all(limits.q_middle[joints] == 0.0) and np.isfinite(limits.q_middle).all()
    assert "inf" in robot.spec.dh_table()


def test_fk_and_jacobian_are_the_presets_and_turn_with_period_two_pi(pair, rng):
    robot, preset, joints = pair
    for q in preset.random_configurations(rng, 20):
        np.testing.assert_array_equal(robot.fk(q), preset.fk(q))
        np.testing.assert_array_equal(robot.jacobian(q), preset.jacobian(q))
        turned = q.copy()
        turned[joints] += np.array([3.0, -2.0][: len(joints)]) * 2.0 * np.pi     # beyond +-2 pi
        np.testing.assert_allclose(robot.fk(turned), robot.fk(q), atol=1e-12)
        np.testing.assert_allclose(robot.jacobian(turned), robot.jacobian(q), atol=1e-12)


def test_random_configurations_draw_continuous_joints_in_plus_minus_pi(pair):
    robot, preset, joints = pair
    for margin in (0.0, 0.2):
        Q = robot.random_configurations(np.random.default_rng(7), 2000, margin=margin)
        assert np.isfinite(Q).all()
        assert np.abs(Q[:, joints]).max() <= np.pi and np.abs(Q[:, joints]).max() > 0.95 * np.pi
        # the other joints draw exactly what the preset's do
        others = [j for j in range(robot.dof) if j not in joints]
        ours = preset.random_configurations(np.random.default_rng(7), 2000, margin=margin)
        np.testing.assert_array_equal(Q[:, others], ours[:, others])


# -- timing --------------------------------------------------------------------------------------------
def waypoints_beyond_two_turns(robot, joints) -> np.ndarray:
    """Three waypoints in the middle of the finite ranges, the continuous joints at 0, 7.5 and -8 rad."""
    W = np.tile(np.where(robot.limits.continuous, 0.0, robot.limits.q_middle), (3, 1))
    W[1] += 0.3
    W[:, joints] = np.array([0.0, 7.5, -8.0])[:, None]
    return W


@pytest.mark.parametrize("method, shape", [("toppra", "monotone"), ("toppra", "spline"), ("toppra", "linear"),
                                           ("ruckig", "monotone"), ("topp3", "monotone")])
def test_timing_through_waypoints_beyond_two_turns_certifies(pair, method, shape):
    robot, _, joints = pair
    W = waypoints_beyond_two_turns(robot, joints)
    profile = retime(robot, W, method=method, shape=shape, speed_scale=0.8)
    report = profile.certificate
    assert report.passed
    assert all(np.isfinite(ratios).all() for ratios in report.ratios.values())
    assert np.all(report.ratios["q"][joints] == 0.0)                  # no limit to come near
    assert np.isfinite(profile.q).all() and np.isfinite(profile.qd).all()
    np.testing.assert_allclose(profile.q[-1], W[-1], atol=1e-9)
    assert profile.q[:, joints].max() > 2.0 * np.pi and profile.q[:, joints].min() < -2.0 * np.pi


# -- writing back: robot file, URDF, Drake ----------------------------------------------------------
def test_robot_file_round_trips(pair, tmp_path):
    robot, _, joints = pair
    document = robot_document(robot.spec, length_unit="m", angle_unit="rad")
    for j, row in enumerate(document["joints"]):
        assert (row.get("continuous") is True) == (j in joints)
        assert ("q_min" in row and "q_max" in row) == (j not in joints)
    written = load_robot(write_robot_file(document, tmp_path / "written.yaml"))
    np.testing.assert_allclose(written.limits.q_min, robot.limits.q_min, rtol=0, atol=1e-13)   # inf == inf
    np.testing.assert_allclose(written.limits.q_max, robot.limits.q_max, rtol=0, atol=1e-13)
    Q = robot.random_configurations(np.random.default_rng(3), 50)
    assert max(float(np.abs(written.fk(q) - robot.fk(q)).max()) for q in Q) < 1e-12
    assert robot_file_text(robot_document(written.spec)) == robot_file_text(robot_document(robot.spec))


def test_urdf_export_writes_continuous_joints_and_import_gives_them_back(pair, tmp_path):
    robot, _, joints = pair
    path = write_urdf(robot, tmp_path / "robot.urdf")
    elements = ET.fromstring(path.read_text()).findall("joint")[: robot.dof]
    for j, element in enumerate(elements):
        limit = element.find("limit").attrib
        assert (element.get("type") == "continuous") == (j in joints)
        assert ("lower" in limit and "upper" in limit) == (j not in joints)
        assert float(limit["velocity"]) == robot.spec.joints[j].qd_max and "effort" in limit
    imported = import_urdf(path)
    assert [bool(row.get("continuous")) for row in imported.document["joints"]] == list(robot.limits.continuous)
    assert not any("continuous" in note for note in imported.document["assumptions"])
    assert imported.max_fk_error_m < 1e-12
    np.testing.assert_array_equal(imported.robot.limits.continuous, robot.limits.continuous)


def test_exported_urdf_parses_in_drake_without_position_limits(pair):
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    robot, _, joints = pair
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.SetStrictParsing()
    parser.AddModelsFromString(urdf_text(robot.spec), "urdf")
    plant.Finalize()
    lower = [plant.GetJointByName(name).position_lower_limits()[0] for name in robot.joint_names]
    np.testing.assert_array_equal(lower, robot.limits.q_min)


def test_drake_plant_has_no_position_limits_on_continuous_joints(pair):
    robot, _, joints = pair
    plant = build_plant(robot.spec)
    np.testing.assert_array_equal(plant.GetPositionLowerLimits(), robot.limits.q_min)
    np.testing.assert_array_equal(plant.GetPositionUpperLimits(), robot.limits.q_max)
    np.testing.assert_array_equal(plant.GetVelocityUpperLimits(), robot.limits.qd_max)


# -- planning --------------------------------------------------------------------------------------------
def test_planning_box_is_half_a_turn_beyond_start_and_goal_on_continuous_joints(pair):
    robot, _, joints = pair
    q_start, q_goal = np.zeros(robot.dof), np.zeros(robot.dof)
    q_start[joints], q_goal[joints] = 7.0, -8.0
    low, high = planning_box(robot.limits, q_start, q_goal)
    np.testing.assert_allclose(low[joints], -8.0 - np.pi)
    np.testing.assert_allclose(high[joints], 7.0 + np.pi)
    others = [j for j in range(robot.dof) if j not in joints]
    np.testing.assert_array_equal(low[others], robot.limits.q_min[others])
    np.testing.assert_array_equal(high[others], robot.limits.q_max[others])
    space, _, start, goal = joint_space(robot, q_start, q_goal)
    bounds = space.getBounds()
    assert [bounds.low[j] for j in range(robot.dof)] == list(low)
    assert space.satisfiesBounds(start) and space.satisfiesBounds(goal)


# -- errors ----------------------------------------------------------------------------------------------
def continuous_slide() -> dict:
    """A linear axis carrying a one-joint arm, the axis said to be continuous."""
    return {"name": "slide", "convention": "standard", "length_unit": "mm", "angle_unit": "deg",
            "joints": [{"a": 0, "alpha": 0, "d": 0, "type": "prismatic", "continuous": True, "qd_max": 200},
                       {"a": 300, "alpha": 0, "d": 0, "q_min": -90, "q_max": 90, "qd_max": 180}]}


def arm6_row(change) -> dict:
    document = preset_document("arm6")
    change(document["joints"][3])
    return document


BAD = {
    "limits with continuous": (lambda: arm6_row(lambda row: row.update(continuous=True)),
                               InvalidValueError, "joints[3].q_min", 3, -170, "has no position limits"),
    "one limit with continuous": (lambda: arm6_row(lambda row: (row.update(continuous=True), row.pop("q_min"))),
                                  InvalidValueError, "joints[3].q_max", 3, 170, "has no position limits"),
    "continuous prismatic": (continuous_slide, InvalidValueError, "joints[0].continuous", 0, True,
                             "only a revolute joint"),
    "continuous not a flag": (lambda: arm6_row(lambda row: (row.update(continuous="yes"), row.pop("q_min"),
                                                            row.pop("q_max"))),
                              InvalidValueError, "joints[3].continuous", 3, "yes", "must be true or false"),
    "no limits, not continuous": (lambda: arm6_row(lambda row: (row.pop("q_min"), row.pop("q_max"))),
                                  MissingFieldError, "joints[3].q_min", 3, None, "continuous: true"),
    "no limits, continuous false": (lambda: arm6_row(lambda row: (row.update(continuous=False), row.pop("q_max"))),
                                    MissingFieldError, "joints[3].q_max", 3, None, "continuous: true"),
    "four turns": (lambda: arm6_row(lambda row: row.update(q_min=-720, q_max=720)),
                   InvalidValueError, "joints[3].q_max", 3, 720, "continuous: true instead"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_continuous_rows_are_typed_errors_naming_file_field_joint_and_value(case, tmp_path):
    make, kind, field, joint, value, problem = BAD[case]
    path = write_doc(tmp_path, make(), "bad")
    with pytest.raises(kind) as error:
        load_robot(path)
    assert isinstance(error.value, RobotFileError)
    assert error.value.source == str(path) and str(error.value).startswith(f"{path}:")
    assert error.value.field == field and error.value.joint == joint and error.value.value == value
    assert problem in error.value.problem


# -- a job and its JSON report ----------------------------------------------------------------------------
def strict_json(text: str):
    """JSON as the standard has it: NaN and Infinity are errors."""
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_a_job_with_continuous_joints_writes_a_valid_json_report(tmp_path):
    robot_path = continuous_file(tmp_path, "arm6_wrist")
    job = {"description": "wrist turns beyond two turns", "robot": robot_path.name, "angle_unit": "rad",
           "waypoints": [[0.0, 0.5, 0.5, 0.0, 0.5, 0.0], [0.5, 0.7, 0.3, 7.0, -0.4, -8.0],
                         [0.2, 0.6, 0.4, -7.5, 0.3, 9.0]],
           "timing": "toppra", "outputs": ["json", "csv", "png"]}
    job_path = tmp_path / "job.yaml"
    job_path.write_text(yaml.safe_dump(job, sort_keys=False))
    outcome = run_job_file(job_path, tmp_path / "out")
    report = strict_json((tmp_path / "out" / "report.json").read_text())
    for view in ("timed", "unscaled"):
        values = report["limits"][view]["values"]
        assert values["q_min"][3] is None and values["q_max"][5] is None
        assert values["q_min"][0] == pytest.approx(-math.radians(170)) and values["qd_max"][3] is not None
        assert report["limits"][view]["ratios"]["q"][3] == 0.0
    assert report["limits"]["timed"]["passed"]               # (toppra does not limit the robot's own jerk)
    assert outcome.profile.q[:, 5].max() >= 9.0 - 1e-9 and (tmp_path / "out" / "profile.png").stat().st_size > 0
