"""Closed-form IK for 6R arms whose last three axes meet (a spherical wrist), from the DH table itself.

Nothing is hand-coded per robot. The joint screws are read off our FK at q = 0 (product of
exponentials, ``X_BE(q) = e^{xi_1 q_1} ... e^{xi_6 q_6} X_BE(0)``) and the solution uses Paden-Kahan
subproblems, so standard and modified DH tables, signs and offsets are all handled alike:

1. the wrist centre c (where axes 4, 5, 6 meet) fixes q1 (axis 2 parallel to axis 3 keeps c's
   component along axis 2 constant: one trigonometric equation, two roots: shoulder front/back);
2. its distance to axis 2 fixes q3 (subproblem 3, two roots: elbow up/down), then q2 (subproblem 1);
3. the wrist rotation gives q4, q5 (subproblem 2, two roots: wrist flip/no flip) and q6 (subproblem 1).
At a wrist singularity (axes 4 and 6 aligned, q5 = 0) only q4 + q6 (or q4 - q6) is fixed: the split
nearest the seed is returned. At a shoulder singularity (wrist centre on axis 1) q1 is the seed's.

Every branch is vectorised over targets and branches, shifted by 2 pi into the joint limits in every
possible way, verified by our FK, and labelled.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from .result import (
    FULL_POSE,
    POSITION_TOLERANCE,
    ROTATION_TOLERANCE,
    TWO_PI,
    IkResult,
    IkTarget,
    Solution,
    distinct_order_batch,
    limit_variants,
    pose_errors,
    rotation_angle,
)

#: Axes closer than this [m] meet; directions closer than this [1] are parallel.
GEOMETRY_TOLERANCE = 1e-9
#: Below this, the wrist centre is on axis 1 [m] or axes 4 and 6 are aligned [1].
SINGULAR_TOLERANCE = 1e-9
#: How far past +-1 a cosine may go through rounding before the target counts as out of reach.
REACH_SLACK = 1e-9
BRANCHES = 8


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products over the last axis (broadcasting)."""
    return (a * b).sum(axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products over the last axis (broadcasting); cheaper than np.cross on small arrays."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _skew(w: np.ndarray) -> np.ndarray:
    """The matrix K with K v = w x v."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


@dataclass(frozen=True, eq=False)
class _Axis:
    """A unit joint axis w with its cross-product matrix K (K v = w x v) and K^2."""

    w: np.ndarray
    K: np.ndarray
    K2: np.ndarray

    @classmethod
    def of(cls, w: np.ndarray) -> "_Axis":
        K = _skew(w)
        return cls(w, K, K @ K)

    def rotate(self, angle: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rodrigues: rotate vectors v (..., 3) about this axis by angle (...) [rad]."""
        c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
        return v + s * (v @ self.K.T) + (1.0 - c) * (v @ self.K2.T)

    def matrix(self, angle: np.ndarray) -> np.ndarray:
        """Rotation matrices (..., 3, 3) about this axis by angle (...) [rad]."""
        c, s = np.cos(angle)[..., None, None], np.sin(angle)[..., None, None]
        return np.eye(3) + s * self.K + (1.0 - c) * self.K2

    def angle(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Subproblem 1: the rotation about this axis taking u's projection onto v's [rad]."""
        y = -_dot(u, v @ self.K.T)                       # w . (u x v)
        x = _dot(u, v) - (u @ self.w) * (v @ self.w)      # projections' dot product
        return np.arctan2(y, x)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Angles into (-pi, pi]."""
    return angle - TWO_PI * np.ceil((angle - math.pi) / TWO_PI)


def _closest_points(p1, w1, p2, w2) -> tuple[np.ndarray, float]:
    """Midpoint of the common perpendicular of two non-parallel lines, and their distance [m]."""
    n = _cross(w1, w2)
    diff = p2 - p1
    t1 = _dot(_cross(diff, w2), n) / _dot(n, n)
    t2 = _dot(_cross(diff, w1), n) / _dot(n, n)
    a, b = p1 + t1 * w1, p2 + t2 * w2
    return (a + b) / 2.0, float(np.linalg.norm(a - b))


@dataclass(frozen=True, eq=False)
class AnalyticSolver:
    """The closed-form solver of one robot, or why the robot does not fit it (``applicable`` False).

    ``axes`` (6, 3) unit joint axes and ``points`` (6, 3) points on them at q = 0, base frame [m];
    ``wrist_centre`` c at q = 0; ``X_BE0`` the end pose at q = 0.
    """

    applicable: bool
    reason: str = ""
    axes: np.ndarray | None = None
    points: np.ndarray | None = None
    wrist_centre: np.ndarray | None = None
    X_BE0: np.ndarray | None = None


_SOLVERS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def analytic_solver_for(robot) -> AnalyticSolver:
    """The (cached) closed-form solver of a robot, derived from its DH table."""
    if robot not in _SOLVERS:
        _SOLVERS[robot] = _derive_solver(robot)
    return _SOLVERS[robot]


def _derive_solver(robot) -> AnalyticSolver:
    spec = robot.spec
    if spec.dof != 6 or not all(j.is_revolute for j in spec.joints):
        return AnalyticSolver(False, f"{spec.name}: the closed form needs 6 revolute joints (has {spec.dof})")
    frames, X_BE0 = robot.joint_frames(np.zeros(6))
    axes = frames[:, :3, 2] * np.array([j.sign for j in spec.joints])[:, None]
    points = frames[:, :3, 3].copy()
    if np.linalg.norm(_cross(axes[3], axes[4])) < GEOMETRY_TOLERANCE:
        return AnalyticSolver(False, f"{spec.name}: axes 4 and 5 are parallel: no spherical wrist")
    centre, gap = _closest_points(points[3], axes[3], points[4], axes[4])
    offset6 = centre - points[5]
    distance6 = float(np.linalg.norm(offset6 - axes[5] * _dot(axes[5], offset6)))
    if gap > GEOMETRY_TOLERANCE or distance6 > GEOMETRY_TOLERANCE:
        return AnalyticSolver(False, f"{spec.name}: axes 4, 5, 6 do not meet in one point "
                                     f"(gaps {gap:.3g} m, {distance6:.3g} m): no spherical wrist")
    if np.linalg.norm(_cross(axes[1], axes[2])) > GEOMETRY_TOLERANCE:
        return AnalyticSolver(False, f"{spec.name}: axes 2 and 3 are not parallel")
    if np.linalg.norm(_cross(axes[0], axes[1])) < GEOMETRY_TOLERANCE:
        return AnalyticSolver(False, f"{spec.name}: axes 1 and 2 are parallel")
    return AnalyticSolver(True, "", axes, points, centre, X_BE0)


@dataclass(frozen=True, eq=False)
class BranchSolutions:
    """Raw closed-form branches for N targets: Q (N, 8, 6) in (-pi, pi], reachable (N, 8), labels (N, 8)."""

    Q: np.ndarray
    reachable: np.ndarray
    labels: np.ndarray


def solve_branches(solver: AnalyticSolver, X_targets: np.ndarray, seeds: np.ndarray) -> BranchSolutions:
    """All 8 closed-form branches for targets X (N, 4, 4) [m]; seeds (N, 6) break singular ties."""
    w, r, c = solver.axes, solver.points, solver.wrist_centre
    ax = [_Axis.of(wi) for wi in w]
    n = X_targets.shape[0]
    R_target, p_target = X_targets[:, :3, :3], X_targets[:, :3, 3]
    c_in_end = solver.X_BE0[:3, :3].T @ (c - solver.X_BE0[:3, 3])
    p_wrist = np.einsum("nij,j->ni", R_target, c_in_end) + p_target                   # (N, 3)

    # q1: (R1(q1) w2) . (p_w - r1) = w2 . (c - r2) - (r1 - r2) . w2, as A cos + B sin = C.
    w1, w2 = w[0], w[1]
    w2_perp = w2 - w1 * (w1 @ w2)
    v = p_wrist - r[0]
    A, B = v @ w2_perp, v @ _cross(w1, w2)
    C = w2 @ (c - r[1]) - (r[0] - r[1]) @ w2 - (v @ w1) * (w1 @ w2)
    rho = np.hypot(A, B)
    shoulder_singular = rho < SINGULAR_TOLERANCE
    ratio = np.where(shoulder_singular, 0.0, C / np.where(shoulder_singular, 1.0, rho))
    reach1 = np.abs(ratio) <= 1.0 + REACH_SLACK
    phi = np.arctan2(B, A)
    spread = np.arccos(np.clip(ratio, -1.0, 1.0))
    q1 = np.stack([phi + spread, phi - spread], axis=1)                                # (N, 2)
    q1 = np.where(shoulder_singular[:, None], seeds[:, :1], q1)

    # q3: |e^{xi3 q3} c - r2| = |p' - r2| with p' = e^{-xi1 q1} p_w (subproblem 3 about axis 3).
    p_prime = r[0] + ax[0].rotate(-q1, (p_wrist - r[0])[:, None, :])                  # (N, 2, 3)
    w3 = w[2]
    u, vv = c - r[2], r[1] - r[2]
    u_p, v_p = u - w3 * (w3 @ u), vv - w3 * (w3 @ vv)
    delta_sq = _dot(p_prime - r[1], p_prime - r[1]) - (w3 @ (c - r[1])) ** 2
    kappa = (u_p @ u_p + v_p @ v_p - delta_sq) / (2.0 * np.linalg.norm(u_p) * np.linalg.norm(v_p))
    reach3 = np.abs(kappa) <= 1.0 + REACH_SLACK
    theta0 = math.atan2(w3 @ _cross(u_p, v_p), u_p @ v_p)
    spread3 = np.arccos(np.clip(kappa, -1.0, 1.0))
    q3 = np.stack([theta0 - spread3, theta0 + spread3], axis=2)                        # (N, 2, 2)

    # q2: rotate e^{xi3 q3} c about axis 2 onto p' (subproblem 1).
    p3 = r[2] + ax[2].rotate(q3, c - r[2])          # (N, 2, 2, 3)
    q2 = ax[1].angle(p3 - r[1], p_prime[:, :, None, :] - r[1])                   # (N, 2, 2)

    q1_b = np.broadcast_to(q1[:, :, None], q3.shape)
    R_arm = ax[0].matrix(q1_b) @ ax[1].matrix(q2) @ ax[2].matrix(q3)
    R_wrist = np.swapaxes(R_arm, -1, -2) @ R_target[:, None, None] @ solver.X_BE0[:3, :3].T  # (N,2,2,3,3)

    # q4, q5: e^{w4 q4} e^{w5 q5} w6 = d (subproblem 2), two roots; then q6 (subproblem 1).
    w4, w5, w6 = w[3], w[4], w[5]
    d = R_wrist @ w6                                                                  # (N, 2, 2, 3)
    c45 = w4 @ w5
    alpha = (c45 * (w5 @ w6) - d @ w4) / (c45**2 - 1.0)
    beta = (c45 * (d @ w4) - w5 @ w6) / (c45**2 - 1.0)
    n45 = _cross(w4, w5)
    gamma = np.sqrt(np.clip((1.0 - alpha**2 - beta**2 - 2 * alpha * beta * c45) / (n45 @ n45), 0.0, None))
    gammas = np.stack([gamma, -gamma], axis=-1)                                       # (N, 2, 2, 2)
    z = (alpha[..., None, None] * w4 + beta[..., None, None] * w5 + gammas[..., None] * n45)
    d_b = np.broadcast_to(d[..., None, :], z.shape)
    q4 = ax[3].angle(z, d_b)
    q5 = ax[4].angle(w6, z)
    wrist_singular = np.linalg.norm(d_b @ ax[3].K.T, axis=-1) < SINGULAR_TOLERANCE
    seed_shape = (n, 1, 1, 1)
    seed4, seed6 = seeds[:, 3].reshape(seed_shape), seeds[:, 5].reshape(seed_shape)
    if wrist_singular.any():
        q4 = np.where(wrist_singular, seed4, q4)
        q5 = np.where(wrist_singular, ax[4].angle(w6, ax[3].rotate(-q4, d_b)), q5)
    R45 = ax[3].matrix(q4) @ ax[4].matrix(q5)
    n6 = _unit(_cross(w6, [1.0, 0.0, 0.0]) if abs(w6[0]) < 0.9 else _cross(w6, [0.0, 1.0, 0.0]))
    R_wrist_b = np.broadcast_to(R_wrist[..., None, :, :], R45.shape)
    target_n6 = np.swapaxes(R45, -1, -2) @ R_wrist_b @ n6
    q6 = ax[5].angle(n6, target_n6)
    if wrist_singular.any():
        # Only q4 + sigma q6 is fixed: split the change nearest the seed.
        sigma = np.sign(ax[4].rotate(q5, w6) @ w4)
        step = _wrap(sigma * (q6 - seed6))
        q4 = np.where(wrist_singular, seed4 + step / 2.0, q4)
        q6 = np.where(wrist_singular, q6 - sigma * step / 2.0, q6)

    shape = (n, 2, 2, 2)
    Q = np.stack([np.broadcast_to(x, shape) for x in (q1[:, :, None, None], q2[..., None], q3[..., None],
                                                      q4, q5, q6)], axis=-1).reshape(n, BRANCHES, 6)
    reachable = np.broadcast_to((reach1[:, None] & reach3)[..., None, None], shape).reshape(n, BRANCHES)
    labels = _labels(solver, Q, p_wrist)
    return BranchSolutions(_wrap(Q), reachable, labels)


def _labels(solver: AnalyticSolver, Q: np.ndarray, p_wrist: np.ndarray) -> np.ndarray:
    """Branch names: shoulder front/back, elbow up/down, wrist flip/noflip, per (N, 8) branch.

    Front: the wrist centre is on the side of axis 1 it is on at q = 0. Up: the elbow (on axis 3) is
    above the shoulder (axis 2) to wrist-centre line. Flip: q5 < 0.
    """
    w, r, c = solver.axes, solver.points, solver.wrist_centre
    axis1, axis2 = _Axis.of(w[0]), _Axis.of(w[1])
    forward0 = (c - r[0]) - w[0] * (w[0] @ (c - r[0]))
    forward = axis1.rotate(Q[..., 0], forward0)
    front = _dot(forward, p_wrist[:, None, :] - r[0]) >= 0.0
    shoulder = r[0] + axis1.rotate(Q[..., 0], r[1] - r[0])
    elbow = r[0] + axis1.rotate(Q[..., 0], r[1] - r[0] + axis2.rotate(Q[..., 1], r[2] - r[1]))
    line = _unit_rows(p_wrist[:, None, :] - shoulder)
    offset = elbow - shoulder
    up = (offset - line * _dot(offset, line)[..., None])[..., 2] >= 0.0
    names = np.empty(Q.shape[:-1], dtype=object)
    for index in np.ndindex(names.shape):
        names[index] = (f"shoulder {'front' if front[index] else 'back'}, elbow {'up' if up[index] else 'down'}, "
                        f"wrist {'flip' if Q[index][4] < 0 else 'noflip'}")
    return names


def configuration_labels_of(robot, solver: AnalyticSolver, Q: np.ndarray) -> list[str]:
    """The branch label of each configuration Q (N, 6) of a robot the closed form fits (from any IK
    method): its wrist centre by our FK, then ``_labels``."""
    X = robot.fk_batch(Q)
    c_in_end = solver.X_BE0[:3, :3].T @ (solver.wrist_centre - solver.X_BE0[:3, 3])
    p_wrist = np.einsum("nij,j->ni", X[:, :3, :3], c_in_end) + X[:, :3, 3]
    return list(_labels(solver, _wrap(Q)[:, None, :], p_wrist)[:, 0])


def _unit_rows(v: np.ndarray) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0.0, norm, 1.0)


def solve_analytic(robot, target: IkTarget, q_seed: np.ndarray) -> IkResult:
    """Closed-form IK of one target: every in-limit branch, verified by our FK, nearest the seed first."""
    return solve_analytic_batch(robot, target.X_BE[None], q_seed[None], target.kind)[0]


def solve_analytic_batch(robot, X_targets: np.ndarray, seeds: np.ndarray, kind: str = FULL_POSE) -> list[IkResult]:
    """Closed-form IK of N targets (N, 4, 4) with seeds (N, 6), vectorised; one IkResult each."""
    solver = analytic_solver_for(robot)
    n = X_targets.shape[0]
    if not solver.applicable or kind != FULL_POSE:
        reason = solver.reason or f"the closed form solves full poses only, not {kind!r} targets"
        return [_failure(robot, X_targets[i], seeds[i], reason) for i in range(n)]
    branches = solve_branches(solver, X_targets, seeds)
    limits = robot.limits
    X_branches = robot.fk_batch(branches.Q.reshape(-1, 6)).reshape(n, BRANCHES, 4, 4)
    position_error = np.linalg.norm(X_branches[..., :3, 3] - X_targets[:, None, :3, 3], axis=-1)
    R_error = np.swapaxes(X_branches[..., :3, :3], -1, -2) @ X_targets[:, None, :3, :3]
    rotation_error = rotation_angle(R_error)
    strict = (position_error <= POSITION_TOLERANCE) & (rotation_error <= ROTATION_TOLERANCE)
    candidates, valid = limit_variants(branches.Q, np.ones(6, dtype=bool), limits.q_min, limits.q_max)
    variants = candidates.shape[2]
    valid &= strict[..., None]
    order, keep = distinct_order_batch(candidates.reshape(n, -1, 6), valid.reshape(n, -1), seeds)
    flat = candidates.reshape(n, -1, 6)
    results = []
    for i in range(n):
        chosen = order[i][keep[i]]
        if chosen.size == 0:
            results.append(_failure_for_target(robot, branches, i, position_error[i], rotation_error[i], strict[i]))
            continue
        branch_of = chosen // variants
        found = tuple(
            Solution(q, e_p, e_r, label)
            for q, e_p, e_r, label in zip(flat[i, chosen], position_error[i, branch_of].tolist(),
                                          rotation_error[i, branch_of].tolist(), branches.labels[i, branch_of])
        )
        best = found[0]
        results.append(IkResult(True, best.q, best.position_error, best.rotation_error, 1, "analytic", "", found,
                                details={"branch": best.branch,
                                         "branches_reachable": int(branches.reachable[i].sum())}))
    return results


def _failure_for_target(robot, branches, i, position_error, rotation_error, strict) -> IkResult:
    """Target i has no exact in-limit branch: the best attempt and why."""
    best_branch = int(np.argmin(position_error + rotation_error))
    if not branches.reachable[i].any():
        reason = "target out of reach: no closed-form branch reaches the wrist centre"
    elif not strict.any():
        reason = "no branch verified by FK (numerical failure near a singularity)"
    else:
        reason = _limit_reason(robot, branches.Q[i][strict])
    return IkResult(False, branches.Q[i, best_branch], float(position_error[best_branch]),
                    float(rotation_error[best_branch]), 1, "analytic", reason, (),
                    details={"branches_reachable": int(branches.reachable[i].sum())})


def closest_limit_violation(robot, Q: np.ndarray) -> tuple[int, float, float]:
    """Of configurations Q (B, 6), each joint shifted by the multiple of 2 pi that brings it nearest
    its limits, the one nearest them: (the joint that violates them most there, its value [rad], by
    how much [rad])."""
    limits = robot.limits
    turns = int(np.ceil(np.abs(np.concatenate([limits.q_min, limits.q_max])).max() / TWO_PI)) + 1
    values = _wrap(Q)[..., None] + TWO_PI * np.arange(-turns, turns + 1)                  # (B, 6, S)
    excess = np.maximum(np.maximum(limits.q_min[:, None] - values, values - limits.q_max[:, None]), 0.0)
    shift = excess.argmin(axis=-1)                                                         # (B, 6)
    nearest = excess.min(axis=-1)
    b = int(np.argmin(nearest.max(axis=-1)))
    j = int(np.argmax(nearest[b]))
    return j, float(values[b, j, shift[b, j]]), float(nearest[b, j])


def _limit_reason(robot, Q_strict: np.ndarray) -> str:
    """Why exact solutions were rejected: the smallest joint-limit violation among them and their 2 pi shifts."""
    j, _, excess = closest_limit_violation(robot, Q_strict)
    return (f"reachable only outside the joint limits: {len(Q_strict)} exact branch(es); the closest violates "
            f"{robot.joint_names[j]} by {excess:.4g} rad")


def _failure(robot, X_target: np.ndarray, seed: np.ndarray, reason: str) -> IkResult:
    """A result for a robot or target the closed form does not fit: the seed, with its errors."""
    position_error, rotation_error = pose_errors(robot.fk(seed), IkTarget(X_target))
    return IkResult(False, np.array(seed, dtype=float), position_error, rotation_error, 0, "analytic", reason)
