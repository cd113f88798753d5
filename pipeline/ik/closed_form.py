"""Compiled (Numba) closed-form IK of 6R arms with a spherical wrist: every branch, its 2 pi variants
inside the limits, each verified by the compiled FK, nearest the seed first.

The method (``pipeline.ik.analytic`` derives the geometry and builds the results): the joint screws
at q = 0 (unit axes ``w`` (6, 3) and points ``r`` (6, 3) on them, base frame [m]), the wrist centre
``c`` and the end pose ``X0`` at q = 0; Paden-Kahan subproblems then give

1. q1 from the wrist centre (two roots: shoulder front/back);
2. q3 from its distance to axis 2 (subproblem 3, two roots: elbow up/down), then q2 (subproblem 1);
3. q4, q5 from the wrist rotation (subproblem 2, two roots: wrist flip/noflip), then q6.

At a wrist singularity (axes 4 and 6 aligned) only q4 +- q6 is fixed: the split nearest the seed is
returned. At a shoulder singularity (the wrist centre on axis 1) q1 is free: the seed's q1 and
SHOULDER_SAMPLES values spread over q1's limits are tried, each with its four arm/wrist branches.

Limits are inclusive: a value within LIMIT_SLACK outside a limit is put on it. A joint whose range
spans more than WIDE_RANGE, four turns (or is continuous), gets one 2 pi variant, the one nearest the seed, and
the number of variants it has is counted rather than enumerated; narrower joints get every variant.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..compiled import _end_pose, cross
from .result import POSITION_TOLERANCE, ROTATION_TOLERANCE

#: Below this, the wrist centre is on axis 1 [m] or axes 4 and 6 are aligned [1].
SINGULAR_TOLERANCE = 1e-9
#: How far past +-1 a cosine may go through rounding before the target counts as out of reach.
REACH_SLACK = 1e-9
#: A value this close outside a limit is on it [rad or m].
LIMIT_SLACK = 1e-9
#: A joint with a wider range than this (four turns) gets one 2 pi variant, the nearest the seed [rad].
WIDE_RANGE = 8.0 * math.pi + 1e-9
#: q1 values tried at a shoulder singularity besides the seed's, spread evenly over its limits.
SHOULDER_SAMPLES = 12
#: Two solutions within this (largest joint difference) are one [rad or m].
DUPLICATE_TOLERANCE = 1e-6
#: Label bits of a branch: shoulder front, elbow up, wrist flip.
FRONT, UP, FLIP = 1, 2, 4
#: Per-target numbers ``solve_batch`` returns in ``info`` (N, INFO): branches that reach the wrist
#: centre, branches verified by FK, the joint and amount [rad or m] of the smallest limit violation of
#: a verified branch (-1, 0 when none), the index into ``raw`` of the branch to report on failure.
REACHABLE, VERIFIED, VIOLATING_JOINT, VIOLATION, BEST_RAW = range(5)
INFO = 5
TWO_PI = 2.0 * math.pi


@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _mm(A, B):
    """A B for 3x3 matrices (no BLAS call: these are too small for it)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True)
def _mv(A, v):
    return np.array([_dot(A[0], v), _dot(A[1], v), _dot(A[2], v)])


@njit(cache=True)
def _rotate(w, angle, v):
    """Rodrigues: v rotated about the unit axis w by angle [rad]."""
    wv = cross(w, v)
    return v + math.sin(angle) * wv + (1.0 - math.cos(angle)) * cross(w, wv)


@njit(cache=True)
def _matrix(w, angle):
    """The rotation matrix about the unit axis w by angle [rad]."""
    c, s = math.cos(angle), math.sin(angle)
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * _mm(K, K)


@njit(cache=True)
def _angle(w, u, v):
    """Subproblem 1: the rotation about w taking u's projection onto v's [rad]."""
    return math.atan2(_dot(w, cross(u, v)), _dot(u, v) - _dot(u, w) * _dot(v, w))


@njit(cache=True)
def _wrap(angle):
    """An angle into (-pi, pi]."""
    return angle - TWO_PI * math.ceil((angle - math.pi) / TWO_PI)


@njit(cache=True)
def wrap_all(q):
    """A copy of q with every value wrapped into (-pi, pi]."""
    out = np.empty_like(q)
    for j in range(q.shape[0]):
        out[j] = _wrap(q[j])
    return out


@njit(cache=True)
def wrist_centre(c, X0, X):
    """Where the wrist centre c (at q = 0, pose X0) is when the end frame is at X."""
    c_in_end = _mv(X0[:3, :3].T, c - X0[:3, 3])
    return _mv(X[:3, :3], c_in_end) + X[:3, 3]


@njit(cache=True)
def label_code(w, r, c, p_wrist, q):
    """FRONT | UP | FLIP bits of configuration q (wrapped) whose wrist centre is at p_wrist.

    Front: the wrist centre is on the side of axis 1 it is on at q = 0. Up: the elbow (on axis 3) is
    above the shoulder (axis 2) to wrist-centre line. Flip: q5 < 0."""
    forward0 = (c - r[0]) - w[0] * _dot(w[0], c - r[0])
    code = FRONT if _dot(_rotate(w[0], q[0], forward0), p_wrist - r[0]) >= 0.0 else 0
    shoulder = r[0] + _rotate(w[0], q[0], r[1] - r[0])
    elbow = r[0] + _rotate(w[0], q[0], r[1] - r[0] + _rotate(w[1], q[1], r[2] - r[1]))
    line = p_wrist - shoulder
    norm = math.sqrt(_dot(line, line))
    if norm > 0.0:
        line = line / norm
    offset = elbow - shoulder
    if offset[2] - line[2] * _dot(offset, line) >= 0.0:
        code |= UP
    if q[4] < 0.0:
        code |= FLIP
    return code


@njit(cache=True)
def _q1_values(w, r, c, p_wrist, seed1, q1_min, q1_max):
    """q1 candidates: the two roots, or (shoulder singularity) the seed's and SHOULDER_SAMPLES spread
    over the limits; and whether the wrist centre is within reach of axis 2's circle."""
    w1, w2 = w[0], w[1]
    v = p_wrist - r[0]
    A, B = _dot(v, w2 - w1 * _dot(w1, w2)), _dot(v, cross(w1, w2))
    C = _dot(w2, c - r[1]) - _dot(r[0] - r[1], w2) - _dot(v, w1) * _dot(w1, w2)
    rho = math.hypot(A, B)
    if rho < SINGULAR_TOLERANCE:
        low, high = max(q1_min, seed1 - math.pi), min(q1_max, seed1 + math.pi)
        values = np.empty(SHOULDER_SAMPLES + 1)
        values[0] = seed1
        values[1:] = np.linspace(low, high, SHOULDER_SAMPLES)
        return values, True
    ratio = C / rho
    phi, spread = math.atan2(B, A), math.acos(min(max(ratio, -1.0), 1.0))
    return np.array([phi + spread, phi - spread]), abs(ratio) <= 1.0 + REACH_SLACK


@njit(cache=True)
def raw_branches(w, r, c, X0, X, seed, q1_min, q1_max):
    """Every closed-form branch of target X (4, 4): (Q (B, 6) wrapped into (-pi, pi], reachable (B,)),
    B = 4 per q1 value (8 away from a shoulder singularity)."""
    R_target = X[:3, :3]
    p_wrist = wrist_centre(c, X0, X)
    q1s, reach1 = _q1_values(w, r, c, p_wrist, seed[0], q1_min, q1_max)
    Q = np.empty((4 * q1s.size, 6))
    reachable = np.zeros(4 * q1s.size, dtype=np.bool_)
    w3, w4, w5, w6 = w[2], w[3], w[4], w[5]
    u, vv = c - r[2], r[1] - r[2]
    u_p, v_p = u - w3 * _dot(w3, u), vv - w3 * _dot(w3, vv)
    theta0 = math.atan2(_dot(w3, cross(u_p, v_p)), _dot(u_p, v_p))
    c45 = _dot(w4, w5)
    n45 = cross(w4, w5)
    n6 = cross(w6, np.array([1.0, 0.0, 0.0]) if abs(w6[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    n6 = n6 / math.sqrt(_dot(n6, n6))
    for i in range(q1s.size):
        q1 = q1s[i]
        p_prime = r[0] + _rotate(w[0], -q1, p_wrist - r[0])
        delta_sq = _dot(p_prime - r[1], p_prime - r[1]) - _dot(w3, c - r[1]) ** 2
        kappa = (_dot(u_p, u_p) + _dot(v_p, v_p) - delta_sq) / (2.0 * math.sqrt(_dot(u_p, u_p) * _dot(v_p, v_p)))
        spread3 = math.acos(min(max(kappa, -1.0), 1.0))
        for e in range(2):
            q3 = theta0 - spread3 if e == 0 else theta0 + spread3
            p3 = r[2] + _rotate(w3, q3, c - r[2])
            q2 = _angle(w[1], p3 - r[1], p_prime - r[1])
            R_arm = _mm(_mm(_matrix(w[0], q1), _matrix(w[1], q2)), _matrix(w3, q3))
            R_wrist = _mm(_mm(R_arm.T, R_target), X0[:3, :3].T)
            d = _mv(R_wrist, w6)
            alpha = (c45 * _dot(w5, w6) - _dot(d, w4)) / (c45 ** 2 - 1.0)
            beta = (c45 * _dot(d, w4) - _dot(w5, w6)) / (c45 ** 2 - 1.0)
            gamma = math.sqrt(max((1.0 - alpha ** 2 - beta ** 2 - 2.0 * alpha * beta * c45) / _dot(n45, n45), 0.0))
            singular = math.sqrt(_dot(cross(w4, d), cross(w4, d))) < SINGULAR_TOLERANCE
            for f in range(2):
                z = alpha * w4 + beta * w5 + (gamma if f == 0 else -gamma) * n45
                q4 = seed[3] if singular else _angle(w4, z, d)
                q5 = _angle(w5, w6, _rotate(w4, -q4, d)) if singular else _angle(w5, w6, z)
                R45 = _mm(_matrix(w4, q4), _matrix(w5, q5))
                q6 = _angle(w6, n6, _mv(_mm(R45.T, R_wrist), n6))
                if singular:                 # only q4 + sigma q6 is fixed: split the change nearest the seed
                    sigma = 1.0 if _dot(_rotate(w5, q5, w6), w4) >= 0.0 else -1.0
                    step = _wrap(sigma * (q6 - seed[5]))
                    q4, q6 = seed[3] + step / 2.0, q6 - sigma * step / 2.0
                b = 4 * i + 2 * e + f
                Q[b, 0], Q[b, 1], Q[b, 2], Q[b, 3], Q[b, 4], Q[b, 5] = q1, q2, q3, q4, q5, q6
                reachable[b] = reach1 and abs(kappa) <= 1.0 + REACH_SLACK
    for b in range(Q.shape[0]):
        Q[b] = wrap_all(Q[b])
    return Q, reachable


@njit(cache=True)
def pose_error(chain, q, X):
    """(position error [m], rotation error [rad]) of FK(q) against X."""
    F = np.empty((4, 4))
    _end_pose(chain, q, F)
    dx, dy, dz = F[0, 3] - X[0, 3], F[1, 3] - X[1, 3], F[2, 3] - X[2, 3]
    E = _mm(F[:3, :3].T, X[:3, :3])
    sx, sy, sz = E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]
    angle = math.atan2(0.5 * math.sqrt(sx * sx + sy * sy + sz * sz), 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0))
    return math.sqrt(dx * dx + dy * dy + dz * dz), angle


@njit(cache=True)
def _joint_values(value, seed, low, high, out):
    """The in-limit 2 pi variants of one revolute joint's value [rad] into out; returns (how many were
    written, the violation [rad] when there is none)."""
    if high - low > WIDE_RANGE:                                  # one representative, nearest the seed
        nearest = value + TWO_PI * round((seed - value) / TWO_PI)
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


@njit(cache=True)
def solve_one(w, r, c, X0, chain, q_min, q_max, X, seed):
    """Every in-limit, FK-verified solution of target X nearest seed first: (Q (M, 6), errors (M, 2),
    label codes (M,), variant counts (M,) (inf: continuous), info (INFO,), raw (B, 6) branches)."""
    raw, reachable = raw_branches(w, r, c, X0, X, seed, q_min[0], q_max[0])
    B = raw.shape[0]
    info = np.zeros(INFO)
    info[VIOLATING_JOINT] = -1.0
    values = np.empty((6, 8))
    counts = np.zeros(6, dtype=np.int64)
    capacity = 64
    Q = np.empty((capacity, 6))
    errors = np.empty((capacity, 2))
    codes = np.empty(capacity, dtype=np.int64)
    variants = np.empty(capacity)
    m = 0
    best_raw, best_error, best_violation = 0, np.inf, np.inf
    p_wrist = wrist_centre(c, X0, X)
    for b in range(B):
        if not reachable[b]:
            continue
        info[REACHABLE] += 1
        e_p, e_r = pose_error(chain, raw[b], X)
        if e_p + e_r < best_error:
            best_raw, best_error = b, e_p + e_r
        if e_p > POSITION_TOLERANCE or e_r > ROTATION_TOLERANCE:
            continue
        info[VERIFIED] += 1
        total, worst, worst_joint = 1, 0.0, -1
        for j in range(6):
            written, violation = _joint_values(raw[b, j], seed[j], q_min[j], q_max[j], values[j])
            counts[j] = written
            total *= written
            if violation > worst:
                worst, worst_joint = violation, j
        if total == 0:
            if worst < best_violation:
                best_violation = worst
                info[VIOLATING_JOINT], info[VIOLATION] = worst_joint, worst
            continue
        code = label_code(w, r, c, p_wrist, raw[b])
        for combo in range(total):
            if m == capacity:
                capacity *= 2
                Q, errors = _grown(Q, capacity), _grown(errors, capacity)
                codes, variants = _grown(codes, capacity), _grown(variants, capacity)
            rest = combo
            for j in range(6):
                Q[m, j] = values[j, rest % counts[j]]
                rest //= counts[j]
            errors[m, 0], errors[m, 1] = pose_error(chain, Q[m], X)
            if errors[m, 0] > POSITION_TOLERANCE or errors[m, 1] > ROTATION_TOLERANCE:
                continue                                          # put on a limit and no longer exact
            codes[m] = code
            variants[m] = _variant_count(raw[b], q_min, q_max)
            m += 1
    info[BEST_RAW] = best_raw
    keep = _distinct_nearest(Q[:m], seed)
    return Q[keep], errors[keep], codes[keep], variants[keep], info, raw


@njit(cache=True)
def _grown(array, capacity):
    out = np.empty((capacity,) + array.shape[1:], dtype=array.dtype)
    out[:array.shape[0]] = array
    return out


@njit(cache=True)
def _variant_count(q, q_min, q_max):
    """How many in-limit 2 pi variants configuration q has in all (a float: inf with a continuous joint)."""
    total = 1.0
    for j in range(6):
        total *= max(math.floor((q_max[j] - q[j]) / TWO_PI) - math.ceil((q_min[j] - q[j]) / TWO_PI) + 1, 0)
    return total


@njit(cache=True)
def _distinct_nearest(Q, seed):
    """Indices of the distinct rows of Q (largest joint difference > DUPLICATE_TOLERANCE), nearest the
    seed first."""
    distance = np.empty(Q.shape[0])
    for i in range(Q.shape[0]):
        distance[i] = math.sqrt(((Q[i] - seed) ** 2).sum())
    order = np.argsort(distance, kind="mergesort")
    keep = np.empty(Q.shape[0], dtype=np.int64)
    n = 0
    for i in order:
        duplicate = False
        for k in range(n):
            if np.abs(Q[keep[k]] - Q[i]).max() <= DUPLICATE_TOLERANCE:
                duplicate = True
                break
        if not duplicate:
            keep[n] = i
            n += 1
    return keep[:n]
