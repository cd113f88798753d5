"""Poses as unit quaternion + position and back (seed 003), through SciPy's rotation type, and the one check of
a homogeneous transform (``check_pose``; compiled as ``is_pose`` for the kernels and the fast path).

Quaternions are scalar-first ``[w, x, y, z]``, as in seed 003 and Drake, with ``w >= 0``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit
from scipy.spatial.transform import Rotation

from ..errors import ConfigurationError
from .arrays import float_array

#: How far a 3x3 matrix may be from orthonormal with det +1 and still count as a rotation.
ROTATION_TOLERANCE = 1e-6


@njit(cache=True)
def is_pose(X, tolerance, max_position):
    """True when X (4, 4) is finite, its 3x3 block a rotation (|R^T R - I| <= tolerance entrywise,
    |entries| <= 1 + tolerance, det >= 0), its position coordinates at most max_position [m] and its
    last row exactly 0 0 0 1."""
    for i in range(4):
        for j in range(4):
            if not abs(X[i, j]) <= 1e300:                   # also False for NaN
                return False
    for i in range(3):
        if abs(X[i, 3]) > max_position:
            return False
    if X[3, 0] != 0.0 or X[3, 1] != 0.0 or X[3, 2] != 0.0 or X[3, 3] != 1.0:
        return False
    for i in range(3):
        for j in range(3):
            if abs(X[i, j]) > 1.0 + tolerance:
                return False
            gram = X[0, i] * X[0, j] + X[1, i] * X[1, j] + X[2, i] * X[2, j]
            if abs(gram - (1.0 if i == j else 0.0)) > tolerance:
                return False
    det = (X[0, 0] * (X[1, 1] * X[2, 2] - X[1, 2] * X[2, 1]) - X[0, 1] * (X[1, 0] * X[2, 2] - X[1, 2] * X[2, 0])
           + X[0, 2] * (X[1, 0] * X[2, 1] - X[1, 1] * X[2, 0]))
    return det >= 0.0


@njit(cache=True)
def first_non_pose(X, tolerance, max_position):
    """The index of the first of X (N, 4, 4) that ``is_pose`` refuses, -1 when there is none."""
    for n in range(X.shape[0]):
        if not is_pose(X[n], tolerance, max_position):
            return n
    return -1


def check_pose(X, what: str = "pose", max_position: float = math.inf) -> np.ndarray:
    """Validate a homogeneous transform (4, 4): finite, a proper rotation, last row [0 0 0 1], and no
    position coordinate beyond ``max_position`` [m]."""
    if type(X) is np.ndarray and X.dtype == np.float64 and X.shape == (4, 4) and \
            is_pose(X if X.flags.c_contiguous else np.ascontiguousarray(X), ROTATION_TOLERANCE, max_position):
        return X                                     # the compiled check passed (of a C-ordered X: one specialisation)
    X = float_array(X, what, (4, 4))
    R = X[:3, :3]
    if (np.abs(R).max() > 1.0 + ROTATION_TOLERANCE or np.abs(R.T @ R - np.eye(3)).max() > ROTATION_TOLERANCE
            or np.linalg.det(R) < 0.0):
        raise ConfigurationError(f"{what}: the 3x3 block is not a rotation matrix (R^T R != I or det < 0)")
    if np.abs(X[3] - [0.0, 0.0, 0.0, 1.0]).max() > 0.0:
        raise ConfigurationError(f"{what}: last row must be [0, 0, 0, 1], got {X[3]}")
    if np.abs(X[:3, 3]).max() > max_position:
        raise ConfigurationError(f"{what}: position {X[:3, 3]} is beyond {max_position:g} m: no arm reaches it "
                                 "(are the units metres?)")
    return X


def pose_to_quaternion_position(X) -> tuple[np.ndarray, np.ndarray]:
    """Pose (4, 4) -> (quaternion [w, x, y, z] with w >= 0, position [m])."""
    X = check_pose(X)
    quat = Rotation.from_matrix(X[:3, :3]).as_quat(scalar_first=True)
    if quat[0] < 0.0:
        quat = -quat
    return quat, X[:3, 3].copy()


def make_pose(R, p) -> np.ndarray:
    """Rotation (3, 3) and position (3,) [m] -> homogeneous pose (4, 4). The one place poses are assembled."""
    X = np.eye(4)
    X[:3, :3] = R
    X[:3, 3] = p
    return X


def rpy_to_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll): roll, pitch, yaw [rad] about the fixed X, Y, Z axes."""
    return Rotation.from_euler("xyz", [roll, pitch, yaw]).as_matrix()


def rotation_to_rpy(R) -> np.ndarray:
    """Roll, pitch, yaw [rad] about the fixed X, Y, Z axes with ``rpy_to_rotation(*rpy) == R``. At pitch
    +-90 deg (gimbal lock), where only roll -+ yaw is defined, yaw is 0."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock", category=UserWarning)
        return Rotation.from_matrix(np.asarray(R, dtype=float)).as_euler("xyz")


def rpy_position_to_pose(rpy, p) -> np.ndarray:
    """(roll, pitch, yaw [rad] about fixed X, Y, Z; position [m]) -> pose (4, 4)."""
    return make_pose(rpy_to_rotation(*np.asarray(rpy, dtype=float)), np.asarray(p, dtype=float))


def quaternion_position_to_pose(quat_wxyz, p) -> np.ndarray:
    """(quaternion [w, x, y, z], position [m]) -> pose (4, 4). The quaternion must be unit length."""
    quat = float_array(quat_wxyz, "quaternion", (4,))
    p = float_array(p, "position", (3,))
    norm = math.hypot(*quat)
    if abs(norm - 1.0) > ROTATION_TOLERANCE:
        raise ConfigurationError(f"quaternion must be unit length, |q| = {norm:.9f}")
    return make_pose(Rotation.from_quat(quat, scalar_first=True).as_matrix(), p)
