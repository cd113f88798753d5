"""Configuration data in each maker's own convention, for any arm whose robot file has a controller section
(issue 35): a real KUKA (the KR 6 R700 sixx of ROS-Industrial's kuka_experimental, in KUKA's zero convention,
imported with ``--controller kuka``) and the presets, each checked against the makers' definitions computed
here independently, from the URDF's joint origins and axes with plain NumPy (not from our DH model)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from pipeline.model.robot import load_robot
from pipeline.model.vendors.configuration import configurations
from pipeline.model.vendors.controller import controller_of
from pipeline.model.vendors.selection import select_solution
from pipeline.model.vendors.sides import wrist_centres
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import parse_job
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR

KUKA_URDF = DATA_DIR / "urdf" / "kuka_kr6r700sixx.urdf"
#: Configurations closer than this to a field's boundary (an axis at 0, the wrist centre on axis 1, the
#: elbow on its singular line) are left out [rad or m]: either side describes them.
BOUNDARY = 1e-9
#: The LR Mate 200iD has no URDF here: its joint origins [m] and axes at q = 0 from models/SOURCES.md
#: (J2 at (50, 0, 330) mm, a2 = 330, a3 = 35, d4 = 335, d6 = 80; axes J1 +z, J2 +y, J3 -y, J4 -x, J5 -y, J6 -x).
LRMATE_CHAIN = [((0, 0, 0), (0, 0, 1)), ((0.05, 0, 0.33), (0, 1, 0)), ((0, 0, 0.33), (0, -1, 0)),
                ((0.335, 0, 0.035), (-1, 0, 0)), ((0, 0, 0), (0, -1, 0)), ((0.08, 0, 0), (-1, 0, 0))]


def urdf_chain(path) -> list:
    """[(origin xyz [m], axis)] of the revolute joints of a URDF whose joint origins carry no rotation."""
    chain = []
    for joint in ET.parse(path).getroot().iter("joint"):
        if joint.get("type") != "revolute":
            continue
        origin = joint.find("origin")
        assert origin.get("rpy", "0 0 0").split() == ["0", "0", "0"]
        chain.append((tuple(map(float, origin.get("xyz").split())), tuple(map(float, joint.find("axis").get("xyz")
                                                                             .split()))))
    return chain


def rotation(axis, angles: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) about a unit axis by angles (N,) [rad]."""
    w = np.asarray(axis, dtype=float)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * K @ K


def joint_frames(chain: list, Q: np.ndarray) -> list:
    """Per joint (R (N, 3, 3), p (N, 3)): its frame in the base frame after turning it by Q[:, i] [rad]."""
    R, p, frames = np.broadcast_to(np.eye(3), (len(Q), 3, 3)), np.zeros((len(Q), 3)), []
    for i, (origin, axis) in enumerate(chain):
        p = p + R @ np.array(origin)
        R = R @ rotation(axis, Q[:, i])
        frames.append((R, p))
    return frames


def wrist_point(chain: list, Q: np.ndarray) -> np.ndarray:
    """The intersection (N, 3) [m] of the axes of joints 4 and 5 (closest point of the two lines)."""
    frames = joint_frames(chain, Q)
    (R4, p4), (R5, p5) = frames[3], frames[4]
    u, v = R4 @ np.array(chain[3][1], float), R5 @ np.array(chain[4][1], float)
    w0 = p4 - p5
    a, b, c = (u * u).sum(1), (u * v).sum(1), (v * v).sum(1)
    d, e = (u * w0).sum(1), (v * w0).sum(1)
    s = (b * e - c * d) / (a * c - b * b)
    t = (a * e - b * d) / (a * c - b * b)
    assert np.abs((p4 + s[:, None] * u) - (p5 + t[:, None] * v)).max() < 1e-12      # the axes meet
    return p4 + s[:, None] * u


def x_in_a1_frame(chain: list, Q: np.ndarray) -> np.ndarray:
    """The wrist point's x (N,) [m] in the frame of joint 1 (turned with it)."""
    R1, p1 = joint_frames(chain, Q)[0]
    return np.einsum("nji,nj->ni", R1, wrist_point(chain, Q) - p1)[:, 0]


def elbow_angles(chain: list) -> float:
    """phi [rad]: the joint-3 angle that puts the wrist point on the line through axes 2 and 3 (the other such
    angle is phi + pi), from the joint origins and axes at q = 0."""
    zero = np.zeros((1, 6))
    p2, p3 = joint_frames(chain, zero)[1][1][0], joint_frames(chain, zero)[2][1][0]
    w3, v0 = np.array(chain[2][1], float), wrist_point(chain, zero)[0] - p3
    u = p3 - p2
    # (u x R(w3, t) v0) . w3 = a cos t + b sin t
    a = np.cross(u, v0) @ w3
    b = np.cross(u, np.cross(w3, v0)) @ w3
    return float(np.arctan2(-a, b))


def elbow_up(chain: list, q3: np.ndarray, q3_up: float) -> np.ndarray:
    """Whether joint 3 at q3 (N,) [rad] is on the side of phi that q3_up (the maker's elbow-up angle) is on."""
    phi = elbow_angles(chain)
    return np.sign(np.sin(q3 - phi)) == np.sign(np.sin(q3_up - phi))


def off_boundaries(chain: list, Q: np.ndarray) -> np.ndarray:
    """Configurations (mask (N,)) no field of any maker has within BOUNDARY of a boundary."""
    phi = elbow_angles(chain)
    quadrant = np.abs(Q / (np.pi / 2) - np.round(Q / (np.pi / 2))) * np.pi / 2        # ABB quadrants, signs, 180
    return (quadrant.min(axis=1) > BOUNDARY) & (np.abs(x_in_a1_frame(chain, Q)) > BOUNDARY) & \
        (np.abs(np.sin(Q[:, 2] - phi)) > BOUNDARY)


# -- the KUKA KR 6 R700 sixx ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def kuka(tmp_path_factory):
    """The imported KR 6 R700 sixx, written as a robot file and read back."""
    path = tmp_path_factory.mktemp("kuka") / "kr6r700sixx.yaml"
    import_urdf(KUKA_URDF, controller="kuka", time_to_full_speed=0.3).write(path)
    return load_robot(path)


def test_kuka_import_has_the_urdfs_fk_and_kukas_controller_section(kuka):
    chain = urdf_chain(KUKA_URDF)
    Q = kuka.random_configurations(np.random.default_rng(1), 200)
    R6, p6 = joint_frames(chain, Q)[5]
    X = kuka.fk_batch(Q)
    R_flange_tool0 = rotation((0, 1, 0), np.array([np.pi / 2]))[0]              # tool0 = flange turned +90 deg
    np.testing.assert_allclose(X[:, :3, 3], p6, atol=1e-12)                     # about y, at the flange
    np.testing.assert_allclose(X[:, :3, :3], R6 @ R_flange_tool0, atol=1e-12)
    controller = controller_of(kuka)
    assert controller.maker == "kuka" and controller.direction == (1,) * 6 and controller.offset == (0.0,) * 6
    np.testing.assert_allclose(controller.elbow_up, [0, -90, 90, 0, 0, 0])
    np.testing.assert_allclose(controller.X_B_base, np.eye(4), atol=1e-15)
    # KUKA's $FLANGE (x out of the flange) in our end frame (tool0): our z is its x
    np.testing.assert_allclose(X[:, :3, :3] @ controller.X_E_flange[:3, :3], R6, atol=1e-12)
    np.testing.assert_allclose(controller.X_E_flange[:3, 3], 0.0, atol=1e-15)


def test_kuka_status_and_turn_are_kukas_definitions_on_10000_configurations(kuka):
    """S bit 0: wrist point x < 0 in the A1 frame; bit 1: A3 >= phi; bit 2: A5 < 0; T bit i: axis i + 1 < 0."""
    chain = urdf_chain(KUKA_URDF)
    phi = np.arctan2(chain[3][0][2], chain[4][0][0])       # the A3-A4 offset over the forearm: atan(35 / 365)
    assert abs(np.degrees(phi) - 5.4774) < 1e-4
    assert abs(elbow_angles(chain) - phi) < 1e-12           # the wrist point on the A2-A3 line there
    Q = kuka.random_configurations(np.random.default_rng(35), 10_000)
    Q = Q[off_boundaries(chain, Q)]
    assert len(Q) == 10_000
    status = (x_in_a1_frame(chain, Q) < 0) + 2 * (Q[:, 2] >= phi) + 4 * (Q[:, 4] < 0)
    turn = ((Q < 0) * 2 ** np.arange(6)).sum(axis=1)
    got = configurations(kuka, Q, "kuka")
    agree = int(((got[:, 0] == status) & (got[:, 1] == turn)).sum())
    assert agree == len(Q)
    assert {0, 1, 2, 3, 4, 5, 6, 7} == set(status.tolist())        # every Status occurs


def test_kuka_a3_of_106_deg_is_elbow_up_and_the_mastering_pose_is_b010(kuka):
    S, T = configurations(kuka, np.radians([0, -90, 106, 0, 30, 0]), "kuka")
    assert S & 2 and (S, T) == (2, 2)                        # 'B010', A2 negative
    assert tuple(configurations(kuka, np.radians([0, -90, 90, 0, 30, 0]), "kuka")) == (2, 2)
    assert not configurations(kuka, np.radians([0, -90, 5, 0, 30, 0]), "kuka")[0] & 2       # A3 5 < phi: down
    assert configurations(kuka, np.radians([0, -90, 6, 0, 30, 0]), "kuka")[0] & 2


def kuka_job(robot_path, X, config: str) -> dict:
    """A job of the robot file to the pose X (4, 4) [m] with the KUKA configuration ``config``."""
    from pipeline.files.poses import rotation_to_rpy

    pose = {"xyz": (X[:3, 3] * 1000).tolist(), "rpy": np.degrees(rotation_to_rpy(X[:3, :3])).tolist()}
    return {"robot": str(robot_path), "length_unit": "mm", "angle_unit": "deg", "outputs": ["json"],
            "allow_branch_change": True, "waypoints": [{**pose, "controller_config": {"kuka": config}}, pose]}


@pytest.mark.parametrize("q_deg", [[30, -100, 120, 40, 50, -60], [-20, -40, -10, 15, -30, 200],
                                   [150, -80, 100, -120, 60, 10]])
def test_a_job_giving_status_and_turn_lands_on_that_configuration(kuka, q_deg):
    q = np.radians(q_deg)
    S, T = configurations(kuka, q, "kuka")
    job = parse_job(kuka_job(kuka.spec.source, kuka.fk(q), f"S 'B{S:03b}', T 'B{T:06b}'"))
    np.testing.assert_allclose(solve_waypoints(job)[0].q, q, atol=1e-9)


@pytest.mark.parametrize("turn", ["B100011", "B101011"])
def test_an_axis_at_zero_by_round_off_is_accepted_either_side(kuka, turn):
    """The issue's job: S 'B000', T 'B100011' (A1, A2, A6 negative) for a target whose A4 is 0 by round-off;
    asking A4 negative ('B101011') must land there too."""
    q = np.radians([-20, -40, 3, 0, 30, -50])
    assert tuple(configurations(kuka, q, "kuka")) == (0, 0b100011)
    X = kuka.fk(q)
    np.testing.assert_allclose(select_solution(kuka, X, f"S 'B000', T '{turn}'", "kuka"), q, atol=1e-9)
    job = parse_job(kuka_job(kuka.spec.source, X, f"S 'B000', T '{turn}'"))
    np.testing.assert_allclose(solve_waypoints(job)[0].q, q, atol=1e-9)


# -- the presets: ABB cfx, FANUC CONFIG, Yaskawa RCONF --------------------------------------------------------
def fields_abb(chain, Q):
    deg = np.degrees(Q)
    behind, down = x_in_a1_frame(chain, Q) < 0, ~elbow_up(chain, Q[:, 2], 0.0)
    return np.column_stack([np.floor(deg[:, [0, 3, 5]] / 90), 4 * behind + 2 * down + (Q[:, 4] < 0)])


def fields_fanuc(chain, Q):
    deg = np.degrees(Q)                                      # J1, J4, J5, J6 as the pendant shows them
    turns = np.ceil((deg[:, [0, 3, 5]] - 180) / 360)
    return np.column_stack([deg[:, 4] >= 0, elbow_up(chain, Q[:, 2], 0.0), x_in_a1_frame(chain, Q) >= 0, turns])


def fields_yaskawa(chain, Q):
    deg = np.degrees(Q)
    r = np.mod(deg[:, 3], 360)                               # Flip for R in (-90, 90] + k 360 deg
    flip = (r <= 90) | (r > 270)
    return np.column_stack([~flip, ~elbow_up(chain, Q[:, 2], 0.0), x_in_a1_frame(chain, Q) < 0,
                            np.abs(deg[:, [3, 5, 0]]) >= 180])


@pytest.mark.parametrize("name, vendor, chain, fields", [
    ("irb1600", "abb", urdf_chain(DATA_DIR / "urdf" / "abb_irb1600_6_12.urdf"), fields_abb),
    ("lrmate200id", "fanuc", LRMATE_CHAIN, fields_fanuc),
    ("gp7", "yaskawa", urdf_chain(DATA_DIR / "urdf" / "motoman_gp7.urdf"), fields_yaskawa),
])
def test_preset_configurations_are_the_makers_definitions(name, vendor, chain, fields):
    robot = load_robot(name)
    assert controller_of(robot).maker == vendor
    Q = robot.random_configurations(np.random.default_rng(7), 2000)
    np.testing.assert_allclose(wrist_point(chain, Q), wrist_centres(robot, Q), atol=1e-12)    # the same arm
    Q = Q[off_boundaries(chain, Q)]
    assert len(Q) == 2000
    np.testing.assert_array_equal(configurations(robot, Q, vendor), fields(chain, Q).astype(int))


def test_krl_writes_the_tool_on_kukas_flange_and_says_where_its_frames_come_from(kuka):
    """A tool 100 mm along our end frame's z (tool0's, out of the flange) is 100 mm along $FLANGE's x."""
    from pipeline.outputs.controllers.krl import write_krl
    from pipeline.program.compile import compile_job

    q = [10, -80, 100, 15, 40, 20]
    job = parse_job({"robot": kuka.spec.source, "length_unit": "mm", "angle_unit": "deg", "outputs": ["json"],
                     "tool": {"xyz": [0, 0, 100], "rpy": [0, 0, 0]}, "waypoints": [q, [15, -75, 95, 10, 45, 25]]})
    src, _ = write_krl(compile_job(job), "KR6")
    assert "$TOOL = {X 100.000,Y 0.000,Z 0.000,A 0.0000,B 90.0000,C 0.0000}" in src
    assert "$ROBROOT, $FLANGE, S/T: the controller section of kr6r700sixx.yaml: kuka base frame = our base frame, " \
           "flange = xyz [0.0, 0.0, 0.0] mm, rpy [0.0, -90.0, 0.0] deg in our end frame" in src
