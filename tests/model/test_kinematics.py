"""NumPy reference kinematics: flange poses from models/SOURCES.md, joint axes, batch = single, shapes."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.chain.dh_convert import standard_to_modified
from pipeline.model.chain.kinematics import dh_modified, dh_standard, finite_difference_jacobian
from pipeline.model.robot import Robot, load_robot

from ..conftest import DATA_DIR

# models/SOURCES.md: flange origin [mm], z_flange and x_flange in the base frame, joint axes at q = 0.
FLANGE_AT_ZERO = {
    "gp7": ([560, 0, 815], [1, 0, 0], [0, 0, 1]),
    "lrmate200id": ([465, 0, 695], [1, 0, 0], [0, 0, 1]),
    "irb1600": ([815, 0, 961.5], [1, 0, 0], [0, 0, -1]),
}
AXES_AT_ZERO = {
    "gp7": ["+z", "+y", "-y", "-x", "-y", "-x"],
    "lrmate200id": ["+z", "+y", "-y", "-x", "-y", "-x"],
    "irb1600": ["+z", "+y", "+y", "+x", "+y", "+x"],
}
POSITION_TOL = 1e-12  # [m]


def unit(label: str) -> np.ndarray:
    v = np.zeros(3)
    v["xyz".index(label[1])] = 1.0 if label[0] == "+" else -1.0
    return v


@pytest.mark.parametrize("name", sorted(FLANGE_AT_ZERO))
def test_flange_pose_at_zero_matches_robot_facts(name):
    robot = load_robot(name)
    p_mm, z_axis, x_axis = FLANGE_AT_ZERO[name]
    X = robot.fk(np.zeros(6))
    np.testing.assert_allclose(X[:3, 3], np.array(p_mm) / 1000.0, atol=POSITION_TOL)
    np.testing.assert_allclose(X[:3, 2], z_axis, atol=1e-15)
    np.testing.assert_allclose(X[:3, 0], x_axis, atol=1e-15)


@pytest.mark.parametrize("name", sorted(AXES_AT_ZERO))
def test_joint_axes_at_zero_match_robot_facts(name):
    robot = load_robot(name)
    J = robot.jacobian(np.zeros(6))
    expected = np.array([unit(label) for label in AXES_AT_ZERO[name]]).T
    np.testing.assert_allclose(J[3:], expected, atol=1e-15)


def test_positive_joint_motion_turns_about_the_stated_axis():
    """A small positive q2 on the GP7 (axis +y) moves the flange down (-z) and forward, as J predicts."""
    robot = load_robot("gp7")
    q = np.zeros(6)
    dq = np.array([0, 1e-4, 0, 0, 0, 0])
    dp = robot.fk(q + dq)[:3, 3] - robot.fk(q)[:3, 3]
    assert dp[2] < 0 and dp[0] > 0
    np.testing.assert_allclose(dp, robot.jacobian(q)[:3] @ dq, atol=1e-8)


def test_batch_equals_single_calls(robot, rng):
    Q = robot.random_configurations(rng, 50)
    X = robot.fk_batch(Q)
    J = robot.jacobian_batch(Q)
    for i, q in enumerate(Q):
        np.testing.assert_array_equal(X[i], robot.fk(q))
        np.testing.assert_array_equal(J[i], robot.jacobian(q))


def test_fk_all_ends_at_fk_and_starts_at_base(robot, rng):
    q = robot.random_configurations(rng, 1)[0]
    frames = robot.fk_all(q)
    assert frames.shape == (robot.dof + 2, 4, 4)
    np.testing.assert_allclose(frames[-1], robot.fk(q), rtol=0, atol=1e-14)   # NumPy vs compiled
    np.testing.assert_array_equal(frames[0], robot.spec.X_BaseD0)


def test_jacobian_matches_finite_differences(robot, rng):
    for q in robot.random_configurations(rng, 20):
        np.testing.assert_allclose(robot.jacobian(q), finite_difference_jacobian(robot.fk, q), atol=1e-6)


def test_textbook_link_matrices():
    """Standard DH equals Rz Tz Tx Rx and modified equals Rx Tx Rz Tz, composed by hand."""
    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.array([[1.0, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])

    def tr(x=0.0, z=0.0):
        T = np.eye(4)
        T[0, 3], T[2, 3] = x, z
        return T

    theta, d, a, alpha = 0.7, 0.3, 0.2, -1.1
    np.testing.assert_allclose(dh_standard(theta, d, a, alpha), rz(theta) @ tr(z=d) @ tr(x=a) @ rx(alpha), atol=1e-15)
    np.testing.assert_allclose(dh_modified(alpha, a, theta, d), rx(alpha) @ tr(x=a) @ rz(theta) @ tr(z=d), atol=1e-15)


def test_same_arm_in_standard_and_modified_dh_gives_the_same_fk(rng):
    """Seed 004's arm: models/arm6.yaml (standard) vs a hand-written modified-DH file."""
    standard = load_robot("arm6")
    modified = load_robot(DATA_DIR / "arm6_modified.yaml")
    assert modified.spec.convention == "modified"
    for q in standard.random_configurations(rng, 200):
        np.testing.assert_allclose(modified.fk(q), standard.fk(q), atol=1e-15)
        np.testing.assert_allclose(modified.jacobian(q), standard.jacobian(q), atol=1e-14)


@pytest.mark.parametrize("name", ["gp7", "lrmate200id", "irb1600", "arm6"])
def test_standard_to_modified_conversion_keeps_fk(name, rng):
    standard = load_robot(name)
    modified = Robot(standard_to_modified(standard.spec))
    for q in standard.random_configurations(rng, 100):
        np.testing.assert_allclose(modified.fk(q), standard.fk(q), atol=1e-14)
        np.testing.assert_allclose(modified.jacobian(q), standard.jacobian(q), atol=1e-14)


def test_prismatic_joint_moves_along_its_axis():
    doc = {
        "name": "gantry", "convention": "standard", "length_unit": "m", "angle_unit": "rad",
        "joints": [
            {"type": "prismatic", "a": 0, "alpha": 0, "d": 0.5, "sign": -1, "q_min": -1, "q_max": 1, "qd_max": 1},
            {"a": 0.3, "alpha": 0, "d": 0, "q_min": -3, "q_max": 3, "qd_max": 1},
        ],
    }
    robot = Robot(parse_robot_spec(doc))
    np.testing.assert_allclose(robot.fk([0.2, 0.0])[:3, 3], [0.3, 0.0, 0.3], atol=1e-15)
    J = robot.jacobian([0.2, 0.4])
    np.testing.assert_allclose(J[:, 0], [0, 0, -1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(J, finite_difference_jacobian(robot.fk, np.array([0.2, 0.4])), atol=1e-8)


@pytest.mark.parametrize("bad", [np.zeros(5), np.zeros((6, 1)), [0, 0, 0, 0, 0, np.nan], [0, 0, 0, np.inf, 0, 0]])
def test_bad_configuration_is_a_typed_error(bad):
    with pytest.raises(ConfigurationError, match="gp7"):
        load_robot("gp7").fk(bad)


def test_bad_batch_is_a_typed_error():
    robot = load_robot("gp7")
    with pytest.raises(ConfigurationError):
        robot.fk_batch(np.zeros((3, 5)))
    with pytest.raises(ConfigurationError):
        robot.jacobian_batch(np.full((2, 6), np.nan))


def test_kinematics_module_never_imports_drake():
    import ast
    import inspect

    import pipeline.files.robot_spec
    import pipeline.model.chain.kinematics
    import pipeline.model.robot

    for module in (pipeline.model.chain.kinematics, pipeline.model.robot, pipeline.files.robot_spec):
        tree = ast.parse(inspect.getsource(module))
        imported = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        assert not any(name.startswith("pydrake") for name in imported), module.__name__


def test_robot_prints_its_dh_table():
    text = str(load_robot("irb1600"))
    assert "theta_off[deg]" in text and "486.5" in text
