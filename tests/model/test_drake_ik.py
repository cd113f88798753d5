"""Drake IK: FK -> IK -> FK round trips, judged by our own FK, and honest failures."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.model.ik import solve_ik
from pipeline.model.ik.drake_ik import IPOPT, SNOPT, pick_solver, solve_drake
from pipeline.model.ik.result import MATCHED_COMPONENTS, is_strict, make_target, pose_errors, within_limits
from pipeline.model.robot import load_robot

ROUND_TRIPS = 30
MIN_STRICT_RATE = 0.9


def _strict(robot, q, target) -> bool:
    return is_strict(*pose_errors(robot.fk(q), target)) and within_limits(q, robot.limits.q_min, robot.limits.q_max)


@pytest.mark.parametrize("name", ["gp7", "irb1600"])
def test_round_trips_are_strict(name):
    robot = load_robot(name)
    rng = np.random.default_rng(2024)
    Q_target = robot.random_configurations(rng, ROUND_TRIPS)
    Q_seed = robot.random_configurations(rng, ROUND_TRIPS)
    successes = 0
    for q_target, q_seed in zip(Q_target, Q_seed):
        X = robot.fk(q_target)
        result = solve_ik(robot, X, q_seed=q_seed, method="drake", rng=rng)
        assert result.method == "drake"
        assert np.isfinite(result.q).all() and result.iterations == result.details["solves"] >= 1
        assert result.details["solver"] in (SNOPT, IPOPT)
        if result.success:
            successes += 1
            # Every reported success passes an independent check with our FK.
            assert _strict(robot, result.q, make_target(X)), result
            assert result.solutions and np.array_equal(result.solutions[0].q, result.q)
            assert all(_strict(robot, s.q, make_target(X)) for s in result.solutions)
            assert result.reason == ""
        else:
            assert result.reason
    assert successes >= MIN_STRICT_RATE * ROUND_TRIPS


def test_position_and_axis_target_on_arm5():
    robot = load_robot("arm5")
    rng = np.random.default_rng(5)
    for q_target in robot.random_configurations(rng, 5):
        X = robot.fk(q_target)
        result = solve_ik(robot, X, method="drake", target_kind="position+axis", rng=rng)
        assert result.success, result.reason
        assert result.matched == MATCHED_COMPONENTS["position+axis"]
        X_got = robot.fk(result.q)
        assert np.linalg.norm(X_got[:3, 3] - X[:3, 3]) <= 1e-6
        assert np.arccos(np.clip(X_got[:3, 2] @ X[:3, 2], -1.0, 1.0)) <= 1e-6 + 1e-8
        assert result.rotation_error <= 1e-6 and within_limits(result.q, robot.limits.q_min, robot.limits.q_max)


def test_position_only_target():
    robot = load_robot("gp7")
    rng = np.random.default_rng(6)
    X = robot.fk(robot.random_configurations(rng, 1)[0])
    result = solve_ik(robot, X, method="drake", target_kind="position", rng=rng)
    assert result.success, result.reason
    assert result.position_error <= 1e-6 and result.rotation_error == 0.0
    assert result.matched == MATCHED_COMPONENTS["position"]


def test_unreachable_target_fails_with_a_reason_within_budget():
    robot = load_robot("gp7")
    rng = np.random.default_rng(7)
    X = robot.fk(robot.random_configurations(rng, 1)[0])
    X[:3, 3] += [2.0, 0.0, 0.0]
    result = solve_ik(robot, X, method="drake", rng=rng, max_restarts=5, time_budget=1.0)
    assert not result.success
    assert "no strict solution" in result.reason and "position error" in result.reason
    assert np.isfinite(result.q).all() and result.position_error > 0.5
    assert result.details["starts"] == 6 and result.solutions == ()


def test_time_budget_stops_restarts():
    robot = load_robot("gp7")
    X = robot.fk(np.zeros(robot.dof))
    X[:3, 3] += [2.0, 0.0, 0.0]
    result = solve_drake(robot, make_target(X), np.zeros(robot.dof), max_restarts=50, time_budget=0.0)
    assert not result.success and result.details["starts"] == 1
    assert result.reason.startswith("time budget")


def test_ipopt_fallback_is_verified_too():
    try:
        label, _ = pick_solver("ipopt")
    except RuntimeError:
        pytest.skip("this pydrake build has no IPOPT")
    robot = load_robot("gp7")
    rng = np.random.default_rng(8)
    q_target = robot.random_configurations(rng, 1)[0]
    X = robot.fk(q_target)
    result = solve_drake(robot, make_target(X), q_target + 0.05, rng=rng, solver="ipopt", max_restarts=3)
    assert result.details["solver"] == label == IPOPT
    assert result.success and _strict(robot, result.q, make_target(X)), result.reason
