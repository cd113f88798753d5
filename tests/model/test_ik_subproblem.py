"""EAIK's closed-form IK (pipeline/model/ik/subproblem.py) on arms with three parallel axes (UR5, UR10 in
tests/data) and on spherical wrists (against pipeline/model/ik/analytic.py): every branch, every answer
checked by our FK, typed failures. Robots with other limits are copies built in memory."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.ik.analytic import solve_analytic_batch
from pipeline.model.ik.result import POSITION_TOLERANCE, ROTATION_TOLERANCE, rotation_angle
from pipeline.model.ik.subproblem import (
    branch_labels,
    eaik_parameters,
    solve_subproblem_batch,
    subproblem_solver_for,
    wrap,
)
from pipeline.model.robot import Robot, load_robot, robot_with_tool
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR

UR5, UR10 = DATA_DIR / "ur5.yaml", DATA_DIR / "ur10.yaml"
LABELS = {f"shoulder {s}, elbow {e}, wrist {w}" for s in ("left", "right") for e in ("up", "down")
          for w in ("up", "down")}


def robot_copy(path: Path, limit_deg: float | None = None, continuous: tuple[int, ...] = (),
               rows: dict[int, dict] | None = None) -> Robot:
    """The robot file's robot with every limit +-limit_deg [deg], the joints ``continuous`` (0-based)
    without limits, and ``rows`` (joint index -> {key: value}) changed."""
    document = yaml.safe_load(path.read_text())
    for i, joint in enumerate(document["joints"]):
        if limit_deg is not None:
            joint.update(q_min=-limit_deg, q_max=limit_deg)
        if i in continuous:
            del joint["q_min"], joint["q_max"]
            joint["continuous"] = True
        joint.update((rows or {}).get(i, {}))
    return Robot(parse_robot_spec(document, str(path)))


def targets(robot: Robot, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random in-limit configurations (count, 6) [rad] of the robot file's own limits and their poses."""
    Q = robot.random_configurations(np.random.default_rng(seed), count)
    return Q, robot.fk_batch(Q)


def verified(robot: Robot, Q: np.ndarray, X: np.ndarray) -> bool:
    """Every row of Q reaches X (4, 4) within the strict tolerances and lies inside the limits."""
    F = robot.fk_batch(Q)
    position = np.linalg.norm(F[:, :3, 3] - X[:3, 3], axis=1)
    rotation = rotation_angle(np.swapaxes(F[:, :3, :3], 1, 2) @ X[:3, :3])
    inside = (Q >= robot.limits.q_min) & (Q <= robot.limits.q_max)
    return bool((position <= POSITION_TOLERANCE).all() and (rotation <= ROTATION_TOLERANCE).all() and inside.all())


def contains(Q: np.ndarray, q: np.ndarray, tolerance: float = 1e-6) -> bool:
    """Whether q is a row of Q, comparing angles modulo 2 pi."""
    return bool((np.abs(wrap(Q - q)).max(axis=1) <= tolerance).any())


@pytest.mark.parametrize("name", [UR5, UR10, "gp7", "irb1600"], ids=["ur5", "ur10", "gp7", "irb1600"])
def test_the_model_given_to_eaik_has_our_fk(name):
    """EAIK's FK at q equals ours with the end frame turned back by X_BE(0)'s rotation."""
    robot = load_robot(name)
    robot = robot_with_tool(robot, np.array([[0, 0, 1, 0.01], [1, 0, 0, 0.02], [0, 1, 0, 0.15], [0, 0, 0, 1.0]]))
    _, _, X_BE0 = eaik_parameters(robot)
    eaik = subproblem_solver_for(robot).eaik
    for q in robot.random_configurations(np.random.default_rng(1), 50):
        X = robot.fk(q)
        X[:3, :3] = X[:3, :3] @ X_BE0[:3, :3].T
        assert np.abs(eaik.fwdKin(q) - X).max() < 1e-12


def test_the_ur5_file_is_the_ros_industrial_ur5():
    """tests/data/ur5.yaml (UR's DH table) has the URDF's FK, with UR's base frame (the URDF's base_link
    turned half a turn about z) and tool0 as the flange."""
    urdf = import_urdf(DATA_DIR / "urdf" / "ur5.urdf").robot
    robot = load_robot(UR5)
    Q, X = targets(robot, 200, 3)
    X_urdf = np.diag([-1.0, -1.0, 1.0, 1.0]) @ urdf.fk_batch(Q)
    assert np.abs(X_urdf - X).max() < 1e-8          # the URDF writes pi/2 as 1.570796325


@pytest.mark.parametrize("path", [UR5, UR10], ids=["ur5", "ur10"])
def test_three_parallel_axes_every_branch_verified_and_labelled(path):
    """Within +-180 deg (one 2 pi variant each), every target of a random in-limit configuration of
    the +-360 deg file is solved; the configuration is among the solutions; every solution reaches
    the target by our FK; each exact branch has its own label; a UR target has 8 branches unless EAIK
    finds a branch out of reach (then 2, 4 or 6)."""
    robot = robot_copy(path, 180.0)
    count = 1000 if path == UR5 else 200
    Q, X = targets(load_robot(path), count, 7)
    results = solve_subproblem_batch(robot, X, np.zeros((count, 6)))
    assert all(r.success and r.method == "analytic" and r.details["solver"] == "eaik" for r in results)
    branches = []
    for q, X_target, result in zip(Q, X, results):
        solutions = np.array([s.q for s in result.solutions])
        assert contains(solutions, q)
        assert verified(robot, solutions, X_target)
        labels = [s.branch for s in result.solutions]
        assert len(set(labels)) == len(labels) == result.details["branches_reachable"]
        assert set(labels) <= LABELS and result.details["branch"] == labels[0]
        branches.append(len(labels))
        if result.details["least_squares"] == 0:
            assert len(labels) == 8
    assert set(branches) <= {2, 4, 6, 8}
    assert np.mean(np.array(branches) == 8) > 0.7
    print(f"\n{robot.name}: targets by branch count {dict(sorted(Counter(branches).items()))}")


@pytest.mark.slow
def test_the_branches_eaik_leaves_out_are_out_of_reach():
    """Damped least squares from random seeds finds no branch EAIK did not (UR5 targets with fewer
    than 8 branches)."""
    robot = robot_copy(UR5, 180.0)
    solver = subproblem_solver_for(robot)
    _, X = targets(load_robot(UR5), 1000, 7)
    results = solve_subproblem_batch(robot, X, np.zeros((1000, 6)))
    few = [(X_target, r) for X_target, r in zip(X, results) if r.details["branches_reachable"] < 8]
    rng = np.random.default_rng(13)
    found = 0
    for X_target, result in few:
        branches = {s.branch for s in result.solutions}
        for seed in robot.random_configurations(rng, 20):
            numeric = robot.ik(X_target, seed, method="jacobian", max_restarts=0)
            if numeric.success:
                found += 1
                assert branch_labels(robot, solver, numeric.q[None])[0] in branches
    assert len(few) > 100 and found > 1000


def test_ur_wrist_label_is_the_sign_of_q5_and_labels_ignore_2pi():
    robot = load_robot(UR5)
    Q = robot.random_configurations(np.random.default_rng(4), 500)
    solver = subproblem_solver_for(robot)
    labels = branch_labels(robot, solver, Q)
    assert [label.endswith("wrist up") for label in labels] == list(np.sin(Q[:, 4]) >= 0.0)
    assert list(branch_labels(robot, solver, wrap(Q))) == list(labels)


def test_full_range_gives_every_2pi_variant_nearest_the_seed_first():
    """+-360 deg: each joint has 2 in-limit values, so 64 solutions per branch; seeded with the
    configuration, it comes first."""
    robot = load_robot(UR5)
    Q, X = targets(robot, 200, 8)
    for q, X_target, result in zip(Q, X, solve_subproblem_batch(robot, X, Q)):
        assert result.success and np.abs(result.q - q).max() < 1e-9
        assert len(result.solutions) == 64 * result.details["branches_reachable"]
        assert verified(robot, np.array([s.q for s in result.solutions]), X_target)


def test_a_tool_offset_and_continuous_joints():
    """A TCP off axis 6 (EAIK's P[6]) and continuous wrist joints (the value nearest the seed)."""
    X_ET = np.array([[0, -1, 0, 0.03], [1, 0, 0, -0.02], [0, 0, 1, 0.12], [0, 0, 0, 1.0]])
    for robot in (robot_with_tool(robot_copy(UR5, 180.0), X_ET), robot_copy(UR5, continuous=(3, 5))):
        Q, X = targets(robot, 200, 9)
        for q, X_target, result in zip(Q, X, solve_subproblem_batch(robot, X, Q)):
            assert result.success and np.abs(result.q - q).max() < 1e-9
            assert verified(robot, np.array([s.q for s in result.solutions]), X_target)


@pytest.mark.parametrize("q", [[0.3, -1.0, 1.2, 0.4, 0.0, 0.7], [0.3, -1.0, 0.0, 0.4, 0.5, 0.7],
                               [0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]])
def test_singular_and_boundary_targets(q):
    """q5 = 0 (axes 4 and 6 aligned: EAIK answers least-squares, q6 is settled about axis 6) and the
    elbow stretched (q3 = 0: EAIK calls the exact answer least-squares, our FK keeps it)."""
    robot = robot_copy(UR5, 180.0)
    q = np.array(q)
    X = robot.fk(q)
    result = solve_subproblem_batch(robot, X[None], np.zeros((1, 6)))[0]
    solutions = np.array([s.q for s in result.solutions])
    assert result.success and verified(robot, solutions, X)
    if q[4] == 0.0:
        assert (np.abs(solutions[:, 4]) < 1e-6).any()                   # the singular branch is kept
    else:
        assert contains(solutions, q)


def test_failures_are_typed_with_a_reason():
    robot = load_robot(UR5)
    X_far = np.eye(4)
    X_far[:3, 3] = [2.0, 0.0, 0.3]
    q = np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7])
    narrow = robot_copy(UR5, rows={0: {"q_min": -10, "q_max": 10}})
    X_turned = robot.fk(q + [2.0, 0, 0, 0, 0, 0])
    far, outside, position_only = (
        solve_subproblem_batch(robot, X_far[None], q[None])[0],
        solve_subproblem_batch(narrow, X_turned[None], q[None])[0],
        solve_subproblem_batch(robot, robot.fk(q)[None], q[None], kind="position")[0])
    assert not far.success and far.reason.startswith("target out of reach") and far.position_error > 0.5
    assert not outside.success and outside.reason.startswith("reachable only outside the joint limits")
    assert "shoulder_pan" in outside.reason
    assert not position_only.success and "full poses only" in position_only.reason
    for result in (far, outside, position_only):
        assert result.method == "analytic" and result.solutions == () and np.isfinite(result.q).all()


def test_arms_eaik_cannot_decompose_are_refused_without_a_crash():
    document = yaml.safe_load(UR5.read_text())
    for joint, alpha in zip(document["joints"], (90, 30, -50, 70, -90, 0)):
        joint["alpha"] = alpha
    general = Robot(parse_robot_spec(document, "general 6R"))
    for robot, reason in ((general, "EAIK knows no closed-form decomposition"), (load_robot("arm5"), "6 revolute")):
        solver = subproblem_solver_for(robot)
        assert not solver.applicable and reason in solver.reason
        q = np.zeros((1, robot.dof))
        result = solve_subproblem_batch(robot, robot.fk_batch(q), q)[0]
        assert not result.success and result.reason == solver.reason


def test_a_spherical_wrist_agrees_with_our_closed_form():
    """gp7: EAIK decomposes it; the same in-limit solutions (and labels) as pipeline.model.ik.analytic."""
    robot = load_robot("gp7")
    solver = subproblem_solver_for(robot)
    assert solver.applicable and solver.family.startswith("6R-SPHERICAL")
    Q, X = targets(robot, 300, 11)
    ours, theirs = solve_analytic_batch(robot, X, Q), solve_subproblem_batch(robot, X, Q)
    for a, b in zip(ours, theirs):
        assert a.success == b.success and len(a.solutions) == len(b.solutions)
        for s in a.solutions:
            match = [t for t in b.solutions if np.abs(t.q - s.q).max() < 1e-6]
            assert len(match) == 1 and match[0].branch == s.branch
