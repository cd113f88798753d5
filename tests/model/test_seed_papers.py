"""Numbers printed in the seed papers, reproduced (or shown to be wrong) by our models."""

from __future__ import annotations

import numpy as np

from pipeline.model.chain.kinematics import dh_standard
from pipeline.model.robot import load_robot

MM = 1e-3


def test_seed002_jacobian_at_zero_reproduces_equations_46_to_53():
    """Seed 002 derives the columns of J at q = 0 by hand (eqs. 46-50 linear, 51-53 angular)."""
    a2, a3, d5, dE = 450 * MM, 350 * MM, 50 * MM, 30 * MM
    linear = np.array([
        [0, a2, 0],                   # eq. 46: z1 x (rE - r1)
        [a3 + d5 + dE, 0, a2],        # eq. 47
        [a3 + d5 + dE, 0, 0],         # eq. 48
        [d5 + dE, 0, 0],              # eq. 49
        [0, 0, 0],                    # eq. 50
    ]).T
    angular = np.array([[0, 0, 1], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, 0, -1]]).T  # eqs. 51-53
    J = load_robot("arm5").jacobian(np.zeros(5))
    np.testing.assert_allclose(J[:3], linear, atol=1e-15)
    np.testing.assert_allclose(J[3:], angular, atol=1e-15)


# Seed 000, Figure 12: the DH rows its MATLAB code multiplies (theta, d, a, alpha) [deg, mm].
SEED000_MATLAB_ROWS = [(90, 330, 40, 0), (90, 0, 445, 0), (0, 0, 40, 0), (-90, 440, 0, 90), (90, 0, 0, -90), (-90, 80, 0, 90)]
# Seed 000, Figure 15: the 6x6 "Jacobian" it prints for the GP7 at that pose (rows v; w, mm and 1).
SEED000_FIGURE15 = np.array([
    [0, 0, 0, 0, 0, 0],
    [0, 0, 0, 0, 0, 80],
    [-770, 440, 440, 440, 0, 0],
    [0, 0, 0, 0, 1, 0],
    [0, 0, 0, 0, 0, -1],
    [-1, 1, 1, 1, 0, 0],
], dtype=float)


def seed000_frames() -> list[np.ndarray]:
    frames = [np.eye(4)]
    for theta, d, a, alpha in SEED000_MATLAB_ROWS:
        frames.append(frames[-1] @ dh_standard(np.radians(theta), d, a, np.radians(alpha)))
    return frames


def test_seed000_figure13_pose_is_what_its_dh_rows_give():
    X = seed000_frames()[-1]
    np.testing.assert_allclose(X[:3, 3], [-485, -40, 770], atol=1e-9)
    np.testing.assert_allclose(X[:3, :3], np.diag([1, -1, -1]), atol=1e-15)


def test_seed000_figure15_cannot_be_a_geometric_jacobian_of_the_gp7():
    """A revolute column is [z x r; z], so its linear part is orthogonal to its axis. Figure 15's first
    four columns have v parallel to w (e.g. column 1: v = (0, 0, -770), w = (0, 0, -1)): impossible for
    any revolute arm. The GP7's J1 axis is vertical, so its column 1 never has vertical velocity."""
    fig = SEED000_FIGURE15
    dots = np.einsum("ij,ij->j", fig[:3], fig[3:])
    assert np.all(np.abs(dots[:4]) > 400)
    gp7 = load_robot("gp7")
    Q = gp7.random_configurations(np.random.default_rng(0), 200)
    J = gp7.jacobian_batch(np.vstack([np.zeros(6), Q]))
    assert np.abs(J[:, 2, 0]).max() == 0.0                     # no vertical velocity from J1, ever
    assert np.abs(np.einsum("nij,nij->nj", J[:, :3], J[:, 3:])).max() < 1e-15


def test_seed000_figure15_is_an_elementwise_product_instead_of_a_cross_product():
    """What Figure 15 is: ``[z_{i-1} .* (p_6 - p_{i-1}); z_{i-1}]`` of the paper's own DH chain (the
    MATLAB line it prints for the Fanuc, ``J=[z0.*(t6-t0) ...]``), with z0 taken as (0, 0, -1)."""
    frames = seed000_frames()
    p6 = frames[-1][:3, 3]
    J = np.zeros((6, 6))
    for i in range(6):
        z = frames[i][:3, 2] if i > 0 else np.array([0.0, 0.0, -1.0])
        J[:3, i] = z * (p6 - frames[i][:3, 3])
        J[3:, i] = z
    np.testing.assert_allclose(J, SEED000_FIGURE15, atol=1e-9)
    cross = np.array([np.cross(frames[i][:3, 2], p6 - frames[i][:3, 3]) for i in range(6)]).T
    assert np.abs(cross - SEED000_FIGURE15[:3]).max() > 400   # the real cross products differ


def test_seed004_wrist_centre_and_reach():
    """Seed 004's arm has a spherical wrist: the last three axes meet at the frame-4 origin."""
    robot = load_robot("arm6")
    q = robot.random_configurations(np.random.default_rng(2), 1)[0]
    frames = robot.fk_all(q)
    centre = frames[4][:3, 3]
    for k in (3, 4, 5):   # axes z3, z4, z5 pass through the wrist centre
        offset = centre - frames[k][:3, 3]
        assert np.linalg.norm(np.cross(frames[k][:3, 2], offset)) < 1e-12
