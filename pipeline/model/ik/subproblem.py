"""Closed-form IK, every branch, for 6R arms the spherical-wrist solver does not fit, by EAIK.

EAIK (``eaik.IK_HP.HPRobot``, compiled C++; Ostermeier, Kuelz and Althoff, "Automatic Geometric
Decomposition for Analytical Inverse Kinematics", RA-L 2025) recognises the arm's kinematic family
from its joint axes and solves it by Paden-Kahan subproblems: the Universal Robots family (UR3, UR5,
UR10: axes 2, 3, 4 parallel, EAIK's "6R-THREE_INNER_PARALLEL"), spherical wrists and more.

The model handed to EAIK is read off our FK at q = 0, as ``analytic.py`` does: H (6, 3) the joint
axes (z of each joint frame times the joint's sign), P (7, 3) the offsets between consecutive axis
points (P[0] from the base origin to axis 1's point, P[6] from axis 6's point to the end frame's
origin), base frame [m]. Our FK is ``X_BE(q) = e^{xi_1 q_1} ... e^{xi_6 q_6} X_BE(0)``; EAIK's end
frame has the base frame's orientation at q = 0, so it is asked for ``[R R_BE(0)^T, p]`` when we
want ``[R, p]``.

Every EAIK answer is checked by our FK (position <= ``POSITION_TOLERANCE``, rotation <=
``ROTATION_TOLERANCE``), whether EAIK calls it exact or least-squares (``is_LS``): it calls exact
answers on the workspace boundary (elbow stretched) least-squares, and its least-squares answers for
an unreachable branch miss the target and are dropped. At a wrist singularity (axes 4 and 6
aligned, |q5| < ~1e-6 rad) EAIK returns a least-squares answer with q6 = 0 that reaches the position
but not the orientation: q6 is then turned about axis 6 by the rotation left (subproblem 1) and the
answer kept if our FK verifies it (one member of the singular family, not the one nearest the seed).
Where no answer of a target is exact (the UR arms' upright pose, say: elbow stretched, axes 4 and 6
aligned and a double root in q1 at once), the target is solved again with joint 1 fixed at each q1
EAIK answered (its 5R decomposition) before it counts as out of reach.

Since the UR family has a compiled closed form of its own (``three_parallel``), ``analytic`` sends
EAIK only the arms of neither compiled family; this module stays the independent check of both
(tests/model/test_ik_ur.py, tests/model/test_ik_subproblem.py).

Branch labels ("shoulder X, elbow Y, wrist Z"), from the joint axes a_i and points r_i of each
solution (our FK; a_i with the joint's positive direction):

* arms with a spherical wrist: the compiled solver's labels (``analytic.configuration_labels_of``);
* arms with axes 2, 3, 4 parallel (the UR family), with p_w the wrist point (the foot on axis 6 of
  the common perpendicular of axes 5 and 6; where they meet, for UR arms), ``three_parallel``'s
  definitions computed here apart, in NumPy (K = a_2 . (p_w - r_1), the same for every q):
  - shoulder ``right`` if K a_1 . (a_2 x (p_w - r_1)) >= 0 (K = 0: its sign taken as +), else ``left``;
  - elbow ``up`` if a_2 . ((r_4 - r_2) x (r_3 - r_2)) has the sign of a_1 . (a_2 x (p_w - r_1)), else
    ``down``;
  - wrist ``up`` if a_5 . (a_4 x a_6) >= 0, else ``down``;
* other arms: "" (no named configurations).
"""

from __future__ import annotations

import os
import weakref
from dataclasses import dataclass

import numpy as np
from eaik.IK_HP import HPRobot

from ...files.branch_names import SPHERICAL_WRIST
from .analytic import (
    GEOMETRY_TOLERANCE,
    _cross,
    _dot,
    _failure,
    analytic_solver_for,
    closest_limit_violation,
    configuration_labels_of,
)
from .result import (
    FULL_POSE,
    POSITION_TOLERANCE,
    ROTATION_TOLERANCE,
    TWO_PI,
    IkResult,
    Solution,
    distinct_order_batch,
    limit_variants,
    rotation_angle,
)

#: Threads EAIK spreads a batch of targets over.
WORKER_THREADS = os.cpu_count() or 1
#: Label styles: the spherical-wrist solver's, the three-parallel-axes one of this module, none.
SPHERICAL, THREE_PARALLEL, UNNAMED = "spherical wrist", "three parallel axes", ""


def wrap(Q: np.ndarray) -> np.ndarray:
    """Angles [rad] into [-pi, pi)."""
    return (Q + np.pi) % TWO_PI - np.pi


@dataclass(frozen=True, eq=False)
class SubproblemSolver:
    """EAIK's solver of one robot, or why the robot does not fit it (``applicable`` False).

    ``family``: EAIK's name for the arm's kinematic family; ``eaik``: the ``HPRobot`` of ``H``, ``P``
    (``eaik_parameters``); ``R_BE0``: the end frame's orientation at q = 0; ``axis6_end``: axis 6 in
    the end frame (constant); ``labels``: the label style; ``wrist_point_end``: p_w in the end frame
    [m] (three parallel axes only).
    """

    applicable: bool
    reason: str = ""
    family: str = ""
    eaik: object = None
    H: np.ndarray | None = None
    P: np.ndarray | None = None
    R_BE0: np.ndarray | None = None
    axis6_end: np.ndarray | None = None
    labels: str = UNNAMED
    wrist_point_end: np.ndarray | None = None


_SOLVERS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def subproblem_solver_for(robot) -> SubproblemSolver:
    """The (cached) EAIK solver of a robot, derived from its DH table."""
    if robot not in _SOLVERS:
        _SOLVERS[robot] = _derive_solver(robot)
    return _SOLVERS[robot]


def eaik_parameters(robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EAIK's model of a 6R robot: H (6, 3) unit joint axes, P (7, 3) offsets [m], and X_BE(0) (4, 4)."""
    frames, X_BE0 = robot.joint_frames(np.zeros(robot.dof))
    H = frames[:, :3, 2] * np.array([j.sign for j in robot.spec.joints])[:, None]
    points = frames[:, :3, 3]
    P = np.vstack([points[0], np.diff(points, axis=0), X_BE0[:3, 3] - points[-1]])
    return H, P, X_BE0


def _derive_solver(robot) -> SubproblemSolver:
    spec = robot.spec
    if spec.dof != 6 or not all(j.is_revolute for j in spec.joints):
        return SubproblemSolver(False, f"{spec.name}: EAIK's closed form needs 6 revolute joints (has {spec.dof})")
    H, P, X_BE0 = eaik_parameters(robot)
    eaik = HPRobot(H, P)
    family = eaik.getKinematicFamily()
    if not eaik.hasKnownDecomposition():
        return SubproblemSolver(False, f"{spec.name}: EAIK knows no closed-form decomposition of this arm ({family})",
                                family)
    R_BE0 = X_BE0[:3, :3]
    labels, wrist_point = _label_style(robot, H, P, X_BE0)
    return SubproblemSolver(True, "", family, eaik, H, P, R_BE0, R_BE0.T @ H[5], labels, wrist_point)


def _label_style(robot, H: np.ndarray, P: np.ndarray, X_BE0: np.ndarray) -> tuple[str, np.ndarray | None]:
    """How solutions of this arm are labelled, and (three parallel axes) p_w in the end frame [m]."""
    if analytic_solver_for(robot).family == SPHERICAL_WRIST:
        return SPHERICAL, None
    parallel = [np.linalg.norm(np.cross(H[i], H[i + 1])) < GEOMETRY_TOLERANCE for i in range(5)]
    if not (parallel[1] and parallel[2]) or parallel[0] or parallel[4]:
        return UNNAMED, None
    points = np.cumsum(P, axis=0)
    n = np.cross(H[4], H[5])
    t6 = np.cross(points[5] - points[4], H[4]) @ n / (n @ n)     # foot on axis 6 of the common perpendicular
    return THREE_PARALLEL, X_BE0[:3, :3].T @ (points[5] + t6 * H[5] - X_BE0[:3, 3])


def branch_labels(robot, solver: SubproblemSolver, Q: np.ndarray) -> np.ndarray:
    """The branch label of each configuration Q (M, 6) (the module docstring defines them) -> (M,) str."""
    if solver.labels == SPHERICAL:
        return np.array(configuration_labels_of(robot, analytic_solver_for(robot), Q), dtype=object)
    if solver.labels == UNNAMED or len(Q) == 0:
        return np.full(len(Q), "", dtype=object)
    frames, X = robot.joint_frames(Q)
    a = frames[..., :3, 2] * np.array([j.sign for j in robot.spec.joints])[:, None]
    r = frames[..., :3, 3]
    p_wrist = np.einsum("mij,j->mi", X[:, :3, :3], solver.wrist_point_end) + X[:, :3, 3]
    side = _dot(a[:, 0], _cross(a[:, 1], p_wrist - r[:, 0]))
    offset = _dot(a[:, 1], p_wrist - r[:, 0])
    right = np.where(np.abs(offset) > GEOMETRY_TOLERANCE, offset, 1.0) * side >= 0.0
    elbow_up = _dot(a[:, 1], _cross(r[:, 3] - r[:, 1], r[:, 2] - r[:, 1])) * side >= 0.0
    wrist_up = _dot(a[:, 4], _cross(a[:, 3], a[:, 5])) >= 0.0
    return np.array([f"shoulder {'right' if s else 'left'}, elbow {'up' if e else 'down'}, "
                     f"wrist {'up' if w else 'down'}" for s, e, w in zip(right, elbow_up, wrist_up)], dtype=object)


@dataclass(frozen=True, eq=False)
class _Answers:
    """EAIK's answers for N targets, padded to K: Q (N, K, 6) [rad], ``present`` and ``least_squares``
    (N, K) bool, and our FK's errors (N, K): ``position_error`` [m], ``rotation_error`` [rad]."""

    Q: np.ndarray
    present: np.ndarray
    least_squares: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray

    @property
    def strict(self) -> np.ndarray:
        return self.present & (self.position_error <= POSITION_TOLERANCE) & (self.rotation_error <= ROTATION_TOLERANCE)


def _eaik_poses(solver: SubproblemSolver, X_targets: np.ndarray) -> np.ndarray:
    """Our targets X (N, 4, 4) [m] as EAIK's end frame sees them: [R R_BE(0)^T, p]."""
    poses = X_targets.copy()
    poses[:, :3, :3] = X_targets[:, :3, :3] @ solver.R_BE0.T
    return poses


def _eaik_answers(solver: SubproblemSolver, poses: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """EAIK's answers for each pose (N, 4, 4) [m]: (Q (k, 6) [rad], is_LS (k,)) per pose."""
    found = [solver.eaik.IK(poses[0])] if len(poses) == 1 else solver.eaik.IK_batched(poses, WORKER_THREADS)
    return [(np.asarray(s.Q, dtype=float).reshape(-1, 6), np.asarray(s.is_LS, dtype=bool)) for s in found]


def _with_joint1_fixed(solver: SubproblemSolver, answers: tuple[np.ndarray, np.ndarray],
                       pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A pose's answers plus, for each q1 among them, those of the 5R arm with joint 1 fixed there.

    At the UR arms' upright pose (the elbow stretched, axes 4 and 6 aligned, the wrist point where
    q1 has a double root) EAIK's 6R answer misses by ~0.2 m and pi rad while its 5R decomposition
    with q1 fixed finds the configuration.
    """
    Q, least_squares = [answers[0]], [answers[1]]
    for q1 in np.unique(answers[0][:, 0]):
        fixed = HPRobot(solver.H, solver.P, fixed_axes=[(0, float(q1))])
        if fixed.hasKnownDecomposition():
            found = fixed.IK(pose)
            Q.append(np.asarray(found.Q, dtype=float).reshape(-1, 6))
            least_squares.append(np.asarray(found.is_LS, dtype=bool))
    return np.concatenate(Q), np.concatenate(least_squares)


def _padded(found: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-pose answers as Q (N, K, 6) [rad] (0 where absent), present (N, K), least_squares (N, K)."""
    width = max([len(Q) for Q, _ in found] + [1])
    Q = np.zeros((len(found), width, 6))
    present = np.zeros((len(found), width), dtype=bool)
    least_squares = np.zeros((len(found), width), dtype=bool)
    for i, (Q_i, least_squares_i) in enumerate(found):
        k = len(Q_i)
        Q[i, :k], least_squares[i, :k] = Q_i, least_squares_i
        present[i, :k] = np.isfinite(Q_i).all(axis=1)
    return np.where(present[..., None], Q, 0.0), present, least_squares


def _errors(robot, Q: np.ndarray, X_targets: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Our FK's rotation matrices (N, K, 3, 3) at Q (N, K, 6), position [m] and rotation [rad] errors (N, K)."""
    X = robot.fk_batch(Q.reshape(-1, 6)).reshape(*Q.shape[:2], 4, 4)
    position_error = np.linalg.norm(X[..., :3, 3] - X_targets[:, None, :3, 3], axis=-1)
    rotation_error = rotation_angle(np.swapaxes(X[..., :3, :3], -1, -2) @ X_targets[:, None, :3, :3])
    return X[..., :3, :3], position_error, rotation_error


def _checked(robot, solver: SubproblemSolver, found: list, X_targets: np.ndarray) -> _Answers:
    """The answers with our FK's errors, the last joint settled where only the orientation is off."""
    Q, present, least_squares = _padded(found)
    R, position_error, rotation_error = _errors(robot, Q, X_targets)
    settle = present & (position_error <= POSITION_TOLERANCE) & (rotation_error > ROTATION_TOLERANCE)
    if settle.any():
        rows, cols = np.nonzero(settle)
        Q[rows, cols, 5] += _last_joint_turn(solver, R[rows, cols], X_targets[rows, :3, :3])
        _, position_error[rows, cols], rotation_error[rows, cols] = (
            e[:, 0] for e in _errors(robot, Q[rows, cols][:, None], X_targets[rows]))
    return _Answers(Q, present, least_squares, position_error, rotation_error)


def _answers(robot, solver: SubproblemSolver, X_targets: np.ndarray) -> _Answers:
    """EAIK's answers checked by our FK; where none is exact, joint 1 fixed at each answer's q1 too."""
    poses = _eaik_poses(solver, X_targets)
    found = _eaik_answers(solver, poses)
    answers = _checked(robot, solver, found, X_targets)
    stuck = np.nonzero(answers.present.any(axis=1) & ~answers.strict.any(axis=1))[0]
    if stuck.size == 0:
        return answers
    for i in stuck:
        found[i] = _with_joint1_fixed(solver, found[i], poses[i])
    return _checked(robot, solver, found, X_targets)


def _last_joint_turn(solver: SubproblemSolver, R_reached: np.ndarray, R_target: np.ndarray) -> np.ndarray:
    """The turn of joint 6 [rad] that best takes orientations R_reached (M, 3, 3) to R_target (M, 3, 3).

    Turning q6 by delta post-multiplies R_BE by the rotation about axis 6 (end frame, ``axis6_end``)
    by delta; subproblem 1 finds the angle about that axis from a normal n to R_left n.
    """
    w = solver.axis6_end
    n = _cross(w, np.eye(3)[np.argmin(np.abs(w))])
    m = (np.swapaxes(R_reached, -1, -2) @ R_target) @ n
    return np.arctan2(_dot(w, _cross(n, m)), m @ n - (n @ w) * (m @ w))


def solve_subproblem_batch(robot, X_targets: np.ndarray, seeds: np.ndarray, kind: str = FULL_POSE) -> list[IkResult]:
    """EAIK's closed-form IK of N targets X (N, 4, 4) [m, base frame] with seeds (N, 6) [rad]: one
    IkResult each (method "analytic"), with every exact in-limit solution (each joint's in-limit 2 pi
    shifts too), nearest the seed first, checked by our FK and labelled (module docstring)."""
    solver = subproblem_solver_for(robot)
    n = X_targets.shape[0]
    if not solver.applicable or kind != FULL_POSE:
        reason = solver.reason or f"the closed form solves full poses only, not {kind!r} targets"
        return [_failure(robot, X_targets[i], seeds[i], reason) for i in range(n)]
    answers = _answers(robot, solver, X_targets)
    strict = answers.strict
    labels = np.full(strict.shape, "", dtype=object)
    labels[strict] = branch_labels(robot, solver, answers.Q[strict])
    _, distinct = distinct_order_batch(wrap(answers.Q), strict, seeds)
    candidates, valid, answer = _in_limit_variants(robot, answers.Q, strict, seeds)
    variants = candidates.shape[2]
    order, keep = distinct_order_batch(candidates.reshape(n, -1, 6), valid.reshape(n, -1), seeds)
    flat = candidates.reshape(n, -1, 6)
    results = []
    for i in range(n):
        details = {"solver": "eaik", "family": solver.family, "answers": int(answers.present[i].sum()),
                   "least_squares": int((answers.present[i] & answers.least_squares[i]).sum()),
                   "branches_reachable": int(distinct[i].sum())}
        chosen = order[i][keep[i]]
        if chosen.size == 0:
            results.append(_failure_for_target(robot, answers, i, X_targets[i], seeds[i], details))
            continue
        answer_of = answer[i, chosen // variants]
        found = tuple(Solution(q, e_p, e_r, label) for q, e_p, e_r, label in zip(
            flat[i, chosen], answers.position_error[i, answer_of].tolist(),
            answers.rotation_error[i, answer_of].tolist(), labels[i, answer_of]))
        best = found[0]
        results.append(IkResult(True, best.q, best.position_error, best.rotation_error, 1, "analytic", "", found,
                                details={"branch": best.branch, **details}))
    return results


def _in_limit_variants(robot, Q: np.ndarray, strict: np.ndarray, seeds: np.ndarray):
    """Every in-limit 2 pi shift of the exact answers Q[strict] (Q (N, K, 6) [rad]) -> candidates
    (N, M, V, 6), their mask (N, M, V) and answer index (N, M). ``result.limit_variants`` sees the
    exact answers only (a padding row of zeros would have 3^6 variants); a continuous joint takes the
    one value nearest the seed."""
    limits = robot.limits
    continuous = limits.continuous
    rows, cols = np.nonzero(strict)
    shifted, inside = limit_variants(Q[rows, cols], np.ones(6, dtype=bool), np.where(continuous, -np.pi, limits.q_min),
                                     np.where(continuous, np.pi, limits.q_max))
    if continuous.any():
        nearest = shifted + TWO_PI * np.round((seeds[rows, None, :] - shifted) / TWO_PI)
        shifted = np.where(continuous, nearest, shifted)
    width = max(int(strict.sum(axis=1).max(initial=0)), 1)
    candidates = np.zeros((len(Q), width) + shifted.shape[1:])
    valid = np.zeros((len(Q), width, shifted.shape[1]), dtype=bool)
    answer = np.zeros((len(Q), width), dtype=int)
    slots = np.cumsum(strict, axis=1)[rows, cols] - 1
    candidates[rows, slots], valid[rows, slots], answer[rows, slots] = shifted, inside, cols
    return candidates, valid, answer


def _failure_for_target(robot, answers: _Answers, i: int, X_target: np.ndarray, seed: np.ndarray,
                        details: dict) -> IkResult:
    """Target i has no exact in-limit solution: the best attempt and why."""
    present, strict = answers.present[i], answers.strict[i]
    if not present.any():
        return _failure(robot, X_target, seed, "target out of reach: EAIK returns no answer")
    misses = np.where(present, answers.position_error[i] + answers.rotation_error[i], np.inf)
    k = int(np.argmin(misses))
    error_p, error_r = float(answers.position_error[i, k]), float(answers.rotation_error[i, k])
    if strict.any():
        j, _, excess = closest_limit_violation(robot, answers.Q[i][strict])
        reason = (f"reachable only outside the joint limits: {int(strict.sum())} exact answer(s); the closest "
                  f"violates {robot.joint_names[j]} by {excess:.4g} rad")
    elif (present & ~answers.least_squares[i]).any():
        reason = (f"no EAIK answer verified by our FK (the best misses by {error_p:.3g} m, {error_r:.3g} rad; "
                  "numerical failure near a singularity)")
    else:
        reason = (f"target out of reach: EAIK finds only least-squares answers, the nearest missing by "
                  f"{error_p:.3g} m, {error_r:.3g} rad")
    return IkResult(False, wrap(answers.Q[i, k]), error_p, error_r, 1, "analytic", reason, (), details=details)
