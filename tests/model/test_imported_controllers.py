"""One real arm per maker besides KUKA, imported from its ROS-Industrial description with ``import-urdf
--controller MAKER`` (issue 35): the ABB IRB 6640-185/2.80, the FANUC LR Mate 200iC and the Yaskawa GP8
(tests/data/urdf). Each gets its maker's controller section (models/SOURCES.md, "Controller sections of
imported robots"), and its configuration data is checked on 2000 random in-limit configurations against the
maker's definitions computed here from the URDF's joint origins and axes (``test_controller_conventions``'s
plain-NumPy helpers), and a job giving the maker's configuration per pose lands on it."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.files.poses import rotation_to_rpy
from pipeline.model.ik import solve_ik_batch
from pipeline.model.robot import load_robot
from pipeline.model.vendors.axes import axis_angles, joint_values
from pipeline.model.vendors.configuration import configurations, format_configuration
from pipeline.model.vendors.controller import controller_of
from pipeline.model.vendors.sides import wrist_centres
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import parse_job
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR
from .test_controller_conventions import (
    fields_abb,
    fields_fanuc,
    fields_yaskawa,
    joint_frames,
    off_boundaries,
    rotation,
    urdf_chain,
    wrist_point,
)

#: (maker, URDF, the maker's fields computed from the URDF chain, the URDF's base link above base_link [m]).
ARMS = {
    "abb": ("abb_irb6640_185_280.urdf", fields_abb, 0.0),
    "fanuc": ("fanuc_lrmate200ic.urdf", fields_fanuc, 0.330),
    "yaskawa": ("motoman_gp8.urdf", fields_yaskawa, 0.330),
}


@pytest.fixture(scope="module")
def imported(tmp_path_factory) -> dict:
    """maker -> the arm imported with its controller section, written as a robot file and read back."""
    folder = tmp_path_factory.mktemp("imported")
    return {maker: load_robot(import_urdf(DATA_DIR / "urdf" / urdf, controller=maker, time_to_full_speed=0.3)
                              .write(folder / f"{maker}.yaml"))
            for maker, (urdf, _, _) in ARMS.items()}


@pytest.mark.parametrize("maker", ARMS)
def test_the_section_is_the_makers_ros_industrial_conventions(imported, maker):
    robot, (_, _, base_z) = imported[maker], ARMS[maker]
    controller = controller_of(robot)
    assert controller.maker == maker and controller.direction == (1,) * 6 and controller.offset == (0.0,) * 6
    assert controller.coupling == ("fanuc_j2_j3" if maker == "fanuc" else None)
    np.testing.assert_allclose(controller.X_B_base[:3, 3], [0, 0, base_z], atol=1e-15)   # the URDF's base link
    np.testing.assert_allclose(controller.X_B_base[:3, :3], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(controller.X_E_flange, np.eye(4), atol=1e-9)             # tool0, our end frame
    np.testing.assert_allclose(controller.elbow_up, 0.0)


def test_fanucs_pendant_j3_is_the_urdfs_j3_minus_j2_and_back(imported):
    """fanuc_driver (J23_factor 1): ROS J3 = pendant J3 + J2."""
    robot = imported["fanuc"]
    q = np.radians([10, 30, 50, -20, 40, 60])
    np.testing.assert_allclose(axis_angles(robot, q, "fanuc"), [10, 30, 20, -20, 40, 60], atol=1e-12)
    np.testing.assert_allclose(joint_values(robot, [10, 30, 20, -20, 40, 60], "fanuc"), q, atol=1e-15)
    assert axis_angles(imported["abb"], q, "abb")[2] == pytest.approx(50.0)             # ABB, Yaskawa: serial
    assert axis_angles(imported["yaskawa"], q, "yaskawa")[2] == pytest.approx(50.0)


def test_tip_flange_puts_fanucs_tool0_in_our_end_frame():
    """Imported up to the ``flange`` link (x out of the faceplate), the controller's flange is tool0 turned
    rpy (pi, -pi/2, 0) from it: its z is our x."""
    robot = import_urdf(DATA_DIR / "urdf" / "fanuc_lrmate200ic.urdf", controller="fanuc", tip="flange").robot
    X = controller_of(robot).X_E_flange
    np.testing.assert_allclose(X[:3, 2], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(np.degrees(rotation_to_rpy(X[:3, :3])), [180, -90, 0], atol=1e-9)


@pytest.mark.parametrize("maker", ARMS)
def test_configurations_are_the_makers_definitions_on_2000_configurations(imported, maker):
    """ABB [cf1, cf4, cf6, cfx], FANUC F/N U/D T/B + turns, Yaskawa RCONF from the URDF geometry."""
    robot, (urdf, fields, _) = imported[maker], ARMS[maker]
    chain = urdf_chain(DATA_DIR / "urdf" / urdf)
    Q = robot.random_configurations(np.random.default_rng(35), 2000)
    np.testing.assert_allclose(wrist_point(chain, Q), wrist_centres(robot, Q), atol=1e-12)    # the same arm
    Q = Q[off_boundaries(chain, Q)]
    assert len(Q) == 2000
    want, got = fields(chain, Q).astype(int), configurations(robot, Q, maker)
    agree = int((want == got).all(axis=1).sum())
    assert agree == len(Q), f"{maker}: {agree} of {len(Q)} agree"
    assert len({tuple(row) for row in want[:, :3]}) >= 6             # many sides and quadrants occur


def job_to(robot, X: np.ndarray, maker: str, config: str) -> dict:
    """A job of the robot file to the pose X (4, 4) [m] with ``maker``'s configuration text ``config``."""
    pose = {"xyz": (X[:3, 3] * 1000).tolist(), "rpy": np.degrees(rotation_to_rpy(X[:3, :3])).tolist()}
    return {"robot": robot.spec.source, "length_unit": "mm", "angle_unit": "deg", "outputs": ["json"],
            "allow_branch_change": True, "waypoints": [{**pose, "controller_config": {maker: config}}, pose]}


@pytest.mark.parametrize("maker", ARMS)
def test_a_job_giving_the_makers_configuration_lands_on_it(imported, maker):
    """Every in-limit solution of three poses (up to 8 branches each), asked by its own configuration."""
    robot, reached = imported[maker], 0
    for q0 in robot.random_configurations(np.random.default_rng(3), 3):
        X = robot.fk(q0)
        Q = np.array([s.q for s in solve_ik_batch(robot, X[None], method="analytic")[0].solutions]).reshape(-1, 6)
        Q = Q[((Q >= robot.limits.q_min) & (Q <= robot.limits.q_max)).all(axis=1)]
        for q in Q:
            fields = configurations(robot, q, maker)
            if len(Q[(configurations(robot, Q, maker) == fields).all(axis=1)]) > 1:
                continue                                     # two solutions share it (no turn field tells them)
            job = parse_job(job_to(robot, X, maker, format_configuration(maker, fields)))
            np.testing.assert_allclose(solve_waypoints(job)[0].q, q, atol=1e-9)
            reached += 1
    assert reached >= 6


def test_the_urdf_and_our_fk_agree_on_tool0(imported):
    """Our end frame is the URDF's tool0: link_6 turned +90 deg about y for the ABB arm (z out of the flange)."""
    robot = imported["abb"]
    chain = urdf_chain(DATA_DIR / "urdf" / ARMS["abb"][0])
    Q = robot.random_configurations(np.random.default_rng(5), 100)
    R6, p6 = joint_frames(chain, Q)[5]
    X = robot.fk_batch(Q)
    np.testing.assert_allclose(X[:, :3, 3], p6, atol=1e-12)
    np.testing.assert_allclose(X[:, :3, :3], R6 @ rotation((0, 1, 0), np.array([np.pi / 2]))[0], atol=1e-9)
