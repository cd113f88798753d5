"""Compiled (Numba) damped least-squares descent, the inner loop of ``pipeline.ik.jacobian``.

Each step solves ``(A^T A + lambda I) dq = A^T e`` (Cholesky; A the Jacobian rows the target asks
for, e its error) with the damping ``lambda`` adapted to progress (smaller after a step that reduced
the error, larger after one that did not); revolute joints are wrapped by 2 pi into their limits
(the representative nearest the current value), then every joint is clamped to its limits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compiled import POSE, POSITION_AND_AXIS, cross, end_pose, pose_and_jacobian, pose_errors
from .result import POSITION_TOLERANCE, ROTATION_TOLERANCE

#: Newton iterations stop once the error is this small (well inside the strict 1e-6 test) [m, rad].
CONVERGED = 1e-10
INITIAL_DAMPING = 1e-3
MIN_DAMPING, MAX_DAMPING = 1e-12, 1e6
#: An attempt is abandoned once the damping has grown this large without progress ...
STALLED_DAMPING = 1e4
#: ... or after this many accepted steps in a row that each cut the squared error by less than 1 %.
STALLED_STEPS = 8
TWO_PI = 2.0 * math.pi


@njit(cache=True)
def _rotation_log(R):
    """Rotation vector (axis * angle, angle in [0, pi]) [rad] of a rotation matrix, accurate at 0 and pi
    (as ``pipeline.kinematics.rotation_log``)."""
    vee = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    sin_angle = 0.5 * math.sqrt(vee[0] ** 2 + vee[1] ** 2 + vee[2] ** 2)
    angle = math.atan2(sin_angle, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0))
    if angle < 1e-6:
        return vee / 2.0
    if angle < math.pi - 1e-6:
        return vee * (angle / (2.0 * sin_angle))
    k = 0
    for i in range(1, 3):
        if R[i, i] > R[k, k]:
            k = i
    B_kk = (R[k, k] + 1.0) / 2.0
    axis = np.array([(R[0, k] + (1.0 if k == 0 else 0.0)) / 2.0, (R[1, k] + (1.0 if k == 1 else 0.0)) / 2.0,
                     (R[2, k] + (1.0 if k == 2 else 0.0)) / 2.0]) / math.sqrt(B_kk)
    if axis @ vee < 0.0:
        axis = -axis
    return axis * angle


@njit(cache=True)
def residual(x, J, X_target, kind, e, A):
    """Fill e (rows,) with the error of the Pose x the target asks for (base frame) and A (rows, dof)
    with the matching Jacobian rows; returns the number of rows (6, 5 or 3)."""
    for i in range(3):
        e[i] = X_target[i, 3] - x[4 * i + 3]
        A[i] = J[i]
    if kind == POSE:
        R = np.empty((3, 3))                                   # R_target R^T
        for i in range(3):
            for j in range(3):
                R[i, j] = X_target[i, 0] * x[4 * j] + X_target[i, 1] * x[4 * j + 1] + X_target[i, 2] * x[4 * j + 2]
        e[3:6] = _rotation_log(R)
        A[3:6] = J[3:6]
        return 6
    if kind == POSITION_AND_AXIS:
        z, z_target = np.array([x[2], x[6], x[10]]), X_target[:3, 2].copy()
        helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        b1 = np.array(cross(z, helper))
        b1 /= math.sqrt(b1 @ b1)
        b2 = np.array(cross(z, b1))
        axis = np.array(cross(z, z_target))
        norm = math.sqrt(axis @ axis)
        angle = math.atan2(norm, z @ z_target)
        e_axis = axis * (angle / norm) if norm > 1e-12 else b1 * angle     # parallel (0) or opposite (pi)
        e[3], e[4] = b1 @ e_axis, b2 @ e_axis
        for j in range(J.shape[1]):
            A[3, j] = b1[0] * J[3, j] + b1[1] * J[4, j] + b1[2] * J[5, j]
            A[4, j] = b2[0] * J[3, j] + b2[1] * J[4, j] + b2[2] * J[5, j]
        return 5
    return 3


@njit(cache=True)
def _damped_step(A, e, rows, damping):
    """dq solving (A^T A + damping I) dq = A^T e by Cholesky (the matrix is positive definite)."""
    n = A.shape[1]
    H, g = np.zeros((n, n)), np.zeros(n)
    for r in range(rows):
        for i in range(n):
            g[i] += A[r, i] * e[r]
            for j in range(i + 1):
                H[i, j] += A[r, i] * A[r, j]
    for i in range(n):
        H[i, i] += damping
    L = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            total = H[i, j]
            for k in range(j):
                total -= L[i, k] * L[j, k]
            L[i, j] = math.sqrt(max(total, 1e-300)) if i == j else total / L[j, j]
    y = np.empty(n)
    for i in range(n):
        total = g[i]
        for k in range(i):
            total -= L[i, k] * y[k]
        y[i] = total / L[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        total = y[i]
        for k in range(i + 1, n):
            total -= L[k, i] * x[k]
        x[i] = total / L[i, i]
    return x


@njit(cache=True)
def into_limits(q, reference, revolute, q_min, q_max):
    """q with each revolute joint shifted by 2 pi to the in-limit representative nearest ``reference``
    (the one nearest it when none fits), then every joint clamped to its limits."""
    out = q.copy()
    for j in range(q.shape[0]):
        if revolute[j] > 0.5:
            nearest = q[j] - TWO_PI * round((q[j] - reference[j]) / TWO_PI)
            best, best_distance = nearest, np.inf
            for shift in (0.0, -TWO_PI, TWO_PI):
                value = nearest + shift
                if q_min[j] <= value <= q_max[j] and abs(value - reference[j]) < best_distance:
                    best, best_distance = value, abs(value - reference[j])
            out[j] = best
        out[j] = min(max(out[j], q_min[j]), q_max[j])
    return out


@njit(cache=True)
def descend(chain, axes, q_min, q_max, X_target, kind, q, max_iterations):
    """One damped least-squares descent from q: (q, iterations, position error [m], rotation error
    [rad] by the compiled FK, strict: both within the IK tolerances and every joint in its limits)."""
    dof = q.shape[0]
    J = np.empty((6, dof))
    e, A = np.empty(6), np.empty((6, dof))
    e_new, A_new = np.empty(6), np.empty((6, dof))
    rows = residual(pose_and_jacobian(chain, axes, q, J), J, X_target, kind, e, A)
    cost = e[:rows] @ e[:rows]
    damping = INITIAL_DAMPING
    slow_steps = iterations = 0
    while iterations < max_iterations:
        if np.abs(e[:rows]).max() <= CONVERGED:
            break
        if damping > STALLED_DAMPING or slow_steps >= STALLED_STEPS:
            break
        iterations += 1
        step = _damped_step(A, e, rows, damping)
        q_new = into_limits(q + step, q, axes[:, 1], q_min, q_max)
        residual(pose_and_jacobian(chain, axes, q_new, J), J, X_target, kind, e_new, A_new)
        cost_new = e_new[:rows] @ e_new[:rows]
        if cost_new < cost:
            slow_steps = slow_steps + 1 if cost_new > 0.99 * cost else 0
            q, cost = q_new, cost_new
            e, e_new, A, A_new = e_new, e, A_new, A
            damping = max(damping / 10.0, MIN_DAMPING)
        else:
            damping = min(damping * 10.0, MAX_DAMPING)
    position_error, rotation_error = pose_errors(end_pose(chain, q), X_target, kind)
    strict = position_error <= POSITION_TOLERANCE and rotation_error <= ROTATION_TOLERANCE
    for j in range(dof):
        strict &= q_min[j] <= q[j] <= q_max[j]
    return q, iterations, position_error, rotation_error, strict
