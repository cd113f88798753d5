"""A tool path -> the joint path that keeps the TCP on it: IK at adaptive samples, singularities found.

IK runs at samples of the tool path through ``solve_ik_path`` (the package's one rule along a path:
one branch, nearest solution, no jump). The joint path is the C2 spline through the samples
(``path_through_samples``); between every two samples it is checked at CHECK_FRACTIONS of the interval
against the ideal pose, and an interval that deviates by more than the tolerance (default 0.1 mm and
0.1 deg) is split and solved again, so the tolerance holds between the samples, not only at them.

Near a singularity the joints must turn fast for a slow TCP: the TCP speed the joint speed limits
allow at a sample is min_j qd_max_j / |dq_j/dsigma|. Where it falls below SINGULAR_SPEED_FRACTION of the
job's TCP speed the move is refused (ToolMoveError naming the move, the sample, the pose, the
singularity measures and the closest sample that works) unless the job allows a slow-down, which is
then reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import PipelineError
from ..model.chain.kinematics import rotation_log
from ..model.chain.singularity import compute_singularity, near_singularity
from ..model.robot import Robot
from ..timing.joint_path import JointPath, path_through_samples
from .tool_path import ToolPath

#: Deviation allowed between the joint path and the ideal tool path, anywhere [m], [rad].
POSITION_TOLERANCE_M = 1e-4
ROTATION_TOLERANCE_RAD = math.radians(0.1)
#: First sample spacing along the track [m], the closest samples may come where the joints jump
#: between them [m], the most rounds of splitting for the deviation, and where each interval is checked
#: (fractions of it).
INITIAL_STEP_M = 0.05
MIN_STEP_M = 1e-4
REFINE_ROUNDS = 10
CHECK_FRACTIONS = (0.25, 0.5, 0.75)
#: Below this fraction of tcp_speed_max the joints would slow the TCP down: a singularity [1].
SINGULAR_SPEED_FRACTION = 0.1


class ToolMoveError(PipelineError):
    """A tool move cannot be followed: ``move`` (its index among the job's waypoints), ``sample``
    (along the move's chain), ``pose`` X_BT (4, 4) [m] where it fails, and what fails."""

    def __init__(self, move: int, sample: int, pose: np.ndarray, problem: str):
        self.move, self.sample, self.pose = move, sample, pose
        xyz = ", ".join(f"{1e3 * v:.1f}" for v in pose[:3, 3])
        super().__init__(f"move to waypoint {move}, sample {sample} (TCP at [{xyz}] mm): {problem}")


@dataclass(frozen=True, eq=False)
class ToolJointPath:
    """The joint path along ``tool_path``: ``path`` (parameter s = sigma / length), the IK ``samples``
    (K, dof) at ``sigma`` (K,) [m]; ``max_position_error`` [m] and ``max_rotation_error`` [rad] of the
    check between samples; ``slowest_tcp_speed`` [m/s]: the lowest TCP speed the joint speed limits
    allow anywhere on the samples, with the sample index ``slowest_sample``."""

    tool_path: ToolPath
    path: JointPath
    sigma: np.ndarray
    samples: np.ndarray
    max_position_error: float
    max_rotation_error: float
    slowest_tcp_speed: float
    slowest_sample: int


def _initial_sigma(tool_path: ToolPath) -> np.ndarray:
    pieces = []
    for a, b in zip(tool_path.breakpoints[:-1], tool_path.breakpoints[1:]):
        count = max(1, math.ceil((b - a) / INITIAL_STEP_M))
        pieces.append(np.linspace(a, b, count + 1)[:-1])
    return np.concatenate([*pieces, [tool_path.length]])


def _deviations(robot: Robot, tool_path: ToolPath, path: JointPath, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per interval between samples: the largest position [m] and rotation [rad] deviation of the
    joint path from the ideal pose at CHECK_FRACTIONS of it."""
    fractions = np.array(CHECK_FRACTIONS)
    checked = (sigma[:-1, None] + np.diff(sigma)[:, None] * fractions).ravel()
    actual = robot.fk_batch(path(checked / tool_path.length))
    ideal = tool_path.poses(checked)
    position = np.linalg.norm(actual[:, :3, 3] - ideal[:, :3, 3], axis=1)
    rotation = np.array([np.linalg.norm(rotation_log(a.T @ b)) for a, b in zip(actual[:, :3, :3], ideal[:, :3, :3])])
    shape = (len(sigma) - 1, fractions.size)
    return position.reshape(shape).max(axis=1), rotation.reshape(shape).max(axis=1)


def joint_path_along(robot: Robot, tool_path: ToolPath, q_start: np.ndarray, tcp_speed_max: float,
                     singularity: str = "stop", method: str = "auto",
                     tolerance_m: float = POSITION_TOLERANCE_M,
                     tolerance_rad: float = ROTATION_TOLERANCE_RAD) -> ToolJointPath:
    """The joint path that keeps ``robot``'s end frame (the TCP) on ``tool_path`` from ``q_start``
    (where the path starts), within the tolerances [m], [rad] between samples; ToolMoveError when a
    sample is out of reach, the joints cannot follow continuously (samples MIN_STEP_M apart still
    jump), or (unless ``singularity`` is ``slow_down``) the joints would slow the TCP below
    SINGULAR_SPEED_FRACTION x ``tcp_speed_max`` [m/s]. With ``slow_down`` the IK branch label may
    change where the joints stay continuous (a wrist passing through q5 = 0)."""
    sigma = _initial_sigma(tool_path)
    for _ in range(REFINE_ROUNDS):
        sigma, samples = _continuous_samples(robot, tool_path, sigma, q_start, method, singularity == "slow_down")
        path = path_through_samples(sigma / tool_path.length, samples)
        position, rotation = _deviations(robot, tool_path, path, sigma)
        over = (position > tolerance_m) | (rotation > tolerance_rad)
        if not over.any():
            break
        sigma = np.sort(np.concatenate([sigma, (sigma[:-1][over] + sigma[1:][over]) / 2.0]))
    else:
        k = int(np.argmax(position / tolerance_m + rotation / tolerance_rad))
        raise ToolMoveError(int(tool_path.move_of(sigma[k])[0]), k, tool_path.poses(sigma[k])[0],
                            f"the joint path still deviates from the ideal track by {1e3 * position[k]:.3g} mm and "
                            f"{math.degrees(rotation[k]):.3g} deg after {REFINE_ROUNDS} rounds of sampling (a "
                            "singularity nearby?)")
    speeds = _allowed_tcp_speeds(robot, path, tool_path.length)
    slowest = int(np.argmin(speeds))
    if speeds[slowest] < SINGULAR_SPEED_FRACTION * tcp_speed_max and singularity != "slow_down":
        raise _singularity_error(robot, tool_path, sigma, samples, speeds, tcp_speed_max, slowest)
    return ToolJointPath(tool_path, path, sigma, samples, float(position.max()), float(rotation.max()),
                         float(speeds[slowest]), slowest)


def _continuous_samples(robot: Robot, tool_path: ToolPath, sigma: np.ndarray, q_start: np.ndarray, method: str,
                        allow_branch_change: bool) -> tuple[np.ndarray, np.ndarray]:
    """(sigma, IK samples) by the package's path rule, with samples added where the joints jump between
    two (a fast turn near a singularity) until they follow continuously; ToolMoveError naming the first
    sample out of reach, or where samples MIN_STEP_M apart still jump."""
    while True:
        poses = tool_path.poses(sigma)
        result = robot.ik_path(poses, q_start, method=method, allow_branch_change=allow_branch_change)
        if result.success:
            return sigma, result.Q
        k = result.failed_index
        move = int(tool_path.move_of(sigma[k])[0])
        q_last = result.Q[-1] if len(result.Q) else q_start
        if not robot.ik(poses[k], q_seed=q_last, method=method).success:
            raise ToolMoveError(move, k, poses[k], "no IK solution inside the joint limits: the point is out of "
                                "reach on this move")
        if k == 0 or sigma[k] - sigma[k - 1] < MIN_STEP_M:
            measures = compute_singularity(robot.jacobian(q_last))
            raise ToolMoveError(move, k, poses[k], f"{result.reason.split(': ', 1)[-1]}; at the last sample that "
                                f"works: {measures}")
        sigma = np.insert(sigma, k, (sigma[k - 1] + sigma[k]) / 2.0)


def _allowed_tcp_speeds(robot: Robot, path: JointPath, length: float) -> np.ndarray:
    """At each knot of ``path``, the TCP speed [m/s] the joint speed limits allow (the track is
    parameterised by arc length, so |dp/dsigma| = 1)."""
    rates = np.abs(path(path.s_waypoints, 1)) / length           # dq/dsigma [rad/m or 1]
    with np.errstate(divide="ignore"):
        return np.min(robot.limits.qd_max / rates, axis=1)


def _singularity_error(robot, tool_path, sigma, samples, speeds, tcp_speed_max, k) -> ToolMoveError:
    """The typed error for a singularity at sample k, with the nearest samples that work."""
    fine = np.flatnonzero(speeds >= SINGULAR_SPEED_FRACTION * tcp_speed_max)
    before, after = fine[fine < k], fine[fine > k]
    closest = [f"sample {i} at [{', '.join(f'{1e3 * v:.1f}' for v in tool_path.position(sigma[i])[0])}] mm"
               for i in (before[-1:].tolist() + after[:1].tolist())]
    J = robot.jacobian(samples[k])
    return ToolMoveError(
        int(tool_path.move_of(sigma[k])[0]), k, tool_path.poses(sigma[k])[0],
        f"near {near_singularity(J)}; {compute_singularity(J)}: the joint speed limits allow the TCP only {speeds[k]:.3g} m/s here, "
        f"below {SINGULAR_SPEED_FRACTION:g} x tcp_speed_max ({tcp_speed_max:g} m/s). Closest samples that work: "
        f"{' and '.join(closest) or 'none'}. Move the path away from the singularity or allow a slow-down "
        "(singularity: slow_down)")
