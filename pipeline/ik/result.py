"""IK results, targets and the strict success test shared by every IK method.

Success is judged by our own NumPy FK, never by the solver: position error <= 1e-6 m, rotation
error <= 1e-6 rad (or the masked components, for arms that cannot reach a full 6-D pose), and every
joint inside its limits.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigurationError
from ..poses import check_pose

POSITION_TOLERANCE = 1e-6   # [m]
ROTATION_TOLERANCE = 1e-6   # [rad]
TWO_PI = 2.0 * math.pi

#: Which parts of the pose a target asks for.
FULL_POSE = "pose"          # position and full orientation (6 constraints)
POSITION_AND_AXIS = "position+axis"   # position and the end frame's z axis (5 constraints)
POSITION_ONLY = "position"  # 3 constraints
TARGET_KINDS = (FULL_POSE, POSITION_AND_AXIS, POSITION_ONLY)
MATCHED_COMPONENTS = {
    FULL_POSE: ("x", "y", "z", "roll", "pitch", "yaw"),
    POSITION_AND_AXIS: ("x", "y", "z", "axis_z"),
    POSITION_ONLY: ("x", "y", "z"),
}


@dataclass(frozen=True, eq=False)
class IkTarget:
    """A validated IK target: the desired end-frame pose X_BE (4x4, base frame, [m]) and what to match."""

    X_BE: np.ndarray
    kind: str = FULL_POSE


def make_target(X_target, kind: str = FULL_POSE) -> IkTarget:
    """Validate a target pose and its kind; raises ConfigurationError on bad input."""
    if kind not in TARGET_KINDS:
        raise ConfigurationError(f"target kind must be one of {', '.join(TARGET_KINDS)}, got {kind!r}")
    return IkTarget(check_pose(X_target, "IK target"), kind)


@dataclass(frozen=True, eq=False)
class Solution:
    """One in-limit IK solution: joint values [rad or m], its errors and its branch label."""

    q: np.ndarray
    position_error: float
    rotation_error: float
    branch: str = ""


@dataclass(frozen=True, eq=False)
class IkResult:
    """What an IK solve returns, whether it succeeded or not (never None).

    ``q``: the best configuration found (the nearest-to-seed strict solution on success; on failure
    the best attempt, never NaN). ``position_error`` [m], ``rotation_error`` [rad] (for
    ``position+axis`` targets, the angle between the z axes). ``solutions``: every distinct in-limit
    strict solution found, nearest to the seed first. ``matched``: the pose components the target
    asked for. ``reason``: why it failed ("" on success). ``details``: the back end's own numbers.
    """

    success: bool
    q: np.ndarray
    position_error: float
    rotation_error: float
    iterations: int
    method: str
    reason: str = ""
    solutions: tuple[Solution, ...] = ()
    matched: tuple[str, ...] = MATCHED_COMPONENTS[FULL_POSE]
    details: dict = field(default_factory=dict)

    def __str__(self) -> str:
        state = "success" if self.success else f"FAILED ({self.reason})"
        q = ", ".join(f"{v:.6f}" for v in self.q)
        return (f"IK [{self.method}] {state}: q = [{q}], position error {self.position_error:.2e} m, "
                f"rotation error {self.rotation_error:.2e} rad, {self.iterations} iterations, "
                f"{len(self.solutions)} solution(s)")


def rotation_angle(R: np.ndarray) -> float:
    """Angle [rad] of a rotation matrix, accurate near 0 (uses the skew part, not only the trace)."""
    sin_part = 0.5 * math.sqrt((R[2, 1] - R[1, 2]) ** 2 + (R[0, 2] - R[2, 0]) ** 2 + (R[1, 0] - R[0, 1]) ** 2)
    cos_part = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    return math.atan2(sin_part, cos_part)


def pose_errors(X: np.ndarray, target: IkTarget) -> tuple[float, float]:
    """(position error [m], rotation error [rad]) of pose X against the target, for its kind."""
    position_error = float(np.linalg.norm(X[:3, 3] - target.X_BE[:3, 3]))
    if target.kind == FULL_POSE:
        rotation_error = rotation_angle(X[:3, :3].T @ target.X_BE[:3, :3])
    elif target.kind == POSITION_AND_AXIS:
        z, z_target = X[:3, 2], target.X_BE[:3, 2]
        rotation_error = math.atan2(float(np.linalg.norm(np.cross(z, z_target))), float(z @ z_target))
    else:
        rotation_error = 0.0
    return position_error, rotation_error


def within_limits(q: np.ndarray, q_min: np.ndarray, q_max: np.ndarray) -> bool:
    return bool(np.all(q >= q_min) and np.all(q <= q_max))


def is_strict(position_error: float, rotation_error: float) -> bool:
    return position_error <= POSITION_TOLERANCE and rotation_error <= ROTATION_TOLERANCE


def wrap_into_limits(q: np.ndarray, revolute: np.ndarray, q_min: np.ndarray, q_max: np.ndarray,
                     reference: np.ndarray | None = None) -> np.ndarray:
    """Shift revolute joints by multiples of 2 pi into their limits where possible.

    Among the in-limit representatives, the one nearest ``reference`` (default: the middle of the
    range) is chosen; joints that cannot be brought inside keep their nearest representative.
    """
    q = np.array(q, dtype=float)
    centre = (q_min + q_max) / 2.0 if reference is None else reference
    for i in np.flatnonzero(revolute):
        k_low = math.ceil((q_min[i] - q[i]) / TWO_PI)
        k_high = math.floor((q_max[i] - q[i]) / TWO_PI)
        if k_low <= k_high:
            candidates = q[i] + TWO_PI * np.arange(k_low, k_high + 1)
        else:
            candidates = q[i] + TWO_PI * np.array([k_high, k_low])
        q[i] = candidates[np.argmin(np.abs(candidates - centre[i]))]
    return q


def two_pi_variants(q: np.ndarray, revolute: np.ndarray, q_min: np.ndarray, q_max: np.ndarray) -> list[np.ndarray]:
    """Every in-limit configuration equal to q up to multiples of 2 pi on revolute joints."""
    options = []
    for i in range(q.size):
        if revolute[i]:
            k_low = math.ceil((q_min[i] - q[i]) / TWO_PI - 1e-12)
            k_high = math.floor((q_max[i] - q[i]) / TWO_PI + 1e-12)
            values = [q[i] + TWO_PI * k for k in range(k_low, k_high + 1)]
            options.append([min(max(v, q_min[i]), q_max[i]) for v in values])
        else:
            options.append([q[i]] if q_min[i] <= q[i] <= q_max[i] else [])
    return [np.array(combo) for combo in itertools.product(*options)]


def distinct_solutions(solutions: list[Solution], q_seed: np.ndarray, tolerance: float = 1e-6) -> tuple[Solution, ...]:
    """Solutions without duplicates (max joint difference <= tolerance), nearest to the seed first."""
    ordered = sorted(solutions, key=lambda s: float(np.linalg.norm(s.q - q_seed)))
    kept: list[Solution] = []
    for s in ordered:
        if all(np.abs(s.q - k.q).max() > tolerance for k in kept):
            kept.append(s)
    return tuple(kept)
