"""IK results, targets and the strict success test shared by every IK method.

Success is judged by our own NumPy FK, never by the solver: position error <= 1e-6 m, rotation
error <= 1e-6 rad (or the masked components, for arms that cannot reach a full 6-D pose), and every
joint inside its limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ...errors import ConfigurationError
from ...files import poses
from ...files.arrays import float_array
from ...files.choices import FULL_POSE, POSITION_AND_AXIS, POSITION_ONLY, TARGET_KINDS
from ...files.poses import check_pose, first_non_pose

POSITION_TOLERANCE = 1e-6   # [m]
ROTATION_TOLERANCE = 1e-6   # [rad]
TWO_PI = 2.0 * math.pi

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


#: A target coordinate beyond this is refused outright [m] (its arithmetic would overflow).
MAX_TARGET_COORDINATE_M = 1e6


def check_search_budget(max_restarts, time_budget, max_iterations=1) -> None:
    """ConfigurationError unless ``max_restarts`` >= 0 and ``max_iterations`` >= 1 are integers and
    ``time_budget`` [s] is a finite number >= 0 (0: the first attempt only)."""
    if type(max_restarts) is int and type(max_iterations) is int and type(time_budget) is float and \
            max_restarts >= 0 and max_iterations >= 1 and 0.0 <= time_budget < math.inf:
        return                                      # the common case, without the checks that word errors
    for name, value, low in (("max_restarts", max_restarts, 0), ("max_iterations", max_iterations, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ConfigurationError(f"{name} must be an integer >= {low}, got {value!r}")
    if isinstance(time_budget, bool) or not isinstance(time_budget, (int, float, np.floating, np.integer)) \
            or not np.isfinite(time_budget) or time_budget < 0:
        raise ConfigurationError(f"time_budget must be a finite number of seconds >= 0, got {time_budget!r}")


def make_target(X_target, kind: str = FULL_POSE) -> IkTarget:
    """Validate a target pose and its kind; raises ConfigurationError on bad input."""
    _check_kind(kind)
    return IkTarget(check_pose(X_target, "IK target", MAX_TARGET_COORDINATE_M), kind)


def check_targets(X_targets, kind: str = FULL_POSE) -> np.ndarray:
    """Validate N target poses (N, 4, 4) [m] and their kind -> a C-contiguous float array; the
    ConfigurationError names the first bad target."""
    _check_kind(kind)
    X = np.ascontiguousarray(float_array(X_targets, "IK targets", (None, 4, 4)))
    bad = first_non_pose(X, poses.ROTATION_TOLERANCE, MAX_TARGET_COORDINATE_M)
    if bad >= 0:
        check_pose(X[bad], f"IK target {bad}", MAX_TARGET_COORDINATE_M)
    return X


def _check_kind(kind: str) -> None:
    if kind not in TARGET_KINDS:
        raise ConfigurationError(f"target kind must be one of {', '.join(TARGET_KINDS)}, got {kind!r}")


class Solution(NamedTuple):
    """One in-limit IK solution: joint values [rad or m], its errors and its branch label."""

    q: np.ndarray
    position_error: float
    rotation_error: float
    branch: str = ""


class Solutions(Sequence):
    """The in-limit solutions of one target as a read-only sequence of Solution (compares equal to the
    tuple of them), built from a kernel's arrays on first use: a batch of many targets pays only for
    the solutions it looks at. ``rows`` (M, dof + 3 or dof + 4): q, position error [m], rotation error
    [rad], the index of the branch's name in ``names`` and, where the solver counts them, ``variants``."""

    __slots__ = ("_rows", "_names", "_dof", "_items")

    def __init__(self, rows: np.ndarray, names: Sequence[str], dof: int):
        self._rows, self._names, self._dof, self._items = rows, names, dof, None

    def _solutions(self) -> tuple[Solution, ...]:
        if self._items is None:
            dof, names = self._dof, self._names
            Q, numbers = self._rows[:, :dof], self._rows[:, dof:dof + 3].tolist()
            self._items = tuple([Solution(q, e[0], e[1], names[int(e[2])]) for q, e in zip(Q, numbers)])
        return self._items

    @property
    def variants(self) -> list[float]:
        """How many in-limit 2 pi variants each solution stands for (the product over its joints; inf
        with a continuous joint): a joint with a range over four turns, or a branch with more than
        ``closed_form.MAX_LISTED_VARIANTS`` variants (a UR arm's +-360 deg: 64), gets only the variant
        nearest the seed, and the others are counted here rather than listed (``limit_variants``
        enumerates them on demand). Empty when not counted."""
        return self._rows[:, self._dof + 3].tolist() if self._rows.shape[1] > self._dof + 3 else []

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, index):
        return self._solutions()[index]

    def __iter__(self):
        return iter(self._solutions())

    def __eq__(self, other) -> bool:
        return self._solutions() == (tuple(other) if isinstance(other, Sequence) else other)

    def __add__(self, other) -> tuple[Solution, ...]:
        return self._solutions() + tuple(other)

    def __repr__(self) -> str:
        return repr(self._solutions())


@dataclass(eq=False)
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
    solutions: Sequence[Solution] = ()
    matched: tuple[str, ...] = MATCHED_COMPONENTS[FULL_POSE]
    details: dict = field(default_factory=dict)

    def __str__(self) -> str:
        state = "success" if self.success else f"FAILED ({self.reason})"
        q = ", ".join(f"{v:.6f}" for v in self.q)
        return (f"IK [{self.method}] {state}: q = [{q}], position error {self.position_error:.2e} m, "
                f"rotation error {self.rotation_error:.2e} rad, {self.iterations} iterations, "
                f"{len(self.solutions)} solution(s)")


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angles [rad] of rotation matrices (..., 3, 3), accurate near 0 (the skew part, not only the trace)."""
    skew = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    return np.arctan2(0.5 * np.linalg.norm(skew, axis=-1), 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0))


def pose_errors(X: np.ndarray, target: IkTarget) -> tuple[float, float]:
    """(position error [m], rotation error [rad]) of pose X against the target, for its kind."""
    position_error = float(np.linalg.norm(X[:3, 3] - target.X_BE[:3, 3]))
    if target.kind == FULL_POSE:
        rotation_error = float(rotation_angle(X[:3, :3].T @ target.X_BE[:3, :3]))
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


def limit_variants(Q: np.ndarray, revolute: np.ndarray, q_min: np.ndarray, q_max: np.ndarray):
    """Every 2 pi shift of configurations Q (..., dof) that fits the limits.

    Returns candidates (..., V, dof) and a mask (..., V) of those inside every limit. Revolute joints
    are wrapped into (-pi, pi], each joint's in-limit shifts are found, and their combinations are
    enumerated in mixed radix, so V is the largest number of combinations any row has (often 1-4).
    Prismatic joints are not shifted.
    """
    Q = np.where(revolute, Q - TWO_PI * np.ceil((Q - np.pi) / TWO_PI), Q)
    k_low = np.where(revolute, np.ceil((q_min - np.pi) / TWO_PI), 0).astype(int)
    k_high = np.where(revolute, np.floor((q_max + np.pi) / TWO_PI), 0).astype(int)
    shifts = TWO_PI * np.arange(k_low.min(), k_high.max() + 1)                     # (S,)
    values = Q[..., None] + np.where(revolute[:, None], shifts, 0.0)[..., :]        # (..., dof, S)
    if not revolute.all():
        values[..., ~revolute, :] = Q[..., ~revolute, None]
    inside = (values >= q_min[:, None]) & (values <= q_max[:, None])
    counts = inside.sum(axis=-1)                                                    # (..., dof)
    total = np.prod(counts, axis=-1)                                                # (..., )
    width = max(int(total.max(initial=0)), 1)
    combo = np.arange(width)                                                        # (V,)
    strides = np.cumprod(np.concatenate([np.ones(counts.shape[:-1] + (1,), int), counts[..., :-1]], axis=-1),
                         axis=-1)                                                   # (..., dof)
    pick = (combo[:, None] // np.maximum(strides, 1)[..., None, :]) % np.maximum(counts, 1)[..., None, :]
    rank = np.cumsum(inside, axis=-1) - 1                                           # rank of each in-limit shift
    chosen = (rank[..., None, :, :] == pick[..., None]) & inside[..., None, :, :]  # (..., V, dof, S)
    candidates = (values[..., None, :, :] * chosen).sum(axis=-1)
    valid = combo < total[..., None]
    return candidates, valid


#: Sorted by distance to the seed, a duplicate is compared with this many nearer candidates: two
#: copies of one solution have equal distances, so only a candidate whose distance falls within
#: 1e-6 of theirs could stand between them.
DUPLICATE_WINDOW = 4


def distinct_order_batch(candidates: np.ndarray, valid: np.ndarray, seeds: np.ndarray,
                         tolerance: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Distinct valid candidates of N problems, nearest the seed first.

    ``candidates`` (N, K, dof), ``valid`` (N, K), ``seeds`` (N, dof). Returns ``order`` (N, M) indices
    into K sorted by distance to the seed, and ``keep`` (N, M): valid and not within ``tolerance``
    (max joint difference) of one of the ``DUPLICATE_WINDOW`` nearer candidates. M is the largest
    valid count.
    """
    distance = np.where(valid, np.linalg.norm(candidates - seeds[:, None, :], axis=-1), np.inf)
    m = max(int(valid.sum(axis=1).max(initial=0)), 1)
    order = np.argsort(distance, axis=1, kind="stable")[:, :m]
    Q = np.take_along_axis(candidates, order[..., None], axis=1)
    is_valid = np.take_along_axis(valid, order, axis=1)
    duplicate = np.zeros_like(is_valid)
    for lag in range(1, min(DUPLICATE_WINDOW, m - 1) + 1):
        close = np.abs(Q[:, lag:] - Q[:, :-lag]).max(axis=-1) <= tolerance
        duplicate[:, lag:] |= close & is_valid[:, :-lag]
    return order, is_valid & ~duplicate


def distinct_order(Q: np.ndarray, q_seed: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """Indices of the distinct rows of Q (k, dof) (max joint difference > tolerance), nearest the seed first."""
    order, keep = distinct_order_batch(Q[None], np.ones((1, len(Q)), dtype=bool), q_seed[None], tolerance)
    return order[0][keep[0]]
