"""Poses as quaternion + position and back (seed 003)."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.poses import pose_to_quaternion_position, quaternion_position_to_pose
from pipeline.model.robot import load_robot


def test_round_trip_on_irb1600_poses(rng):
    robot = load_robot("irb1600")
    for X in robot.fk_batch(robot.random_configurations(rng, 100)):
        quat, p = pose_to_quaternion_position(X)
        assert quat[0] >= 0 and np.linalg.norm(quat) == pytest.approx(1.0)
        np.testing.assert_allclose(quaternion_position_to_pose(quat, p), X, atol=1e-14)


def test_known_quaternion_is_scalar_first():
    X = quaternion_position_to_pose([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], [1, 2, 3])
    np.testing.assert_allclose(X[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    quat, p = pose_to_quaternion_position(X)
    np.testing.assert_allclose(quat, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-15)


def test_irb1600_flange_at_zero_quaternion():
    """Flange at q = 0: z along base +x, x along base -z: a +90 deg turn about base y."""
    quat, p = pose_to_quaternion_position(load_robot("irb1600").fk(np.zeros(6)))
    np.testing.assert_allclose(quat, [np.sqrt(0.5), 0, np.sqrt(0.5), 0], atol=1e-15)
    np.testing.assert_allclose(p, [0.815, 0, 0.9615], atol=1e-15)


@pytest.mark.parametrize("X", [np.eye(3), np.diag([1.0, 1, -1, 1]), np.diag([2.0, 1, 1, 1]), np.full((4, 4), np.nan)])
def test_bad_pose_is_a_typed_error(X):
    with pytest.raises(ConfigurationError):
        pose_to_quaternion_position(X)


def test_non_unit_quaternion_is_a_typed_error():
    with pytest.raises(ConfigurationError, match="unit"):
        quaternion_position_to_pose([1, 1, 0, 0], [0, 0, 0])
