"""Compiled (Numba) kinematics of a DH chain: FK, the Jacobian and their batches.

The chain is ``X_BE(q) = K_0 M_1(v_1) K_1 ... M_n(v_n) K_n`` with constant transforms ``K_i`` and
``M_i`` a rotation about z (revolute) or a translation along z (prismatic) by ``v_i = sign_i q_i``; the
same constants as ``pipeline.model.chain.kinematics.DhKinematics`` (the NumPy oracle these are checked against),
which evaluates them another way. Applying ``M_i`` mixes two columns (or adds one into the
translation), so each joint costs a column update and one dense compose.

A chain is one float array ``chain`` (dof + 1, CHAIN_COLUMNS): row i holds the 12 entries of K_i's top
three rows, row by row, then (rows 1 to dof) joint i's sign and kind (1.0 revolute, 0.0 prismatic).

Poses travel between kernels as ``Pose`` tuples: the 12 entries of the top three rows of a 4x4
transform, row by row (the last row is always 0 0 0 1), so no kernel allocates on the way.

The kernels Python calls (``kernel``) write into arrays the caller allocates (returning a new array from a
kernel costs more than the FK itself) and have one signature each, compiled on their first call (not on
import: a process compiles only the kernels it uses) and cached on disk beside this file. The arrays a
caller brings (joint values, target poses, seeds) are declared with any layout and read-only, so C-ordered,
Fortran-ordered (Drake's ``GetAsMatrix4()``), strided and read-only float64 arrays all enter the same machine
code; the arrays ``Robot`` allocates are C-contiguous. Any other input raises TypeError, a bad length or value
ValueError; ``pipeline.model.robot.Robot`` then checks it for the typed error that names it.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.core import config
from numba.core.compiler_lock import global_compiler_lock
from numba.core.registry import CPUDispatcher

from ...files.arrays import MAX_MAGNITUDE

#: Array types of kernel signatures: float64 arrays the pipeline allocates (C-contiguous, 2- and 3-d) and
#: float64 arrays a caller brings, which the kernels only read (any layout, read-only or not; 1-, 2- and 3-d).
MATRIX, STACK = "float64[:, ::1]", "float64[:, :, ::1]"
ANY_VECTOR, ANY_MATRIX, ANY_STACK = (f"Array(float64, {ndim}, 'A', readonly=True)" for ndim in (1, 2, 3))
#: Kernels whose products and sums may fuse into FMA instructions (as exact or more; never reordered).
FUSED = {"contract"}
#: Columns of a chain row: K_i (12), then joint i's sign and kind.
SIGN, REVOLUTE = 12, 13
CHAIN_COLUMNS = 14


class _InnerDispatcher(CPUDispatcher):
    """The dispatcher of an ``inner`` function: called from Python it raises TypeError (its machine code has no
    entry point for Python: Numba would jump to none)."""

    def __call__(self, *args, **kws):
        raise TypeError(f"{self.py_func.__qualname__} is compiled for kernels only: call it from compiled code")


def inner(**options):
    """Decorator of the functions only compiled code calls: ``njit(cache=True, **options)`` without the entry
    points Python would call them through (building those is most of a small function's compile time: a few
    hundredths of a second rather than about a tenth)."""
    def decorate(function):
        if config.DISABLE_JIT:                         # as njit does: the function runs as written
            return function
        dispatcher = _InnerDispatcher(py_func=function, locals={}, targetoptions={
            "nopython": True, "no_cpython_wrapper": True, "no_cfunc_wrapper": True, **options})
        dispatcher.enable_caching()
        return dispatcher

    return decorate


def kernel(signature: str, **options):
    """Decorator: ``njit(cache=True, **options)`` compiled for ``signature`` alone, when it is first called
    (from Python or from another kernel; loaded from the disk cache when it is there) rather than on
    import, and never again for other argument types: they are converted to the signature's (a
    C-ordered array to an any-layout one) or refused with TypeError. One specialisation, whatever layouts
    the callers bring. (Numba's own ``njit(signature)`` compiles on import; its lazy ``njit`` compiles one
    specialisation per layout it meets.)"""
    def decorate(function):
        dispatcher = njit(cache=True, **options)(function)
        if config.DISABLE_JIT:                         # njit gave the function back: it runs as written
            return dispatcher
        dispatcher.kernel_signature = signature        # what ``pipeline.model.ik.prebuilt`` builds ahead of time
        compile_signature = dispatcher.compile

        def compile_once(*_requested):
            with global_compiler_lock:                 # one compile when threads call it first together
                if not dispatcher.signatures:
                    compile_signature(signature)
                    dispatcher.disable_compile()

        # Numba asks these two for a new specialisation: ``compile`` when a kernel calling this one is
        # typed, ``_compile_for_args`` (then calls what it returns) when Python's arguments match none.
        dispatcher.compile = compile_once
        dispatcher._compile_for_args = lambda *args, **kws: compile_once() or dispatcher
        return dispatcher

    return decorate


def pack_chain(K: np.ndarray, sign: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """The chain of constant factors K (dof + 1, 4, 4) and each joint's sign and kind (dof,)."""
    chain = np.zeros((len(K), CHAIN_COLUMNS))
    chain[:, :12] = K[:, :3, :].reshape(len(K), 12)
    chain[1:, SIGN], chain[1:, REVOLUTE] = sign, revolute
    return chain


# -- sin and cos together: the joint angles' trigonometry is most of FK's time --------------------
# Polynomials and the two-step reduction by pi/2 are those of fdlibm (k_sin.c, k_cos.c, e_rem_pio2.c),
# in musl's arrangement; fdlibm's notice: "Copyright (C) 1993 by Sun Microsystems, Inc. All rights
# reserved. Developed at SunSoft, a Sun Microsystems, Inc. business. Permission to use, copy, modify,
# and distribute this software is freely granted, provided that this notice is preserved."
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_TO_INTEGER = 1.5 / np.finfo(float).eps              # x + this - this rounds x to an integer
_TWO_OVER_PI = 6.36619772367581382433e-01
_PI_2_HIGH, _PI_2_MIDDLE, _PI_2_LOW = 1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624879595063154e-21
#: Beyond this |angle| [rad], ``sincos`` leaves the reduction to the C library's sin and cos.
SINCOS_RANGE = 1.0e6


@njit(cache=True, inline="always")
def sincos(angle):
    """(sin, cos) of an angle [rad], within 1 ulp of ``math.sin`` / ``math.cos`` and about twice as fast
    (no call, no branch on the quadrant)."""
    if not abs(angle) <= SINCOS_RANGE:                 # also NaN and inf
        return math.sin(angle), math.cos(angle)
    turns = angle * _TWO_OVER_PI + _TO_INTEGER - _TO_INTEGER  # the nearest multiple of pi/2
    quadrant = int(turns)
    high = angle - turns * _PI_2_HIGH                  # exact: _PI_2_HIGH has 33 bits
    w = turns * _PI_2_MIDDLE
    r = high - w
    w = turns * _PI_2_LOW - ((high - r) - w)
    y = r - w                                          # angle - quadrant pi/2 = y + tail, |y| <= pi/4
    tail = (r - y) - w
    z = y * y
    zz = z * z
    v = z * y
    rs = _S2 + z * (_S3 + z * _S4) + z * zz * (_S5 + z * _S6)
    sin = y - ((z * (0.5 * tail - v * rs) - tail) - v * _S1)
    rc = z * (_C1 + z * (_C2 + z * _C3)) + zz * zz * (_C4 + z * (_C5 + z * _C6))
    half = 0.5 * z
    one = 1.0 - half
    cos = one + (((1.0 - one) - half) + (z * rc - y * tail))
    odd = quadrant & 1
    return (1.0 - (quadrant & 2)) * (cos if odd else sin), (1.0 - ((quadrant + 1) & 2)) * (sin if odd else cos)


@inner()
def cross(a, b):
    """a x b of two 3-vectors (tuples or arrays) -> tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@inner()
def unit(v):
    """The 3-vector v (tuple or array) divided by its length -> tuple."""
    norm = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / norm, v[1] / norm, v[2] / norm)


@njit(cache=True)
def check_configuration(q, dof):
    """ValueError unless q has dof values, each finite and at most MAX_MAGNITUDE."""
    if q.shape[0] != dof:
        raise ValueError("wrong number of joint values")
    for value in q:
        if not abs(value) <= MAX_MAGNITUDE:          # also False for NaN
            raise ValueError("joint value not finite or too large")


@inner()
def _constant(chain, i):
    """The Pose of K_i."""
    return (chain[i, 0], chain[i, 1], chain[i, 2], chain[i, 3], chain[i, 4], chain[i, 5], chain[i, 6], chain[i, 7],
            chain[i, 8], chain[i, 9], chain[i, 10], chain[i, 11])


@inner(fastmath=FUSED)
def _moved(chain, i, x, value):
    """The Pose x M_i K_i (i from 1) at joint i's value [rad or m]."""
    v = chain[i, SIGN] * value
    if chain[i, REVOLUTE] > 0.5:                                  # x Rz(v): columns 0 and 1 turn
        s, c = sincos(v)
        x = (c * x[0] + s * x[1], c * x[1] - s * x[0], x[2], x[3], c * x[4] + s * x[5], c * x[5] - s * x[4], x[6], x[7],
             c * x[8] + s * x[9], c * x[9] - s * x[8], x[10], x[11])
    else:                                                         # x Tz(v): along column 2
        x = (x[0], x[1], x[2], x[3] + v * x[2], x[4], x[5], x[6], x[7] + v * x[6], x[8], x[9], x[10], x[11] + v * x[10])
    return compose(x, _constant(chain, i))


@inner(fastmath=FUSED)
def compose(x, a):
    """The Pose x a."""
    return (x[0] * a[0] + x[1] * a[4] + x[2] * a[8], x[0] * a[1] + x[1] * a[5] + x[2] * a[9],
            x[0] * a[2] + x[1] * a[6] + x[2] * a[10], x[0] * a[3] + x[1] * a[7] + x[2] * a[11] + x[3],
            x[4] * a[0] + x[5] * a[4] + x[6] * a[8], x[4] * a[1] + x[5] * a[5] + x[6] * a[9],
            x[4] * a[2] + x[5] * a[6] + x[6] * a[10], x[4] * a[3] + x[5] * a[7] + x[6] * a[11] + x[7],
            x[8] * a[0] + x[9] * a[4] + x[10] * a[8], x[8] * a[1] + x[9] * a[5] + x[10] * a[9],
            x[8] * a[2] + x[9] * a[6] + x[10] * a[10], x[8] * a[3] + x[9] * a[7] + x[10] * a[11] + x[11])


@inner()
def end_pose(chain, q):
    """The Pose X_BE(q) [m]; q already checked."""
    return moved_pose(chain, base_pose(chain), q, 0, q.shape[0])


@inner()
def base_pose(chain):
    """The Pose K_0: where the chain starts."""
    return _constant(chain, 0)


@inner()
def moved_pose(chain, x, q, first, stop):
    """The Pose x carried through joints first to stop - 1 (counted from 0) at their values in q (an
    array or tuple): the end pose from a pose part way along the chain."""
    for i in range(first, stop):
        x = _moved(chain, i + 1, x, q[i])
    return x


@inner()
def _write_pose(x, X):
    """X (4, 4) = the Pose x."""
    for k in range(12):
        X[k // 4, k % 4] = x[k]
    X[3, 0], X[3, 1], X[3, 2], X[3, 3] = 0.0, 0.0, 0.0, 1.0


@inner(fastmath=FUSED)
def pose_and_jacobian(chain, q, J):
    """The Pose X_BE(q) [m], with J (6, dof) set to its geometric Jacobian, rows [v; w], base frame, at
    E's origin; q already checked."""
    x = base_pose(chain)
    for i in range(q.shape[0]):                        # J[:3] holds joint origins until the end is known
        sign = chain[i + 1, SIGN]
        J[3, i], J[4, i], J[5, i] = x[2] * sign, x[6] * sign, x[10] * sign
        J[0, i], J[1, i], J[2, i] = x[3], x[7], x[11]
        x = _moved(chain, i + 1, x, q[i])
    for i in range(q.shape[0]):
        ax, ay, az = J[3, i], J[4, i], J[5, i]
        if chain[i + 1, REVOLUTE] > 0.5:
            lx, ly, lz = x[3] - J[0, i], x[7] - J[1, i], x[11] - J[2, i]
            J[0, i], J[1, i], J[2, i] = ay * lz - az * ly, az * lx - ax * lz, ax * ly - ay * lx
        else:
            J[0, i], J[1, i], J[2, i] = ax, ay, az
            J[3, i], J[4, i], J[5, i] = 0.0, 0.0, 0.0
    return x


#: Target kinds as the kernels take them: full pose, position and the z axis, position only.
POSE, POSITION_AND_AXIS, POSITION = 0, 1, 2


@inner()
def _relative(x, X_target):
    """E = R^T R_target (row-major 9-tuple), R the rotation of the Pose x and R_target that of X_target (4, 4)."""
    return (x[0] * X_target[0, 0] + x[4] * X_target[1, 0] + x[8] * X_target[2, 0],
            x[0] * X_target[0, 1] + x[4] * X_target[1, 1] + x[8] * X_target[2, 1],
            x[0] * X_target[0, 2] + x[4] * X_target[1, 2] + x[8] * X_target[2, 2],
            x[1] * X_target[0, 0] + x[5] * X_target[1, 0] + x[9] * X_target[2, 0],
            x[1] * X_target[0, 1] + x[5] * X_target[1, 1] + x[9] * X_target[2, 1],
            x[1] * X_target[0, 2] + x[5] * X_target[1, 2] + x[9] * X_target[2, 2],
            x[2] * X_target[0, 0] + x[6] * X_target[1, 0] + x[10] * X_target[2, 0],
            x[2] * X_target[0, 1] + x[6] * X_target[1, 1] + x[10] * X_target[2, 1],
            x[2] * X_target[0, 2] + x[6] * X_target[1, 2] + x[10] * X_target[2, 2])


@inner()
def pose_errors(x, X_target, kind):
    """(position error [m], rotation error [rad]) of the Pose x against X_target (4, 4) for the target
    kind: the rotation angle between them (POSE), the angle between their z axes (POSITION_AND_AXIS),
    0 (POSITION). As ``pipeline.model.ik.result.pose_errors``."""
    dx, dy, dz = x[3] - X_target[0, 3], x[7] - X_target[1, 3], x[11] - X_target[2, 3]
    position_error = math.sqrt(dx * dx + dy * dy + dz * dz)
    if kind == POSE:                                   # E = R^T R_target: its angle, accurate near 0
        E = _relative(x, X_target)
        sx, sy, sz = E[7] - E[5], E[2] - E[6], E[3] - E[1]
        trace = E[0] + E[4] + E[8]
        return position_error, math.atan2(0.5 * math.sqrt(sx * sx + sy * sy + sz * sz), 0.5 * (trace - 1.0))
    if kind == POSITION_AND_AXIS:
        z, z_target = (x[2], x[6], x[10]), (X_target[0, 2], X_target[1, 2], X_target[2, 2])
        n = cross(z, z_target)
        return position_error, math.atan2(math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]),
                                          z[0] * z_target[0] + z[1] * z_target[1] + z[2] * z_target[2])
    return position_error, 0.0


@kernel(f"void({MATRIX}, {ANY_VECTOR}, {MATRIX})")
def fk_into(chain, q, X):
    """X (4, 4) = X_BE [m] at one configuration q (dof,)."""
    check_configuration(q, chain.shape[0] - 1)
    _write_pose(end_pose(chain, q), X)


@kernel(f"void({MATRIX}, {ANY_MATRIX}, {STACK})")
def fk_batch_into(chain, Q, out):
    """out (N, 4, 4) = X_BE [m] for configurations Q (N, dof)."""
    for n in range(Q.shape[0]):
        check_configuration(Q[n], chain.shape[0] - 1)
        _write_pose(end_pose(chain, Q[n]), out[n])


@kernel(f"void({MATRIX}, {ANY_VECTOR}, {MATRIX})")
def jacobian_into(chain, q, J):
    """J (6, dof) = the geometric Jacobian at one configuration q (dof,)."""
    check_configuration(q, chain.shape[0] - 1)
    pose_and_jacobian(chain, q, J)


@kernel(f"void({MATRIX}, {ANY_VECTOR}, {MATRIX}, {MATRIX})")
def fk_and_jacobian_into(chain, q, X, J):
    """X (4, 4) = X_BE [m] and J (6, dof) its Jacobian, from one pass along the chain."""
    check_configuration(q, chain.shape[0] - 1)
    _write_pose(pose_and_jacobian(chain, q, J), X)


@kernel(f"void({MATRIX}, {ANY_MATRIX}, {STACK})")
def jacobian_batch_into(chain, Q, out):
    """out (N, 6, dof) = the geometric Jacobians at configurations Q (N, dof)."""
    for n in range(Q.shape[0]):
        check_configuration(Q[n], chain.shape[0] - 1)
        pose_and_jacobian(chain, Q[n], out[n])
