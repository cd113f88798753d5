"""Compiled (Numba) closed-form IK of 6R arms with a spherical wrist: every branch, its 2 pi variants
inside the limits, verified by the compiled FK, nearest the seed first.

The method (``pipeline.model.ik.analytic`` derives the geometry and builds the results): the joint screws
at q = 0 (unit axes ``w`` and points ``r`` on them, base frame [m]), the wrist centre ``c`` and the
end pose ``X0`` at q = 0; Paden-Kahan subproblems then give

1. q1 from the wrist centre (two roots: shoulder front/back);
2. q3 from its distance to axis 2 (subproblem 3, two roots: elbow up/down), then q2 (subproblem 1);
3. q4, q5 from the wrist rotation (subproblem 2, two roots: wrist flip/noflip), then q6.

At a wrist singularity (axes 4 and 6 aligned) only q4 +- q6 is fixed: the split nearest the seed is
returned. At a shoulder singularity (the wrist centre on axis 1) q1 is free: the seed's q1 and
SHOULDER_SAMPLES values spread over q1's limits are tried, each with its four arm/wrist branches.

Every branch is verified by the compiled FK. Its 2 pi variants are the same pose (their errors are the
branch's); a variant with a value on a limit is verified again, as that value may have been moved
there. Limits are inclusive: a value within LIMIT_SLACK outside a limit is put on it. A joint whose range
spans more than WIDE_RANGE, four turns (or is continuous), gets one 2 pi variant, the one nearest the
seed, and the number of variants it has is counted rather than enumerated; narrower joints get every
variant, unless the branch has more than MAX_LISTED_VARIANTS of them in all (a UR arm's +-360 deg
ranges: 64): then each joint's variant nearest the seed alone is listed and the rest counted. The
counts are ``Solutions.variants``; ``result.limit_variants`` enumerates them on demand.

Layouts: ``geometry`` (GEOMETRY_ROWS, 3, of ``pack_geometry``) holds w (rows AXES), r (rows POINTS), c
(row CENTRE) and X0 (its rotation in rows R0, its position in row P0), then what follows from them
alone (rows N6 to WRIST: computed once per robot, not per target); ``limits`` (2, 6) holds q_min and
q_max [rad]. The solvers write each target's solutions into ``out`` (capacity, SOLUTION_COLUMNS): q (6),
position and rotation errors [m, rad], label code, number of 2 pi variants (inf: continuous joint);
and its numbers into ``info`` (INFO,). Vectors and rotations are tuples inside the kernels: nothing is
allocated per branch. The UR family's solver (``three_parallel``) writes the same layouts through the
per-branch helpers here (``_start``, ``_limit_values``, ``_write_variants``, ``finish``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...files.poses import ROTATION_TOLERANCE as POSE_TOLERANCE, is_pose
from ..chain.compiled import (ANY_MATRIX, ANY_STACK, ANY_VECTOR, FUSED, MATRIX, POSE, STACK, base_pose,
                              check_configuration, cross, end_pose, inner, kernel, moved_pose, pose_errors, sincos)
from .result import MAX_TARGET_COORDINATE_M, POSITION_TOLERANCE, ROTATION_TOLERANCE

#: Below this, the wrist centre is on axis 1 [m] or axes 4 and 6 are aligned [1].
SINGULAR_TOLERANCE = 1e-9
#: Below this sine of the angle between axes 4 and 6 the wrist is taken as singular: the change of q4 +- q6 from the
#: seed's is split evenly between them [1]. That split (instead of the one the pose gives) turns the end frame by at
#: most twice this (8e-7 rad < ROTATION_TOLERANCE; < POSITION_TOLERANCE up to 1.25 m from the wrist centre), so a
#: pose a rounding away from the singularity (a quaternion to 7 digits: the solved q5 is up to 5 times the rounding)
#: keeps the wrist where the seed (the previous waypoint) has it, not at a split the rounding decides, up to half a
#: turn away.
WRIST_SINGULAR_TOLERANCE = 4e-7
#: How far past +-1 a cosine may go through rounding before the target counts as out of reach.
REACH_SLACK = 1e-9
#: A value this close outside a limit is on it [rad or m].
LIMIT_SLACK = 1e-9
#: A joint with a wider range than this (four turns) gets one 2 pi variant, the nearest the seed [rad].
WIDE_RANGE = 8.0 * math.pi + 1e-9
#: A branch with more in-limit 2 pi variants than this (the product over its joints: 64 for a UR arm's
#: +-360 deg ranges) is listed once, each joint's variant nearest the seed; the rest are counted.
MAX_LISTED_VARIANTS = 16
#: q1 values tried at a shoulder singularity besides the seed's, spread evenly over its limits.
SHOULDER_SAMPLES = 12
#: Two solutions within this (largest joint difference) are one [rad or m].
DUPLICATE_TOLERANCE = 1e-6
#: Label bits of a branch: shoulder front, elbow up, wrist flip.
FRONT, UP, FLIP = 1, 2, 4
#: Rows of ``geometry``: the screws at q = 0, then constants derived from them (``_derived_rows``).
AXES, POINTS, CENTRE, R0, P0 = 0, 6, 12, 13, 16
N6, N45, ELBOW, WRIST = 17, 18, 19, 20
GEOMETRY_ROWS = 21
#: Columns of ``out``: joint values, errors, label code, variant count.
Q_COLUMNS, POSITION_ERROR, ROTATION_ERROR, CODE, VARIANTS = slice(0, 6), 6, 7, 8, 9
SOLUTION_COLUMNS = 10
#: Entries of ``info``: solutions written (more than ``out`` holds: call again with this capacity),
#: branches that reach the wrist centre, branches verified by FK, the joint and amount [rad] of the
#: smallest limit violation of a verified branch (-1, 0 when none), and the first solution's errors
#: [m, rad] and label code (0 when there is none). With no solution, ``out[0, :6]`` holds the branch
#: nearest to the target (by FK error), to report on.
COUNT, REACHABLE, VERIFIED, VIOLATING_JOINT, VIOLATION = range(5)
FIRST_POSITION_ERROR, FIRST_ROTATION_ERROR, FIRST_CODE = range(5, 8)
INFO = 8
TWO_PI = 2.0 * math.pi

#: The solvers' signatures (``kernel``): geometry, chain, limits, then the target(s) and seed(s) of any
#: layout, then ``out`` (and ``info``).
SOLVE_SIGNATURE = f"UniTuple(float64, {INFO})({MATRIX}, {MATRIX}, {MATRIX}, {ANY_MATRIX}, {ANY_VECTOR}, {MATRIX})"
BATCH_SIGNATURE = f"void({MATRIX}, {MATRIX}, {MATRIX}, {ANY_STACK}, {ANY_MATRIX}, {STACK}, {MATRIX})"


# -- 3-vectors and rotations (row-major 9-tuples) --------------------------------------------------------
@inner(fastmath=FUSED)
def _row(A, i):
    return (A[i, 0], A[i, 1], A[i, 2])


@inner(fastmath=FUSED)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@inner(fastmath=FUSED)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@inner(fastmath=FUSED)
def _scale(k, a):
    return (k * a[0], k * a[1], k * a[2])


@inner(fastmath=FUSED)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@inner(fastmath=FUSED)
def _rotate(w, angle, v):
    """Rodrigues: v rotated about the unit axis w by angle [rad]."""
    wv = cross(w, v)
    s, c = sincos(angle)
    return _add(_add(v, _scale(s, wv)), _scale(1.0 - c, cross(w, wv)))


@inner(fastmath=FUSED)
def _mm(A, B):
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
            A[0] * B[2] + A[1] * B[5] + A[2] * B[8], A[3] * B[0] + A[4] * B[3] + A[5] * B[6],
            A[3] * B[1] + A[4] * B[4] + A[5] * B[7], A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
            A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


@inner(fastmath=FUSED)
def _t(A):
    return (A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8])


@inner(fastmath=FUSED)
def _mv(A, v):
    return (A[0] * v[0] + A[1] * v[1] + A[2] * v[2], A[3] * v[0] + A[4] * v[1] + A[5] * v[2],
            A[6] * v[0] + A[7] * v[1] + A[8] * v[2])


@inner(fastmath=FUSED)
def _rotation_of(X):
    """The rotation of a 4x4 array."""
    return (X[0, 0], X[0, 1], X[0, 2], X[1, 0], X[1, 1], X[1, 2], X[2, 0], X[2, 1], X[2, 2])


@inner(fastmath=FUSED)
def _angle(w, u, v):
    """Subproblem 1: the rotation about w taking u's projection onto v's [rad]."""
    return math.atan2(_dot(w, cross(u, v)), _dot(u, v) - _dot(u, w) * _dot(v, w))


@inner(fastmath=FUSED)
def _wrap(angle):
    """An angle into (-pi, pi]."""
    return angle - TWO_PI * math.ceil((angle - math.pi) / TWO_PI)


# -- the branches ----------------------------------------------------------------------------------------
@inner(fastmath=FUSED)
def _home_rotation(geometry):
    """The rotation of X0, the end pose at q = 0."""
    return (geometry[R0, 0], geometry[R0, 1], geometry[R0, 2], geometry[R0 + 1, 0], geometry[R0 + 1, 1],
            geometry[R0 + 1, 2], geometry[R0 + 2, 0], geometry[R0 + 2, 1], geometry[R0 + 2, 2])


@njit(cache=True, fastmath=FUSED)
def wrist_centre(geometry, X):
    """Where the wrist centre (at q = 0, pose X0) is when the end frame is at X (4, 4) [m]."""
    c_in_end = _mv(_t(_home_rotation(geometry)), _sub(_row(geometry, CENTRE), _row(geometry, P0)))
    return _add(_mv(_rotation_of(X), c_in_end), (X[0, 3], X[1, 3], X[2, 3]))


@inner(fastmath=FUSED)
def label_code(geometry, p_wrist, q):
    """FRONT | UP | FLIP bits of configuration q (wrapped into (-pi, pi]) whose wrist centre is at p_wrist.

    Front: the wrist centre is on the side of axis 1 it is on at q = 0. Up: the elbow (on axis 3) is
    above the shoulder (axis 2) to wrist-centre line. Flip: q5 < 0."""
    w1, w2 = _row(geometry, AXES), _row(geometry, AXES + 1)
    r1, r2, r3 = _row(geometry, POINTS), _row(geometry, POINTS + 1), _row(geometry, POINTS + 2)
    c = _row(geometry, CENTRE)
    forward0 = _sub(_sub(c, r1), _scale(_dot(w1, _sub(c, r1)), w1))
    code = FRONT if _dot(_rotate(w1, q[0], forward0), _sub(p_wrist, r1)) >= 0.0 else 0
    shoulder = _add(r1, _rotate(w1, q[0], _sub(r2, r1)))
    elbow = _add(r1, _rotate(w1, q[0], _add(_sub(r2, r1), _rotate(w2, q[1], _sub(r3, r2)))))
    line = _sub(p_wrist, shoulder)
    norm = math.sqrt(_dot(line, line))
    if norm > 0.0:
        line = _scale(1.0 / norm, line)
    offset = _sub(elbow, shoulder)
    if offset[2] - line[2] * _dot(offset, line) >= 0.0:
        code |= UP
    if q[4] < 0.0:
        code |= FLIP
    return code


@inner(fastmath=FUSED)
def _shoulder(geometry, p_wrist):
    """(phi, spread, reach): q1 = phi +- spread are the two roots, reach whether they reach the wrist
    centre; spread < 0 at a shoulder singularity (q1 is free)."""
    w1, w2 = _row(geometry, AXES), _row(geometry, AXES + 1)
    r1, r2 = _row(geometry, POINTS), _row(geometry, POINTS + 1)
    v = _sub(p_wrist, r1)
    A, B = _dot(v, _sub(w2, _scale(_dot(w1, w2), w1))), _dot(v, cross(w1, w2))
    C = _dot(w2, _sub(_row(geometry, CENTRE), r2)) - _dot(_sub(r1, r2), w2) - _dot(v, w1) * _dot(w1, w2)
    rho = math.hypot(A, B)
    if rho < SINGULAR_TOLERANCE:
        return 0.0, -1.0, True
    ratio = C / rho
    return math.atan2(B, A), math.acos(min(max(ratio, -1.0), 1.0)), abs(ratio) <= 1.0 + REACH_SLACK


@inner(fastmath=FUSED)
def _q1_count(spread):
    return SHOULDER_SAMPLES + 1 if spread < 0.0 else 2


@inner(fastmath=FUSED)
def _q1_value(i, phi, spread, seed1, q1_min, q1_max):
    """The i-th q1 candidate: a root, or (shoulder singularity) the seed's and then SHOULDER_SAMPLES
    values spread over the limits within half a turn of it."""
    if spread >= 0.0:
        return phi + spread if i == 0 else phi - spread
    if i == 0:
        return seed1
    low, high = max(q1_min, seed1 - math.pi), min(q1_max, seed1 + math.pi)
    return low + (high - low) * (i - 1) / (SHOULDER_SAMPLES - 1)


def pack_geometry(axes: np.ndarray, points: np.ndarray, centre: np.ndarray, X_BE0: np.ndarray,
                  rows: int = GEOMETRY_ROWS, derive=None) -> np.ndarray:
    """The ``geometry`` array (rows, 3) of an arm: unit joint axes (6, 3) and points on them (6, 3) at
    q = 0 [m], the wrist centre (3,) and the end pose X_BE0 (4, 4) at q = 0, then the rows ``derive``
    (default ``_derived_rows``: another family's layout passes its own) computes from them."""
    geometry = np.zeros((rows, 3))
    geometry[:P0 + 1] = np.vstack([axes, points, centre, X_BE0[:3, :3], X_BE0[:3, 3]])
    (derive or _derived_rows)(geometry)
    return geometry


@njit(cache=True, fastmath=FUSED)
def _derived_rows(geometry):
    """Rows N6 (a unit vector normal to axis 6, whose turn about it gives q6), N45 (w4 x w5), ELBOW
    (theta0, |u_p|^2 + |v_p|^2, 2 |u_p| |v_p| of subproblem 3 for q3) and WRIST (w4 . w5, |w4 x w5|^2,
    (w3 . (c - r2))^2)."""
    w3, w4 = _row(geometry, AXES + 2), _row(geometry, AXES + 3)
    w5, w6 = _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    r2, r3, c = _row(geometry, POINTS + 1), _row(geometry, POINTS + 2), _row(geometry, CENTRE)
    n6 = cross(w6, (1.0, 0.0, 0.0) if abs(w6[0]) < 0.9 else (0.0, 1.0, 0.0))
    n45 = cross(w4, w5)
    u, vv = _sub(c, r3), _sub(r2, r3)
    u_p, v_p = _sub(u, _scale(_dot(w3, u), w3)), _sub(vv, _scale(_dot(w3, vv), w3))
    rows = (_scale(1.0 / math.sqrt(_dot(n6, n6)), n6), n45,
            (math.atan2(_dot(w3, cross(u_p, v_p)), _dot(u_p, v_p)), _dot(u_p, u_p) + _dot(v_p, v_p),
             2.0 * math.sqrt(_dot(u_p, u_p) * _dot(v_p, v_p))),
            (_dot(w4, w5), _dot(n45, n45), _dot(w3, _sub(c, r2)) ** 2))
    for k in range(4):
        for j in range(3):
            geometry[N6 + k, j] = rows[k][j]


@inner(fastmath=FUSED)
def _goal_axes(geometry, X):
    """Where the joints must turn axis 6 and n6 (``_wrist_reference``) for target X (4, 4): R_goal w6
    and R_goal n6, with R_goal = R_target R0^T the rotation of all six joints together."""
    R_goal = _mm(_rotation_of(X), _t(_home_rotation(geometry)))
    return _mv(R_goal, _row(geometry, AXES + 5)), _mv(R_goal, _row(geometry, N6))


@inner(fastmath=FUSED)
def _elbow(geometry, goal_axes, p_wrist, q1):
    """What one q1 leaves to the elbow: (theta0, spread3: q3 = theta0 -+ spread3 for elbow down/up,
    whether the elbow reaches, p' (the wrist centre turned back by q1), R1^T R_goal w6 and
    R1^T R_goal n6 (of ``_goal_axes``))."""
    w1, r1, r2 = _row(geometry, AXES), _row(geometry, POINTS), _row(geometry, POINTS + 1)
    theta0, squares, twice_product = _row(geometry, ELBOW)
    p_prime = _add(r1, _rotate(w1, -q1, _sub(p_wrist, r1)))
    delta_sq = _dot(_sub(p_prime, r2), _sub(p_prime, r2)) - geometry[WRIST, 2]
    kappa = (squares - delta_sq) / twice_product
    spread3 = math.acos(min(max(kappa, -1.0), 1.0))
    after1 = (_rotate(w1, -q1, goal_axes[0]), _rotate(w1, -q1, goal_axes[1]))
    return theta0, spread3, abs(kappa) <= 1.0 + REACH_SLACK, p_prime, after1


@inner(fastmath=FUSED)
def _arm(geometry, after1, p_prime, q1, q3):
    """The arm (q1, q2, q3) wrapped into (-pi, pi] for one q1 and q3, and what the wrist must do: d and
    m (where axis 6 and n6 must go, R_wrist w6 and R_wrist n6 with R_wrist = R_arm^T R_goal), axis 5's
    two solutions centre +- offset, and whether the wrist is singular (axes 4 and 6 aligned)."""
    w2, w3 = _row(geometry, AXES + 1), _row(geometry, AXES + 2)
    w4, w5, w6 = _row(geometry, AXES + 3), _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    r2, r3, c = _row(geometry, POINTS + 1), _row(geometry, POINTS + 2), _row(geometry, CENTRE)
    c45, n45_squared, n45 = geometry[WRIST, 0], geometry[WRIST, 1], _row(geometry, N45)
    p3 = _add(r3, _rotate(w3, q3, _sub(c, r3)))
    q2 = _angle(w2, _sub(p3, r2), _sub(p_prime, r2))
    d = _rotate(w3, -q3, _rotate(w2, -q2, after1[0]))
    m = _rotate(w3, -q3, _rotate(w2, -q2, after1[1]))
    alpha = (c45 * _dot(w5, w6) - _dot(d, w4)) / (c45 ** 2 - 1.0)
    beta = (c45 * _dot(d, w4) - _dot(w5, w6)) / (c45 ** 2 - 1.0)
    gamma = math.sqrt(max((1.0 - alpha ** 2 - beta ** 2 - 2.0 * alpha * beta * c45) / n45_squared, 0.0))
    w4d = cross(w4, d)
    singular = math.sqrt(_dot(w4d, w4d)) < WRIST_SINGULAR_TOLERANCE
    return ((_wrap(q1), _wrap(q2), _wrap(q3)), d, m, _add(_scale(alpha, w4), _scale(beta, w5)), _scale(gamma, n45),
            singular)


@inner(fastmath=FUSED)
def _branch(geometry, arm, d, m, z_centre, z_offset, singular, flip, seed):
    """The branch (noflip: flip 0, flip: 1) of one arm, of ``_arm``: q as a 6-tuple in (-pi, pi]."""
    z = _add(z_centre, z_offset) if flip == 0 else _sub(z_centre, z_offset)
    return _wrist_branch(geometry, arm, d, m, z, singular, _row(geometry, N6), seed)


@inner(fastmath=FUSED)
def _wrist_branch(geometry, arm, d, m, z, singular, n6, seed):
    """One branch: the arm's (q1, q2, q3) and the wrist's q4, q5, q6 that put axis 6 along d with axis
    5 along z (m: where n6 must go); at a wrist singularity, the split of q4 +- q6 nearest the seed."""
    w4, w5, w6 = _row(geometry, AXES + 3), _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    q4 = seed[3] if singular else _angle(w4, z, d)
    q5 = _angle(w5, w6, _rotate(w4, -q4, d)) if singular else _angle(w5, w6, z)
    q6 = _angle(w6, n6, _rotate(w5, -q5, _rotate(w4, -q4, m)))       # (R4 R5)^T R_wrist n6
    if singular:                         # only q4 + sigma q6 is fixed: split the change nearest the seed
        sigma = 1.0 if _dot(_rotate(w5, q5, w6), w4) >= 0.0 else -1.0
        step = _wrap(sigma * (q6 - seed[5]))
        q4, q6 = seed[3] + step / 2.0, q6 - sigma * step / 2.0
    return (arm[0], arm[1], arm[2], _wrap(q4), _wrap(q5), _wrap(q6))


@njit(cache=True, fastmath=FUSED)
def raw_branches(geometry, X, seed, q1_min, q1_max):
    """Every closed-form branch of target X (4, 4): (Q (B, 6) wrapped into (-pi, pi], reachable (B,)),
    B = 4 per q1 value (8 away from a shoulder singularity), in the order elbow down, up, each noflip, flip."""
    goal_axes = _goal_axes(geometry, X)
    p_wrist = wrist_centre(geometry, X)
    phi, spread, reach1 = _shoulder(geometry, p_wrist)
    count = _q1_count(spread)
    Q = np.empty((4 * count, 6))
    reachable = np.zeros(4 * count, dtype=np.bool_)
    for i in range(count):
        q1 = _q1_value(i, phi, spread, seed[0], q1_min, q1_max)
        theta0, spread3, reach3, p_prime, after1 = _elbow(geometry, goal_axes, p_wrist, q1)
        for k in range(4):
            arm, d, m, z_centre, z_offset, singular = _arm(geometry, after1, p_prime, q1,
                                                           theta0 + (spread3 if k >= 2 else -spread3))
            branch = _branch(geometry, arm, d, m, z_centre, z_offset, singular, k % 2, seed)
            for j in range(6):
                Q[4 * i + k, j] = branch[j]
            reachable[4 * i + k] = reach1 and reach3
    return Q, reachable


@inner(fastmath=FUSED)
def _pose_error(chain, q, X):
    """(position error [m], rotation error [rad]) of FK(q) against X (4, 4)."""
    return pose_errors(end_pose(chain, q), X, POSE)


@inner(fastmath=FUSED)
def _joint_values(value, seed, low, high, out):
    """The in-limit 2 pi variants of one revolute joint's value [rad] into out; returns (how many were
    written, the violation [rad] when there is none)."""
    if high - low > WIDE_RANGE:                                  # one representative, nearest the seed
        nearest = value + TWO_PI * round((seed - value) / TWO_PI)
        if nearest > high + LIMIT_SLACK:                          # the seed is near or past a limit
            nearest -= TWO_PI
        elif nearest < low - LIMIT_SLACK:
            nearest += TWO_PI
        out[0] = min(max(nearest, low), high)
        return 1, 0.0
    k_low = math.ceil((low - LIMIT_SLACK - value) / TWO_PI)
    k_high = math.floor((high + LIMIT_SLACK - value) / TWO_PI)
    count = 0
    for k in range(k_low, k_high + 1):
        out[count] = min(max(value + TWO_PI * k, low), high)
        count += 1
    if count:
        return count, 0.0
    below = low - (value + TWO_PI * k_high)                       # the nearest shifts below and above
    above = value + TWO_PI * k_low - high
    return 0, min(below, above)


@inner(fastmath=FUSED)
def _variant_count(q, limits):
    """How many in-limit 2 pi variants configuration q has in all (a float: inf with a continuous joint)."""
    total = 1.0
    for j in range(6):
        low, high = limits[0, j], limits[1, j]
        if math.isinf(high - low):
            total = math.inf
        else:
            total *= max(math.floor((high - q[j]) / TWO_PI) - math.ceil((low - q[j]) / TWO_PI) + 1, 0)
    return total


@inner(fastmath=FUSED)
def _start(out, info):
    """Clear ``info`` for a new target; returns the per-target scratch: a joint's in-limit variants
    (6, 5: at most 5 below WIDE_RANGE), their counts (6,), a configuration (6,) and the nearest
    branch so far (6,) with its error (of ``_keep_nearest``)."""
    for k in range(INFO):                    # element by element: a slice assignment compiles its shape check
        info[k] = 0.0
    info[VIOLATING_JOINT] = -1.0
    return np.empty((6, 5)), np.zeros(6, dtype=np.int64), np.empty(6), np.zeros(6), np.full(1, np.inf)


@inner(fastmath=FUSED)
def _keep_nearest(raw, e_p, e_r, best, best_error):
    """Remember the branch raw (a 6-tuple) as the one nearest the target when its errors are the smallest yet."""
    if e_p + e_r < best_error[0]:
        best_error[0] = e_p + e_r
        for j in range(6):
            best[j] = raw[j]


@inner(fastmath=FUSED)
def _limit_values(raw, seed, limits, values, counts, info):
    """Each joint's in-limit 2 pi variants of the verified branch raw (a 6-tuple) into values and
    counts; returns how many configurations they make (0: none in the limits, the smallest violation
    then kept in ``info``). A branch of more than MAX_LISTED_VARIANTS keeps each joint's variant
    nearest the seed alone (the others are counted, ``_variant_count``)."""
    total, worst, worst_joint = 1, 0.0, -1
    for j in range(6):
        written, violation = _joint_values(raw[j], seed[j], limits[0, j], limits[1, j], values[j])
        counts[j] = written
        total *= written
        if violation > worst:
            worst, worst_joint = violation, j
    if total == 0:
        if info[VIOLATING_JOINT] < 0.0 or worst < info[VIOLATION]:
            info[VIOLATING_JOINT], info[VIOLATION] = worst_joint, worst
        return 0
    if total > MAX_LISTED_VARIANTS:
        for j in range(6):
            nearest = 0
            for k in range(1, counts[j]):
                if abs(values[j, k] - seed[j]) < abs(values[j, nearest] - seed[j]):
                    nearest = k
            values[j, 0], counts[j] = values[j, nearest], 1
        total = 1
    return total


@inner(fastmath=FUSED)
def _write_variants(chain, limits, X, values, counts, total, e_p, e_r, code, variants, q, out, m):
    """The ``total`` configurations of ``_limit_values`` (a branch with errors e_p [m], e_r [rad], its
    label code and variant count) into out from row m on (rows past its capacity only counted); a
    value put on a limit is verified again by FK. Returns the next row."""
    capacity = out.shape[0]
    for combo in range(total):
        rest, on_limit = combo, False
        for j in range(6):
            q[j] = values[j, rest % counts[j]]
            on_limit |= q[j] == limits[0, j] or q[j] == limits[1, j]
            rest //= counts[j]
        errors = _pose_error(chain, q, X) if on_limit else (e_p, e_r)
        if errors[0] > POSITION_TOLERANCE or errors[1] > ROTATION_TOLERANCE:
            continue                                          # put on a limit and no longer exact
        if m < capacity:
            for j in range(6):
                out[m, j] = q[j]
            out[m, POSITION_ERROR], out[m, ROTATION_ERROR] = errors
            out[m, CODE], out[m, VARIANTS] = code, variants
        m += 1
    return m


@inner(fastmath=FUSED)
def finish(out, info, m, seed, best):
    """Close a target's ``info`` after m rows were written: sorted and distinct (nearest the seed
    first) with the first one's numbers, or with no solution the nearest branch in ``out[0, :6]``."""
    info[COUNT] = m
    if m == 0:
        for j in range(6):
            out[0, j] = best[j]
    elif m <= out.shape[0]:
        info[COUNT] = _sort_distinct(out, m, seed)
        info[FIRST_POSITION_ERROR], info[FIRST_ROTATION_ERROR] = out[0, POSITION_ERROR], out[0, ROTATION_ERROR]
        info[FIRST_CODE] = out[0, CODE]


@inner(fastmath=FUSED)
def _is_duplicate(out, i, k):
    """Whether rows i and k of out are one solution (largest joint difference <= DUPLICATE_TOLERANCE)."""
    for j in range(6):
        if abs(out[i, j] - out[k, j]) > DUPLICATE_TOLERANCE:
            return False
    return True


@inner(fastmath=FUSED)
def _sort_distinct(out, m, seed):
    """Sort the first m rows of out by distance to the seed (stable, in place) and drop duplicates;
    returns how many rows are left."""
    distance = np.empty(m)
    for i in range(m):
        total = 0.0
        for j in range(6):
            total += (out[i, j] - seed[j]) ** 2
        distance[i] = math.sqrt(total)
    for i in range(1, m):                                    # insertion sort: m is small
        k = i
        while k > 0 and distance[k - 1] > distance[k]:
            distance[k - 1], distance[k] = distance[k], distance[k - 1]
            for j in range(out.shape[1]):
                out[k - 1, j], out[k, j] = out[k, j], out[k - 1, j]
            k -= 1
    n = 0
    for i in range(m):
        duplicate = False
        for k in range(n - 1, -1, -1):      # a duplicate's distance differs by at most sqrt(6) DUPLICATE_TOLERANCE
            if distance[i] - distance[k] > 3.0 * DUPLICATE_TOLERANCE:
                break
            if _is_duplicate(out, i, k):
                duplicate = True
                break
        if not duplicate:
            if n != i:
                for j in range(out.shape[1]):
                    out[n, j] = out[i, j]
                distance[n] = distance[i]
            n += 1
    return n


@inner()
def check_target(X, seed):
    """ValueError unless X is a pose (``pipeline.files.poses.check_pose``, within MAX_TARGET_COORDINATE_M) and
    the seed 6 finite joint values (the caller then words the error)."""
    if X.shape[0] != 4 or X.shape[1] != 4 or not is_pose(X, POSE_TOLERANCE, MAX_TARGET_COORDINATE_M):
        raise ValueError("not a pose")
    check_configuration(seed, 6)


@inner()
def info_entries(info):
    """The INFO entries of ``info`` as a tuple (no array for Python to unpack)."""
    return (info[0], info[1], info[2], info[3], info[4], info[5], info[6], info[7])


@kernel(SOLVE_SIGNATURE, fastmath=FUSED)
def solve_one(geometry, chain, limits, X, seed, out):
    """Every in-limit, FK-verified solution of target X (4, 4) nearest seed (6,) first, into out;
    returns the target's ``info`` entries (a tuple: no array to unpack; see the module's layouts).

    X and the seed come unchecked: ``check_target``. The solver is this kernel's own body, not a function it
    calls: a compiled function optimises again all it calls, and the first IK call compiles this one alone."""
    check_target(X, seed)
    info = np.empty(INFO)
    values, counts, q, best, best_error = _start(out, info)
    goal_axes = _goal_axes(geometry, X)
    p_wrist = wrist_centre(geometry, X)
    phi, spread, reach1 = _shoulder(geometry, p_wrist)
    m = np.int64(0)                          # not the literal 0: the helpers m goes to would compile twice
    for i in range(_q1_count(spread)):
        q1 = _q1_value(i, phi, spread, seed[0], limits[0, 0], limits[1, 0])
        theta0, spread3, reach3, p_prime, after1 = _elbow(geometry, goal_axes, p_wrist, q1)
        if not (reach1 and reach3):
            continue
        for k in range(4):                     # elbow down, up (k // 2), each wrist noflip, flip (k % 2)
            if k % 2 == 0:                     # the two wrist branches of an elbow share q1, q2 and q3
                arm, d, m6, z_centre, z_offset, singular = _arm(geometry, after1, p_prime, q1,
                                                                theta0 + (spread3 if k >= 2 else -spread3))
                arm_pose, arm_code = moved_pose(chain, base_pose(chain), arm, 0, 3), -1
            raw = _branch(geometry, arm, d, m6, z_centre, z_offset, singular, k % 2, seed)
            info[REACHABLE] += 1
            e_p, e_r = pose_errors(moved_pose(chain, arm_pose, raw, 3, 6), X, POSE)
            _keep_nearest(raw, e_p, e_r, best, best_error)
            if e_p > POSITION_TOLERANCE or e_r > ROTATION_TOLERANCE:
                continue
            info[VERIFIED] += 1
            total = _limit_values(raw, seed, limits, values, counts, info)
            if total == 0:
                continue
            if arm_code < 0:                   # shoulder and elbow bits: the same for both wrists
                arm_code = label_code(geometry, p_wrist, raw) & (FRONT | UP)
            m = _write_variants(chain, limits, X, values, counts, total, e_p, e_r,
                                arm_code | (FLIP if raw[4] < 0.0 else 0), _variant_count(raw, limits), q, out, m)
    finish(out, info, m, seed, best)
    return info_entries(info)


@kernel(BATCH_SIGNATURE)
def solve_batch(geometry, chain, limits, X, seeds, out, info):
    """``solve_one`` for targets X (N, 4, 4) and seeds (N, 6), into out (N, capacity, SOLUTION_COLUMNS)
    and info (N, INFO)."""
    for n in range(X.shape[0]):
        numbers = solve_one(geometry, chain, limits, X[n], seeds[n], out[n])
        for k in range(INFO):
            info[n, k] = numbers[k]


@njit(cache=True, fastmath=FUSED)
def label_codes(geometry, chain, Q, codes):
    """codes (N,) = the label code of each configuration Q (N, 6), its wrist centre by the compiled FK."""
    q = np.empty(6)
    X = np.empty((4, 4))
    for n in range(Q.shape[0]):
        x = end_pose(chain, Q[n])
        for k in range(12):
            X[k // 4, k % 4] = x[k]
        for j in range(6):
            q[j] = _wrap(Q[n, j])
        codes[n] = label_code(geometry, wrist_centre(geometry, X), q)
