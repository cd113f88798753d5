"""Compiled (Numba) damped least-squares descent, the inner loop of ``pipeline.model.ik.jacobian``.

Each step solves ``(A^T A + lambda I) v = A^T e`` (Cholesky; A the Jacobian rows the target asks for, e its
error) with the damping ``lambda`` adapted to progress (smaller after a step that reduced the error, larger
after one that did not), adds the geodesic acceleration ``a`` (M. K. Transtrum and J. P. Sethna, "Improvements
to the Levenberg-Marquardt algorithm for nonlinear least-squares minimization", 2012): ``(A^T A + lambda I) a =
A^T e''``, e'' the error's second derivative along v (by finite differences, from the error at
``q + PROBE v``), and moves by ``v + a / 2`` (undamped, the step that zeroes the error to second order);
revolute joints are wrapped by 2 pi into their limits (the representative nearest the current value), then
every joint is clamped to its limits. A descent allocates its work arrays once: no iteration allocates.

The acceleration is for targets near a singularity. Near a shoulder singularity (the wrist centre within a
millimetre of axis 1) q1 barely moves the end and the near-solutions form a curved valley along q1, the wrist
turning with it; the damped steps alone follow its bend only in short steps (about 1e-3 rad), so a descent ran
out of iterations or stalled before reaching the solution, and restarts landed in the same valley (a seeded
LR Mate set solved 299/300). The second-order term lets the steps follow the bend.
"""

from __future__ import annotations

import math

import numpy as np

from ..chain.compiled import (ANY_MATRIX, ANY_VECTOR, MATRIX, POSE, POSITION_AND_AXIS, REVOLUTE, cross, end_pose, inner,
                              kernel, pose_and_jacobian, pose_errors, unit)
from .result import POSITION_TOLERANCE, ROTATION_TOLERANCE

#: Newton iterations stop once the error is this small (well inside the strict 1e-6 test) [m, rad].
CONVERGED = 1e-10
INITIAL_DAMPING = 1e-3
MIN_DAMPING, MAX_DAMPING = 1e-12, 1e6
#: An attempt is abandoned once the damping has grown this large without progress ...
STALLED_DAMPING = 1e4
#: ... or after this many accepted steps in a row that each cut the squared error by less than 1 %.
STALLED_STEPS = 8
#: The geodesic acceleration's probe: the error at q + PROBE v (v the damped Gauss-Newton step) gives the
#: error's second derivative along v by finite differences [1] (Transtrum and Sethna's choice).
PROBE = 0.1
TWO_PI = 2.0 * math.pi


@inner()
def _rotation_log(R):
    """Rotation vector (axis * angle, angle in [0, pi]) [rad] of a rotation R (row-major 9-tuple), accurate
    at 0 and pi (as ``pipeline.model.chain.kinematics.rotation_log``)."""
    vx, vy, vz = R[7] - R[5], R[2] - R[6], R[3] - R[1]
    sin_angle = 0.5 * math.sqrt(vx * vx + vy * vy + vz * vz)
    angle = math.atan2(sin_angle, 0.5 * (R[0] + R[4] + R[8] - 1.0))
    if angle < 1e-6:
        return 0.5 * vx, 0.5 * vy, 0.5 * vz
    if angle < math.pi - 1e-6:
        scale = angle / (2.0 * sin_angle)
        return scale * vx, scale * vy, scale * vz
    k = 0
    for i in range(1, 3):
        if R[4 * i] > R[4 * k]:
            k = i
    scale = 0.5 / math.sqrt((R[4 * k] + 1.0) / 2.0)
    ax, ay, az = (R[k] + (k == 0)) * scale, (R[3 + k] + (k == 1)) * scale, (R[6 + k] + (k == 2)) * scale
    if ax * vx + ay * vy + az * vz < 0.0:
        ax, ay, az = -ax, -ay, -az
    return ax * angle, ay * angle, az * angle


@inner()
def _axis_basis(x):
    """(b1, b2): two unit vectors normal to the z axis of the Pose x, along which a position+axis target's
    axis error is measured."""
    z = (x[2], x[6], x[10])
    b1 = unit(cross(z, (1.0, 0.0, 0.0) if abs(z[0]) < 0.9 else (0.0, 1.0, 0.0)))
    return b1, cross(z, b1)


@inner()
def _errors(x, X_target, kind, basis, e):
    """Fill e (rows,) with the error of the Pose x the target asks for (base frame; a position+axis
    target's axis error along ``basis``, of ``_axis_basis``); returns the number of rows (6, 5 or 3)."""
    for i in range(3):
        e[i] = X_target[i, 3] - x[4 * i + 3]
    if kind == POSE:
        e[3], e[4], e[5] = _rotation_log((                      # of R_target R^T
            X_target[0, 0] * x[0] + X_target[0, 1] * x[1] + X_target[0, 2] * x[2],
            X_target[0, 0] * x[4] + X_target[0, 1] * x[5] + X_target[0, 2] * x[6],
            X_target[0, 0] * x[8] + X_target[0, 1] * x[9] + X_target[0, 2] * x[10],
            X_target[1, 0] * x[0] + X_target[1, 1] * x[1] + X_target[1, 2] * x[2],
            X_target[1, 0] * x[4] + X_target[1, 1] * x[5] + X_target[1, 2] * x[6],
            X_target[1, 0] * x[8] + X_target[1, 1] * x[9] + X_target[1, 2] * x[10],
            X_target[2, 0] * x[0] + X_target[2, 1] * x[1] + X_target[2, 2] * x[2],
            X_target[2, 0] * x[4] + X_target[2, 1] * x[5] + X_target[2, 2] * x[6],
            X_target[2, 0] * x[8] + X_target[2, 1] * x[9] + X_target[2, 2] * x[10]))
        return 6
    if kind == POSITION_AND_AXIS:
        b1, b2 = basis
        z, z_target = (x[2], x[6], x[10]), (X_target[0, 2], X_target[1, 2], X_target[2, 2])
        axis = cross(z, z_target)
        norm = math.sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2])
        angle = math.atan2(norm, z[0] * z_target[0] + z[1] * z_target[1] + z[2] * z_target[2])
        scale = angle / norm if norm > 1e-12 else angle        # parallel (0) or opposite (pi): about b1
        e_axis = (axis[0] * scale, axis[1] * scale, axis[2] * scale) if norm > 1e-12 else \
            (b1[0] * scale, b1[1] * scale, b1[2] * scale)
        e[3] = b1[0] * e_axis[0] + b1[1] * e_axis[1] + b1[2] * e_axis[2]
        e[4] = b2[0] * e_axis[0] + b2[1] * e_axis[1] + b2[2] * e_axis[2]
        return 5
    return 3


@inner()
def residual(x, J, X_target, kind, e, A):
    """Fill e (rows,) with the error of the Pose x the target asks for (``_errors``) and A (rows, dof)
    with the matching Jacobian rows; returns the number of rows (6, 5 or 3)."""
    basis = _axis_basis(x)
    rows = _errors(x, X_target, kind, basis, e)
    for j in range(J.shape[1]):
        for i in range(3):
            A[i, j] = J[i, j]
        if rows == 6:
            for i in range(3, 6):
                A[i, j] = J[i, j]
        elif rows == 5:
            b1, b2 = basis
            A[3, j] = b1[0] * J[3, j] + b1[1] * J[4, j] + b1[2] * J[5, j]
            A[4, j] = b2[0] * J[3, j] + b2[1] * J[4, j] + b2[2] * J[5, j]
    return rows


@inner()
def _factor(A, rows, damping, L):
    """L (dof, dof): the Cholesky factor (lower triangle) of A^T A + damping I, positive definite."""
    n = A.shape[1]
    for i in range(n):
        for j in range(i + 1):
            total = damping if i == j else 0.0
            for r in range(rows):
                total += A[r, i] * A[r, j]
            L[i, j] = total
    for i in range(n):                                 # L L^T, in place of the lower triangle
        for j in range(i + 1):
            total = L[i, j]
            for k in range(j):
                total -= L[i, k] * L[j, k]
            L[i, j] = math.sqrt(max(total, 1e-300)) if i == j else total / L[j, j]


@inner()
def _solve(L, A, b, rows, x):
    """x (dof,) solving (A^T A + damping I) x = A^T b, L the factor of ``_factor``."""
    n = A.shape[1]
    for i in range(n):
        total = 0.0
        for r in range(rows):
            total += A[r, i] * b[r]
        x[i] = total
    for i in range(n):                                 # L y = A^T b, then L^T x = y, in place
        total = x[i]
        for k in range(i):
            total -= L[i, k] * x[k]
        x[i] = total / L[i, i]
    for i in range(n - 1, -1, -1):
        total = x[i]
        for k in range(i + 1, n):
            total -= L[k, i] * x[k]
        x[i] = total / L[i, i]


@inner()
def _wrap_and_clamp(q, reference, revolute, q_min, q_max, out):
    """out = q with each revolute joint shifted by 2 pi to the in-limit representative nearest
    ``reference`` (the one nearest it when none fits), then every joint clamped to its limits (out may
    be q)."""
    for j in range(q.shape[0]):
        value = q[j]
        if revolute[j] > 0.5:
            nearest = value - TWO_PI * round((value - reference[j]) / TWO_PI)
            best, best_distance = nearest, np.inf
            for shift in (0.0, -TWO_PI, TWO_PI):
                candidate = nearest + shift
                if q_min[j] <= candidate <= q_max[j] and abs(candidate - reference[j]) < best_distance:
                    best, best_distance = candidate, abs(candidate - reference[j])
            value = best
        out[j] = min(max(value, q_min[j]), q_max[j])


@inner()
def _squared_norm(e, rows):
    total = 0.0
    for r in range(rows):
        total += e[r] * e[r]
    return total


@inner()
def _largest(e, rows):
    largest = 0.0
    for r in range(rows):
        largest = max(largest, abs(e[r]))
    return largest


@kernel("Tuple((float64[::1], int64, float64, float64, boolean))"
        f"({MATRIX}, float64[::1], float64[::1], {ANY_MATRIX}, int64, {ANY_VECTOR}, int64)")
def descend(chain, q_min, q_max, X_target, kind, q, max_iterations):
    """One damped least-squares descent from q (first wrapped and clamped into the limits): (q,
    iterations, position error [m], rotation error [rad] by the compiled FK, strict: both within the
    IK tolerances and every joint in its limits)."""
    dof = q.shape[0]
    revolute = chain[1:, REVOLUTE]
    q, q_new, step, acceleration = q.copy(), np.empty(dof), np.empty(dof), np.empty(dof)
    _wrap_and_clamp(q, q, revolute, q_min, q_max, q)
    J, L = np.empty((6, dof)), np.empty((dof, dof))
    e, A = np.empty(6), np.empty((6, dof))
    e_new, A_new = np.empty(6), np.empty((6, dof))
    x = pose_and_jacobian(chain, q, J)
    rows = residual(x, J, X_target, kind, e, A)
    cost = _squared_norm(e, rows)
    damping = INITIAL_DAMPING
    slow_steps = iterations = 0
    while iterations < max_iterations:
        if _largest(e, rows) <= CONVERGED:
            break
        if damping > STALLED_DAMPING or slow_steps >= STALLED_STEPS:
            break
        iterations += 1
        _factor(A, rows, damping, L)
        _solve(L, A, e, rows, step)                    # the damped Gauss-Newton step v
        for j in range(dof):                           # the error a PROBE of the way along v
            q_new[j] = q[j] + PROBE * step[j]
        _errors(end_pose(chain, q_new), X_target, kind, _axis_basis(x), e_new)
        for r in range(rows):                          # e_new = the error's second derivative along v
            predicted = 0.0
            for j in range(dof):
                predicted += A[r, j] * step[j]
            e_new[r] = 2.0 / PROBE * (predicted - (e[r] - e_new[r]) / PROBE)
        _solve(L, A, e_new, rows, acceleration)        # the geodesic acceleration a: the step is v + a / 2
        for j in range(dof):
            q_new[j] = q[j] + step[j] + 0.5 * acceleration[j]
        _wrap_and_clamp(q_new, q, revolute, q_min, q_max, q_new)
        x_new = pose_and_jacobian(chain, q_new, J)
        residual(x_new, J, X_target, kind, e_new, A_new)
        cost_new = _squared_norm(e_new, rows)
        if cost_new < cost:
            slow_steps = slow_steps + 1 if cost_new > 0.99 * cost else 0
            cost, x = cost_new, x_new
            q, q_new, e, e_new, A, A_new = q_new, q, e_new, e, A_new, A
            damping = max(damping / 10.0, MIN_DAMPING)
        else:
            damping = min(damping * 10.0, MAX_DAMPING)
    position_error, rotation_error = pose_errors(end_pose(chain, q), X_target, kind)
    strict = position_error <= POSITION_TOLERANCE and rotation_error <= ROTATION_TOLERANCE
    for j in range(dof):
        strict &= q_min[j] <= q[j] <= q_max[j]
    return q, iterations, position_error, rotation_error, strict


@kernel(f"boolean({MATRIX}, float64[::1], float64[::1], {ANY_VECTOR}, float64[::1], int64, float64, float64)")
def nudge_position(chain, q_min, q_max, target, q, iterations, tolerance, damping):
    """Damped least squares on the end's position alone, from q (dof,) in place: up to ``iterations`` steps
    q += (J^T J + damping^2 I)^-1 J^T e (J the position rows of the Jacobian, e the error to ``target`` (3,) [m];
    no clamping, the orientation left free). True when the error gets below ``tolerance`` [m] with every joint in
    its limits (q is then the answer)."""
    dof = q.shape[0]
    J, L, step, e = np.empty((6, dof)), np.empty((dof, dof)), np.empty(dof), np.empty(3)
    for _ in range(iterations):
        x = pose_and_jacobian(chain, q, J)
        e[0], e[1], e[2] = target[0] - x[3], target[1] - x[7], target[2] - x[11]
        if math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) < tolerance:
            for j in range(dof):
                if not q_min[j] <= q[j] <= q_max[j]:
                    return False
            return True
        _factor(J, 3, damping * damping, L)
        _solve(L, J, e, 3, step)
        for j in range(dof):
            q[j] += step[j]
    return False
