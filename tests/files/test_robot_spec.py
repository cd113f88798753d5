"""Robot file format: the documented core is accepted as written; every bad input is a typed error
naming the file, the joint and the field."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import yaml

from pipeline.errors import (
    InvalidValueError,
    MissingFieldError,
    RobotFileError,
    RobotNotFoundError,
    UnknownFieldError,
)
from pipeline.files.poses import rpy_to_rotation
from pipeline.files.robot_spec import load_robot_spec, parse_robot_spec

CORE_EXAMPLE = """
name: my_arm
convention: standard        # standard (distal DH) | modified (Craig, proximal)
length_unit: mm             # mm | m
angle_unit: deg             # deg | rad
joints:                     # base to tip, one row per joint
  - {a: 25, alpha: -90, d: 400, theta_offset: 0, sign: -1, q_min: -170, q_max: 170, qd_max: 360}
tool: {xyz: [0, 0, 0], rpy: [0, 0, 0]}   # optional fixed transform after the last DH frame
base: {xyz: [0, 0, 0], rpy: [0, 0, 0]}   # optional fixed transform before the first DH frame
"""


def valid_doc() -> dict:
    return {
        "name": "two_link",
        "convention": "standard",
        "length_unit": "mm",
        "angle_unit": "deg",
        "joints": [
            {"a": 100, "alpha": 0, "d": 0, "q_min": -90, "q_max": 90, "qd_max": 180},
            {"a": 50, "alpha": 0, "d": 0, "q_min": -90, "q_max": 90, "qd_max": 180},
        ],
    }


def write(tmp_path, doc) -> str:
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(doc) if isinstance(doc, dict) else doc)
    return str(path)


def test_core_example_is_accepted_exactly_as_written(tmp_path):
    spec = load_robot_spec(write(tmp_path, CORE_EXAMPLE))
    joint = spec.joints[0]
    assert spec.name == "my_arm" and spec.dof == 1
    assert joint.a == pytest.approx(0.025) and joint.d == pytest.approx(0.4)
    assert joint.alpha == pytest.approx(-math.pi / 2) and joint.sign == -1.0
    assert joint.q_min == pytest.approx(-170 * math.pi / 180) and joint.qd_max == pytest.approx(2 * math.pi)
    assert joint.kind == "revolute" and joint.name == "joint1"
    assert spec.limits.qdd_max is None


def test_defaults_sign_offset_and_identity_frames():
    spec = parse_robot_spec(valid_doc())
    assert all(j.sign == 1.0 and j.theta_offset == 0.0 for j in spec.joints)
    np.testing.assert_array_equal(spec.X_BaseD0, np.eye(4))
    np.testing.assert_array_equal(spec.X_DnE, np.eye(4))


def test_rpy_is_rz_ry_rx_about_fixed_axes():
    roll, pitch, yaw = 0.3, -0.4, 1.1
    rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)], [0, math.sin(roll), math.cos(roll)]])
    ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0], [-math.sin(pitch), 0, math.cos(pitch)]])
    rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    np.testing.assert_allclose(rpy_to_rotation(roll, pitch, yaw), rz @ ry @ rx, atol=1e-15)


def test_tool_and_base_are_converted_to_si():
    doc = valid_doc()
    doc["tool"] = {"xyz": [0, 0, 100], "rpy": [0, 0, 90]}
    doc["base"] = {"xyz": [10, 0, 0]}
    spec = parse_robot_spec(doc)
    np.testing.assert_allclose(spec.X_DnE[:3, 3], [0, 0, 0.1])
    np.testing.assert_allclose(spec.X_DnE[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(spec.X_BaseD0[:3, 3], [0.01, 0, 0])


def test_prismatic_limits_are_lengths():
    doc = valid_doc()
    doc["joints"][1].update(type="prismatic", q_min=0, q_max=200, qd_max=500)
    joint = parse_robot_spec(doc).joints[1]
    assert joint.kind == "prismatic"
    assert (joint.q_min, joint.q_max, joint.qd_max) == pytest.approx((0.0, 0.2, 0.5))


def test_dh_table_prints_headers_for_the_convention():
    spec = parse_robot_spec(valid_doc())
    text = str(spec)
    assert "a[mm]" in text and "alpha[deg]" in text and "two_link" in text
    doc = valid_doc()
    doc["convention"] = "modified"
    assert "alpha_i-1[deg]" in str(parse_robot_spec(doc))


def mutate(path, value):
    """A copy of the valid document with ``path`` (tuple of keys/indices) set, or deleted if value is DELETE."""
    doc = copy.deepcopy(valid_doc())
    target = doc
    for key in path[:-1]:
        target = target[key]
    if value is DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return doc


DELETE = object()

BAD_INPUTS = [
    # (what, path, value, error type, joint index, field named)
    ("unknown top key", ("colour",), "red", UnknownFieldError, None, "colour"),
    ("unknown joint key", ("joints", 1, "alfa"), 0, UnknownFieldError, 1, "alfa"),
    ("missing convention", ("convention",), DELETE, MissingFieldError, None, "convention"),
    ("missing length unit", ("length_unit",), DELETE, MissingFieldError, None, "length_unit"),
    ("missing angle unit", ("angle_unit",), DELETE, MissingFieldError, None, "angle_unit"),
    ("bad convention", ("convention",), "distal", InvalidValueError, None, "convention"),
    ("bad length unit", ("length_unit",), "inch", InvalidValueError, None, "length_unit"),
    ("bad angle unit", ("angle_unit",), "grad", InvalidValueError, None, "angle_unit"),
    ("empty joint list", ("joints",), [], InvalidValueError, None, "joints"),
    ("missing joint field", ("joints", 0, "d"), DELETE, MissingFieldError, 0, "d"),
    ("q_min equal q_max", ("joints", 1, "q_min"), 90, InvalidValueError, 1, "q_min"),
    ("q_min above q_max", ("joints", 0, "q_min"), 100, InvalidValueError, 0, "q_min"),
    ("non-finite limit", ("joints", 1, "q_max"), float("inf"), InvalidValueError, 1, "q_max"),
    ("NaN length", ("joints", 0, "a"), float("nan"), InvalidValueError, 0, "a"),
    ("zero speed", ("joints", 1, "qd_max"), 0, InvalidValueError, 1, "qd_max"),
    ("negative speed", ("joints", 0, "qd_max"), -5, InvalidValueError, 0, "qd_max"),
    ("negative acceleration", ("joints", 0, "qdd_max"), -1, InvalidValueError, 0, "qdd_max"),
    ("text for a number", ("joints", 0, "alpha"), "ninety", InvalidValueError, 0, "alpha"),
    ("boolean for a number", ("joints", 1, "d"), True, InvalidValueError, 1, "d"),
    ("sign not +-1", ("joints", 1, "sign"), 2, InvalidValueError, 1, "sign"),
    ("unknown joint type", ("joints", 0, "type"), "spherical", InvalidValueError, 0, "type"),
    ("tool xyz too short", ("tool",), {"xyz": [0, 0]}, InvalidValueError, None, "tool.xyz"),
    ("unknown tool key", ("tool",), {"xyz": [0, 0, 0], "quat": [1, 0, 0, 0]}, UnknownFieldError, None, "tool.quat"),
    ("bad inertia", ("joints", 0, "inertia"), {"mass": -1}, InvalidValueError, 0, "inertia.mass"),
    ("duplicate joint names", ("joints", 1, "name"), "joint1", InvalidValueError, 1, "name"),
    ("torque limit without inertia", ("joints", 0, "tau_max"), 10, MissingFieldError, 0, "inertia"),
    ("negative torque limit", ("joints", 0, "tau_max"), -10, InvalidValueError, 0, "tau_max"),
]


@pytest.mark.parametrize("what, path, value, error, joint, field", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_input_is_a_typed_error_naming_file_joint_and_field(tmp_path, what, path, value, error, joint, field):
    source = write(tmp_path, mutate(path, value))
    with pytest.raises(error) as info:
        load_robot_spec(source)
    exc = info.value
    assert isinstance(exc, RobotFileError)
    full_field = field if joint is None else f"joints[{joint}].{field}"
    assert exc.source == source and exc.field == full_field and exc.joint == joint
    assert str(exc).startswith(f"{source}:{exc.line}: {full_field}: ") and exc.line >= 1


def test_acceleration_limits_all_or_none():
    doc = valid_doc()
    doc["joints"][0]["qdd_max"] = 500
    with pytest.raises(MissingFieldError, match=r"joints\[1\]\.qdd_max"):
        parse_robot_spec(doc)


def test_unphysical_inertia_is_rejected():
    doc = valid_doc()
    doc["joints"][0]["inertia"] = {"mass": 1.0, "I": [1.0, 0.1, 0.1, 0, 0, 0]}
    with pytest.raises(InvalidValueError, match=r"joints\[0\]\.inertia\.I"):
        parse_robot_spec(doc)


def test_invalid_yaml_and_non_mapping(tmp_path):
    with pytest.raises(RobotFileError, match="not valid YAML"):
        load_robot_spec(write(tmp_path, "name: [unclosed\n"))
    with pytest.raises(InvalidValueError, match="mapping"):
        load_robot_spec(write(tmp_path, "- just\n- a list\n"))


def test_unknown_robot_names_the_presets():
    with pytest.raises(RobotNotFoundError, match="gp7"):
        load_robot_spec("no_such_robot")


@pytest.mark.parametrize("key, value, hint", [
    ("qd_max", 3.93, "is it in rad/s? Then write 225.2 (deg/s)"),           # rad/s typed under degrees
    ("qdd_max", 10.0, "is it in rad/s^2? Then write 573 (deg/s^2)"),
    ("qd_max", 0.05, ""),                                                  # slower than any axis in either unit
])
def test_joint_rates_plausible_only_in_radians_get_the_hint(tmp_path, key, value, hint):
    """qd_max: 3.93 under degrees (0.069 rad/s) ended in 'near a shoulder singularity' far from the file."""
    doc = valid_doc()
    doc["joints"][0][key] = value
    with pytest.raises(RobotFileError) as error:
        load_robot_spec(write(tmp_path, doc))
    assert error.value.field == f"joints[0].{key}" and "slower than any robot axis" in str(error.value)
    assert hint in str(error.value)
