"""Closed-form IK for 6R arms of two families, from the DH table itself: a spherical wrist (the last
three axes meet: ``pipeline.model.ik.closed_form``) and three parallel axes (axes 2, 3, 4 parallel, axes 5
and 6 meeting: the UR family, ``pipeline.model.ik.three_parallel``).

Nothing is hand-coded per robot. The joint screws are read off our FK at q = 0 (product of
exponentials, ``X_BE(q) = e^{xi_1 q_1} ... e^{xi_6 q_6} X_BE(0)``); the compiled solvers (Paden-Kahan
subproblems) take them from here, so standard and modified DH tables, signs and offsets are all
handled alike. This module derives that geometry (or says why an arm fits neither family) and turns
the solvers' arrays (one layout for both) into IkResults with named branches.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...files.branch_names import SPHERICAL_WRIST, THREE_PARALLEL
from . import closed_form, three_parallel
from .prebuilt import python_entry
from .result import FULL_POSE, TWO_PI, IkResult, IkTarget, Solutions, pose_errors

#: Axes closer than this [m] meet; directions closer than this [1] are parallel.
GEOMETRY_TOLERANCE = 1e-9


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

    ``family``: ``configurations.SPHERICAL_WRIST`` or ``THREE_PARALLEL``; ``axes`` (6, 3) unit joint
    axes and ``points`` (6, 3) points on them at q = 0, base frame [m]; ``wrist_centre`` c at q = 0 (the
    wrist centre, or where axes 5 and 6 meet); ``X_BE0`` the end pose at q = 0; ``geometry`` all of them
    packed for ``kernels`` (the family's compiled module); ``labels`` the branch names by label code.
    """

    applicable: bool
    reason: str = ""
    axes: np.ndarray | None = None
    points: np.ndarray | None = None
    wrist_centre: np.ndarray | None = None
    X_BE0: np.ndarray | None = None
    geometry: np.ndarray | None = None
    family: str = ""
    kernels: object = None
    labels: tuple[str, ...] = ()


def analytic_solver_for(robot) -> AnalyticSolver:
    """The closed-form solver of a robot, derived from its DH table once (cached on the robot)."""
    return robot._analytic_solver


def derive_solver(robot) -> AnalyticSolver:
    """The closed-form solver of a robot (or why it fits neither family), from its DH table."""
    spec = robot.spec
    revolute = sum(j.is_revolute for j in spec.joints)
    if spec.dof != 6 or revolute != 6:
        return AnalyticSolver(False, f"{spec.name}: the closed form needs 6 revolute joints (has {spec.dof} joints, "
                                     f"{revolute} of them revolute)")
    frames, X_BE0 = robot.joint_frames(np.zeros(6))
    axes = frames[:, :3, 2] * np.array([j.sign for j in spec.joints])[:, None]
    points = frames[:, :3, 3].copy()
    reason = _not_spherical(spec.name, axes, points)
    if not reason:
        family, kernels, labels, meeting = SPHERICAL_WRIST, closed_form, LABELS, 3      # axes 4 and 5 meet at c
    elif _not_three_parallel(axes, points):
        return AnalyticSolver(False, reason)
    else:
        family, kernels, labels, meeting = THREE_PARALLEL, three_parallel, THREE_PARALLEL_LABELS, 4   # axes 5 and 6
    centre, _ = _closest_points(points[meeting], axes[meeting], points[meeting + 1], axes[meeting + 1])
    return AnalyticSolver(True, "", axes, points, centre, X_BE0, kernels.pack_geometry(axes, points, centre, X_BE0),
                          family, kernels, labels)


def _not_spherical(name: str, axes: np.ndarray, points: np.ndarray) -> str:
    """Why the axes (6, 3) and points (6, 3) at q = 0 are no spherical-wrist arm ("" when they are one)."""
    if np.linalg.norm(_cross(axes[3], axes[4])) < GEOMETRY_TOLERANCE:
        return f"{name}: axes 4 and 5 are parallel: no spherical wrist"
    centre, gap = _closest_points(points[3], axes[3], points[4], axes[4])
    offset6 = centre - points[5]
    distance6 = float(np.linalg.norm(offset6 - axes[5] * _dot(axes[5], offset6)))
    if gap > GEOMETRY_TOLERANCE or distance6 > GEOMETRY_TOLERANCE:
        return (f"{name}: axes 4, 5, 6 do not meet in one point (gaps {gap:.3g} m, {distance6:.3g} m): no spherical "
                "wrist, nor axes 2, 3, 4 parallel with axes 5 and 6 meeting (the UR family)")
    if np.linalg.norm(_cross(axes[1], axes[2])) > GEOMETRY_TOLERANCE:
        return f"{name}: axes 2 and 3 are not parallel"
    if np.linalg.norm(_cross(axes[0], axes[1])) < GEOMETRY_TOLERANCE:
        return f"{name}: axes 1 and 2 are parallel"
    return ""


def _not_three_parallel(axes: np.ndarray, points: np.ndarray) -> bool:
    """Whether the arm is not of the UR family: axes 2, 3, 4 parallel, axis 1 not parallel to them,
    axes 5 and 6 meeting and neither parallel to axis 4, and non-zero upper arm and forearm."""
    n = axes[1]
    parallel = np.linalg.norm(_cross(n, axes[2:4]), axis=-1) < GEOMETRY_TOLERANCE
    apart = [np.linalg.norm(_cross(axes[i], axes[j])) > GEOMETRY_TOLERANCE for i, j in ((0, 1), (4, 5), (1, 4))]
    if not (parallel.all() and all(apart)):
        return True
    _, gap = _closest_points(points[4], axes[4], points[5], axes[5])
    links = [np.linalg.norm(_cross(n, points[i + 1] - points[i])) for i in (1, 2)]
    return gap > GEOMETRY_TOLERANCE or min(links) < GEOMETRY_TOLERANCE


#: Branch names by label code: closed_form's FRONT | UP | FLIP bits, three_parallel's RIGHT | UP | WRIST_UP.
LABELS = tuple(", ".join((f"shoulder {'front' if code & closed_form.FRONT else 'back'}",
                          f"elbow {'up' if code & closed_form.UP else 'down'}",
                          f"wrist {'flip' if code & closed_form.FLIP else 'noflip'}")) for code in range(8))
THREE_PARALLEL_LABELS = tuple(", ".join((f"shoulder {'right' if code & three_parallel.RIGHT else 'left'}",
                                         f"elbow {'up' if code & three_parallel.UP else 'down'}",
                                         f"wrist {'up' if code & three_parallel.WRIST_UP else 'down'}"))
                              for code in range(8))


@dataclass(frozen=True, eq=False)
class BranchSolutions:
    """Raw closed-form branches of one target: Q (B, 6) in (-pi, pi], reachable (B,), labels (B,)."""

    Q: np.ndarray
    reachable: np.ndarray
    labels: tuple[str, ...]


def solve_branches(robot, solver: AnalyticSolver, X_target: np.ndarray, seed: np.ndarray) -> BranchSolutions:
    """Every closed-form branch of one target X (4, 4) [m], in limits or not; the seed breaks singular ties."""
    Q, reachable = solver.kernels.raw_branches(solver.geometry, X_target, seed, robot.limits.q_min[0],
                                               robot.limits.q_max[0])
    return BranchSolutions(Q, reachable, tuple(configuration_labels_of(robot, solver, Q)))


def configuration_labels_of(robot, solver: AnalyticSolver, Q: np.ndarray) -> list[str]:
    """The branch label of each configuration Q (N, 6) of a robot the closed form fits (from any IK
    method): its wrist centre by our FK, then the family's ``label_code``."""
    Q = np.ascontiguousarray(Q, dtype=float)
    codes = np.empty(len(Q), dtype=np.int64)
    solver.kernels.label_codes(solver.geometry, robot._chain, Q, codes)
    return [solver.labels[code] for code in codes.tolist()]


def solve_analytic(robot, target: IkTarget, q_seed: np.ndarray) -> IkResult:
    """Closed-form IK of one target: every in-limit branch, verified by our FK, nearest the seed first."""
    solver = analytic_solver_for(robot)
    if not solver.applicable or target.kind != FULL_POSE:
        return solve_analytic_batch(robot, target.X_BE[None], q_seed[None], target.kind)[0]
    return _solve_one(robot, solver, target.X_BE, q_seed)


def solve_analytic_unchecked(robot, X_target, q_seed) -> IkResult | None:
    """``solve_analytic`` of a full pose straight from the caller's arrays (float64 of any layout: a
    pose from Drake's ``GetAsMatrix4()`` is Fortran-ordered), which the kernel checks itself: the fast
    path of single calls. None when the closed form does not fit the arm, or when the pose or seed is
    not one the kernel takes (not a float64 array, or refused): the caller then checks them and words the
    error."""
    solver = analytic_solver_for(robot)
    if not solver.applicable:
        return None
    try:
        return _solve_one(robot, solver, X_target, robot._q_middle if q_seed is None else q_seed)
    except (TypeError, ValueError):
        return None


def nearest_analytic(robot, X_target, q_seed) -> tuple[bool, np.ndarray | None]:
    """(whether the closed form fits the arm, the in-limit solution of the full pose X_target (4, 4) [m] nearest
    q_seed (6,) [rad] or None when none is): ``solve_analytic_unchecked``'s first solution without building its
    IkResult (a planner's many single poses: a fifth of the call). A pose or seed the kernel refuses counts as
    not fitting (the caller's slower path then checks them)."""
    solver = analytic_solver_for(robot)
    if not solver.applicable:
        return False, None
    out = np.empty((SINGLE_CAPACITY, closed_form.SOLUTION_COLUMNS))
    try:
        numbers = python_entry(solver.kernels.solve_one)(solver.geometry, robot._chain, robot._limit_rows, X_target,
                                                         q_seed, out)
    except (TypeError, ValueError):
        return False, None
    count = numbers[closed_form.COUNT]
    if count > SINGLE_CAPACITY:                        # unsorted beyond the buffer: the full call sorts them
        return True, _solve_one(robot, solver, X_target, q_seed).q
    return True, (out[0, :6].copy() if count > 0 else None)


def _solve_one(robot, solver: AnalyticSolver, X: np.ndarray, seed: np.ndarray) -> IkResult:
    out = np.empty((SINGLE_CAPACITY, closed_form.SOLUTION_COLUMNS))
    solve_one = python_entry(solver.kernels.solve_one)
    numbers = solve_one(solver.geometry, robot._chain, robot._limit_rows, X, seed, out)
    if numbers[closed_form.COUNT] > SINGLE_CAPACITY:
        out = np.empty((int(numbers[closed_form.COUNT]), closed_form.SOLUTION_COLUMNS))
        numbers = solve_one(solver.geometry, robot._chain, robot._limit_rows, X, seed, out)
    return _result(robot, solver.labels, out, numbers, X)


#: Rows of the solution buffer of one target: enough for every branch and its 2 pi variants on most
#: arms (a call that finds more is repeated with a buffer that holds them all).
SINGLE_CAPACITY, BATCH_CAPACITY = 64, 32


def solve_analytic_batch(robot, X_targets: np.ndarray, seeds: np.ndarray, kind: str = FULL_POSE) -> list[IkResult]:
    """Closed-form IK of N targets (N, 4, 4) with seeds (N, 6), compiled; one IkResult each (a failure with the
    reason on arms of neither family: ``pipeline.model.ik.solve_closed_form_batch`` gives those to EAIK)."""
    solver = analytic_solver_for(robot)
    if not solver.applicable or kind != FULL_POSE:
        reason = solver.reason or f"the closed form solves full poses only, not {kind!r} targets"
        return [_failure(robot, X_targets[i], seeds[i], reason) for i in range(X_targets.shape[0])]
    out = np.empty((len(X_targets), BATCH_CAPACITY, closed_form.SOLUTION_COLUMNS))
    info = np.empty((len(X_targets), closed_form.INFO))
    python_entry(solver.kernels.solve_batch)(solver.geometry, robot._chain, robot._limit_rows, X_targets, seeds, out,
                                             info)
    results = []
    for n, X in enumerate(X_targets):
        if info[n, closed_form.COUNT] > BATCH_CAPACITY:
            results.append(solve_analytic(robot, IkTarget(X), seeds[n]))
        else:
            results.append(_result(robot, solver.labels, out[n], info[n].tolist(), X))
    return results


def _result(robot, labels: tuple[str, ...], out: np.ndarray, numbers, X_target: np.ndarray) -> IkResult:
    """An IkResult from a closed-form kernel's ``out`` and ``info`` entries (``numbers``, a sequence) of
    one target, its branches named by ``labels`` (out is the caller's own buffer: the result keeps views
    of it)."""
    count, reachable = int(numbers[closed_form.COUNT]), int(numbers[closed_form.REACHABLE])
    if count == 0:
        q = out[0, :6].copy()
        position_error, rotation_error = pose_errors(robot.fk(q), IkTarget(X_target))
        return IkResult(False, q, position_error, rotation_error, 1, "analytic", _failure_reason(robot, numbers), (),
                        details={"branches_reachable": reachable})
    return IkResult(True, out[0, :6], numbers[closed_form.FIRST_POSITION_ERROR],
                    numbers[closed_form.FIRST_ROTATION_ERROR], 1, "analytic", "", Solutions(out[:count], labels, 6),
                    details={"branches_reachable": reachable, "branch": labels[int(numbers[closed_form.FIRST_CODE])]})


def _failure_reason(robot, info) -> str:
    """Why no branch is left: out of reach, not verified by FK, or only outside the limits (the joint
    and the true amount of the smallest violation of any exact branch and its 2 pi shifts)."""
    if info[closed_form.REACHABLE] == 0:
        return "target out of reach: no closed-form branch reaches the wrist centre"
    if info[closed_form.VERIFIED] == 0:
        return "no branch verified by FK (numerical failure near a singularity)"
    j = int(info[closed_form.VIOLATING_JOINT])
    return (f"reachable only outside the joint limits: {int(info[closed_form.VERIFIED])} exact branch(es); the "
            f"closest violates {robot.joint_names[j]} by {info[closed_form.VIOLATION]:.4g} rad")


def closest_limit_violation(robot, Q: np.ndarray) -> tuple[int, float, float]:
    """Of configurations Q (B, 6), each joint shifted by the multiple of 2 pi that brings it nearest
    its limits, the one nearest them: (the joint that violates them most there, its value [rad], by
    how much [rad]). Two candidate shifts per joint, whatever the range (no enumeration)."""
    limits = robot.limits
    finite = np.isfinite(limits.q_max - limits.q_min)
    top = np.where(finite, limits.q_max, 0.0)
    below = Q + TWO_PI * np.floor((top - Q) / TWO_PI)              # the highest shift not above q_max
    under = np.where(finite, np.maximum(limits.q_min - below, 0.0), 0.0)
    over = np.where(finite, below + TWO_PI - top, np.inf)           # the lowest shift above it
    nearest = np.minimum(under, over)
    values = np.where(under <= over, np.where(finite, below, Q), below + TWO_PI)
    b = int(np.argmin(nearest.max(axis=-1)))
    j = int(np.argmax(nearest[b]))
    return j, float(values[b, j]), float(nearest[b, j])


def _failure(robot, X_target: np.ndarray, seed: np.ndarray, reason: str) -> IkResult:
    """A result for a robot or target the closed form does not fit: the seed, with its errors."""
    position_error, rotation_error = pose_errors(robot.fk(seed), IkTarget(X_target))
    return IkResult(False, np.array(seed, dtype=float), position_error, rotation_error, 0, "analytic", reason)
