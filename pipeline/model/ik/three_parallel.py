"""Compiled (Numba) closed-form IK of 6R arms whose axes 2, 3 and 4 are parallel and whose axes 5 and 6
meet (the Universal Robots family: UR3, UR5, UR10, their e-Series): 8 branches, verified by the
compiled FK, nearest the seed first.

The geometry is read off our FK at q = 0 as for the spherical wrist (``pipeline.model.ik.analytic``): unit
axes ``w`` and points ``r`` (base frame [m]), the wrist point ``c`` (where axes 5 and 6 meet, fixed in
the end frame) and the end pose ``X0``. With ``n = w2`` (axes 3 and 4 are +-n), joints 2, 3 and 4 turn
about parallel axes, so together they are one turn about n by ``theta = s2 q2 + s3 q3 + s4 q4`` (s_i =
w_i . n = +-1) and they keep every point's and vector's component along n. Hence, in the product of
exponentials ``X(q) = e^{xi_1 q1} ... e^{xi_6 q6} X0``:

1. q1 (two roots): the wrist point turned back by q1 has c's component along n (the spherical-wrist
   solver's shoulder equation, ``closed_form._shoulder``); on axis 1 (possible only without a shoulder
   offset) q1 is free: the seed's and values spread over its limits are tried, as there;
2. q5 (two roots per q1): axis 6 turned back by q1 has w6's component along n after q5 alone;
3. q6 from the direction n seen from the end (subproblem 1 about axis 6); with axes 4 and 6 aligned
   (q5 = 0 on UR tables) q6 is free and takes the seed's value; then theta from the rest;
4. the planar 3R: wrist 1 (axis 4's point) is the wrist point less the turned wrist, then q3 (two
   roots, subproblem 3), q2 (subproblem 1) and q4 = s4 (theta - s2 q2 - s3 q3).

Branch labels (codes RIGHT | UP | WRIST_UP), defined from the geometry of a configuration, with a_i
the joint axes (positive direction), r_i points on them, p_w the wrist point, and K = a_2 . (c - r_1)
at q = 0 the offset of the arm's plane (normal to axes 2-4) from axis 1 along a_2 (109 mm on a UR5):

* shoulder ``right`` if K a_1 . (a_2 x (p_w - r_1)) >= 0: seen from above (axis 1 pointing at the
  viewer) and looking from axis 1 at the wrist point, the arm's plane (upper arm and forearm) lies to
  the right; else ``left`` (without a shoulder offset, K = 0, the sign of a_1 . (a_2 x (p_w - r_1))).
  The two q1 roots have opposite shoulders; the label changes only where they meet (p_w on the plane
  of axes 1 and 2);
* elbow ``up`` if the elbow (axis 3) lies on axis 1's side ("above", for a floor-mounted arm) of the
  line from the shoulder (axis 2) to wrist 1 (axis 4), that line taken pointing to the side of axis 1
  the wrist point is on: a_2 . ((r_4 - r_2) x (r_3 - r_2)) has the sign of a_1 . (a_2 x (p_w - r_1));
  else ``down``. The two q3 roots have opposite elbows; the label changes only with the elbow
  stretched or folded (or with the shoulder). For the usual forward reach this is the elbow above or
  below the shoulder-wrist line;
* wrist ``up`` if a_5 . (a_4 x a_6) >= 0: turning axis 4 towards axis 6 about axis 5 is positive (on
  UR's tables 0 < q5 < pi); else ``down``. The two q5 roots have opposite wrists; the label changes
  only with axes 4 and 6 aligned.

The names are those of the UR family's 8 closed-form solutions: shoulder left/right (the two q1),
elbow up/down (the two q3), wrist up/down (the two q5), as in K. P. Hawkins, "Analytic Inverse
Kinematics for the Universal Robots UR-5/UR-10 Arms" (Georgia Tech, 2013) and its ROS-Industrial
``ur_kinematics`` solver, which number the solutions by the same three choices. Hawkins picks each
choice by the sign of a joint value (q1's root, q3, q5); the signs above are the geometric form of
those choices, so that they do not depend on a table's zero positions or joint directions.

The ``out``/``info`` layouts, the 2 pi variants, the limits and the failure numbers are
``closed_form``'s (its per-branch helpers are shared); ``geometry`` (GEOMETRY_ROWS, 3) holds w, r, c,
X0's rotation and position in closed_form's rows, then the rows derived once per robot (N6 to K).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..chain.compiled import FUSED, POSE, cross, end_pose, inner, kernel, pose_errors, sincos
from . import closed_form
from .closed_form import (AXES, BATCH_SIGNATURE, CENTRE, INFO, N6, POINTS, REACH_SLACK, REACHABLE, SHOULDER_SAMPLES,
                          SINGULAR_TOLERANCE, SOLVE_SIGNATURE, VERIFIED, _add, _angle, _dot, _home_rotation,
                          _keep_nearest, _limit_values, _mm, _mv, _q1_count, _q1_value, _rotate, _rotation_of, _row,
                          _scale, _shoulder, _start, _sub, _t, _variant_count, _wrap, _write_variants, check_target,
                          finish, info_entries, wrist_centre)
from .result import POSITION_TOLERANCE, ROTATION_TOLERANCE

#: Label bits of a branch: shoulder right, elbow up, wrist up.
RIGHT, UP, WRIST_UP = 1, 2, 4
#: Derived rows of ``geometry`` (after closed_form's N6 = 17): a unit vector normal to n (NX); the
#: elbow's subproblem 3 (ELBOW: theta0, |u_p|^2 + |v_p|^2, 2 |u_p| |v_p| with u = r4 - r3, v = r2 - r3);
#: q5's equation n . R5(q5) w6 = a cos q5 + b sin q5 + c (WRIST: a, b, c); SIGNS (s2, s3, s4); K
#: (the shoulder offset K, 0, 0).
NX, ELBOW, WRIST, SIGNS, K = 18, 19, 20, 21, 22
GEOMETRY_ROWS = 23


def pack_geometry(axes: np.ndarray, points: np.ndarray, centre: np.ndarray, X_BE0: np.ndarray) -> np.ndarray:
    """The ``geometry`` array of an arm: unit joint axes (6, 3) and points on them (6, 3) at q = 0
    [m], the wrist point (3,) and the end pose X_BE0 (4, 4) at q = 0, then the derived rows."""
    return closed_form.pack_geometry(axes, points, centre, X_BE0, GEOMETRY_ROWS, _derived_rows)


@inner(fastmath=FUSED)
def _normal(w):
    """A unit vector normal to the unit vector w."""
    n = cross(w, (1.0, 0.0, 0.0) if abs(w[0]) < 0.9 else (0.0, 1.0, 0.0))
    return _scale(1.0 / math.sqrt(_dot(n, n)), n)


@njit(cache=True, fastmath=FUSED)
def _derived_rows(geometry):
    """Rows N6 to K (the module's layout) from the screws at q = 0."""
    n, w3 = _row(geometry, AXES + 1), _row(geometry, AXES + 2)
    w5, w6 = _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    r1, r2, r3, r4 = (_row(geometry, POINTS), _row(geometry, POINTS + 1), _row(geometry, POINTS + 2),
                      _row(geometry, POINTS + 3))
    u, v = _sub(r4, r3), _sub(r2, r3)
    u_p, v_p = _sub(u, _scale(_dot(w3, u), w3)), _sub(v, _scale(_dot(w3, v), w3))
    w6_normal = _sub(w6, _scale(_dot(w6, w5), w5))
    rows = (_normal(w6), _normal(n),
            (math.atan2(_dot(w3, cross(u_p, v_p)), _dot(u_p, v_p)), _dot(u_p, u_p) + _dot(v_p, v_p),
             2.0 * math.sqrt(_dot(u_p, u_p) * _dot(v_p, v_p))),
            (_dot(n, w6_normal), _dot(n, cross(w5, w6)), _dot(w6, w5) * _dot(n, w5)),
            (1.0, _dot(w3, n), _dot(_row(geometry, AXES + 3), n)),
            (_dot(n, _sub(_row(geometry, CENTRE), r1)), 0.0, 0.0))
    for k in range(6):
        for j in range(3):
            geometry[N6 + k, j] = rows[k][j]


@inner(fastmath=FUSED)
def _axis_rotation(w, angle):
    """The rotation (row-major 9-tuple) about the unit axis w by angle [rad]."""
    s, c = sincos(angle)
    t = 1.0 - c
    return (c + t * w[0] * w[0], t * w[0] * w[1] - s * w[2], t * w[0] * w[2] + s * w[1],
            t * w[1] * w[0] + s * w[2], c + t * w[1] * w[1], t * w[1] * w[2] - s * w[0],
            t * w[2] * w[0] - s * w[1], t * w[2] * w[1] + s * w[0], c + t * w[2] * w[2])


@inner(fastmath=FUSED)
def _wrist_roots(geometry, G):
    """q5 = phi5 +- spread5 for G = R1^T R_goal (9-tuple), and whether they exist: n . R5 w6 = n . G w6."""
    a, b, c = _row(geometry, WRIST)
    rho = math.hypot(a, b)
    ratio = (_dot(_row(geometry, AXES + 1), _mv(G, _row(geometry, AXES + 5))) - c) / rho
    return math.atan2(b, a), math.acos(min(max(ratio, -1.0), 1.0)), abs(ratio) <= 1.0 + REACH_SLACK


@inner(fastmath=FUSED)
def _wrist(geometry, G, p_prime, q5, seed6):
    """For one q1 (G = R1^T R_goal, p' the wrist point turned back by q1) and q5: (q6 [rad], theta
    [rad], p4: the wrist 1 point turned back by q1 [m]). With axes 4 and 6 aligned, q6 is the seed's."""
    n, w5, w6 = _row(geometry, AXES + 1), _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    u = _mv(_t(G), n)                                      # n seen from the end frame's turn
    v = _rotate(w5, -q5, n)
    uw = cross(u, w6)
    q6 = seed6 if math.sqrt(_dot(uw, uw)) < SINGULAR_TOLERANCE else _angle(w6, u, v)
    x = _row(geometry, NX)
    turn = _mm(G, _mm(_t(_axis_rotation(w6, q6)), _t(_axis_rotation(w5, q5))))   # Rot(n, theta)
    theta = _angle(n, x, _mv(turn, x))
    c, r4 = _row(geometry, CENTRE), _row(geometry, POINTS + 3)
    return q6, theta, _sub(p_prime, _rotate(n, theta, _sub(c, r4)))


@inner(fastmath=FUSED)
def _elbow_roots(geometry, p4):
    """q3 = theta0 -+ spread3 (elbow roots) putting wrist 1 at p4 (turned back by q1), and whether they exist."""
    theta0, squares, twice_product = _row(geometry, ELBOW)
    n, r2 = _row(geometry, AXES + 1), _row(geometry, POINTS + 1)
    d = _sub(p4, r2)
    along = _dot(n, d)
    kappa = (squares - (_dot(d, d) - along * along)) / twice_product
    return theta0, math.acos(min(max(kappa, -1.0), 1.0)), abs(kappa) <= 1.0 + REACH_SLACK


@inner(fastmath=FUSED)
def _arm(geometry, p4, q3, theta):
    """(q2, q4) for q3, putting wrist 1 at p4 with joints 2-4 turned by theta about n [rad]."""
    w2, w3 = _row(geometry, AXES + 1), _row(geometry, AXES + 2)
    r2, r3, r4 = _row(geometry, POINTS + 1), _row(geometry, POINTS + 2), _row(geometry, POINTS + 3)
    s2, s3, s4 = _row(geometry, SIGNS)
    p3 = _add(r3, _rotate(w3, q3, _sub(r4, r3)))
    q2 = _angle(w2, _sub(p3, r2), _sub(p4, r2))
    return q2, s4 * (theta - s2 * q2 - s3 * q3)


@inner(fastmath=FUSED)
def label_code(geometry, p_wrist, q):
    """RIGHT | UP | WRIST_UP bits (the module's definitions) of configuration q whose wrist point is at
    p_wrist [m]; the tests are made with the arm turned back by q1 (axis 1 keeps its place)."""
    w1, w2, w3 = _row(geometry, AXES), _row(geometry, AXES + 1), _row(geometry, AXES + 2)
    w4, w5, w6 = _row(geometry, AXES + 3), _row(geometry, AXES + 4), _row(geometry, AXES + 5)
    r1, r2, r3, r4 = (_row(geometry, POINTS), _row(geometry, POINTS + 1), _row(geometry, POINTS + 2),
                      _row(geometry, POINTS + 3))
    side = _dot(w1, cross(w2, _rotate(w1, -q[0], _sub(p_wrist, r1))))
    offset = geometry[K, 0]
    code = RIGHT if (side * offset if offset != 0.0 else side) >= 0.0 else 0
    upper = _rotate(w2, q[1], _sub(r3, r2))
    line = _add(upper, _rotate(w2, q[1], _rotate(w3, q[2], _sub(r4, r3))))
    if _dot(w2, cross(line, upper)) * side >= 0.0:
        code |= UP
    if _dot(w5, cross(w4, _rotate(w5, q[4], w6))) >= 0.0:
        code |= WRIST_UP
    return code


@inner(fastmath=FUSED)
def _branches(geometry, X, seed, q1_min, q1_max, Q, reachable):
    """Every branch of target X (4, 4) into Q (8 per q1 value, 6) wrapped into (-pi, pi] and reachable;
    returns how many rows were written. Order per q1: wrist roots, each with elbow roots."""
    R_goal = _mm(_rotation_of(X), _t(_home_rotation(geometry)))
    p_wrist = wrist_centre(geometry, X)
    phi, spread, reach1 = _shoulder(geometry, p_wrist)
    w1, r1 = _row(geometry, AXES), _row(geometry, POINTS)
    m = 0
    for i in range(_q1_count(spread)):
        q1 = _q1_value(i, phi, spread, seed[0], q1_min, q1_max)
        G = _mm(_axis_rotation(w1, -q1), R_goal)
        p_prime = _add(r1, _rotate(w1, -q1, _sub(p_wrist, r1)))
        phi5, spread5, reach5 = _wrist_roots(geometry, G)
        for j in range(2):
            q5 = phi5 + (spread5 if j == 0 else -spread5)
            q6, theta, p4 = _wrist(geometry, G, p_prime, q5, seed[5])
            theta0, spread3, reach3 = _elbow_roots(geometry, p4)
            for k in range(2):
                q3 = theta0 + (-spread3 if k == 0 else spread3)
                q2, q4 = _arm(geometry, p4, q3, theta)
                raw = (_wrap(q1), _wrap(q2), _wrap(q3), _wrap(q4), _wrap(q5), _wrap(q6))
                for c in range(6):
                    Q[m, c] = raw[c]
                reachable[m] = reach1 and reach5 and reach3
                m += 1
    return m


@njit(cache=True, fastmath=FUSED)
def raw_branches(geometry, X, seed, q1_min, q1_max):
    """Every closed-form branch of target X (4, 4): (Q (B, 6) wrapped into (-pi, pi], reachable (B,)),
    B = 8 per q1 value (8 away from a shoulder singularity)."""
    count = 8 * _q1_count(_shoulder(geometry, wrist_centre(geometry, X))[1])
    Q = np.empty((count, 6))
    reachable = np.zeros(count, dtype=np.bool_)
    _branches(geometry, X, seed, q1_min, q1_max, Q, reachable)
    return Q, reachable


@kernel(SOLVE_SIGNATURE, fastmath=FUSED)
def solve_one(geometry, chain, limits, X, seed, out):
    """Every in-limit, FK-verified solution of target X (4, 4) nearest seed (6,) first, into out;
    returns the target's ``info`` entries (``closed_form.solve_one``'s contract)."""
    check_target(X, seed)
    info = np.empty(INFO)
    values, counts, q, best, best_error = _start(out, info)
    Q = np.empty((8 * (SHOULDER_SAMPLES + 1), 6))
    reachable = np.zeros(Q.shape[0], dtype=np.bool_)
    branches = _branches(geometry, X, seed, limits[0, 0], limits[1, 0], Q, reachable)
    p_wrist = wrist_centre(geometry, X)
    m = np.int64(0)                          # not the literal 0: the helpers m goes to would compile twice
    for b in range(branches):
        if not reachable[b]:
            continue
        raw = (Q[b, 0], Q[b, 1], Q[b, 2], Q[b, 3], Q[b, 4], Q[b, 5])
        info[REACHABLE] += 1
        e_p, e_r = pose_errors(end_pose(chain, Q[b]), X, POSE)
        _keep_nearest(raw, e_p, e_r, best, best_error)
        if e_p > POSITION_TOLERANCE or e_r > ROTATION_TOLERANCE:
            continue
        info[VERIFIED] += 1
        total = _limit_values(raw, seed, limits, values, counts, info)
        if total > 0:
            m = _write_variants(chain, limits, X, values, counts, total, e_p, e_r, label_code(geometry, p_wrist, raw),
                                _variant_count(raw, limits), q, out, m)
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
    """codes (N,) = the label code of each configuration Q (N, 6), its wrist point by the compiled FK."""
    X = np.empty((4, 4))
    for n in range(Q.shape[0]):
        x = end_pose(chain, Q[n])
        for k in range(12):
            X[k // 4, k % 4] = x[k]
        codes[n] = label_code(geometry, wrist_centre(geometry, X), Q[n])
