"""The IK branches of a TCP target (``pipeline.ui.branches``): a known configuration's branch comes back with that
configuration, every branch reaches the target, the vendor texts are the controller module's, and the states
(colliding with the closest pair in the GP7 shelf cell, near a singularity, unreachable) are the ones expected."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.cell.collision import Clearance
from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.chain.singularity import compute_singularity
from pipeline.model.ik import solve_ik_batch
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.ik.result import limit_variants, rotation_angle
from pipeline.model.robot import load_robot, robot_with_tool
from pipeline.model.vendors import configurations, format_configuration
from pipeline.ui.branches import CLEARANCE_SHOWN_WITHIN_M, NEAR_SINGULAR, maker_vendor, target_branches

#: A closed-form branch reaches its target to round-off [m, rad].
POSE_TOL = 1e-9
#: The gripper of the demo cells: its TCP 120 mm along the flange's z.
X_FT = rpy_position_to_pose([0.0, 0.0, 0.0], [0.0, 0.0, 0.12])
#: A GP7 configuration away from limits and singularities [rad].
Q0 = np.radians([10.0, 30.0, -20.0, 15.0, -40.0, 25.0])


@pytest.fixture(scope="module")
def gp7():
    return robot_with_tool(load_robot("gp7"), X_FT)


@pytest.fixture(scope="module")
def shelf():
    """The GP7 in gp7_shelf_cell with the gripper: (robot with its TCP, collision model, X_BW)."""
    from pipeline.cell.cell_file import load_cell, resolve_cell_path
    from pipeline.cell.collision import CollisionModel

    cell = load_cell(resolve_cell_path("gp7_shelf_cell"))
    robot_F = cell.load_robot()
    return robot_with_tool(robot_F, X_FT), CollisionModel(robot_F, cell), np.linalg.inv(cell.X_WB)


def _pose_errors(robot, q, X):
    X_q = robot.fk(q)
    return float(np.linalg.norm(X_q[:3, 3] - X[:3, 3])), float(rotation_angle(X_q[:3, :3].T @ X[:3, :3]))


def test_a_configurations_branch_comes_back_with_that_configuration(gp7):
    view = target_branches(gp7, gp7.fk(Q0), q_reference=Q0)
    name = configuration_labels(gp7, Q0[None])[0]
    assert view.reason is None and view.vendor == "yaskawa"
    mine = [b for b in view.branches if b.name == name]
    assert len(mine) == 1 and np.allclose(mine[0].q, Q0, rtol=0.0, atol=1e-9)
    assert view.branches[0] is mine[0]                          # nearest the reference first
    distances = [np.linalg.norm(b.q - Q0) for b in view.branches]
    assert distances == sorted(distances)


def test_every_branch_is_one_of_the_closed_form_and_reaches_the_target(gp7):
    X = gp7.fk(Q0)
    view = target_branches(gp7, X)                               # reference: the middle of the ranges
    every = solve_ik_batch(gp7, X[None], gp7.limits.q_middle, method="analytic")[0].solutions
    assert sorted(b.name for b in view.branches) == sorted({s.branch for s in every})
    for b in view.branches:
        assert max(_pose_errors(gp7, b.q, X)) <= POSE_TOL
        assert np.all(b.q >= gp7.limits.q_min) and np.all(b.q <= gp7.limits.q_max)
        on_branch = [s.q for s in every if s.branch == b.name]  # its 2 pi variants: b is the nearest
        assert min(np.linalg.norm(q - gp7.limits.q_middle) for q in on_branch) == \
            pytest.approx(np.linalg.norm(b.q - gp7.limits.q_middle), abs=1e-12)
        _, valid = limit_variants(b.q[None], gp7.revolute_mask, gp7.limits.q_min, gp7.limits.q_max)
        assert b.variants == int(valid.sum()) >= 1
        assert b.state == "free" and b.clearance is None and b.sigma_min >= NEAR_SINGULAR


def test_vendor_texts_are_the_controllers_and_the_maker_is_the_presets(gp7):
    view = target_branches(gp7, gp7.fk(Q0), Q0)
    for b in view.branches:
        assert b.vendor_config == format_configuration("yaskawa", configurations(gp7, b.q, "yaskawa"))
    assert len({b.vendor_config for b in view.branches}) == len(view.branches)
    assert [maker_vendor(load_robot(n)) for n in ("gp7", "irb1600", "lrmate200id", "arm6")] == \
        ["yaskawa", "abb", "fanuc", None]
    arm6 = load_robot("arm6")
    other = target_branches(arm6, arm6.fk(Q0), Q0)
    assert other.vendor is None and other.branches and all(b.vendor_config is None for b in other.branches)


def test_a_target_inside_a_shelf_board_collides_and_names_the_board(shelf):
    robot, scene, X_BW = shelf
    X_WT = rpy_position_to_pose([0.0, np.pi / 2, 0.0], [0.70, 0.0, 0.45])      # in board_middle, tool along +x
    view = target_branches(robot, X_BW @ X_WT, None, scene)
    assert view.branches
    for b in view.branches:
        assert b.state == "colliding" and b.clearance.obstacle_pair[1] == "board_middle"
        assert b.clearance.obstacle < 0.0
        assert max(_pose_errors(robot, b.q, X_BW @ X_WT)) <= POSE_TOL
    text = view.describe()
    assert "colliding" in text and "board_middle" in text and view.branches[0].vendor_config in text


@pytest.mark.parametrize("q_deg, close", [([0.0, 0.0, 18.0, 0.0, -60.0, 0.0], True),     # tool 29 mm from board_high
                                           ([90.0, 0.0, 0.0, 0.0, -60.0, 0.0], False)])  # 265 mm from the floor
def test_a_free_branch_carries_its_clearance_only_when_close(shelf, q_deg, close):
    robot, scene, _ = shelf
    q = np.radians(q_deg)
    view = target_branches(robot, robot.fk(q), q, scene)
    b = view.branches[0]
    assert np.allclose(b.q, q, atol=1e-9) and b.state == "free"
    if close:
        assert b.clearance == scene.clearance(b.q) and b.clearance.obstacle_pair == ("tool", "board_high")
        assert scene.clearance_m < b.clearance.obstacle < scene.clearance_m + CLEARANCE_SHOWN_WITHIN_M
    else:
        assert b.clearance is None and scene.clearance(q).obstacle > scene.clearance_m + CLEARANCE_SHOWN_WITHIN_M


def test_a_near_singular_target_is_flagged_with_its_smallest_singular_value(gp7):
    q = Q0.copy()
    q[4] = 1e-4                                                  # the wrist nearly stretched: J4, J6 aligned
    view = target_branches(gp7, gp7.fk(q), q)
    b = view.branches[0]
    # q4 and q6 are ill-conditioned at q5 ~ 1e-4 (the pose's round-off moves them ~1e4 times as much): 1e-6 rad
    assert np.allclose(b.q, q, rtol=0.0, atol=1e-6) and max(_pose_errors(gp7, b.q, gp7.fk(q))) <= POSE_TOL
    assert b.state == "near_singular"
    assert b.sigma_min == pytest.approx(compute_singularity(gp7.jacobian(b.q)).smallest_singular_value, rel=1e-9)
    assert b.sigma_min < NEAR_SINGULAR
    assert any(other.state == "free" for other in view.branches)     # elbow down is far from it


def test_colliding_wins_over_near_singular(gp7):
    class Colliding:                          # a scene where everything collides: no Drake needed
        def is_free(self, q):
            return False

        def clearance(self, q):
            return Clearance(-0.01, ("link6", "wall"), 0.05, ("link2", "link5"))

    q = Q0.copy()
    q[4] = 1e-4
    view = target_branches(gp7, gp7.fk(q), q, Colliding())
    assert view.branches[0].sigma_min < NEAR_SINGULAR
    assert {b.state for b in view.branches} == {"colliding"}
    assert "link6 - wall -10.0 mm" in view.describe()


def test_an_unreachable_target_is_a_result_with_a_reason(gp7):
    view = target_branches(gp7, rpy_position_to_pose([0.0, 0.0, 0.0], [3.0, 0.0, 0.0]))
    assert view.branches == () and "out of reach" in view.reason and "3000.000, 0.000, 0.000" in view.reason
    assert view.describe().splitlines()[-1].startswith("no branch: ")


def test_an_arm_without_a_closed_form_gets_the_numeric_answer_from_the_reference():
    arm5 = load_robot("arm5")
    q = np.radians([10.0, 20.0, 30.0, 40.0, 50.0])
    view = target_branches(arm5, arm5.fk(q), q)
    assert len(view.branches) == 1 and view.vendor is None
    b = view.branches[0]
    assert b.name == "" and b.vendor_config is None and b.variants >= 1
    assert max(_pose_errors(arm5, b.q, arm5.fk(q))) <= 1e-6      # the numeric IK's strict tolerance


def test_bad_input_is_a_typed_error(gp7):
    with pytest.raises(ConfigurationError, match="TCP target"):
        target_branches(gp7, np.eye(3))
    with pytest.raises(ConfigurationError):
        target_branches(gp7, gp7.fk(Q0), q_reference=[0.0, 1.0])


def test_a_drag_through_a_singular_wrist_keeps_axes_4_and_6(gp7):
    """Dragging the target along a line with axes 4 and 6 aligned (each target a rounding away from the
    singularity: turned by 5e-8 rad, a 7-digit quaternion's rounding): each step's nearest branch keeps q4 and q6
    where the arm was (the rule of pose waypoints)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(4)
    q = np.radians([0.0, 20.0, -10.0, 30.0, 0.0, -20.0])
    for step in range(10):
        X = gp7.fk(q + np.r_[0.02 * step, 0.01 * step, 0.0, 0.0, 0.0, 0.0])
        turn = rng.normal(size=3)
        X[:3, :3] = Rotation.from_rotvec(turn / np.linalg.norm(turn) * 5e-8).as_matrix() @ X[:3, :3]
        nearest = target_branches(gp7, X, q_reference=q).branches[0].q
        assert np.abs(nearest[[3, 5]] - q[[3, 5]]).max() < 0.1
        q = nearest
