"""Compiled (Numba) kinematics of a DH chain: FK, the Jacobian and their batches.

The same factorisation as ``pipeline.kinematics.DhKinematics`` (the NumPy oracle these are checked
against): ``X_BE(q) = K_0 (M_1 K_1) ... (M_n K_n)`` with ``M_i K_i = P_i + cos(q_i) C_i + sin(q_i) S_i
+ q_i V_i`` (the joint's sign folded into S_i and V_i). A chain is one float array ``chain`` (dof + 1,
4, 4, 4): ``chain[0, 0] = K_0`` and ``chain[i] = (P_i, C_i, S_i, V_i)``; ``axes`` (dof, 2) holds each
joint's sign and 1.0 for revolute (0.0 prismatic). Kernels are ``@njit(cache=True)``: their machine
code is compiled on the first call on a machine and cached on disk beside this file.

Inputs are checked inside the kernels (length, finite, magnitude); a bad input raises ValueError, and
the caller re-checks it with ``DhKinematics.as_configuration`` for the typed error that names it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .arrays import MAX_MAGNITUDE


def pack_chain(P: np.ndarray, C: np.ndarray, S: np.ndarray, V: np.ndarray, K0: np.ndarray, sign: np.ndarray,
               revolute: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(chain, axes) of a DhKinematics' constant factors (each (dof, 4, 4); K0 (4, 4); sign, revolute (dof,))."""
    dof = len(sign)
    chain = np.zeros((dof + 1, 4, 4, 4))
    chain[0, 0] = K0
    chain[1:, 0], chain[1:, 1] = P, C
    chain[1:, 2], chain[1:, 3] = S * sign[:, None, None], V * sign[:, None, None]
    return chain, np.column_stack([sign, revolute.astype(float)])


@njit(cache=True)
def cross(a, b):
    """a x b of two 3-vectors."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def _check(q, dof):
    if q.shape[0] != dof:
        raise ValueError("wrong number of joint values")
    for value in q:
        if not abs(value) <= MAX_MAGNITUDE:          # also False for NaN
            raise ValueError("joint value not finite or too large")


@njit(cache=True)
def _times_link(X, chain, i, value, out):
    """out = X @ (M_i K_i)(value), X and out affine 4x4 (last row 0 0 0 1)."""
    c, s = np.cos(value), np.sin(value)
    L = chain[i + 1]
    for b in range(4):
        t0 = L[0, 0, b] + c * L[1, 0, b] + s * L[2, 0, b] + value * L[3, 0, b]
        t1 = L[0, 1, b] + c * L[1, 1, b] + s * L[2, 1, b] + value * L[3, 1, b]
        t2 = L[0, 2, b] + c * L[1, 2, b] + s * L[2, 2, b] + value * L[3, 2, b]
        t3 = L[0, 3, b] + c * L[1, 3, b] + s * L[2, 3, b] + value * L[3, 3, b]
        for a in range(3):
            out[a, b] = X[a, 0] * t0 + X[a, 1] * t1 + X[a, 2] * t2 + X[a, 3] * t3
    out[3, 0], out[3, 1], out[3, 2], out[3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True)
def _end_pose(chain, q, X):
    """X = X_BE(q); q already checked."""
    work = np.empty((4, 4))
    X[:] = chain[0, 0]
    for i in range(q.shape[0]):
        _times_link(X, chain, i, q[i], work)
        X[:] = work


@njit(cache=True)
def _jacobian_into(chain, axes, q, X, J):
    """X = X_BE(q) and J (6, dof) = its geometric Jacobian, rows [v; w], base frame, at E's origin."""
    dof = q.shape[0]
    frames = np.empty((dof, 3, 2))                     # per joint: its axis (sign applied) and origin
    work = np.empty((4, 4))
    X[:] = chain[0, 0]
    for i in range(dof):
        for a in range(3):
            frames[i, a, 0] = X[a, 2] * axes[i, 0]
            frames[i, a, 1] = X[a, 3]
        _times_link(X, chain, i, q[i], work)
        X[:] = work
    for i in range(dof):
        ax, ay, az = frames[i, 0, 0], frames[i, 1, 0], frames[i, 2, 0]
        if axes[i, 1] > 0.5:
            lx, ly, lz = X[0, 3] - frames[i, 0, 1], X[1, 3] - frames[i, 1, 1], X[2, 3] - frames[i, 2, 1]
            J[0, i], J[1, i], J[2, i] = ay * lz - az * ly, az * lx - ax * lz, ax * ly - ay * lx
            J[3, i], J[4, i], J[5, i] = ax, ay, az
        else:
            J[0, i], J[1, i], J[2, i] = ax, ay, az
            J[3, i], J[4, i], J[5, i] = 0.0, 0.0, 0.0


@njit(cache=True)
def fk(chain, q):
    """X_BE (4, 4) [m] at one configuration q (dof,)."""
    _check(q, chain.shape[0] - 1)
    X = np.empty((4, 4))
    _end_pose(chain, q, X)
    return X


@njit(cache=True)
def fk_batch(chain, Q):
    """X_BE (N, 4, 4) [m] for configurations Q (N, dof)."""
    out = np.empty((Q.shape[0], 4, 4))
    for n in range(Q.shape[0]):
        _check(Q[n], chain.shape[0] - 1)
        _end_pose(chain, Q[n], out[n])
    return out


@njit(cache=True)
def jacobian(chain, axes, q):
    """Geometric Jacobian (6, dof) at one configuration q (dof,)."""
    _check(q, chain.shape[0] - 1)
    J = np.empty((6, q.shape[0]))
    _jacobian_into(chain, axes, q, np.empty((4, 4)), J)
    return J


@njit(cache=True)
def fk_and_jacobian(chain, axes, q):
    """(X_BE (4, 4) [m], Jacobian (6, dof)) from one pass along the chain."""
    _check(q, chain.shape[0] - 1)
    X, J = np.empty((4, 4)), np.empty((6, q.shape[0]))
    _jacobian_into(chain, axes, q, X, J)
    return X, J


@njit(cache=True)
def jacobian_batch(chain, axes, Q):
    """Geometric Jacobians (N, 6, dof) for configurations Q (N, dof)."""
    out = np.empty((Q.shape[0], 6, Q.shape[1]))
    X = np.empty((4, 4))
    for n in range(Q.shape[0]):
        _check(Q[n], chain.shape[0] - 1)
        _jacobian_into(chain, axes, Q[n], X, out[n])
    return out


@njit(cache=True)
def is_pose(X, tolerance):
    """True when X (4, 4) is finite, its 3x3 block a rotation (|R^T R - I| <= tolerance entrywise,
    |entries| <= 1 + tolerance, det >= 0) and its last row exactly 0 0 0 1."""
    for i in range(4):
        for j in range(4):
            if not abs(X[i, j]) <= 1e300:
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
