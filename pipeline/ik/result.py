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
    range) is chosen; a joint that cannot be brought inside keeps the representative nearest it.
    """
    reference = (q_min + q_max) / 2.0 if reference is None else reference
    nearest = q - TWO_PI * np.round((q - reference) / TWO_PI)
    candidates = nearest[:, None] + _NEIGHBOUR_SHIFTS                     # (dof, 3): nearest first
    inside = (candidates >= q_min[:, None]) & (candidates <= q_max[:, None])
    distance = np.abs(candidates - reference[:, None]) + np.where(inside, 0.0, np.inf)
    pick = np.where(inside.any(axis=1), np.argmin(distance, axis=1), 0)
    return np.where(revolute, candidates[np.arange(q.size), pick], q)


_NEIGHBOUR_SHIFTS = np.array([0.0, -TWO_PI, TWO_PI])


#: 2 pi shifts tried per joint: enough for joint ranges up to 4 pi (+-720 deg).
_SHIFTS = TWO_PI * np.arange(-2, 3)


def limit_variants(Q: np.ndarray, revolute: np.ndarray, q_min: np.ndarray, q_max: np.ndarray):
    """Every 2 pi shift of configurations Q (..., dof) that may fit the limits.

    Returns candidates (..., V, dof) and a mask (..., V) of those inside every limit. Joints whose
    range spans more than 2 pi are enumerated (V = 5^m for m such joints); the others have at most one
    in-limit representative, which is taken. Prismatic joints are not shifted.
    """
    values = Q[..., None] + np.where(revolute[:, None], _SHIFTS, 0.0)            # (..., dof, 5)
    inside = (values >= q_min[:, None]) & (values <= q_max[:, None])
    multi = np.flatnonzero(revolute & (q_max - q_min > TWO_PI))
    single = np.setdiff1d(np.arange(Q.shape[-1]), multi)
    combos = np.array(list(itertools.product(range(_SHIFTS.size), repeat=multi.size)), dtype=int).reshape(-1, multi.size)
    candidates = np.repeat(Q[..., None, :], len(combos), axis=-2)
    pick = np.argmax(inside[..., single, :], axis=-1)                             # first in-limit shift
    candidates[..., single] = np.take_along_axis(values[..., single, :], pick[..., None], axis=-1)[..., 0][..., None, :]
    valid = np.take_along_axis(inside[..., single, :], pick[..., None], axis=-1)[..., 0].all(axis=-1)[..., None]
    valid = np.broadcast_to(valid, candidates.shape[:-1]).copy()
    for column, joint in enumerate(multi):
        candidates[..., joint] = values[..., joint, :][..., combos[:, column]]
        valid &= inside[..., joint, :][..., combos[:, column]]
    return candidates, valid


def distinct_order(Q: np.ndarray, q_seed: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """Indices of the distinct rows of Q (k, dof) (max joint difference > tolerance), nearest the seed first."""
    order = np.argsort(np.linalg.norm(Q - q_seed, axis=1), kind="stable")
    Q = Q[order]
    close = np.abs(Q[:, None, :] - Q[None, :, :]).max(axis=-1) <= tolerance
    duplicate = np.tril(close, k=-1).any(axis=1)
    return order[~duplicate]
