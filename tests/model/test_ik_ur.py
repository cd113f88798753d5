"""The compiled closed form of the UR family (pipeline/model/ik/three_parallel.py) on the UR5 of tests/data:
every branch verified by FK, one representative per branch with its 2 pi variants counted, named
branches (labels, ``config:`` in job files), the singular cases, and EAIK (pipeline/model/ik/subproblem.py)
as an independent check. Robots with other limits or links are copies built in memory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq

from pipeline.errors import ConfigurationError, JobFileError
from pipeline.files.branch_names import parse_configuration
from pipeline.files.poses import rotation_to_rpy
from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.ik.analytic import THREE_PARALLEL_LABELS, analytic_solver_for, solve_analytic_batch
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.ik.result import limit_variants
from pipeline.model.ik.subproblem import solve_subproblem_batch, wrap
from pipeline.model.robot import Robot, load_robot
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import load_job
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR
from .test_ik_subproblem import verified

UR5, UR10 = DATA_DIR / "ur5.yaml", DATA_DIR / "ur10.yaml"
#: Two joint vectors within this (largest difference modulo 2 pi) [rad] are one solution.
SAME = 1e-6


def ur5_copy(limit_deg: float | None = None, rows: dict[int, dict] | None = None, path: Path = UR5) -> Robot:
    """The UR5 (or the robot file ``path``) with every limit +-limit_deg [deg] and ``rows`` (joint index
    -> {key: value}) changed."""
    document = yaml.safe_load(path.read_text())
    for i, joint in enumerate(document["joints"]):
        if limit_deg is not None:
            joint.update(q_min=-limit_deg, q_max=limit_deg)
        joint.update((rows or {}).get(i, {}))
    return Robot(parse_robot_spec(document, str(path)))


def solution_array(result) -> np.ndarray:
    return np.array([s.q for s in result.solutions]).reshape(-1, 6)


def index_of(Q: np.ndarray, q: np.ndarray) -> int:
    """The row of Q that is q modulo 2 pi (-1: none)."""
    distance = np.abs(wrap(Q - q)).max(axis=1)
    k = int(np.argmin(distance))
    return k if distance[k] <= SAME else -1


def test_the_ur5_gets_the_compiled_closed_form_from_its_file_and_its_urdf():
    for robot in (load_robot(UR5), import_urdf(DATA_DIR / "urdf" / "ur5.urdf").robot):
        solver = analytic_solver_for(robot)
        assert solver.applicable and solver.family == "three parallel axes"
        q = np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7])
        result = robot.ik(robot.fk(q), q)
        assert result.success and result.method == "analytic" and np.abs(result.q - q).max() < 1e-9
        assert "solver" not in result.details                          # not EAIK


def test_every_configuration_is_found_once_per_branch_with_its_label():
    """300 random in-limit configurations of the +-360 deg UR5, random seeds: each is among the
    solutions (modulo 2 pi) with its own label; one solution per branch (distinct labels, at most 8),
    each the 2 pi variant nearest the seed, every one verified, 64 variants counted per branch."""
    robot = load_robot(UR5)
    rng = np.random.default_rng(5)
    Q, seeds = robot.random_configurations(rng, 300), robot.random_configurations(rng, 300)
    X = robot.fk_batch(Q)
    labels = configuration_labels(robot, Q)
    for q, seed, X_target, label in zip(Q, seeds, X, labels):
        result = robot.ik(X_target, seed)
        solutions = solution_array(result)
        k = index_of(solutions, q)
        assert result.success and k >= 0 and result.solutions[k].branch == label
        branches = [s.branch for s in result.solutions]
        assert len(set(branches)) == len(branches) == result.details["branches_reachable"] <= 8
        assert verified(robot, solutions, X_target)
        for shift in (-2.0 * np.pi, 2.0 * np.pi):                           # the in-limit variant nearest the seed
            shifted = solutions + shift
            inside = (shifted >= robot.limits.q_min) & (shifted <= robot.limits.q_max)
            assert (np.abs(solutions - seed) <= np.where(inside, np.abs(shifted - seed), np.inf) + 1e-9).all()
        assert result.solutions.variants == [64.0] * len(branches)
        assert set(branches) <= set(THREE_PARALLEL_LABELS)


def test_the_variants_of_a_branch_are_enumerated_on_demand():
    robot = load_robot(UR5)
    q = np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7])
    result = robot.ik(robot.fk(q), q)
    candidates, valid = limit_variants(solution_array(result)[:1], np.ones(6, dtype=bool), robot.limits.q_min,
                                       robot.limits.q_max)
    assert valid.sum() == result.solutions.variants[0] == 64
    assert verified(robot, candidates[0][valid[0]], robot.fk(q))


@pytest.mark.parametrize("path, limit_deg", [(UR5, 180.0), pytest.param(UR5, 360.0, marks=pytest.mark.slow),
                                              pytest.param(UR10, 360.0, marks=pytest.mark.slow)],
                         ids=["ur5-180", "ur5-360", "ur10-360"])
def test_the_solution_set_is_eaiks(path, limit_deg):
    """EAIK's exact answers (an independent solver), modulo 2 pi, are ours and carry our labels (its
    NumPy labels of the same definitions): targets of random configurations and random seeds."""
    robot = ur5_copy(limit_deg, path=path)
    rng = np.random.default_rng(6)
    Q, seeds = robot.random_configurations(rng, 150), robot.random_configurations(rng, 150)
    X = robot.fk_batch(Q)
    for ours, theirs in zip(solve_analytic_batch(robot, X, seeds), solve_subproblem_batch(robot, X, seeds)):
        assert ours.success and theirs.success
        mine = solution_array(ours)
        distinct = {}
        for s in theirs.solutions:
            distinct.setdefault(tuple(np.round(wrap(s.q), 5)), s)
        assert len(distinct) == len(mine)
        for s in distinct.values():
            k = index_of(mine, s.q)
            assert k >= 0 and ours.solutions[k].branch == s.branch


@pytest.mark.parametrize("q", [[0.3, -1.0, 1.2, 0.4, 0.0, 0.7], [0.3, -1.0, 1.2, 0.4, np.pi, 0.7]])
def test_axes_4_and_6_aligned_q6_takes_the_seeds_value(q):
    """q5 = 0 or pi: only q2 + q3 + q4 + -q6 is fixed; the branch keeps the seed's q6 and reaches the pose."""
    robot = load_robot(UR5)
    q = np.array(q)
    X = robot.fk(q)
    seed = q + np.array([0.05, -0.05, 0.05, 0.3, 0.0, -0.4])
    result = robot.ik(X, seed)
    assert result.success and verified(robot, solution_array(result), X)
    assert abs(result.q[5] - seed[5]) < 1e-9 and abs(np.sin(result.q[4])) < 1e-6


@pytest.mark.parametrize("q", [[0.3, -1.0, 0.0, 0.4, 0.5, 0.7], [0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]])
def test_the_elbow_stretched_and_the_upright_pose(q):
    """q3 = 0 (the two elbow roots meet) and the upright pose (also axes 4 and 6 aligned): the
    configuration itself is found (the seed's q6 at the wrist singularity)."""
    robot = load_robot(UR5)
    q = np.array(q)
    X = robot.fk(q)
    result = robot.ik(X, q)
    assert result.success and index_of(solution_array(result), q) >= 0
    assert verified(robot, solution_array(result), X)


def test_the_wrist_point_on_axis_1_leaves_q1_free():
    """Without the shoulder offset (d4 = 0) the wrist point (where axes 5 and 6 meet: joint 6's frame
    origin) can lie on axis 1: q1 is free, and the solution nearest the seed keeps the seed's q1."""
    robot = ur5_copy(rows={3: {"d": 0.0}})
    q = np.array([0.4, -1.2, 0.0, 0.0, 0.7, 0.2])

    def along(joint: int, point: int):
        """The horizontal distance from axis 1, in the arm's plane, of a joint frame's origin as joint
        ``joint`` of q turns [m]."""
        def distance(value: float) -> float:
            turned = q.copy()
            turned[joint] = value
            return robot.joint_frames(turned)[0][point, :3, 3] @ np.array([np.cos(q[0]), np.sin(q[0]), 0.0])
        return distance

    q[2] = brentq(along(2, 3), -1.5, 0.0)                     # wrist 1 (joint 4's origin) onto axis 1
    grid = np.linspace(-np.pi, np.pi, 73)
    signs = np.sign([along(3, 5)(value) for value in grid])
    k = int(np.flatnonzero(np.diff(signs))[0])
    q[3] = brentq(along(3, 5), grid[k], grid[k + 1])          # then the wrist point, turning about wrist 1
    assert np.linalg.norm(robot.joint_frames(q)[0][5, :2, 3]) < 1e-12
    X = robot.fk(q)
    seed = q + np.array([0.2, 0.05, -0.05, 0.05, 0.05, 0.05])
    result = robot.ik(X, seed)
    assert result.success and verified(robot, solution_array(result), X)
    assert abs(result.q[0] - seed[0]) < 1e-9


def test_failures_are_results_with_a_reason():
    robot = load_robot(UR5)
    X_far = np.eye(4)
    X_far[:3, 3] = [2.0, 0.0, 0.3]
    q = np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7])
    narrow = ur5_copy(rows={0: {"q_min": -10, "q_max": 10}})
    far = robot.ik(X_far, q, method="analytic")
    outside = narrow.ik(robot.fk(q + [2.0, 0, 0, 0, 0, 0]), q, method="analytic")
    assert not far.success and far.reason.startswith("target out of reach") and far.position_error > 0.5
    assert not outside.success and outside.reason.startswith("reachable only outside the joint limits")
    assert "shoulder_pan" in outside.reason
    for result in (far, outside):
        assert result.solutions == () and np.isfinite(result.q).all()


def ur_job(tmp_path: Path, X: np.ndarray, config) -> Path:
    """A UR5 job file whose two pose waypoints are at X (4, 4) [m], the first naming ``config``."""
    pose = {"xyz": (X[:3, 3] * 1000.0).tolist(), "rpy": np.degrees(rotation_to_rpy(X[:3, :3])).tolist()}
    doc = {"robot": str(UR5), "length_unit": "mm", "angle_unit": "deg", "ik": "analytic",
           "waypoints": [{**pose, "config": config}, pose]}
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_each_of_the_8_branches_is_requested_by_name(tmp_path):
    robot = load_robot(UR5)
    q = np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7])
    X = robot.fk(q)
    labels = {s.branch for s in robot.ik(X, q).solutions}
    assert labels == set(THREE_PARALLEL_LABELS)
    for label in THREE_PARALLEL_LABELS:
        config = dict(part.split() for part in label.split(", "))
        solved = solve_waypoints(load_job(ur_job(tmp_path, X, config)))
        assert [s.branch for s in solved] == [label, label] and verified(robot, solved[0].q[None], X)


@pytest.mark.parametrize("config, match", [
    ({"shoulder": "front"}, r"configuration shoulder must be left or right for ur5 \(the UR family \(axes 2, 3, 4 "
                            r"parallel\): shoulder left\|right, elbow up\|down, wrist up\|down\), got 'front' "
                            r"\('shoulder front' names a branch of a spherical wrist\)"),
    ({"wrist": "flip"}, r"configuration wrist must be up or down for ur5 .*'wrist flip' names a branch of a "
                        r"spherical wrist"),
    ("N U T", r"a configuration for ur5 .* is a mapping"),
])
def test_spherical_wrist_names_are_refused_for_the_ur5(tmp_path, config, match):
    X = load_robot(UR5).fk(np.array([0.3, -1.0, 1.2, 0.4, 0.5, 0.7]))
    with pytest.raises(JobFileError, match=r"waypoints\[0\]\.config: " + match):
        load_job(ur_job(tmp_path, X, config))


def test_ur_names_are_refused_for_a_spherical_wrist():
    with pytest.raises(ConfigurationError, match=r"shoulder must be front or back for gp7 \(a spherical wrist: "
                                                  r"shoulder front\|back, elbow up\|down, wrist flip\|noflip\), got "
                                                  r"'left' \('shoulder left' names a branch of the UR family"):
        parse_configuration({"shoulder": "left"}, "spherical wrist", "gp7")
    assert parse_configuration({"wrist": "up"}, "three parallel axes", "ur5") == {"wrist": "up"}
