"""One stretch of a program (from one stop to the next) as one joint path with its limits move by move.

The stretch is a chain of segments, each a JointPath: a run of tool moves (the C2 spline through its
IK samples), a run of unplanned joint moves (the job's path shape through their targets), a planned
move (the C2 spline through the planner's vertices where it stays in the limits and keeps the
clearance, ``_smooth_plan``; else each edge, straight in joint space between two vertices). Where two
segments meet, the corner is rounded in joint space by a Hermite blend that matches both segments'
derivatives up to BLEND_ORDER where it leaves and joins them (so neither back end sees a jump it
limits): at a waypoint with a zone R, the blend leaves the segment before where the TCP is R from the
waypoint (on a tool move: R along its line or arc) and joins the next one likewise, each at most half
of the move's last or first edge; at a planner's inner vertex, and on the planned side of a zone (the
planner chose that path, the program only its end), the blend takes AUTO_BLEND of the edge or of the
spline's first or last interval. A blend that leaves the joint limits, or, in a cell, comes closer to
an obstacle than the clearance (checked at configurations CHECK_STEP_RAD apart), is narrowed
(halved) until it does not; ``narrowed`` counts that.

Each segment is parameterised by its joint-space length u (so |dq/du| is about 1 everywhere and the
blends, whose parameter width is the length they replace, neither loop nor stall); the stretch's s in
[0, 1] is u over the total. The ``schedule`` (``pipeline.timing.schedule``) gives each part its limits: a
tool move's line or arc outside its zones its TCP speed and the job's TCP acceleration; a joint move
and a blend the joint speed fraction of its move (a blend between two moves, or a run of joint moves
the path passes through, the smallest, with a bound at each waypoint it passes, so that the timing's time
there is exact).
``passages`` are the s at which the stretch passes its waypoints (a blend's middle at a zone).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..timing.joint_path import JointPath, PathError, hermite_matrix, kept_indices, make_path
from ..timing.schedule import LimitSchedule
from .model import JOINT, Move, Program

#: The highest derivative a blend matches at its ends, per timing method: toppra limits velocity and
#: acceleration, so its blends are C2 (quintic: a C1 cubic let a joint resting along a line start
#: turning at once, but its jump in d2q/ds2 was constrained on one side only and needed a 1.07 uniform
#: slow-down on a shelf program); topp3 limits jerk, so its blends are C3 (septic).
BLEND_ORDER = {"toppra": 2, "topp3": 3}
#: Fraction of each edge a blend at a planner's inner vertex takes [1].
AUTO_BLEND = 0.45
#: Blend check resolution in a cell: configurations at most this far apart [rad]; blend narrowing rounds.
CHECK_STEP_RAD = 0.01
NARROW_ROUNDS = 12
#: Breakpoints closer than this in s are one, a piece's bound kept (a segment's own breakpoint at a
#: blend's end: a microscopic grid interval there made toppra's path acceleration explode) [1].
BREAKPOINT_GAP = 1e-9
#: TCP samples on a joint segment's end half when finding where the TCP is R from the corner.
ZONE_SAMPLES = 200


@dataclass
class Segment:
    """A JointPath ``path`` of joint-space length ``length`` [rad or m] and the moves it carries:
    ``moves`` (the program's Move values), ``kind`` ("track", "joint", "curve": a planned move's spline,
    or "edge": one edge of a planned move), and the parts cut
    off at its ends for blends, ``cut_in`` and ``cut_out`` [same units]."""

    path: JointPath
    moves: tuple[Move, ...]
    kind: str
    cut_in: float = 0.0
    cut_out: float = 0.0

    @property
    def length(self) -> float:
        return max(self.path.length, 1e-12)

    def local(self, u: np.ndarray, order: int) -> np.ndarray:
        """d^order q / du^order at the segment's own u [0, length]."""
        return self.path(np.clip(u / self.length, 0.0, 1.0), order) / self.length**order


@dataclass
class Blend:
    """The blend between segments ``before`` and ``after`` (indices), its ``zone`` [m] (None: at a
    planner's vertex), the ``waypoint`` it rounds (None at a planner's vertex) and the coefficients of
    its Hermite polynomial in tau = (u - start) / width (set by ``StretchPath``)."""

    before: int
    after: int
    zone: float | None
    waypoint: int | None
    coefficients: np.ndarray | None = None
    narrowed: int = 0


class StretchPath:
    """The joint path of stretch ``first`` .. ``last`` (waypoint indices) of ``program``; see the module
    docstring. ``path``: the JointPath (shape "program"); ``schedule``: its LimitSchedule over s;
    ``passages``: s of each waypoint first+1 .. last; ``blends``."""

    def __init__(self, program: Program, first: int, last: int, scene=None):
        self.program, self.first, self.last, self.scene = program, first, last, scene
        self.blend_order = BLEND_ORDER.get(program.timing, 3)
        self.segments, self.blends = _segments(program, first, last, scene)
        for blend in self.blends:
            self._place_blend(blend)
        self.rebuild()

    # -- geometry -------------------------------------------------------------------------------------
    def _cut(self, segment: Segment, zone: float, at_end: bool) -> float:
        """The joint-space length [rad or m] cut off ``segment`` at its end (or start) for a zone of
        ``zone`` [m]: on a tool move or an unplanned joint move, where the TCP is ``zone`` from the corner,
        at most half the move there; on a planned move (a path the planner chose, not one the program
        gave) AUTO_BLEND of its edge or of its spline's end interval, as at the planner's own vertices."""
        if segment.kind == "edge":
            return AUTO_BLEND * segment.length
        if segment.kind == "curve":
            knots = segment.path.s_waypoints
            return AUTO_BLEND * (1.0 - knots[-2] if at_end else knots[1]) * segment.length
        if segment.kind == "track":
            along = segment.moves[0].track.along
            tool_path = along.tool_path
            edge = np.diff(tool_path.starts)[-1 if at_end else 0]
            return min(zone, edge / 2.0) / tool_path.length * segment.length
        robot = self.program.robot
        if segment.kind == "joint" and len(segment.path.s_waypoints) > 2:
            s_edge = segment.path.s_waypoints[-2] if at_end else segment.path.s_waypoints[1]
            half = (1.0 - s_edge) / 2.0 if at_end else s_edge / 2.0
        else:
            half = 0.5
        s = 1.0 - np.linspace(0.0, half, ZONE_SAMPLES) if at_end else np.linspace(0.0, half, ZONE_SAMPLES)
        tcp = robot.fk_batch(segment.path(s))[:, :3, 3]
        distance = np.linalg.norm(tcp - tcp[0], axis=1)
        beyond = np.flatnonzero(distance >= zone)
        reach = half if beyond.size == 0 else float(np.abs(s[beyond[0]] - s[0]))
        return reach * segment.length

    def _place_blend(self, blend: Blend) -> None:
        before, after = self.segments[blend.before], self.segments[blend.after]
        if blend.zone is None:
            before.cut_out, after.cut_in = AUTO_BLEND * before.length, AUTO_BLEND * after.length
        else:
            before.cut_out = self._cut(before, blend.zone, at_end=True)
            after.cut_in = self._cut(after, blend.zone, at_end=False)

    def rebuild(self) -> None:
        """Make the path (and check the blends, narrowing those that fail) from the segments' cuts."""
        for _ in range(NARROW_ROUNDS):
            self._assemble()
            failing = [b for b in self.blends if not self._blend_ok(b)]
            if not failing:
                return
            for blend in failing:
                self.narrow(blend)
        self._assemble()

    def narrow(self, blend: Blend) -> None:
        """Halve the parts ``blend`` replaces."""
        self.segments[blend.before].cut_out /= 2.0
        self.segments[blend.after].cut_in /= 2.0
        blend.narrowed += 1

    def _assemble(self) -> None:
        """Pieces in order: (kind, index, u_start, u_end) with u the stretch's joint-space length."""
        pieces, u = [], 0.0
        for i, segment in enumerate(self.segments):
            kept = segment.length - segment.cut_in - segment.cut_out
            pieces.append(("segment", i, u, u + kept))
            u += kept
            blend = next((b for b in self.blends if b.before == i), None)
            if blend is not None:
                width = segment.cut_out + self.segments[blend.after].cut_in
                blend.coefficients = self._coefficients(blend, width)
                pieces.append(("blend", self.blends.index(blend), u, u + width))
                u += width
        self.pieces, self.total = pieces, u
        self.path = self._joint_path()
        self.schedule = self._schedule()

    def _coefficients(self, blend: Blend, width: float) -> np.ndarray:
        """The blend's Hermite coefficients (2 BLEND_ORDER + 2, dof) in tau: values and derivatives up to
        BLEND_ORDER of both segments where it leaves and joins them (derivatives in tau = u / width)."""
        before, after = self.segments[blend.before], self.segments[blend.after]
        u_out, u_in = before.length - before.cut_out, after.cut_in
        orders = range(self.blend_order + 1)
        ends = [before.local(np.array([u_out]), d)[0] * width**d for d in orders]
        ends += [after.local(np.array([u_in]), d)[0] * width**d for d in orders]
        return hermite_matrix(2 * self.blend_order + 1) @ np.array(ends)

    def _piece_values(self, u: np.ndarray, order: int) -> np.ndarray:
        """d^order q / du^order at the stretch's u (n,)."""
        out = np.empty((u.size, self.program.robot.dof))
        starts = np.array([p[2] for p in self.pieces])
        index = np.clip(np.searchsorted(starts, u, side="right") - 1, 0, len(self.pieces) - 1)
        for k, (kind, i, u0, u1) in enumerate(self.pieces):
            mask = index == k
            if not mask.any():
                continue
            if kind == "segment":
                segment = self.segments[i]
                out[mask] = segment.local(u[mask] - u0 + segment.cut_in, order)
            else:
                width = u1 - u0
                coefficients = self.blends[i].coefficients
                poly = np.polynomial.polynomial.polyder(coefficients, order) if order else coefficients
                out[mask] = np.polynomial.polynomial.polyval((u[mask] - u0) / width, poly).T / width**order
        return out

    def _joint_path(self) -> JointPath:
        """The stretch's JointPath: a single segment's own (s = u / length already), else the pieces."""
        if len(self.segments) == 1:
            return self.segments[0].path
        total = self.total

        def pieces(s, order):
            s = np.asarray(s, dtype=float)
            values = self._piece_values(np.atleast_1d(s) * total, order) * total**order
            return values[0] if s.ndim == 0 else values

        bounds = np.array([p[2] for p in self.pieces] + [total]) / total
        inner = [self._segment_breakpoints(k) for k in range(len(self.pieces))]
        inner = np.unique(np.concatenate(inner)) if inner else np.empty(0)
        inner = inner[np.concatenate([[True], np.diff(inner) > BREAKPOINT_GAP])] if inner.size else inner
        apart = np.abs(inner[:, None] - bounds[None, :]).min(axis=1) > BREAKPOINT_GAP if inner.size else []
        breakpoints = np.unique(np.concatenate([bounds, inner[apart]]))
        waypoints = self._piece_values(bounds * total, 0)
        continuity = min([self.blend_order] + [s.path.continuity for s in self.segments])
        return JointPath(waypoints, bounds, breakpoints, "program", total, continuity, pieces)

    def _segment_breakpoints(self, k: int) -> np.ndarray:
        """The inner breakpoints of piece k's segment, in the stretch's s."""
        kind, i, u0, u1 = self.pieces[k]
        if kind != "segment":
            return np.empty(0)
        u = self._stretch_u(k, self.segments[i].path.breakpoints)
        return u[(u > u0) & (u < u1)] / self.total

    def _stretch_u(self, k: int, x: np.ndarray) -> np.ndarray:
        """The stretch's u at s = ``x`` (n,) of piece k's segment's own path."""
        _, i, u0, _ = self.pieces[k]
        segment = self.segments[i]
        return x * segment.length - segment.cut_in + u0

    def _blend_ok(self, blend: Blend) -> bool:
        """The blend stays inside the joint limits and, in a cell, keeps the clearance."""
        k = next(j for j, p in enumerate(self.pieces) if p[0] == "blend" and self.blends[p[1]] is blend)
        _, _, u0, u1 = self.pieces[k]
        step = CHECK_STEP_RAD if self.scene is not None else (u1 - u0) / 50.0
        u = np.linspace(u0, u1, max(3, int(np.ceil((u1 - u0) / max(step, 1e-12))) + 1))
        q = self._piece_values(u, 0)
        limits = self.program.robot.limits
        if np.any(q < limits.q_min) or np.any(q > limits.q_max):
            return False
        return self.scene is None or all(self.scene.is_free(x) for x in q)

    # -- limits and passages ----------------------------------------------------------------------------
    def s_of(self, k: int, u_local: float) -> float:
        """The stretch's s of piece k's segment at its own u."""
        kind, i, u0, _ = self.pieces[k]
        return (u0 + u_local - self.segments[i].cut_in) / self.total

    def _schedule(self) -> LimitSchedule:
        """The limits along s (see the module docstring)."""
        rows = []            # (s_start, s_end, joint_speed, tcp_speed, tcp_accel)
        accel = np.inf if self.program.tcp_accel_max is None else self.program.tcp_accel_max
        for k, (kind, i, u0, u1) in enumerate(self.pieces):
            s0, s1 = u0 / self.total, u1 / self.total
            if kind == "blend":
                blend = self.blends[i]
                speeds = [m.speed for j in (blend.before, blend.after) for m in self.segments[j].moves
                          if m.kind == JOINT]
                rows.append((s0, s1, min(speeds + [1.0]), np.inf, np.inf))
                continue
            segment = self.segments[i]
            if segment.kind == "track":
                rows += self._track_rows(k, segment, accel)
            else:
                # A bound at every waypoint a joint run passes (each a breakpoint of the path): the timing's time
                # there is exact (``passages``).
                inner = self._inner_passages(k)[1]
                inner = inner[(inner > s0) & (inner < s1) & np.isin(inner, self.path.breakpoints)]
                edges = [s0, *np.unique(inner).tolist(), s1]
                speed = min(m.speed for m in segment.moves)
                rows += [(a, b, speed, np.inf, np.inf) for a, b in itertools.pairwise(edges)]
        bounds = np.array([r[0] for r in rows] + [1.0])
        mids = (bounds[:-1] + bounds[1:]) / 2.0
        values = np.array([[r[2], r[3], r[4]] for r in rows])
        owner = np.clip(np.searchsorted([r[0] for r in rows], mids, side="right") - 1, 0, len(rows) - 1)
        return LimitSchedule(bounds, *values[owner].T)

    def _track_rows(self, k: int, segment: Segment, accel: float) -> list[tuple]:
        """Schedule rows of a track's kept part: per tool move its speed; in a zone between two tool
        moves the smaller of theirs."""
        along = segment.moves[0].track.along
        tool_path = along.tool_path
        points = np.unique(np.concatenate([tool_path.starts, *[[b.start, b.end] for b in tool_path.blends]]))
        speeds = {m.end: m.speed for m in segment.moves}
        rows = []
        for a, b in zip(points[:-1], points[1:]):
            middle = (a + b) / 2.0
            inside = [blend for blend in tool_path.blends if blend.start <= middle <= blend.end]
            ends = (tool_path.move_of(middle - (b - a) / 2.0 + 1e-12)[0], tool_path.move_of(b - 1e-12)[0])
            speed = min(speeds[int(e)] for e in ends) if inside else speeds[int(tool_path.move_of(middle)[0])]
            s0, s1 = (self.s_of(k, x / tool_path.length * segment.length) for x in (a, b))
            lo, hi = self.pieces[k][2] / self.total, self.pieces[k][3] / self.total
            if s1 > lo and s0 < hi:
                rows.append((max(s0, lo), min(s1, hi), 1.0, speed, accel))
        return rows

    @property
    def passages(self) -> list[float]:
        """s at which the stretch passes waypoints first+1 .. last: at a zone the middle of its blend, the
        stretch's end at 1, the others where their segment passes them (``_inner_passages``)."""
        blend_pieces = {i: (u0, u1) for kind, i, u0, u1 in self.pieces if kind == "blend"}
        blended = {}
        for i, blend in enumerate(self.blends):
            u0, u1 = blend_pieces[i]
            blended.setdefault(blend.waypoint, (u0 + u1) / 2.0 / self.total)
        inner = {}
        for k, piece in enumerate(self.pieces):
            if piece[0] == "segment":
                for end, s in zip(*self._inner_passages(k)):
                    inner.setdefault(end, float(s))
        return [blended[end] if end in blended else 1.0 if end == self.last else inner.get(end, 1.0)
                for end in range(self.first + 1, self.last + 1)]

    def _inner_passages(self, k: int) -> tuple[list[int], np.ndarray]:
        """The waypoints inside piece k's segment (the ends of its moves but the last, which ends the segment)
        and the s at which the stretch passes each, within the piece: on a track its tool path's corner (as the
        track's schedule rows place it), on a joint run its path's waypoint (a waypoint merged into the one
        before as a duplicate: that one's), to the last bit the path's breakpoint there."""
        _, i, u0, u1 = self.pieces[k]
        segment = self.segments[i]
        ends = [m.end for m in segment.moves[:-1]]
        if not ends or segment.kind not in ("track", "joint"):
            return [], np.empty(0)
        count = np.arange(1, len(ends) + 1)
        if segment.kind == "track":
            tool_path = segment.moves[0].track.along.tool_path
            s = self.s_of(k, tool_path.starts[count] / tool_path.length * segment.length)
        else:
            points = self.program.targets[ends[0] - 1: ends[-1] + 2]          # the run's start and targets
            x = segment.path.s_waypoints[np.searchsorted(kept_indices(points), count, side="right") - 1]
            s = x if len(self.segments) == 1 else self._stretch_u(k, x) / self.total
        return ends, np.clip(s, u0 / self.total, u1 / self.total)


def _smooth_plan(planned, robot, scene, tilt) -> JointPath | None:
    """The C2 spline through a planned move's vertices (its ``smooth_waypoints`` where the planner gives
    them, else its edges' vertices, when there is an inner one) if it stays inside the joint limits and
    keeps the clearance (and the ``tilt`` limit, None: none) at configurations CHECK_STEP_RAD apart (None
    otherwise): every joint swings smoothly through the vertices, where edges and blends would turn
    sharply at each."""
    limits = robot.limits
    vertices = planned.waypoints if planned.smooth_waypoints is None else planned.smooth_waypoints
    if len(vertices) < 3:
        return None
    try:
        curve = make_path(vertices, limits.q_min, limits.q_max, "spline")
    except PathError:
        return None
    Q = curve(np.linspace(0.0, 1.0, max(3, int(np.ceil(curve.length / CHECK_STEP_RAD)) + 1)))
    if tilt is not None and not tilt.keeps(robot, Q):
        return None
    return curve if scene is None or all(scene.is_free(q) for q in Q) else None


def _segments(program: Program, first: int, last: int, scene=None) -> tuple[list[Segment], list[Blend]]:
    """The segments of the stretch and the blends between them (see the module docstring)."""
    moves = program.moves[first: last]
    limits = program.robot.limits
    targets = program.targets
    segments: list[Segment] = []
    blends: list[Blend] = []
    k = 0
    while k < len(moves):
        move = moves[k]
        start = targets[move.end - 1]
        if move.track is not None:
            run = [m for m in moves[k:] if m.track is move.track]
            segments.append(Segment(move.track.along.path, tuple(run), "track"))
            k += len(run)
        elif move.planned is not None and (curve := _smooth_plan(move.planned, program.robot, scene,
                                                                                    program.tilt)) is not None:
            segments.append(Segment(curve, (move,), "curve"))
            k += 1
        elif move.planned is not None:
            vertices = move.planned.waypoints
            for j in range(len(vertices) - 1):
                if j:
                    blends.append(Blend(len(segments) - 1, len(segments), None, None))
                segments.append(Segment(make_path(vertices[j: j + 2], limits.q_min, limits.q_max, "monotone"),
                                        (move,), "edge"))
            k += 1
        else:
            run = [move]
            while k + len(run) < len(moves) and run[-1].zone <= 0.0 and moves[k + len(run)].kind == JOINT \
                    and moves[k + len(run)].planned is None:
                run.append(moves[k + len(run)])
            points = np.array([start] + [m.target for m in run])
            segments.append(Segment(make_path(points, limits.q_min, limits.q_max, program.path or "monotone"),
                                    tuple(run), "joint"))
            k += len(run)
        if k < len(moves):
            ending = moves[k - 1]
            blends.append(Blend(len(segments) - 1, len(segments), ending.zone, ending.end))
    return segments, blends
