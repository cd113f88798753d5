"""Odd arguments to the public Python API are ConfigurationErrors naming the argument, never NumPy's
or Python's own exceptions; an IK search that runs out of budget is a failed result with a reason."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline import compute_singularity, load_robot
from pipeline.errors import ConfigurationError
from pipeline.files.poses import check_pose, quaternion_position_to_pose
from pipeline.model.chain.dh_convert import standard_to_modified
from pipeline.model.jacobian_check import check_robot

ROBOT = load_robot("gp7")
NOT_POSES = {"text": "pose", "dict": {"xyz": [0, 0, 0]}, "ragged": [[1, 0, 0, 0], [0, 1, 0]], "none": None,
             "bools": np.eye(4, dtype=bool), "objects": np.array([object()] * 16).reshape(4, 4),
             "nan": np.full((4, 4), np.nan), "inf": np.where(np.eye(4) > 0, np.inf, 0.0), "3x3": np.eye(3),
             "huge rotation": np.eye(4) * 1e308}
NOT_CONFIGURATIONS = {"text": "q", "short": [0.0] * 5, "nan": [0, 0, np.nan, 0, 0, 0], "strings": ["a"] * 6,
                      "huge": [1e308] * 6, "none": None, "dict": {"q1": 0}, "ragged": [[0, 0], [0]]}


@pytest.mark.parametrize("case", list(NOT_POSES))
def test_a_pose_that_is_not_a_pose(case):
    with pytest.raises(ConfigurationError, match="pose|IK target"):
        check_pose(NOT_POSES[case])
    for method in ("analytic", "jacobian", "auto"):
        with pytest.raises(ConfigurationError, match="IK target"):
            ROBOT.ik(NOT_POSES[case], method=method)


@pytest.mark.parametrize("case", list(NOT_CONFIGURATIONS))
def test_a_configuration_that_is_not_one(case):
    value = NOT_CONFIGURATIONS[case]
    for call in (ROBOT.fk, ROBOT.jacobian, ROBOT.fk_all, ROBOT.joint_frames):
        with pytest.raises(ConfigurationError, match="gp7: q"):
            call(value)
    if value is not None:                           # q_seed=None: the middle of the ranges
        with pytest.raises(ConfigurationError):
            ROBOT.ik(ROBOT.fk(np.zeros(6)), q_seed=value, method="jacobian")


def test_batches_and_jacobians_are_checked():
    with pytest.raises(ConfigurationError, match=r"must have shape \(N, 6\)"):
        ROBOT.fk_batch(np.zeros((3, 5)))
    with pytest.raises(ConfigurationError, match=r"IK targets must have shape \(N, 4, 4\)"):
        ROBOT.ik_batch(np.zeros((3, 4)))
    with pytest.raises(ConfigurationError, match=r"IK path poses"):
        ROBOT.ik_path([[1, 2], [3]], np.zeros(6))
    with pytest.raises(ConfigurationError, match=r"Jacobian must have shape \(6, N\)"):
        compute_singularity(np.zeros((5, 6)))
    with pytest.raises(ConfigurationError, match="twist"):
        ROBOT.joint_velocities(np.zeros(6), [1e308] * 6)


@pytest.mark.parametrize("X_far", [1.7e308, -1e308, 2e6])
@pytest.mark.parametrize("method", ["auto", "analytic", "jacobian", "drake"])
def test_absurdly_far_targets_are_refused(X_far, method):
    X = np.eye(4)
    X[0, 3] = X_far
    with pytest.raises(ConfigurationError, match="beyond 1e\\+06 m"):
        ROBOT.ik(X, method=method)
    with pytest.raises(ConfigurationError, match="beyond"):
        ROBOT.ik_batch(X[None], method=method if method != "drake" else "analytic")


@pytest.mark.parametrize("options, problem", [
    ({"max_iterations": 0}, "max_iterations must be an integer >= 1"),
    ({"max_restarts": -1}, "max_restarts must be an integer >= 0"),
    ({"max_restarts": 1.5}, "max_restarts must be an integer"),
    ({"time_budget": float("nan")}, "time_budget must be a finite number"),
    ({"time_budget": -1.0}, "time_budget must be a finite number"),
    ({"max_iteration": 5}, "unknown IK option 'max_iteration'"),
])
@pytest.mark.parametrize("method", ["jacobian", "drake"])
def test_bad_search_options_name_the_option(options, problem, method):
    if method == "drake" and "max_iterations" in options:
        options = {"max_restarts": -1}
        problem = "max_restarts must be an integer >= 0"
    with pytest.raises(ConfigurationError, match=problem):
        ROBOT.ik(ROBOT.fk(np.full(6, 0.3)), method=method, **options)


def test_a_zero_time_budget_is_one_attempt_and_a_result():
    X = ROBOT.fk(np.full(6, 0.3))
    result = ROBOT.ik(X, q_seed=np.full(6, -1.0), method="jacobian", time_budget=0.0)
    assert result.success in (True, False) and (result.success or result.reason)
    assert result.q.shape == (6,)


def test_other_api_arguments():
    with pytest.raises(ConfigurationError, match="samples must be >= 1"):
        check_robot(ROBOT, samples=0)
    with pytest.raises(ConfigurationError, match="expected a standard-DH spec"):
        standard_to_modified(standard_to_modified(ROBOT.spec))
    with pytest.raises(ConfigurationError, match="quaternion must hold numbers"):
        quaternion_position_to_pose("wxyz", [0, 0, 0])
    with pytest.raises(ConfigurationError, match="unit length"):
        quaternion_position_to_pose([1e308, 0, 0, 0], [0, 0, 0])
