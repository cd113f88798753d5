"""Joint waypoints -> a geometric joint path q(s), s in [0, 1], with its first three derivatives.

Three shapes, each parameterised by cumulative joint-space chord length:

- ``monotone`` (the default): a shape-preserving C3 curve through every waypoint. Each segment is a
  septic Hermite piece with the waypoints' values, knot slopes limited per joint to 1.25 x the
  smaller neighbouring secant slope with the secants' sign (zero at a local extremum of the joint),
  zero third derivative, and zero second derivative except where the joint turns (a local extremum:
  there it curves like a parabola, 3 x the smaller |rise| / length^2, so that a waypoint where every
  joint turns is a clean reversal of the path, not a cusp). On a segment normalised to rise 1 over
  length 1, with slopes alpha, beta in [0, 1.25] and second derivatives gamma0 in [0, 3] (only where
  alpha = 0) and gamma1 in [-3, 0] (only where beta = 0), dq/dt is linear in (alpha, beta, gamma0,
  gamma1) and >= 0 at every corner of that set (checked in tests/timing/test_joint_path.py; it stays >= 0 up to
  slopes 1.8 and turns 14), so >= 0 on all of it: every joint is monotone between neighbouring
  waypoints. The path never leaves the box the waypoints span, so never leaves the joint limits
  when they are inside them, and its jerk along the path is continuous, as jerk-limited path
  following needs.
- ``spline``: a C2 cubic spline through every waypoint (not-a-knot ends: a clamped spline's zero
  slope at the ends costs toppra ~3x the discretisation gap), parameterised by cumulative
  joint-space chord length. A spline can overshoot between waypoints, so it is sampled
  densely and rejected, naming the segment and the joint, if it leaves the joint limits.
- ``linear``: straight segments in joint space with each interior corner rounded by a quadratic
  blend (C1: d2q/ds2 jumps, so not for jerk-limited timing). It never leaves the limits (the box of
  limits is convex), passes through the first and last waypoints exactly and within the blend of
  each interior one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

from ..errors import TimingError
from ..files.choices import DEFAULT_PATH_SHAPE, PATH_SHAPES

SHAPES = PATH_SHAPES
#: Fraction of the shorter neighbouring segment used by each corner blend of a linear path.
DEFAULT_BLEND = 0.2
#: Each shape's smoothness: the highest derivative of q(s) that is continuous (``samples``: the C2 spline
#: through dense IK samples of a tool move, ``path_through_samples``).
CONTINUITY = {"monotone": 3, "spline": 2, "linear": 1, "samples": 2}
#: How far a spline may pass a joint limit (round-off) before it is refused [rad or m].
LIMIT_SLACK = 1e-12
#: Samples per segment when checking that a spline stays inside the joint limits, and segments checked at once.
LIMIT_CHECK_SAMPLES = 200
LIMIT_CHECK_SEGMENTS = 500
#: Waypoints closer than this (joint-space norm) to the last one kept are one waypoint [rad or m]:
#: far below any controller resolution, and a curve through two such knots would swing wildly between
#: them. The last waypoint is always kept (it replaces the last one kept when they are that close).
DUPLICATE_DISTANCE = 1e-6
#: Waypoints that all lie this close to the first one are no motion at all [rad or m].
NO_MOTION_DISTANCE = 1e-9
#: Knot slopes of the monotone shape are at most this times the smaller neighbouring secant slope:
#: the bound under which every segment is monotone (see the module docstring) [1].
MONOTONE_SLOPE_LIMIT = 1.25
#: Second derivative of the monotone shape at a joint's local extremum, in units of the smaller
#: |rise| / length^2 of the two segments there (see the module docstring) [1].
MONOTONE_TURN = 3.0


class PathError(TimingError):
    """A path cannot be built from the waypoints (names the waypoint or segment and the joint)."""


@dataclass(frozen=True, eq=False)
class JointPath:
    """A geometric path: ``q(s)`` and its derivatives for s in [0, 1] (arrays broadcast over s).

    ``waypoints`` (K, dof) after merging duplicates, ``s_waypoints`` (K,) their path parameters,
    ``breakpoints``: every s where a derivative of the path may jump (knots, blend ends), ``shape``,
    ``length`` the joint-space chord length [rad or m], ``continuity``: the highest continuous
    derivative across breakpoints (3: monotone, 2: spline, 1: linear); between them every path is a polynomial.
    """

    waypoints: np.ndarray
    s_waypoints: np.ndarray
    breakpoints: np.ndarray
    shape: str
    length: float
    continuity: int
    _pieces: object

    @property
    def dof(self) -> int:
        return self.waypoints.shape[1]

    def __call__(self, s, order: int = 0) -> np.ndarray:
        """q (order 0), dq/ds (1), d2q/ds2 (2) or d3q/ds3 (3: between breakpoints, where every path is a
        polynomial; continuous across them from C3 on) at s (scalar or (n,)) -> (dof,) or (n, dof)."""
        if order not in (0, 1, 2, 3):
            raise PathError(f"the {self.shape} path has no derivative of order {order}")
        return self._pieces(np.clip(s, 0.0, 1.0), order)


def kept_indices(waypoints: np.ndarray) -> np.ndarray:
    """The indices of the waypoints duplicate merging keeps: those beyond DUPLICATE_DISTANCE of the last
    one kept, and always the last waypoint (replacing the last one kept when they are that close, unless
    that is the first; then kept beside it unless within NO_MOTION_DISTANCE). A waypoint beyond that distance
    of the one before, itself kept, is kept: only the runs that start with a shorter step are looked at one
    by one, each up to its first waypoint kept."""
    count = len(waypoints)
    keep = np.ones(count, dtype=bool)
    looked = 0
    for start in np.flatnonzero(np.linalg.norm(np.diff(waypoints, axis=0), axis=1) <= DUPLICATE_DISTANCE) + 1:
        if start <= looked:
            continue
        reference, looked = start - 1, start        # the waypoint before is kept (a run ends at one kept)
        while looked < count:
            keep[looked] = np.linalg.norm(waypoints[looked] - waypoints[reference]) > DUPLICATE_DISTANCE
            if keep[looked]:
                break
            looked += 1
    kept = np.flatnonzero(keep)
    if kept[-1] != count - 1:
        if len(kept) > 1:
            kept[-1] = count - 1
        elif np.linalg.norm(waypoints[-1] - waypoints[0]) > NO_MOTION_DISTANCE:
            kept = np.append(kept, count - 1)
    return kept


def merge_duplicates(waypoints: np.ndarray) -> np.ndarray:
    """The waypoints ``kept_indices`` keeps."""
    return waypoints[kept_indices(waypoints)]


def check_waypoints(waypoints, q_min: np.ndarray, q_max: np.ndarray) -> np.ndarray:
    """Validate joint waypoints (K >= 2, dof) [rad or m]: finite and inside the limits; PathError names
    the waypoint and joint."""
    waypoints = np.asarray(waypoints, dtype=float)
    if waypoints.ndim != 2 or waypoints.shape[1] != q_min.size:
        raise PathError(f"waypoints must have shape (K, {q_min.size}), got {waypoints.shape}")
    if len(waypoints) < 2:
        raise PathError(f"a path needs at least 2 waypoints, got {len(waypoints)}")
    finite = np.isfinite(waypoints).all(axis=1)
    bad = np.flatnonzero(~finite | ((waypoints < q_min) | (waypoints > q_max)).any(axis=1))
    if bad.size:
        k = int(bad[0])
        q = waypoints[k]
        if not finite[k]:
            raise PathError(f"waypoint {k} has non-finite values: {q}")
        j = int(np.flatnonzero((q < q_min) | (q > q_max))[0])
        raise PathError(f"waypoint {k}: joint {j + 1} = {q[j]:.6g} is outside its limits "
                        f"[{q_min[j]:.6g}, {q_max[j]:.6g}]")
    return waypoints


def _spline_pieces(s_knots: np.ndarray, waypoints: np.ndarray):
    if len(s_knots) == 3:
        return _polynomial_pieces(_parabola(s_knots, waypoints))
    cubic = CubicSpline(s_knots, waypoints, bc_type="not-a-knot" if len(s_knots) > 2 else "natural", axis=0)
    return _polynomial_pieces(cubic)


def _parabola(s_knots: np.ndarray, waypoints: np.ndarray) -> PPoly:
    """The not-a-knot cubic spline through three knots, the parabola through them, made directly (SciPy's
    CubicSpline solves a dense 3 x 3 system for it, 1-5 ms through its batched solver)."""
    h = np.diff(s_knots)
    first, second = (waypoints[1] - waypoints[0]) / h[0], (waypoints[2] - waypoints[1]) / h[1]
    curvature = (second - first) / (s_knots[2] - s_knots[0])
    zero = np.zeros_like(curvature)
    c = np.array([[zero, zero], [curvature, curvature], [first - curvature * h[0], first + curvature * h[0]],
                  [waypoints[0], waypoints[1]]])
    return PPoly(c, s_knots)


def _polynomial_pieces(poly: PPoly):
    """``(s, order) -> derivative`` of a piecewise polynomial, the derivatives made once."""
    derivatives = (poly, poly.derivative(1), poly.derivative(2), poly.derivative(3))
    return lambda s, order: derivatives[order](s)


def monotone_knots(s_knots: np.ndarray, waypoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knot slopes dq/ds and second derivatives d2q/ds2 (K, dof) of the monotone shape.

    Slopes: the weighted harmonic mean of the neighbouring secants (as PCHIP), limited to
    MONOTONE_SLOPE_LIMIT x the smaller one, zero where the secants differ in sign or one is zero; the end
    slopes are the end secants. Second derivatives: zero, except at a strict local extremum of a joint,
    where the joint turns like a parabola, d2q/ds2 = MONOTONE_TURN x the smaller |rise| / length^2 of
    the two segments, towards the inside (so that a waypoint where every joint turns is a clean
    reversal of the path, not a cusp with dq/ds = d2q/ds2 = 0).
    """
    h = np.diff(s_knots)[:, None]
    rises = np.diff(waypoints, axis=0)
    secants = rises / h
    left, right = secants[:-1], secants[1:]
    w_left, w_right = 2.0 * h[1:] + h[:-1], h[1:] + 2.0 * h[:-1]
    same_sign = left * right > 0.0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):   # 0 or tiny secants: no slope
        harmonic = (w_left + w_right) / (w_left / left + w_right / right)
    bound = MONOTONE_SLOPE_LIMIT * np.minimum(np.abs(left), np.abs(right))
    interior_slopes = np.where(same_sign, np.sign(left) * np.minimum(np.abs(harmonic), bound), 0.0)
    turn = MONOTONE_TURN * np.minimum(np.abs(rises[:-1]) / h[:-1] ** 2, np.abs(rises[1:]) / h[1:] ** 2)
    interior_turns = np.where(left * right < 0.0, np.sign(right) * turn, 0.0)
    zero = np.zeros((1, waypoints.shape[1]))
    return (np.concatenate([secants[:1], interior_slopes, secants[-1:]]),
            np.concatenate([zero, interior_turns, zero]))


def hermite_matrix(degree: int) -> np.ndarray:
    """M (degree + 1, degree + 1): the monomial coefficients on t in [0, 1] of the Hermite polynomial
    whose derivatives 0 .. degree // 2 at t = 0, then at t = 1, are the vector they multiply."""
    orders = range((degree + 1) // 2)
    powers = np.arange(degree + 1)

    def row(t: float, k: int) -> np.ndarray:
        falling = np.prod([powers - i for i in range(k)], axis=0) if k else np.ones(degree + 1)
        return falling * np.where(powers >= k, t ** np.maximum(powers - k, 0), 0.0)

    return np.linalg.inv(np.array([row(0.0, k) for k in orders] + [row(1.0, k) for k in orders]))


#: The septic Hermite basis (values, slopes, second and third derivatives at both ends).
SEPTIC = hermite_matrix(7)


def _monotone_pieces(s_knots: np.ndarray, waypoints: np.ndarray):
    """Septic Hermite pieces with the knot values, the slopes m and second derivatives a of
    ``monotone_knots`` and zero third derivatives (so the pieces join C3)."""
    m, a = monotone_knots(s_knots, waypoints)
    h = np.diff(s_knots)[:, None]
    zero = np.zeros_like(h * m[:-1])
    # Relative to each segment's start value (the rise, not two large values, enters the polynomial).
    ends = np.stack([zero, m[:-1] * h, a[:-1] * h**2, zero,
                     np.diff(waypoints, axis=0), m[1:] * h, a[1:] * h**2, zero])  # (8, K-1, dof), in t = x / h
    in_t = np.einsum("nk,kij->nij", SEPTIC, ends)                               # coefficient of t^n
    in_t[0] += waypoints[:-1]
    in_x = in_t / h[None] ** np.arange(8)[:, None, None]
    derivatives = _polynomial_pieces(PPoly(in_x[::-1], s_knots))
    low, high = np.minimum(waypoints[:-1], waypoints[1:]), np.maximum(waypoints[:-1], waypoints[1:])

    def evaluate(s, order):
        if order > 0:
            return derivatives(s, order)
        # Each segment is monotone, so it lies between its end values: clipping removes round-off only.
        k = np.clip(np.searchsorted(s_knots, s, side="right") - 1, 0, len(h) - 1)
        return np.clip(derivatives(s, 0), low[k], high[k])

    return evaluate


def _blend_pieces(s_knots: np.ndarray, waypoints: np.ndarray, blend: float):
    """Linear segments with a quadratic blend of half-width b_i around each interior knot i.

    Inside a blend (u = s - s_i + b_i in [0, 2 b_i]) the slope turns linearly from the incoming to the
    outgoing segment's: q = w_i - m_in b_i + m_in u + (m_out - m_in) u^2 / (4 b_i). The blends do not overlap
    (b_i <= blend x the shorter neighbouring segment, blend <= 1/2), so each s is in at most one, found by
    bisection: an evaluation costs O(n log K) for n values of s and K knots.
    """
    ds = np.diff(s_knots)
    slopes = np.diff(waypoints, axis=0) / ds[:, None]                        # dq/ds of each segment
    half = blend * np.minimum(ds[:-1], ds[1:])                               # b_i of interior knot i = 1 .. K-2
    starts = s_knots[1:-1] - half

    def evaluate(s, order):
        s = np.asarray(s, dtype=float)
        flat = np.atleast_1d(s)
        k = np.clip(np.searchsorted(s_knots, flat, side="right") - 1, 0, len(ds) - 1)
        if order == 0:
            out = waypoints[k] + slopes[k] * (flat - s_knots[k])[:, None]
        elif order == 1:
            out = slopes[k]
        else:
            out = np.zeros((flat.size, waypoints.shape[1]))
        j = np.searchsorted(starts, flat, side="right") - 1                 # the blend that starts last at or before s
        candidate = np.flatnonzero(j >= 0)
        b = half[j[candidate]]
        u = flat[candidate] - starts[j[candidate]]
        inside = (b > 0.0) & (u < 2.0 * b)                   # at a breakpoint: the piece that starts there
        rows, i, b, uu = candidate[inside], j[candidate][inside] + 1, b[inside][:, None], u[inside][:, None]
        m_in, m_out = slopes[i - 1], slopes[i]
        turn = (m_out - m_in) / (2.0 * b)
        if order == 0:
            out[rows] = waypoints[i] - m_in * b + m_in * uu + turn * uu**2 / 2.0
        elif order == 1:
            out[rows] = m_in + turn * uu
        elif order == 2:
            out[rows] = turn
        return out[0] if s.ndim == 0 else out

    return evaluate


def make_path(waypoints, q_min: np.ndarray, q_max: np.ndarray, shape: str = DEFAULT_PATH_SHAPE,
              blend: float = DEFAULT_BLEND) -> JointPath:
    """A geometric path through joint waypoints (K, dof) [rad or m], checked against the limits (a
    continuous joint's -inf, +inf never bind; ``blend``: the corner blend of the ``linear`` shape)."""
    if shape not in SHAPES:
        raise PathError(f"path shape must be one of {', '.join(SHAPES)}, got {shape!r}")
    if not 0.0 <= blend <= 0.5:
        raise PathError(f"blend must be in [0, 0.5], got {blend}")
    waypoints = merge_duplicates(check_waypoints(waypoints, q_min, q_max))
    if len(waypoints) < 2:
        raise PathError(f"all waypoints are the same configuration (within {NO_MOTION_DISTANCE:g}): there is no "
                        "motion to time")
    s_knots, length = chord_knots(chords_of(waypoints))
    if shape == "linear":
        pieces = _blend_pieces(s_knots, waypoints, blend)
        half = blend * np.minimum(np.diff(s_knots)[:-1], np.diff(s_knots)[1:])
        breakpoints = np.unique(np.concatenate([s_knots, s_knots[1:-1] - half, s_knots[1:-1] + half]))
    else:
        pieces = (_spline_pieces if shape == "spline" else _monotone_pieces)(s_knots, waypoints)
        breakpoints = s_knots
    path = JointPath(waypoints, s_knots, breakpoints, shape, length, CONTINUITY[shape], pieces)
    if shape == "spline":
        _check_spline_limits(path, q_min, q_max)
    return path


def chords_of(waypoints: np.ndarray) -> np.ndarray:
    """(K - 1,) the joint-space lengths of the segments between consecutive waypoints (K, dof) [rad or m]."""
    return np.linalg.norm(np.diff(waypoints, axis=0), axis=1)


def chord_knots(chords: np.ndarray) -> tuple[np.ndarray, float]:
    """The path parameters (K,) of waypoints ``chords`` apart (K - 1,), from 0 to 1 by cumulative chord length, and
    that length [rad or m] (> 0)."""
    length = float(chords.sum())
    s_knots = np.concatenate([[0.0], np.cumsum(chords) / length])
    s_knots[-1] = 1.0
    return s_knots, length


def path_through_samples(s_knots: np.ndarray, samples: np.ndarray) -> JointPath:
    """The C2 cubic spline (not-a-knot) through dense joint samples (K, dof) [rad or m] at path
    parameters ``s_knots`` (K,), increasing from 0 to 1: the joint path of a tool move, whose samples
    are IK solutions close enough together that the spline between them is checked, not assumed."""
    s_knots, samples = np.asarray(s_knots, dtype=float), np.asarray(samples, dtype=float)
    length = float(np.linalg.norm(np.diff(samples, axis=0), axis=1).sum())
    return JointPath(samples, s_knots, s_knots, "samples", length, CONTINUITY["samples"],
                     _spline_pieces(s_knots, samples))


def _check_spline_limits(path: JointPath, q_min: np.ndarray, q_max: np.ndarray) -> None:
    """Reject a spline that leaves the joint limits between waypoints (LIMIT_CHECK_SAMPLES per segment, each
    end included; LIMIT_CHECK_SEGMENTS segments an evaluation), naming the first such segment and its joint."""
    knots = path.s_waypoints
    fractions = np.linspace(0.0, 1.0, LIMIT_CHECK_SAMPLES)
    for first in range(0, len(knots) - 1, LIMIT_CHECK_SEGMENTS):
        last = min(first + LIMIT_CHECK_SEGMENTS, len(knots) - 1)
        start, end = knots[first: last], knots[first + 1: last + 1]
        q = path((start[:, None] + (end - start)[:, None] * fractions).ravel())
        outside = (q < q_min - LIMIT_SLACK) | (q > q_max + LIMIT_SLACK)
        if outside.any():
            row, joint = np.argwhere(outside)[0]
            k = first + row // LIMIT_CHECK_SAMPLES
            raise PathError(
                f"the spline leaves the limits of joint {joint + 1} between waypoints {k} and {k + 1} "
                f"(reaches {q[row, joint]:.6g}, limits [{q_min[joint]:.6g}, {q_max[joint]:.6g}]); "
                "move the waypoints away from the limit or use the 'monotone' path shape, which never leaves them")
