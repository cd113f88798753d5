"""Inverse kinematics: round trips for every 6-DOF preset and method, agreement between methods,
unreachable targets, singular targets, paths, inverse velocity, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.model.ik.analytic import analytic_solver_for
from pipeline.model.ik.result import POSITION_TOLERANCE, ROTATION_TOLERANCE, make_target, pose_errors
from pipeline.model.robot import load_robot

SIX_DOF = ["gp7", "lrmate200id", "irb1600", "arm6"]
ROUND_TRIPS = 500


def strict_in_limits(robot, result, X_target, kind="pose"):
    """Independent judgement of a result: our FK, the strict tolerances, the limits."""
    position_error, rotation_error = pose_errors(robot.fk(result.q), make_target(X_target, kind))
    limits = robot.limits
    return (position_error <= POSITION_TOLERANCE and rotation_error <= ROTATION_TOLERANCE
            and np.all(result.q >= limits.q_min) and np.all(result.q <= limits.q_max))


def round_trip(name: str, seed: int, method: str, **options):
    """ROUND_TRIPS targets from seeded random in-limit configurations, solved from random seeds:
    (robot, original configurations, target poses, results)."""
    robot = load_robot(name)
    rng = np.random.default_rng(seed)
    Q = robot.random_configurations(rng, ROUND_TRIPS)
    seeds = robot.random_configurations(rng, ROUND_TRIPS)
    X = robot.fk_batch(Q)
    return robot, Q, X, robot.ik_batch(X, seeds, method=method, **options)


@pytest.mark.parametrize("name", SIX_DOF)
def test_analytic_round_trip_finds_the_original_configuration_every_time(name):
    robot, Q, X, results = round_trip(name, 10, "analytic")
    for q, x, result in zip(Q, X, results):
        assert result.success, result.reason
        assert strict_in_limits(robot, result, x)
        assert any(np.abs(s.q - q).max() < 1e-7 for s in result.solutions)
        for s in result.solutions:      # every listed solution is exact and in limits
            assert s.position_error <= POSITION_TOLERANCE and s.rotation_error <= ROTATION_TOLERANCE
            assert np.all(s.q >= robot.limits.q_min) and np.all(s.q <= robot.limits.q_max)
            np.testing.assert_allclose(robot.fk(s.q), x, atol=1e-9)
        assert len(result.solutions) <= 8 * 27


@pytest.mark.parametrize("name", SIX_DOF)
def test_jacobian_round_trip(name):
    robot, _, X, results = round_trip(name, 11, "jacobian", rng=np.random.default_rng(0))
    successes = [strict_in_limits(robot, r, x) for r, x in zip(results, X)]
    assert all(r.success == s for r, s in zip(results, successes))     # reported success is strict
    assert np.mean(successes) >= 0.998


#: Seeded targets (robot, seed, index: ``bench ik``'s draw of 300 targets and 300 seeds) whose wrist centre lies
#: 0.03-1 mm from axis 1, near a shoulder singularity: damped least squares missed the first five in every restart
#: (it crawled along q1, almost free there), found by running seeds 0-319 of every preset; the last one its
#: second-order step solves only with the 200 iterations a descent now has.
NEAR_SHOULDER_SINGULARITY = [("lrmate200id", 11, 81), ("lrmate200id", 21, 201), ("gp7", 33, 92), ("irb1600", 93, 42),
                             ("arm6", 102, 239), ("lrmate200id", 201, 197)]


@pytest.mark.parametrize("name, seed, index", NEAR_SHOULDER_SINGULARITY)
def test_jacobian_solves_seeded_targets_near_a_shoulder_singularity(name, seed, index):
    robot = load_robot(name)
    rng = np.random.default_rng(seed)
    Q = robot.random_configurations(rng, 300)
    seeds = robot.random_configurations(rng, 300)
    X = robot.fk(Q[index])
    result = robot.ik(X, seeds[index], method="jacobian")
    assert result.success, result.reason
    assert strict_in_limits(robot, result, X)


def test_solutions_are_sorted_nearest_to_the_seed_and_distinct():
    robot = load_robot("gp7")
    q = np.radians([20, 30, 10, 50, 40, -30])
    seed = q + 0.05
    result = robot.ik(robot.fk(q), seed, method="analytic")
    distances = [np.linalg.norm(s.q - seed) for s in result.solutions]
    assert distances == sorted(distances)
    np.testing.assert_allclose(result.q, q, atol=1e-9)
    Q = np.array([s.q for s in result.solutions])
    gaps = np.abs(Q[:, None] - Q[None]).max(axis=-1) + np.eye(len(Q)) * 10
    assert gaps.min() > 1e-6


def test_all_eight_branches_labelled_for_a_general_gp7_pose():
    robot = load_robot("gp7")
    q = np.radians([5, 10, 20, 30, 40, 50])
    result = robot.ik(robot.fk(q), q, method="analytic")
    labels = {s.branch for s in result.solutions}
    assert "shoulder front, elbow up, wrist noflip" == result.details["branch"]
    assert any("elbow down" in b for b in labels) and any("wrist flip" in b for b in labels)
    # the J6 +-360 deg range gives 2 pi variants of the same branch
    assert len(result.solutions) > len(labels)


def test_irb1600_back_shoulder_branches_exist_in_its_wide_j3_range():
    """J3's -235..55 deg range lets the IRB 1600 reach over the top: 'shoulder back' solutions."""
    robot = load_robot("irb1600")
    q = np.radians([0, 60, -180, 10, 30, 0])
    result = robot.ik(robot.fk(q), q, method="analytic")
    assert any("shoulder back" in s.branch for s in result.solutions)


@pytest.mark.parametrize("name", SIX_DOF)
def test_methods_agree_on_reachable_targets(name):
    robot = load_robot(name)
    rng = np.random.default_rng(12)
    for q in robot.random_configurations(rng, 10):
        X = robot.fk(q)
        analytic = robot.ik(X, q, method="analytic")
        numeric = robot.ik(X, q + 0.02, method="jacobian")
        assert analytic.success and numeric.success
        # the numeric answer is one of the closed-form solutions (up to 2 pi it is the nearest)
        assert min(np.abs(s.q - numeric.q).max() for s in analytic.solutions) < 1e-6


@pytest.mark.parametrize("method", ["analytic", "jacobian"])
def test_target_beyond_reach_fails_with_a_reason(method):
    robot = load_robot("gp7")
    X = robot.fk(np.zeros(6))
    X[:3, 3] = [2.0, 0.0, 0.5]
    result = robot.ik(X, method=method, time_budget=0.2, max_restarts=5)
    assert not result.success and result.reason
    assert np.all(np.isfinite(result.q)) and result.position_error > 0.5
    assert result.solutions == ()


def test_auto_tries_jacobian_once_after_the_closed_form_fails(monkeypatch):
    """``auto`` on a single call: the closed form's failure goes to damped least squares once, and both
    reasons are reported (the fast path does not solve the closed form a second time)."""
    import pipeline.model.ik as ik

    calls = []
    monkeypatch.setattr(ik, "solve_analytic", lambda *args: calls.append("checked path") or None)
    robot = load_robot("gp7")
    X = robot.fk(np.zeros(6))
    X[:3, 3] = [2.0, 0.0, 0.5]
    result = robot.ik(X)
    assert not result.success and calls == []
    assert result.reason.startswith("target out of reach: no closed-form branch")
    assert "; jacobian: no strict" in result.reason


def test_target_reachable_only_outside_the_limits_fails_with_a_reason():
    """Poses of out-of-limit configurations: some have no in-limit branch at all. The first such one
    (seeded search) must fail for both methods, with a reason, within the budget."""
    robot = load_robot("gp7")
    rng = np.random.default_rng(5)
    for q in rng.uniform(-np.pi, np.pi, size=(200, 6)):
        analytic = robot.ik(robot.fk(q), np.zeros(6), method="analytic")
        if not analytic.success:
            break
    assert "outside the joint limits" in analytic.reason and "by" in analytic.reason
    numeric = robot.ik(robot.fk(q), np.zeros(6), method="jacobian", time_budget=0.3, max_restarts=10)
    assert not numeric.success and "no strict solution" in numeric.reason


@pytest.mark.parametrize("name", SIX_DOF)
def test_wrist_singular_target_returns_the_continuous_solution_nearest_the_seed(name):
    robot = load_robot(name)
    q = np.radians([15, 25, 10, 30, 0, -20])          # q5 = 0: J4 and J6 aligned
    seed = q + np.radians([1, -1, 1, 7, 1, -4])
    result = robot.ik(robot.fk(q), seed, method="analytic")
    assert result.success, result.reason
    assert strict_in_limits(robot, result, robot.fk(q))
    # only q4 +- q6 is fixed: the split nearest the seed moves J4 and J6 equally far from it
    assert abs(abs(result.q[3] - seed[3]) - abs(result.q[5] - seed[5])) < 1e-9
    assert np.abs(result.q - seed).max() < np.radians(8)


def test_shoulder_singular_target_on_the_irb1600():
    """Wrist centre on the J1 axis: q1 is free; the closed form keeps the seed's q1."""
    robot = load_robot("irb1600")
    frames = lambda q2: robot.fk_all(np.array([0.4, q2, -1.2, 0.3, 0.5, 0.1]))[4][:3, 3]
    lo, hi = -1.1, 1.9
    for _ in range(200):   # bisection on the wrist centre's distance from the J1 axis (signed x in link frame)
        mid = (lo + hi) / 2
        sign = lambda q2: np.sign(np.array([np.cos(0.4), np.sin(0.4), 0]) @ frames(q2))
        lo, hi = (mid, hi) if sign(lo) == sign(mid) else (lo, mid)
    q = np.array([0.4, lo, -1.2, 0.3, 0.5, 0.1])
    assert np.linalg.norm(frames(lo)[:2]) < 1e-9
    result = robot.ik(robot.fk(q), q + 0.01, method="analytic")
    assert result.success, result.reason
    assert strict_in_limits(robot, result, robot.fk(q))
    assert result.q[0] == pytest.approx(q[0] + 0.01)


def test_arm5_position_and_tool_axis_target():
    robot = load_robot("arm5")
    assert not analytic_solver_for(robot).applicable
    rng = np.random.default_rng(3)
    for q in robot.random_configurations(rng, 50, margin=0.05):
        X = robot.fk(q)
        result = robot.ik(X, target_kind="position+axis")
        assert result.success, result.reason
        assert result.matched == ("x", "y", "z", "axis_z") and result.method == "jacobian"
        assert strict_in_limits(robot, result, X, "position+axis")


def test_arm5_analytic_says_it_does_not_fit():
    robot = load_robot("arm5")
    result = robot.ik(robot.fk(np.zeros(5)), method="analytic")
    assert not result.success and "6 revolute joints" in result.reason


def test_path_keeps_one_branch_and_reports_where_continuity_breaks():
    robot = load_robot("gp7")
    q_start = np.radians([0, 10, 10, 20, 40, 0])
    # a straight line in x of the flange, keeping its orientation
    X0 = robot.fk(q_start)
    poses = np.repeat(X0[None], 30, axis=0)
    poses[:, 0, 3] += np.linspace(0, 0.15, 30)
    path = robot.ik_path(poses, q_start)
    assert path.success and path.Q.shape == (30, 6) and path.failed_index is None
    assert np.abs(np.diff(path.Q, axis=0)).max() < 0.1
    assert len(set(path.branches)) == 1
    for q, X in zip(path.Q, poses):
        np.testing.assert_allclose(robot.fk(q), X, atol=1e-9)
    # a jump to a pose far away cannot be continuous
    far = poses.copy()
    far[20:] = robot.fk(np.radians([90, 30, 20, -40, 60, 90]))
    broken = robot.ik_path(far, q_start)
    assert not broken.success and broken.failed_index == 20 and "continuity" in broken.reason
    assert broken.Q.shape == (20, 6)


def test_inverse_velocity_kinematics_and_singular_flag():
    robot = load_robot("irb1600")
    q = np.radians([10, 20, -30, 40, 50, 60])
    twist = np.array([0.1, -0.05, 0.02, 0.1, 0.2, -0.3])
    result = robot.joint_velocities(q, twist)
    assert not result.near_singular and result.residual < 1e-12
    np.testing.assert_allclose(robot.jacobian(q) @ result.qd, twist, atol=1e-12)
    singular = robot.joint_velocities(np.radians([10, 20, -30, 40, 0, 60]), twist)
    assert singular.near_singular and singular.damping > 0 and np.all(np.isfinite(singular.qd))


@pytest.mark.parametrize("bad", [np.eye(3), np.full((4, 4), np.nan), np.diag([1.0, 1.0, -1.0, 1.0]),
                                 np.diag([1.0, 2.0, 1.0, 1.0])])
def test_bad_target_is_a_typed_error(bad):
    with pytest.raises(ConfigurationError):
        load_robot("gp7").ik(bad)


def test_bad_seed_method_and_kind_are_typed_errors():
    robot = load_robot("gp7")
    X = robot.fk(np.zeros(6))
    with pytest.raises(ConfigurationError, match="method"):
        robot.ik(X, method="newton")
    with pytest.raises(ConfigurationError):
        robot.ik(X, q_seed=np.zeros(5))
    with pytest.raises(ConfigurationError):
        robot.ik(X, q_seed=[0, 0, np.nan, 0, 0, 0])
    with pytest.raises(ConfigurationError, match="kind"):
        robot.ik(X, target_kind="orientation")
    with pytest.raises(ConfigurationError):
        robot.ik_batch(np.zeros((3, 4)))


@pytest.mark.slow           # Drake's IK round trips in the quick run: tests/model/test_drake_ik.py
@pytest.mark.parametrize("name", SIX_DOF)
def test_drake_round_trip(name):
    """500 targets from random seeds: every reported success is strict, and >= 99 % succeed."""
    robot, _, X, results = round_trip(name, 13, "drake", rng=np.random.default_rng(0))
    strict = [strict_in_limits(robot, r, x) for r, x in zip(results, X)]
    assert all(s for r, s in zip(results, strict) if r.success)
    assert np.mean(strict) >= 0.99


def test_jacobian_answer_is_the_representative_nearest_the_seed():
    """Found by fuzzing: a restart's answer came back 2 pi away from the seed's representative on gp7's
    wide joints 4 and 6, although both are inside the limits."""
    robot = load_robot("gp7")
    rng = np.random.default_rng(1)
    q, seed = robot.random_configurations(rng, 1)[0], robot.random_configurations(rng, 1)[0]
    result = robot.ik(robot.fk(q), seed, method="jacobian", rng=np.random.default_rng(0))
    assert result.success and result.details["restarts"] >= 1
    limits = robot.limits
    for j in range(robot.dof):
        for shift in (-2 * np.pi, 2 * np.pi):
            other = result.q[j] + shift
            if limits.q_min[j] <= other <= limits.q_max[j]:
                assert abs(result.q[j] - seed[j]) <= abs(other - seed[j]), (j, result.q[j], seed[j])
    np.testing.assert_allclose(robot.fk(result.q), robot.fk(q), atol=1e-9)
