"""Tool moves as geometry: straight lines and circular arcs between TCP poses, corners rounded in zones.

A ``ToolPath`` is the TCP pose X_BT(sigma) (4, 4) [m] along a chain of moves, ``sigma`` [m] the
arc length of the TCP's straight or circular track (a move that only turns the tool is measured as
ROTATION_RADIUS x its angle). Orientation goes by slerp from the move's start to its end orientation,
in step with the track (SciPy's ``Rotation``: no hand-written quaternion algebra).

A zone of radius R at the corner between two moves rounds it as the pendant zones of ABB (zones),
Fanuc (CNT) and Yaskawa (PL) do: the TCP leaves the first move R before the corner (at most half of
either move) and joins the next one R after it, along a septic Hermite curve that matches both moves'
first three derivatives where it leaves and joins them (so the track stays C3 and its jerk finite),
and the orientation blends from the first move's slerp to the second's with a C3 smoothstep. A corner
without a zone is a stop: the chain ends there (``split_at_stops``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ConfigurationError
from ..files.choices import TOOL_MOVES
from ..files.poses import make_pose

#: A move that only turns the tool counts ROTATION_RADIUS x its angle as its length [m].
ROTATION_RADIUS = 0.1
#: Shorter translations than this are none (the move only turns the tool) [m].
MIN_TRACK_M = 1e-6
#: A via point closer than this to the line through the arc's ends makes no circle [m].
MIN_ARC_SAGITTA_M = 1e-6

#: C3 smoothstep w(t) = 35 t^4 - 84 t^5 + 70 t^6 - 20 t^7 and its derivatives (coefficients of t^0..t^7).
_SMOOTHSTEP = np.array([0.0, 0.0, 0.0, 0.0, 35.0, -84.0, 70.0, -20.0])


@dataclass(frozen=True, eq=False)
class ToolMove:
    """One move to ``X_end`` (4, 4) [m]: ``kind`` linear or circular (through ``via`` (3,) [m]), and the
    ``zone`` radius [m] that rounds the corner at its end into the next move (0: stop there)."""

    kind: str
    X_end: np.ndarray
    via: np.ndarray | None = None
    zone: float = 0.0


class _Segment:
    """One move's track p(t) and orientation R(t) over its own t in [0, length] [m] (and beyond: the
    blends read a move a little past its ends)."""

    def __init__(self, X_start: np.ndarray, move: ToolMove, index: int):
        self.index = index
        self.p0, self.p1 = X_start[:3, 3], move.X_end[:3, 3]
        self.R0 = Rotation.from_matrix(X_start[:3, :3])
        self.turn = (self.R0.inv() * Rotation.from_matrix(move.X_end[:3, :3])).as_rotvec()
        self.arc = None
        if move.kind == "circular":
            self.arc = _circle(self.p0, move.via, self.p1, index)
            self.length = self.arc[1] * self.arc[4]             # radius x angle
        else:
            self.length = float(np.linalg.norm(self.p1 - self.p0))
        if self.length < MIN_TRACK_M:
            self.length = max(ROTATION_RADIUS * float(np.linalg.norm(self.turn)), 0.0)
            self.still = True
        else:
            self.still = False
        if self.length <= 0.0:
            raise ConfigurationError(f"move {index}: ends where it starts, in position and orientation")

    def position(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """d^order p / dt^order at t (n,) -> (n, 3) [m / m^order]."""
        t = np.asarray(t, dtype=float)
        if self.still:
            return np.tile(self.p0 if order == 0 else np.zeros(3), (t.size, 1))
        if self.arc is None:
            direction = (self.p1 - self.p0) / self.length
            if order == 0:
                return self.p0 + t[:, None] * direction
            return np.tile(direction if order == 1 else np.zeros(3), (t.size, 1))
        centre, radius, e1, e2, _ = self.arc
        theta = t / radius
        # d^k/dtheta^k of (cos, sin) is (cos, sin) turned by k quarter turns; each d/dt adds 1 / radius.
        c, s = np.cos(theta + order * np.pi / 2.0), np.sin(theta + order * np.pi / 2.0)
        p = radius ** (1 - order) * (c[:, None] * e1 + s[:, None] * e2)
        return p + centre if order == 0 else p

    def rotation(self, t: np.ndarray) -> Rotation:
        """The slerp from the start to the end orientation, in step with t (extrapolated beyond)."""
        return self.R0 * Rotation.from_rotvec(np.outer(np.asarray(t, dtype=float) / self.length, self.turn))


def _circle(p0: np.ndarray, via: np.ndarray, p1: np.ndarray, index: int):
    """(centre, radius, e1, e2, angle) of the arc from p0 through via to p1: p = centre + r (cos e1 +
    sin e2) at angle theta from p0, the arc's angle in (0, 2 pi)."""
    a, b = via - p0, p1 - p0
    normal = np.cross(a, b)
    area = float(np.linalg.norm(normal))
    if area < MIN_ARC_SAGITTA_M * max(float(np.linalg.norm(b)), 1e-9):
        raise ConfigurationError(f"move {index}: the via point is on the line through the arc's ends (or on an "
                                 "end): no circle passes through them; use a linear move")
    # Circumcentre of the triangle p0, via, p1.
    centre = p0 + (np.dot(a, a) * np.cross(b, normal) + np.dot(b, b) * np.cross(normal, a)) / (2.0 * area**2)
    radius = float(np.linalg.norm(p0 - centre))
    n = normal / area
    e1 = (p0 - centre) / radius
    e2 = np.cross(n, e1)

    def angle_of(p):
        v = p - centre
        return math.atan2(float(v @ e2), float(v @ e1)) % (2.0 * math.pi)

    return centre, radius, e1, e2, angle_of(p1) or 2.0 * math.pi


def move_length(p_start: np.ndarray, p_end: np.ndarray, via: np.ndarray | None = None) -> float:
    """The TCP's length [m] of a move, as a controller measures a zone against it: a circular move's arc from
    ``p_start`` through ``via`` to ``p_end`` (3,) [m] (their chord sum where the three are in line), every other
    move's straight distance (a joint move's too)."""
    if via is None:
        return float(np.linalg.norm(p_end - p_start))
    try:
        _, radius, _, _, angle = _circle(p_start, via, p_end, 0)
    except ConfigurationError:
        return float(np.linalg.norm(via - p_start) + np.linalg.norm(p_end - via))
    return radius * angle


def _smoothstep(t: np.ndarray, order: int = 0) -> np.ndarray:
    coefficients = np.polynomial.polynomial.polyder(_SMOOTHSTEP, order) if order else _SMOOTHSTEP
    return np.polynomial.polynomial.polyval(t, coefficients)


def _hermite_basis() -> np.ndarray:
    """H (8, 8): H @ ends gives the coefficients (t^0..t^7) of the septic polynomial whose derivatives
    0..3 at t = 0, then at t = 1, are ``ends``."""
    rows = []
    for t in (0.0, 1.0):
        for d in range(4):
            rows.append([math.factorial(n) / math.factorial(n - d) * t ** (n - d) if n >= d else 0.0
                         for n in range(8)])
    return np.linalg.inv(np.array(rows))


_HERMITE = _hermite_basis()


@dataclass(frozen=True, eq=False)
class _Blend:
    """A rounded corner over sigma in [start, end] between segments ``before`` and ``after``."""

    before: _Segment
    after: _Segment
    start: float
    end: float
    before_t0: float            # the first segment's own t at sigma = start
    coefficients: np.ndarray    # (8, 3): the track's septic polynomial in tau = (sigma - start) / width

    @property
    def width(self) -> float:
        return self.end - self.start


#: Breakpoints closer than this [m] are one (the rounding of sums of move lengths).
BREAKPOINT_MERGE_M = 1e-9


class ToolPath:
    """The TCP pose along a chain of tool moves from ``X_start`` (see the module docstring).

    ``length`` [m]; ``poses(sigma)`` (n, 4, 4); ``position(sigma, order)`` (n, 3) with its first three
    derivatives in sigma; ``breakpoints``: every sigma where a move or a blend starts or ends;
    ``move_of(sigma)``: the index of the move each sigma belongs to (a blend counts to the move it
    leaves until its middle).
    """

    def __init__(self, X_start: np.ndarray, moves: list[ToolMove], first_index: int = 0):
        if not moves:
            raise ConfigurationError("a tool path needs at least one move")
        self.segments, X = [], X_start
        for k, move in enumerate(moves):
            if move.kind not in TOOL_MOVES:
                raise ConfigurationError(f"move {first_index + k}: kind must be one of {', '.join(TOOL_MOVES)}")
            self.segments.append(_Segment(X, move, first_index + k))
            X = move.X_end
        self.X_start, self.X_end = X_start, X
        self.starts = np.concatenate([[0.0], np.cumsum([s.length for s in self.segments])])
        self.length = float(self.starts[-1])
        self.blends = [self._blend(k, moves[k].zone) for k in range(len(moves) - 1) if moves[k].zone > 0.0]
        points = np.sort(np.concatenate([self.starts, *[[b.start, b.end] for b in self.blends]]))
        # Two zones that take half of the same move each meet in its middle: one breakpoint there, not two a
        # rounding apart (the later of a close pair is kept, so the last stays the length).
        self.breakpoints = points[np.concatenate([np.diff(points) > BREAKPOINT_MERGE_M, [True]])]

    def _blend(self, k: int, zone: float) -> _Blend:
        before, after = self.segments[k], self.segments[k + 1]
        half = min(zone, before.length / 2.0, after.length / 2.0)
        corner = self.starts[k + 1]
        t_before, t_after = before.length - half, half
        width = 2.0 * half
        ends = [before.position(np.array([t_before]), d)[0] * width**d for d in range(4)]
        ends += [after.position(np.array([t_after]), d)[0] * width**d for d in range(4)]
        return _Blend(before, after, corner - half, corner + half, t_before, _HERMITE @ np.array(ends))

    def _blend_at(self, sigma: np.ndarray) -> list[tuple[_Blend, np.ndarray]]:
        return [(b, (sigma >= b.start) & (sigma <= b.end)) for b in self.blends]

    def _segment_index(self, sigma: np.ndarray) -> np.ndarray:
        return np.clip(np.searchsorted(self.starts, sigma, side="right") - 1, 0, len(self.segments) - 1)

    def position(self, sigma, order: int = 0) -> np.ndarray:
        """d^order p / dsigma^order (n, 3) at sigma (n,) [m / m^order], order 0..3."""
        sigma = np.clip(np.atleast_1d(np.asarray(sigma, dtype=float)), 0.0, self.length)
        out = np.empty((sigma.size, 3))
        index = self._segment_index(sigma)
        for k, segment in enumerate(self.segments):
            mask = index == k
            if mask.any():
                out[mask] = segment.position(sigma[mask] - self.starts[k], order)
        for blend, mask in self._blend_at(sigma):
            if mask.any():
                tau = (sigma[mask] - blend.start) / blend.width
                poly = np.polynomial.polynomial.polyder(blend.coefficients, order) if order else blend.coefficients
                out[mask] = np.polynomial.polynomial.polyval(tau, poly).T / blend.width**order
        return out

    def rotation(self, sigma) -> Rotation:
        """The TCP orientation at sigma (n,)."""
        sigma = np.clip(np.atleast_1d(np.asarray(sigma, dtype=float)), 0.0, self.length)
        index = self._segment_index(sigma)
        quats = np.empty((sigma.size, 4))
        for k, segment in enumerate(self.segments):
            mask = index == k
            if mask.any():
                quats[mask] = segment.rotation(sigma[mask] - self.starts[k]).as_quat()
        for blend, mask in self._blend_at(sigma):
            if mask.any():
                local = sigma[mask] - blend.start
                first = blend.before.rotation(blend.before_t0 + local)
                second = blend.after.rotation(local - blend.width / 2.0)
                towards = (first.inv() * second).as_rotvec() * _smoothstep(local / blend.width)[:, None]
                quats[mask] = (first * Rotation.from_rotvec(towards)).as_quat()
        return Rotation.from_quat(quats)

    def poses(self, sigma) -> np.ndarray:
        """X_BT (n, 4, 4) [m] at sigma (n,)."""
        positions = self.position(sigma)
        matrices = self.rotation(sigma).as_matrix()
        return np.array([make_pose(R, p) for R, p in zip(matrices, positions)])

    def move_of(self, sigma) -> np.ndarray:
        """The index (as given to the moves) of the move each sigma (n,) lies on."""
        index = self._segment_index(np.clip(np.atleast_1d(np.asarray(sigma, dtype=float)), 0.0, self.length))
        return np.array([self.segments[k].index for k in index])


def split_at_stops(moves: list[ToolMove]) -> list[list[ToolMove]]:
    """The moves in runs that end at a stop (a corner without a zone, or the last move)."""
    runs, current = [], []
    for move in moves:
        current.append(move)
        if move.zone <= 0.0:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    return runs
