"""Poses as unit quaternion + position and back (seed 003), through SciPy's rotation type.

Quaternions are scalar-first ``[w, x, y, z]``, as in seed 003 and Drake, with ``w >= 0``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from .arrays import float_array
from .compiled import is_pose
from .errors import ConfigurationError

#: How far a 3x3 matrix may be from orthonormal with det +1 and still count as a rotation.
ROTATION_TOLERANCE = 1e-6


def check_pose(X, what: str = "pose", max_position: float = math.inf) -> np.ndarray:
    """Validate a homogeneous transform (4, 4): finite, a proper rotation, last row [0 0 0 1], and no
    position coordinate beyond ``max_position`` [m]."""
    if type(X) is np.ndarray and X.dtype == np.float64 and X.shape == (4, 4) and \
            is_pose(X, ROTATION_TOLERANCE, max_position):
        return X                                     # the compiled check passed: no error to word
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
