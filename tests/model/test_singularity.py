"""Singularity measures: wrist and shoulder singularities found and named; regular poses are not."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.model.chain.singularity import compute_singularity
from pipeline.model.robot import load_robot


def test_gp7_wrist_singularity_names_j4_and_j6():
    robot = load_robot("gp7")
    q = np.radians([10, 20, -30, 40, 0, 25])          # q5 = 0: J4 and J6 axes line up
    report = compute_singularity(robot.jacobian(q))
    assert report.is_singular and report.rank == 5
    assert report.dependent_joint_sets == ((3, 5),)
    assert abs(report.determinant) < 1e-12 and report.smallest_singular_value < 1e-12
    assert "J4, J6" in str(report)


def test_irb1600_shoulder_singularity_wrist_centre_on_j1_axis():
    """Wrist centre on the J1 axis: J1 only spins the wrist centre in place (with a1 = 150 mm,
    that needs the arm reaching back over the base)."""
    robot = load_robot("irb1600")
    # Solve q2 for the wrist centre x = 0 at q3 chosen, by bisection on the wrist-centre x coordinate.
    def wrist_x(q2):
        return robot.fk_all(np.array([0, q2, -1.2, 0, 0.5, 0]))[4][0, 3]

    lo, hi = -1.1, 1.9
    assert wrist_x(lo) * wrist_x(hi) < 0
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if wrist_x(lo) * wrist_x(mid) > 0 else (lo, mid)
    report = compute_singularity(robot.jacobian(np.array([0, lo, -1.2, 0, 0.5, 0])))
    assert report.is_singular and report.smallest_singular_value < 1e-9
    assert 0 in report.dependent_joint_sets[0]


def test_regular_configuration_is_not_singular(robot, rng):
    q = robot.random_configurations(rng, 1, margin=0.1)[0]
    report = compute_singularity(robot.jacobian(q))
    assert not report.is_singular and report.dependent_joint_sets == ()
    assert report.rank == min(6, robot.dof)
    s = np.linalg.svd(robot.jacobian(q), compute_uv=False)
    assert report.manipulability == pytest.approx(np.prod(s))
    if robot.dof == 6:
        assert report.manipulability == pytest.approx(abs(report.determinant))
    else:
        assert report.determinant is None
