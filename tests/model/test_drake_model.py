"""The Drake plant built from a RobotSpec: structure, limits, frames, and agreement with NumPy."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.chain.drake_model import (
    BASE_FRAME,
    END_FRAME,
    PLACEHOLDER_MASS_KG,
    angular_first_to_linear_first,
    build_drake_robot,
)
from pipeline.model.robot import Robot

EXACT = 1e-12


def test_plant_structure_and_limits(robot, drake_robots):
    drake = drake_robots[robot.name]
    plant = drake.plant
    assert plant.is_finalized()
    assert plant.num_positions() == robot.dof == plant.num_velocities()
    limits = robot.limits
    np.testing.assert_allclose(plant.GetPositionLowerLimits(), limits.q_min)
    np.testing.assert_allclose(plant.GetPositionUpperLimits(), limits.q_max)
    np.testing.assert_allclose(plant.GetVelocityUpperLimits(), limits.qd_max)
    np.testing.assert_allclose(plant.GetVelocityLowerLimits(), -limits.qd_max)
    if limits.qdd_max is not None:
        np.testing.assert_allclose(plant.GetAccelerationUpperLimits(), limits.qdd_max)
    for i, name in enumerate(robot.joint_names, start=1):
        assert plant.HasJointNamed(name)
        assert plant.HasBodyNamed(f"link{i}")
    assert plant.HasFrameNamed(BASE_FRAME) and plant.HasFrameNamed(END_FRAME)


def test_drake_fk_and_jacobian_equal_numpy(robot, drake_robots, rng):
    drake = drake_robots[robot.name]
    for q in robot.random_configurations(rng, 200):
        np.testing.assert_allclose(drake.fk(q), robot.fk(q), atol=EXACT, rtol=0)
        np.testing.assert_allclose(drake.jacobian(q), robot.jacobian(q), atol=EXACT, rtol=0)


def test_row_order_conversion_is_linear_first():
    J_wv = np.arange(12.0).reshape(6, 2)
    np.testing.assert_array_equal(angular_first_to_linear_first(J_wv), np.vstack([J_wv[3:], J_wv[:3]]))


def test_base_tool_prismatic_and_modified_rows_agree_with_numpy(rng):
    """Every row type (standard/modified x revolute/prismatic, signs, offsets, base and tool)."""
    joints = [
        {"a": 50, "alpha": -90, "d": 300, "theta_offset": 30, "sign": -1, "q_min": -170, "q_max": 170, "qd_max": 90},
        {"type": "prismatic", "a": 20, "alpha": 90, "d": 100, "theta_offset": -45, "sign": -1,
         "q_min": -200, "q_max": 200, "qd_max": 500},
        {"a": 200, "alpha": 0, "d": 40, "theta_offset": 90, "q_min": -170, "q_max": 170, "qd_max": 90,
         "inertia": {"mass": 2.0, "com": [100, 0, 0], "I": [0.01, 0.02, 0.02, 0, 0, 0]}},
    ]
    for convention in ("standard", "modified"):
        doc = {
            "name": f"mixed_{convention}", "convention": convention, "length_unit": "mm", "angle_unit": "deg",
            "joints": joints,
            "base": {"xyz": [10, -20, 30], "rpy": [5, -10, 15]},
            "tool": {"xyz": [0, 15, 120], "rpy": [90, 0, -30]},
        }
        robot = Robot(parse_robot_spec(doc))
        drake = build_drake_robot(robot.spec)
        assert drake.plant.GetBodyByName("link3").default_mass() == pytest.approx(2.0)
        assert drake.plant.GetBodyByName("link1").default_mass() == pytest.approx(PLACEHOLDER_MASS_KG)
        for q in robot.random_configurations(rng, 50):
            np.testing.assert_allclose(drake.fk(q), robot.fk(q), atol=EXACT, rtol=0)
            np.testing.assert_allclose(drake.jacobian(q), robot.jacobian(q), atol=EXACT, rtol=0)
