"""Compiled (Numba) kinematics of a DH chain: FK, the Jacobian and their batches.

The same factorisation as ``pipeline.kinematics.DhKinematics`` (the NumPy oracle these are checked
against): ``X_BE(q) = K_0 (M_1 K_1) ... (M_n K_n)`` with ``M_i K_i = P_i + cos(q_i) C_i + sin(q_i) S_i
+ q_i V_i`` (the joint's sign folded into S_i and V_i). A chain is one float array ``chain`` (dof + 1,
4, 4, 4): ``chain[0, 0] = K_0`` and ``chain[i] = (P_i, C_i, S_i, V_i)``; ``axes`` (dof, 2) holds each
joint's sign and 1.0 for revolute (0.0 prismatic).

Poses travel between kernels as ``Pose`` tuples: the 12 entries of the top three rows of a 4x4
transform, row by row (the last row is always 0 0 0 1), so no kernel allocates on the way.

The kernels Python calls write into arrays the caller allocates (returning a new array from a kernel
costs more than the FK itself) and have explicit signatures: C-contiguous float64 arrays only, compiled
once on a machine and cached on disk beside this file. Any other input raises TypeError, a bad
length or value ValueError; ``pipeline.robot.Robot`` then checks it for the typed error that names it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .arrays import MAX_MAGNITUDE

#: Types of the kernels Python calls: 1-, 2-, 3- and 4-d C-contiguous float64 arrays.
_V, _M, _T, _C = "float64[::1]", "float64[:, ::1]", "float64[:, :, ::1]", "float64[:, :, :, ::1]"


def pack_chain(P: np.ndarray, C: np.ndarray, S: np.ndarray, V: np.ndarray, K0: np.ndarray, sign: np.ndarray,
               revolute: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chain, axes) of a DhKinematics' constant factors (each (dof, 4, 4); K0 (4, 4); sign, revolute (dof,))."""
    dof = len(sign)
    chain = np.zeros((dof + 1, 4, 4, 4))
    chain[0, 0] = K0
    chain[1:, 0], chain[1:, 1] = P, C
    chain[1:, 2], chain[1:, 3] = S * sign[:, None, None], V * sign[:, None, None]
    return chain, np.ascontiguousarray(np.column_stack([sign, revolute.astype(float)]))


@njit(cache=True)
def cross(a, b):
    """a x b of two 3-vectors (tuples or arrays) -> tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def check_configuration(q, dof):
    """ValueError unless q has dof values, each finite and at most MAX_MAGNITUDE."""
    if q.shape[0] != dof:
        raise ValueError("wrong number of joint values")
    for value in q:
        if not abs(value) <= MAX_MAGNITUDE:          # also False for NaN
            raise ValueError("joint value not finite or too large")


@njit(cache=True)
def pose_of(X):
    """The Pose tuple of a 4x4 array."""
    return (X[0, 0], X[0, 1], X[0, 2], X[0, 3], X[1, 0], X[1, 1], X[1, 2], X[1, 3],
            X[2, 0], X[2, 1], X[2, 2], X[2, 3])


@njit(cache=True)
def _link(chain, i, value):
    """The Pose of M_i K_i at the joint value [rad or m] (i from 0)."""
    c, s = math.cos(value), math.sin(value)
    L = chain[i + 1]
    return (L[0, 0, 0] + c * L[1, 0, 0] + s * L[2, 0, 0] + value * L[3, 0, 0],
            L[0, 0, 1] + c * L[1, 0, 1] + s * L[2, 0, 1] + value * L[3, 0, 1],
            L[0, 0, 2] + c * L[1, 0, 2] + s * L[2, 0, 2] + value * L[3, 0, 2],
            L[0, 0, 3] + c * L[1, 0, 3] + s * L[2, 0, 3] + value * L[3, 0, 3],
            L[0, 1, 0] + c * L[1, 1, 0] + s * L[2, 1, 0] + value * L[3, 1, 0],
            L[0, 1, 1] + c * L[1, 1, 1] + s * L[2, 1, 1] + value * L[3, 1, 1],
            L[0, 1, 2] + c * L[1, 1, 2] + s * L[2, 1, 2] + value * L[3, 1, 2],
            L[0, 1, 3] + c * L[1, 1, 3] + s * L[2, 1, 3] + value * L[3, 1, 3],
            L[0, 2, 0] + c * L[1, 2, 0] + s * L[2, 2, 0] + value * L[3, 2, 0],
            L[0, 2, 1] + c * L[1, 2, 1] + s * L[2, 2, 1] + value * L[3, 2, 1],
            L[0, 2, 2] + c * L[1, 2, 2] + s * L[2, 2, 2] + value * L[3, 2, 2],
            L[0, 2, 3] + c * L[1, 2, 3] + s * L[2, 2, 3] + value * L[3, 2, 3])


@njit(cache=True)
def compose(x, a):
    """The Pose x a."""
    return (x[0] * a[0] + x[1] * a[4] + x[2] * a[8], x[0] * a[1] + x[1] * a[5] + x[2] * a[9],
            x[0] * a[2] + x[1] * a[6] + x[2] * a[10], x[0] * a[3] + x[1] * a[7] + x[2] * a[11] + x[3],
            x[4] * a[0] + x[5] * a[4] + x[6] * a[8], x[4] * a[1] + x[5] * a[5] + x[6] * a[9],
            x[4] * a[2] + x[5] * a[6] + x[6] * a[10], x[4] * a[3] + x[5] * a[7] + x[6] * a[11] + x[7],
            x[8] * a[0] + x[9] * a[4] + x[10] * a[8], x[8] * a[1] + x[9] * a[5] + x[10] * a[9],
            x[8] * a[2] + x[9] * a[6] + x[10] * a[10], x[8] * a[3] + x[9] * a[7] + x[10] * a[11] + x[11])


@njit(cache=True)
def end_pose(chain, q):
    """The Pose X_BE(q) [m]; q already checked."""
    x = pose_of(chain[0, 0])
    for i in range(q.shape[0]):
        x = compose(x, _link(chain, i, q[i]))
    return x


@njit(cache=True)
def _write_pose(x, X):
    """X (4, 4) = the Pose x."""
    for k in range(12):
        X[k // 4, k % 4] = x[k]
    X[3, 0], X[3, 1], X[3, 2], X[3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True)
def pose_and_jacobian(chain, axes, q, J):
    """The Pose X_BE(q) [m], with J (6, dof) set to its geometric Jacobian, rows [v; w], base frame, at
    E's origin; q already checked."""
    x = pose_of(chain[0, 0])
    for i in range(q.shape[0]):                        # J[:3] holds joint origins until the end is known
        J[3, i], J[4, i], J[5, i] = x[2] * axes[i, 0], x[6] * axes[i, 0], x[10] * axes[i, 0]
        J[0, i], J[1, i], J[2, i] = x[3], x[7], x[11]
        x = compose(x, _link(chain, i, q[i]))
    for i in range(q.shape[0]):
        ax, ay, az = J[3, i], J[4, i], J[5, i]
        if axes[i, 1] > 0.5:
            lx, ly, lz = x[3] - J[0, i], x[7] - J[1, i], x[11] - J[2, i]
            J[0, i], J[1, i], J[2, i] = ay * lz - az * ly, az * lx - ax * lz, ax * ly - ay * lx
        else:
            J[0, i], J[1, i], J[2, i] = ax, ay, az
            J[3, i], J[4, i], J[5, i] = 0.0, 0.0, 0.0
    return x


#: Target kinds as the kernels take them: full pose, position and the z axis, position only.
POSE, POSITION_AND_AXIS, POSITION = 0, 1, 2


@njit(cache=True)
def pose_errors(x, X_target, kind):
    """(position error [m], rotation error [rad]) of the Pose x against X_target (4, 4) for the target
    kind: the rotation angle between them (POSE), the angle between their z axes (POSITION_AND_AXIS),
    0 (POSITION). As ``pipeline.ik.result.pose_errors``."""
    dx, dy, dz = x[3] - X_target[0, 3], x[7] - X_target[1, 3], x[11] - X_target[2, 3]
    position_error = math.sqrt(dx * dx + dy * dy + dz * dz)
    if kind == POSE:                                   # E = R^T R_target: its angle, accurate near 0
        E = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                E[i, j] = x[i] * X_target[0, j] + x[4 + i] * X_target[1, j] + x[8 + i] * X_target[2, j]
        sx, sy, sz = E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]
        return position_error, math.atan2(0.5 * math.sqrt(sx * sx + sy * sy + sz * sz),
                                          0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0))
    if kind == POSITION_AND_AXIS:
        z, z_target = (x[2], x[6], x[10]), (X_target[0, 2], X_target[1, 2], X_target[2, 2])
        n = cross(z, z_target)
        return position_error, math.atan2(math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]),
                                          z[0] * z_target[0] + z[1] * z_target[1] + z[2] * z_target[2])
    return position_error, 0.0


@njit(f"void({_C}, {_V}, {_M})", cache=True)
def fk_into(chain, q, X):
    """X (4, 4) = X_BE [m] at one configuration q (dof,)."""
    check_configuration(q, chain.shape[0] - 1)
    _write_pose(end_pose(chain, q), X)


@njit(f"void({_C}, {_M}, {_T})", cache=True)
def fk_batch_into(chain, Q, out):
    """out (N, 4, 4) = X_BE [m] for configurations Q (N, dof)."""
    for n in range(Q.shape[0]):
        check_configuration(Q[n], chain.shape[0] - 1)
        _write_pose(end_pose(chain, Q[n]), out[n])


@njit(f"void({_C}, {_M}, {_V}, {_M})", cache=True)
def jacobian_into(chain, axes, q, J):
    """J (6, dof) = the geometric Jacobian at one configuration q (dof,)."""
    check_configuration(q, chain.shape[0] - 1)
    pose_and_jacobian(chain, axes, q, J)


@njit(f"void({_C}, {_M}, {_V}, {_M}, {_M})", cache=True)
def fk_and_jacobian_into(chain, axes, q, X, J):
    """X (4, 4) = X_BE [m] and J (6, dof) its Jacobian, from one pass along the chain."""
    check_configuration(q, chain.shape[0] - 1)
    _write_pose(pose_and_jacobian(chain, axes, q, J), X)


@njit(f"void({_C}, {_M}, {_M}, {_T})", cache=True)
def jacobian_batch_into(chain, axes, Q, out):
    """out (N, 6, dof) = the geometric Jacobians at configurations Q (N, dof)."""
    for n in range(Q.shape[0]):
        check_configuration(Q[n], chain.shape[0] - 1)
        pose_and_jacobian(chain, axes, Q[n], out[n])


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
