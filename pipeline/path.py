"""Joint waypoints -> a geometric joint path q(s), s in [0, 1], with its first two derivatives.

Two shapes:

- ``spline``: a C2 cubic spline through every waypoint (not-a-knot ends: a clamped spline's zero
  slope at the ends costs toppra ~3x the discretisation gap), parameterised by cumulative
  joint-space chord length. A spline can overshoot between waypoints, so it is sampled
  densely and rejected, naming the segment and the joint, if it leaves the joint limits.
- ``linear``: straight segments in joint space with each interior corner rounded by a quadratic
  blend (C1). It never leaves the limits (the box of limits is convex), passes through the first
  and last waypoints exactly and within the blend of each interior one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from .choices import PATH_SHAPES
from .errors import TimingError

SHAPES = PATH_SHAPES
#: Fraction of the shorter neighbouring segment used by each corner blend of a linear path.
DEFAULT_BLEND = 0.2
#: Samples per segment when checking that a spline stays inside the joint limits.
LIMIT_CHECK_SAMPLES = 200
#: Waypoints closer than this (joint-space norm) are one waypoint [rad or m]: far below any
#: controller resolution, and a spline through two such knots would swing wildly between them.
DUPLICATE_DISTANCE = 1e-6


class PathError(TimingError):
    """A path cannot be built from the waypoints (names the waypoint or segment and the joint)."""


@dataclass(frozen=True, eq=False)
class JointPath:
    """A geometric path: ``q(s)``, ``dq/ds``, ``d2q/ds2`` for s in [0, 1] (arrays broadcast over s).

    ``waypoints`` (K, dof) after merging duplicates, ``s_waypoints`` (K,) their path parameters,
    ``breakpoints``: every s where d2q/ds2 may jump (knots, blend ends), ``shape``, ``length`` the
    joint-space chord length [rad or m].
    """

    waypoints: np.ndarray
    s_waypoints: np.ndarray
    breakpoints: np.ndarray
    shape: str
    length: float
    _pieces: object

    @property
    def dof(self) -> int:
        return self.waypoints.shape[1]

    def __call__(self, s, order: int = 0) -> np.ndarray:
        """q (order 0), dq/ds (1) or d2q/ds2 (2) at s (scalar or (n,)) -> (dof,) or (n, dof)."""
        return self._pieces(np.clip(s, 0.0, 1.0), order)


def merge_duplicates(waypoints: np.ndarray) -> np.ndarray:
    """Drop waypoints that repeat the previous one (within DUPLICATE_DISTANCE)."""
    keep = [0] + [i for i in range(1, len(waypoints))
                  if np.linalg.norm(waypoints[i] - waypoints[i - 1]) > DUPLICATE_DISTANCE]
    return waypoints[keep]


def check_waypoints(waypoints, q_min: np.ndarray, q_max: np.ndarray) -> np.ndarray:
    """Validate joint waypoints (K >= 2, dof) [rad or m]: finite and inside the limits; PathError names
    the waypoint and joint."""
    waypoints = np.asarray(waypoints, dtype=float)
    if waypoints.ndim != 2 or waypoints.shape[1] != q_min.size:
        raise PathError(f"waypoints must have shape (K, {q_min.size}), got {waypoints.shape}")
    if len(waypoints) < 2:
        raise PathError(f"a path needs at least 2 waypoints, got {len(waypoints)}")
    for k, q in enumerate(waypoints):
        if not np.isfinite(q).all():
            raise PathError(f"waypoint {k} has non-finite values: {q}")
        outside = np.flatnonzero((q < q_min) | (q > q_max))
        if outside.size:
            j = int(outside[0])
            raise PathError(f"waypoint {k}: joint {j + 1} = {q[j]:.6g} is outside its limits "
                            f"[{q_min[j]:.6g}, {q_max[j]:.6g}]")
    return waypoints


def _spline_pieces(s_knots: np.ndarray, waypoints: np.ndarray):
    cubic = CubicSpline(s_knots, waypoints, bc_type="not-a-knot" if len(s_knots) > 2 else "natural", axis=0)
    derivatives = (cubic, cubic.derivative(1), cubic.derivative(2))
    return lambda s, order: derivatives[order](s)


def _blend_pieces(s_knots: np.ndarray, waypoints: np.ndarray, blend: float):
    """Linear segments with a quadratic blend of half-width b_i around each interior knot i.

    Inside a blend (u = s - s_i + b_i in [0, 2 b_i]) the slope turns linearly from the incoming to the
    outgoing segment's: q = w_i - m_in b_i + m_in u + (m_out - m_in) u^2 / (4 b_i).
    """
    ds = np.diff(s_knots)
    slopes = np.diff(waypoints, axis=0) / ds[:, None]                        # dq/ds of each segment
    interior = range(1, len(s_knots) - 1)
    half = {i: blend * min(ds[i - 1], ds[i]) for i in interior}

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
        for i in interior:
            b = half[i]
            u = flat - (s_knots[i] - b)
            inside = (u >= 0.0) & (u < 2.0 * b)          # at a breakpoint: the piece that starts there
            if b <= 0.0 or not inside.any():
                continue
            m_in, m_out = slopes[i - 1], slopes[i]
            turn = (m_out - m_in) / (2.0 * b)
            uu = u[inside][:, None]
            if order == 0:
                out[inside] = waypoints[i] - m_in * b + m_in * uu + turn * uu**2 / 2.0
            elif order == 1:
                out[inside] = m_in + turn * uu
            else:
                out[inside] = turn
        return out[0] if s.ndim == 0 else out

    return evaluate


def make_path(waypoints, q_min: np.ndarray, q_max: np.ndarray, shape: str = "spline",
              blend: float = DEFAULT_BLEND) -> JointPath:
    """A geometric path through joint waypoints (K, dof) [rad or m], checked against the limits."""
    if shape not in SHAPES:
        raise PathError(f"path shape must be one of {', '.join(SHAPES)}, got {shape!r}")
    if not 0.0 <= blend <= 0.5:
        raise PathError(f"blend must be in [0, 0.5], got {blend}")
    waypoints = merge_duplicates(check_waypoints(waypoints, q_min, q_max))
    if len(waypoints) < 2:
        raise PathError("all waypoints are the same configuration: there is no motion to time")
    chords = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    length = float(chords.sum())
    s_knots = np.concatenate([[0.0], np.cumsum(chords) / length])
    s_knots[-1] = 1.0
    if shape == "linear":
        pieces = _blend_pieces(s_knots, waypoints, blend)
        half = blend * np.minimum(np.diff(s_knots)[:-1], np.diff(s_knots)[1:])
        breakpoints = np.unique(np.concatenate([s_knots, s_knots[1:-1] - half, s_knots[1:-1] + half]))
    else:
        pieces = _spline_pieces(s_knots, waypoints)
        breakpoints = s_knots
    path = JointPath(waypoints, s_knots, breakpoints, shape, length, pieces)
    if shape == "spline":
        _check_spline_limits(path, q_min, q_max)
    return path


def _check_spline_limits(path: JointPath, q_min: np.ndarray, q_max: np.ndarray) -> None:
    """Reject a spline that leaves the joint limits between waypoints, naming segment and joint."""
    for k in range(len(path.s_waypoints) - 1):
        s = np.linspace(path.s_waypoints[k], path.s_waypoints[k + 1], LIMIT_CHECK_SAMPLES)
        q = path(s)
        below, above = q < q_min - 1e-12, q > q_max + 1e-12
        if below.any() or above.any():
            row, joint = np.argwhere(below | above)[0]
            raise PathError(
                f"the spline leaves the limits of joint {joint + 1} between waypoints {k} and {k + 1} "
                f"(reaches {q[row, joint]:.6g}, limits [{q_min[joint]:.6g}, {q_max[joint]:.6g}]); "
                "move the waypoints away from the limit or use the 'linear' path shape")
