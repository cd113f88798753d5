"""Tool moves: the geometry of lines, arcs and zones; the joint path that follows them; the timed profile
checked on dense samples (finer than its own); singularities and unreachable points as typed errors."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation, Slerp

from pipeline import load_robot
from pipeline.errors import ConfigurationError, JobFileError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.chain.kinematics import rotation_log
from pipeline.program.job import load_job, parse_job
from pipeline.program.tool_moves import POSITION_TOLERANCE_M, ROTATION_TOLERANCE_RAD, ToolMoveError, joint_path_along
from pipeline.program.tool_path import ToolMove, ToolPath
from pipeline.runner import run_job
from pipeline.timing import retime
from pipeline.timing.profile import certify, limits_at
from pipeline.timing.tcp import TcpMotion

from ..test_runner import ROOT

DENSE_DT = 0.0005          # finer than any job's samples (default 0.004 s)
SPEED, ACCEL = 0.5, 3.0    # [m/s], [m/s^2]
DOWN = [math.pi, 0.0, 0.0]


def pose(xyz_mm, rpy=DOWN):
    return rpy_position_to_pose(rpy, np.array(xyz_mm) / 1e3)


# -- geometry -------------------------------------------------------------------------------------------
def test_a_line_is_straight_at_unit_speed_and_turns_by_scipys_slerp():
    X0, X1 = pose([500, -200, 400], [math.pi, 0, 0]), pose([600, 200, 300], [math.pi, 0.3, 0.8])
    path = ToolPath(X0, [ToolMove("linear", X1)])
    assert path.length == pytest.approx(np.linalg.norm(X1[:3, 3] - X0[:3, 3]))
    sigma = np.linspace(0.0, path.length, 101)
    p = path.position(sigma)
    direction = (X1[:3, 3] - X0[:3, 3]) / path.length
    assert np.abs(p - (X0[:3, 3] + sigma[:, None] * direction)).max() < 1e-15
    assert np.abs(np.linalg.norm(path.position(sigma, 1), axis=1) - 1.0).max() < 1e-15
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix([X0[:3, :3], X1[:3, :3]]))
    assert np.abs(path.rotation(sigma).as_matrix() - slerp(sigma / path.length).as_matrix()).max() < 1e-12
    assert np.abs(path.poses([0.0, path.length]) - [X0, X1]).max() < 1e-12


def test_an_arc_passes_through_its_via_point_on_one_circle():
    X0, X1, via = pose([500, -200, 400]), pose([500, 200, 400]), np.array([0.62, 0.0, 0.45])
    path = ToolPath(X0, [ToolMove("circular", X1, via=via)])
    sigma = np.linspace(0.0, path.length, 20001)
    p = path.position(sigma)
    assert np.linalg.norm(p - via, axis=1).min() < 1e-4                     # the via point is on the track
    centre = p[0] + (path.position(sigma[:1], 2)[0]) * path.segments[0].arc[1] ** 2
    radius = np.linalg.norm(p - centre, axis=1)
    assert np.ptp(radius) < 1e-12 and np.abs(p[-1] - X1[:3, 3]).max() < 1e-12
    assert np.abs(np.linalg.norm(path.position(sigma, 1), axis=1) - 1.0).max() < 1e-12
    with pytest.raises(ConfigurationError, match="on the line through the arc's ends"):
        ToolPath(X0, [ToolMove("circular", X1, via=np.array([0.5, 0.0, 0.4]))])


def test_a_zone_rounds_the_corner_within_its_radius_and_keeps_the_track_c3():
    corner = pose([500, 200, 400])
    zone = 0.05
    path = ToolPath(pose([500, -200, 400]), [ToolMove("linear", corner, zone=zone),
                                             ToolMove("linear", pose([700, 200, 300], [math.pi, 0.2, 0.4]))])
    sigma = np.linspace(0.0, path.length, 40001)
    p = path.position(sigma)
    near = np.abs(sigma - 0.4) <= zone
    assert np.linalg.norm(p - corner[:3, 3], axis=1).min() > 1e-3          # the corner itself is cut
    # Outside the zone the TCP is on the two lines exactly.
    assert np.abs(p[~near & (sigma < 0.4)][:, [0, 2]] - [0.5, 0.4]).max() < 1e-12
    for b in path.breakpoints[1:-1]:
        for order in range(4):
            left, right = path.position([b - 1e-9], order)[0], path.position([b + 1e-9], order)[0]
            assert np.abs(left - right).max() < 1e-4 * max(1.0, np.abs(left).max())
    rotations = path.rotation(sigma).as_matrix()
    steps = [np.linalg.norm(rotation_log(a.T @ b)) for a, b in zip(rotations[:-1], rotations[1:])]
    assert max(steps) < 1e-3                                                # orientation without jumps


# -- the joint path and its profile, on dense samples ---------------------------------------------------------
def track(robot_name: str):
    """A chain of a line, an arc and a line with zones, turning the tool, in front of the robot."""
    if robot_name == "irb1600":
        tilt = [0.0, 0.75 * math.pi, 0.0]
        return [pose([950, -250, 900], tilt), [
            ToolMove("linear", pose([950, 250, 900], tilt), zone=0.04),
            ToolMove("circular", pose([950, 150, 650], [0.0, 0.75 * math.pi, 0.3]),
                     via=np.array([0.95, 0.3, 0.78]), zone=0.03),
            ToolMove("linear", pose([950, -250, 600], tilt))]]
    return [pose([500, 350, 330], [math.pi, 0, 0.6]), [
        ToolMove("linear", pose([500, 350, 200], [math.pi, 0, 0.6]), zone=0.03),
        ToolMove("circular", pose([500, -350, 330], [math.pi, 0, -0.6]), via=np.array([0.7, 0.0, 0.38]), zone=0.05),
        ToolMove("linear", pose([500, -350, 200], [math.pi, 0, -0.6]))]]


@pytest.fixture(scope="module", params=["gp7", "irb1600"])
def followed(request):
    robot = load_robot(request.param)
    X_start, moves = track(request.param)
    path = ToolPath(X_start, moves)
    q_start = robot.ik(X_start, q_seed=np.radians([0, 10, -10, 0, -45 if request.param == "gp7" else 45, 0])).q
    along = joint_path_along(robot, path, q_start, SPEED)
    limits = dataclasses.replace(robot.limits, tcp_speed_max=SPEED, tcp_accel_max=ACCEL)
    profiles = {method: retime(robot, along.path, method=method, limits=limits, tcp=TcpMotion(robot), dt=DENSE_DT)
                for method in ("toppra", "topp3")}
    return robot, path, along, profiles


def deviations(robot, path: ToolPath, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] of each sample's TCP from the ideal track (its nearest point, on 0.02 mm spacing),
    and the rotation angle [rad] from the ideal orientation there."""
    sigma = np.linspace(0.0, path.length, int(path.length / 2e-5) + 2)
    ideal = path.position(sigma)
    X = robot.fk_batch(q)
    distance, nearest = cKDTree(ideal).query(X[:, :3, 3])
    R_ideal = path.rotation(sigma[nearest]).as_matrix()
    angle = np.array([np.linalg.norm(rotation_log(a.T @ b)) for a, b in zip(X[:, :3, :3], R_ideal)])
    return distance, angle


@pytest.mark.parametrize("method", ["toppra", "topp3"])
def test_profile_keeps_the_tcp_on_the_track_within_tolerance_between_samples(followed, method):
    robot, path, along, profiles = followed
    distance, angle = deviations(robot, path, profiles[method].q)
    assert distance.max() <= POSITION_TOLERANCE_M + 2e-6                  # 2 um: the ideal's sample spacing
    assert angle.max() <= ROTATION_TOLERANCE_RAD + 1e-4
    assert along.max_position_error <= POSITION_TOLERANCE_M


@pytest.mark.parametrize("method", ["toppra", "topp3"])
def test_profile_respects_tcp_and_joint_limits_without_branch_flips(followed, method):
    robot, path, along, profiles = followed
    profile = profiles[method]
    assert profile.certificate.passed and certify(profile).passed
    # Independently of certify(): the TCP's speed from finite differences of FK positions.
    p = robot.fk_batch(profile.q)[:, :3, 3]
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(profile.t)
    assert speed.max() <= SPEED * (1.0 + 1e-3)
    assert profile.tcp.accel.max() <= ACCEL * (1.0 + 1e-6)
    limits = robot.limits
    assert (profile.q >= limits.q_min - 1e-12).all() and (profile.q <= limits.q_max + 1e-12).all()
    steps = np.abs(np.diff(profile.q, axis=0)) / np.diff(profile.t)[:, None]
    assert (steps <= limits.qd_max * (1.0 + 1e-3)).all()                    # no branch flip between samples
    assert np.abs(profile.q[[0, -1]] - along.samples[[0, -1]]).max() < 1e-9


@pytest.mark.parametrize("method", ["toppra", "topp3"])
def test_the_tcp_speed_limit_is_reached_on_the_straight_part(followed, method):
    _, _, _, profiles = followed
    assert profiles[method].tcp.speed.max() >= 0.99 * SPEED


def test_topp3_limits_the_tcp_at_its_stations_not_by_slowing_everything(followed):
    """copp gets the TCP rows itself: the jerk limit costs a few percent over toppra, not the factor
    of up to 2 a uniform slow-down for the TCP's peak costs (1.8-1.9x on the demo tool jobs)."""
    _, _, _, profiles = followed
    assert profiles["topp3"].details.time_stretch < 1.01
    assert profiles["topp3"].duration < 1.15 * profiles["toppra"].duration


# -- singularities and unreachable points ------------------------------------------------------------------
def wrist_line(tilt_deg: float):
    """IRB 1600: a line across the front with the tool along base x, tilted ``tilt_deg`` down, so that
    the wrist passes that close to q5 = 0 halfway (J4 and J6 turn fast there)."""
    rpy = [0.0, math.pi / 2 + math.radians(tilt_deg), 0.0]
    return rpy_position_to_pose(rpy, [0.815, -0.2, 0.9615]), rpy_position_to_pose(rpy, [0.815, 0.2, 0.9615])


def test_a_move_near_a_wrist_singularity_is_a_typed_error_naming_move_sample_and_kind():
    robot = load_robot("irb1600")
    X0, X1 = wrist_line(0.2)
    q0 = robot.ik(X0, q_seed=np.zeros(6)).q
    with pytest.raises(ToolMoveError, match=r"move to waypoint 0, sample \d+ \(TCP at \[815\.0, 0\.0, 961\.5\] mm\): "
                       r"near a wrist singularity.*Closest samples that work") as caught:
        joint_path_along(robot, ToolPath(X0, [ToolMove("linear", X1)]), q0, SPEED)
    assert caught.value.move == 0 and abs(caught.value.pose[1, 3]) < 0.01


def test_a_move_near_a_wrist_singularity_slows_down_when_allowed_within_the_limits():
    robot = load_robot("irb1600")
    X0, X1 = wrist_line(0.2)
    path = ToolPath(X0, [ToolMove("linear", X1)])
    along = joint_path_along(robot, path, robot.ik(X0, q_seed=np.zeros(6)).q, SPEED, singularity="slow_down")
    assert along.slowest_tcp_speed < 0.1 * SPEED                            # it does slow down, and says so
    limits = dataclasses.replace(robot.limits, tcp_speed_max=SPEED, tcp_accel_max=ACCEL)
    profile = retime(robot, along.path, limits=limits, tcp=TcpMotion(robot), dt=DENSE_DT)
    assert profile.certificate.passed
    assert profile.tcp.speed[np.argmin(np.abs(profile.tcp.position[:, 1]))] < 0.1 * SPEED
    distance, _ = deviations(robot, path, profile.q)
    assert distance.max() <= POSITION_TOLERANCE_M + 2e-6


def test_an_unreachable_point_in_the_middle_of_a_line_is_a_typed_error_naming_move_and_sample():
    robot = load_robot("gp7")
    X0, X1 = pose([400, 0, 300]), pose([-400, 0, 300])
    q0 = robot.ik(X0, q_seed=np.radians([0, 0, 0, 0, -90, 0])).q
    with pytest.raises(ToolMoveError, match=r"move to waypoint 3, sample \d+ .*out of reach on this move"):
        joint_path_along(robot, ToolPath(X0, [ToolMove("linear", X1)], first_index=3), q0, SPEED)


# -- jobs -------------------------------------------------------------------------------------------------------
JOBS = ROOT / "trajectories" / "jobs"


@pytest.mark.parametrize("name", ["gp7_pick_place", "irb1600_tool_moves"])
def test_demo_tool_jobs_on_dense_samples(name, tmp_path):
    job = dataclasses.replace(load_job(JOBS / f"{name}.yaml"), dt=DENSE_DT, outputs=("json",))
    outcome = run_job(job, tmp_path / name)
    profile = outcome.profile
    assert profile.certificate.passed and profile.tcp is not None
    # The TCP keeps the tool moves' limits on their lines and arcs (joint moves and blends run at the joints').
    _, speed_limit, accel_limit = limits_at(profile.limits, profile.schedule, profile.t)
    assert np.isfinite(speed_limit).any() and speed_limit[np.isfinite(speed_limit)].max() == pytest.approx(job.tcp_speed_max)
    assert (profile.tcp.speed <= speed_limit * (1 + 1e-6)).all() and (profile.tcp.accel <= accel_limit * (1 + 1e-6)).all()
    steps = np.abs(np.diff(profile.q, axis=0)) / np.diff(profile.t)[:, None]
    assert (steps <= job.robot.limits.qd_max * (1.0 + 1e-3)).all()
    # Every stop is reached exactly, at rest; every zone corner is passed within its radius.
    positions = profile.tcp.position
    for k, waypoint in enumerate(job.waypoints[1:], start=1):
        distance = np.linalg.norm(positions - waypoint.X_BE[:3, 3], axis=1).min()
        assert distance <= (waypoint.zone if waypoint.zone > 0 else 1e-6), k
    stops = outcome.report["program"]["stops"]
    assert len(outcome.report["timing_details"]["stretches"]) == len(stops) - 1
    for move in outcome.report["program"]["moves"]:
        if move["kind"] != "joint":
            assert move["track"]["max_position_error_m"] <= POSITION_TOLERANCE_M


def tool_job(**changes) -> dict:
    job = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 500,
           "start": [0, 0, 0, 0, -90, 0],
           "waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0]},
                         {"xyz": [500, -300, 330], "rpy": [180, 0, 0], "move": "linear", "zone": 50},
                         {"xyz": [500, -300, 200], "rpy": [180, 0, 0], "move": "linear"}]}
    job.update(changes)
    return job


@pytest.mark.parametrize("change, field, message", [
    ({"tcp_speed_max": None}, "tcp_speed_max", "required because waypoint 1 is a linear move"),
    ({"timing": "ruckig"}, "timing", "tool moves and TCP limits need toppra or topp3"),
    ({"tcp_speed_max": 50_000}, "tcp_speed_max", "above any arm"),
    ({"waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0], "move": "linear"},
                    {"xyz": [500, -300, 330], "rpy": [180, 0, 0]}]}, r"waypoints\[0\]\.move", "has no move to it"),
    ({"waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0]},
                    {"xyz": [500, -300, 330], "rpy": [180, 0, 0], "move": "linear", "zone": 50}]},
     r"waypoints\[1\]\.zone", "the motion ends at rest on the last waypoint"),
    ({"waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0]},
                    {"xyz": [500, -300, 330], "rpy": [180, 0, 0], "move": "circular"}]},
     r"waypoints\[1\]\.via", "required"),
    ({"waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0]},
                    {"xyz": [500, -300, 330], "rpy": [180, 0, 0], "move": "linear", "via": {"xyz": [1, 2, 3]}}]},
     r"waypoints\[1\]\.via", "via point of a circular move"),
    ({"waypoints": [{"xyz": [500, 300, 330], "rpy": [180, 0, 0]},
                    {"xyz": [500, -300, 330], "rpy": [180, 0, 0], "move": "teleport"}]},
     r"waypoints\[1\]\.move", "must be one of joint, linear, circular"),
    ({"singularity": "ignore"}, "singularity", "must be one of stop, slow_down"),
    ({"tool": {"xyz": [0, 0, 5e6]}}, r"tool\.xyz", "farther than"),
])
def test_bad_tool_jobs_get_typed_errors_naming_the_field(change, field, message):
    document = {key: value for key, value in {**tool_job(), **change}.items() if value is not None}
    with pytest.raises(JobFileError, match=rf"{field}: .*{message}"):
        parse_job(document)


def test_a_job_through_an_unreachable_point_names_the_waypoint_and_sample(tmp_path):
    document = tool_job(waypoints=[{"xyz": [300, 300, 300], "rpy": [180, 0, 0]},
                                   {"xyz": [-300, -300, 300], "rpy": [180, 0, 0], "move": "linear"}],
                        allow_branch_change=True)
    job = parse_job(document)
    with pytest.raises(JobFileError, match=r"waypoints\[1\]: move to waypoint 1, sample \d+ .*out of reach"):
        run_job(job, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_tool_move_to_where_the_tcp_already_is_is_a_job_error():
    from pipeline.program.compile import compile_job

    pose = {"xyz": [500, 0, 400], "rpy": [180, 0, 0]}
    job = parse_job({"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 200,
                     "waypoints": [pose, {**pose, "move": "linear"}, {**pose, "xyz": [500, 100, 400], "move": "linear"}]},
                    "still.yaml", "still")
    with pytest.raises(JobFileError, match=r"waypoints\[1\].move: a linear move to where the TCP already is"):
        compile_job(job)
    turned = parse_job({"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 200,
                        "waypoints": [pose, {**pose, "rpy": [180, 0, 20], "move": "linear"}]}, "turn.yaml", "turn")
    assert compile_job(turned).moves[0].track is not None          # turning in place is a move
