"""The inverse-Jacobian method of seed 000 as damped least-squares (Levenberg-Marquardt) Newton steps.

Inner loop on our NumPy model. Each step solves ``(J^T J + lambda I) dq = J^T e`` with the damping
``lambda`` adapted to progress (smaller after a step that reduced the error, larger after one that
did not); revolute joints are wrapped by 2 pi into their limits (joints with more than 360 deg of
travel keep the representative nearest the current value), then every joint is clamped to its
limits. Seeded random restarts inside the limits, within an iteration and time budget.
"""

from __future__ import annotations

import time

import numpy as np

from ..kinematics import rotation_log
from .result import (
    FULL_POSE,
    MATCHED_COMPONENTS,
    POSITION_AND_AXIS,
    IkResult,
    IkTarget,
    Solution,
    check_search_budget,
    is_strict,
    pose_errors,
    within_limits,
    wrap_into_limits,
)

#: Newton iterations stop once the error is this small (well inside the strict 1e-6 test) [m, rad].
CONVERGED = 1e-10
INITIAL_DAMPING = 1e-3
MIN_DAMPING, MAX_DAMPING = 1e-12, 1e6
#: An attempt is abandoned once the damping has grown this large without progress ...
STALLED_DAMPING = 1e4
#: ... or after this many accepted steps in a row that each cut the squared error by less than 1 %.
STALLED_STEPS = 8


def _basis_perpendicular(z: np.ndarray) -> np.ndarray:
    """Two unit rows (2, 3) spanning the plane perpendicular to the unit vector z."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    b1 = np.cross(z, helper)
    b1 /= np.linalg.norm(b1)
    return np.stack([b1, np.cross(z, b1)])


def residual(X: np.ndarray, J: np.ndarray, target: IkTarget) -> tuple[np.ndarray, np.ndarray]:
    """Error vector e (what the target asks for, base frame) and the matching Jacobian rows."""
    e_position = target.X_BE[:3, 3] - X[:3, 3]
    if target.kind == FULL_POSE:
        e_rotation = rotation_log(target.X_BE[:3, :3] @ X[:3, :3].T)
        return np.concatenate([e_position, e_rotation]), J
    if target.kind == POSITION_AND_AXIS:
        z, z_target = X[:3, 2], target.X_BE[:3, 2]
        basis = _basis_perpendicular(z)
        angle = np.arctan2(np.linalg.norm(np.cross(z, z_target)), z @ z_target)
        axis = np.cross(z, z_target)
        norm = np.linalg.norm(axis)
        e_axis = axis * (angle / norm) if norm > 1e-12 else basis[0] * angle   # parallel (0) or opposite (pi)
        return np.concatenate([e_position, basis @ e_axis]), np.vstack([J[:3], basis @ J[3:]])
    return e_position, J[:3]


def _descend(robot, target: IkTarget, q: np.ndarray, max_iterations: int, deadline: float):
    """One damped least-squares descent from q; returns (q, iterations, converged)."""
    limits = robot.limits
    revolute = robot.revolute_mask
    X, J = robot.fk_and_jacobian(q)
    e, A = residual(X, J, target)
    cost = e @ e
    damping = INITIAL_DAMPING
    slow_steps = iterations = 0
    while iterations < max_iterations:
        if np.abs(e).max() <= CONVERGED:
            return q, iterations, True
        if damping > STALLED_DAMPING or slow_steps >= STALLED_STEPS or time.perf_counter() > deadline:
            break
        iterations += 1
        H = A.T @ A
        step = np.linalg.solve(H + damping * np.eye(H.shape[0]), A.T @ e)
        q_new = wrap_into_limits(q + step, revolute, limits.q_min, limits.q_max, reference=q)
        q_new = np.clip(q_new, limits.q_min, limits.q_max)
        X_new, J_new = robot.fk_and_jacobian(q_new)
        e_new, A_new = residual(X_new, J_new, target)
        cost_new = e_new @ e_new
        if cost_new < cost:
            slow_steps = slow_steps + 1 if cost_new > 0.99 * cost else 0
            q, e, A, cost = q_new, e_new, A_new, cost_new
            damping = max(damping / 10.0, MIN_DAMPING)
        else:
            damping = min(damping * 10.0, MAX_DAMPING)
    return q, iterations, np.abs(e).max() <= CONVERGED


def solve_jacobian(robot, target: IkTarget, q_seed: np.ndarray, rng: np.random.Generator | None = None,
                   max_restarts: int = 50, max_iterations: int = 100, time_budget: float = 0.5) -> IkResult:
    """Damped least-squares IK from the seed, then from seeded random in-limit restarts.

    ``max_restarts`` random restarts after the seed, ``max_iterations`` per descent, ``time_budget`` [s]
    for the whole solve. The answer is judged by our FK: strict errors and every joint in limits.
    """
    check_search_budget(max_restarts, time_budget, max_iterations)
    limits = robot.limits
    rng = np.random.default_rng(0) if rng is None else rng
    deadline = time.perf_counter() + time_budget
    start = np.clip(wrap_into_limits(q_seed, robot.revolute_mask, limits.q_min, limits.q_max, reference=q_seed),
                    limits.q_min, limits.q_max)
    best = None
    total_iterations = 0
    for attempt in range(max_restarts + 1):
        if attempt > 0:
            if time.perf_counter() > deadline:
                break
            start = robot.random_configurations(rng, 1)[0]
        q, iterations, _ = _descend(robot, target, start, max_iterations, deadline)
        total_iterations += iterations
        position_error, rotation_error = pose_errors(robot.fk(q), target)
        if best is None or position_error + rotation_error < best[1] + best[2]:
            best = (q, position_error, rotation_error)
        if is_strict(position_error, rotation_error) and within_limits(q, limits.q_min, limits.q_max):
            solution = Solution(q, position_error, rotation_error)
            return IkResult(True, q, position_error, rotation_error, total_iterations, "jacobian", "", (solution,),
                            MATCHED_COMPONENTS[target.kind], {"restarts": attempt})
    q, position_error, rotation_error = best
    reason = (f"no strict solution after {attempt + 1} descent(s) and {total_iterations} iterations "
              f"(budget: {max_restarts} restarts, {max_iterations} iterations each, {time_budget:g} s): best position "
              f"error {position_error:.3g} m, rotation error {rotation_error:.3g} rad; the target may be out of reach "
              "or reachable only outside the joint limits")
    return IkResult(False, q, position_error, rotation_error, total_iterations, "jacobian", reason, (),
                    MATCHED_COMPONENTS[target.kind], {"restarts": attempt})
