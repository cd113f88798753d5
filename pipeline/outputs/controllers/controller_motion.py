"""What a controller does with a written program: the joint path it may take, its cycle time, its certificate.

A controller program is a second description of the motion, read by a controller with its own interpolation
(issue 36, "What is written is what was certified"). This module models that reading in one place, from the
moves as a writer writes them (``WrittenMove``: a joint target, or a tool pose reached by a line or an arc, each
with its zone as written), and gives

* ``controller_path(robot, q_start, moves)`` -> ``ControllerPath``: the joint-space path the controller may take,
  sampled, with per move whether the motion stops at its end, the corner's size and its deviation from the
  written segments;
* ``time_written(program, path)`` -> ``WrittenTiming``: the cycle time of the program as written, the
  time-optimal motion along that path by the package's own timing (``pipeline.timing.time_path``: toppra, or
  topp3 for a jerk-limited program, with
  the job's joint limits, its safety TCP limit, its tool moves' TCP speeds and TCP acceleration and its joint
  moves' speed fractions), resting exactly where the written program stops;
* ``certify_written(program, path, timing, certified, scene)`` -> ``WrittenCertificate``: that motion checked
  by ``pipeline.timing.profile.certify`` (joint limits, speeds, accelerations, the TCP limits and, in a cell,
  the clearance through ``pipeline.timing.clearance`` on ``pipeline.cell.collision.CollisionModel``: Drake's
  distance queries), with the smallest clearance and, per move, the largest joint-space distance from the
  modelled path to the certified profile's path.

``written_moves(program, exact_stops=..., pass_through_zone_m=..., flow_zone_m=...)`` gives the moves the writers
write for a Program without its certified profile (planned moves as the planner's raw vertices, each an exact stop;
``Program.exact_stop_at``), or variants of it; ``written_program_certificate`` runs the three steps.

``certified_moves(program, certified, scene)`` -> ``WrittenProgram`` is the one place that chooses what RAPID and KRL
write with the certified profile (``runner.written_motion``; the writers only render it): a planned move as joint
targets sampled from the certified path (as few as keep the joint segments within half of WRITTEN_DEVIATION_RAD of
it), zones wherever the certified motion does not stop (the program's own, INNER_ZONE_M at most half the shorter TCP
chord at the inner targets), exact stops only at ``program.stops``; a plain joint move likewise where its certified
path departs from the straight joint segment by more than WRITTEN_DEVIATION_RAD (joint targets on it with corners as
large as the controller makes them; written straight, and reported, for jerk-limited timing, where the modelled
corners cost more than the departure), its target an exact stop where the certified motion rests there, else a
zone (the certified blend's TCP reach where the path misses the target, a corner where it passes it); then the
written moves' certificate, the zones at fault halved (or dropped) until it passes and the inner targets' deviation
is within WRITTEN_DEVIATION_RAD, each change
recorded with its reason (``WrittenProgram.changes``, in the file's header and printed by ``program``).

The model (what is published, and what is assumed):

* **Joint moves** are straight lines in joint space from the previous target to the written joint target: every
  axis starts and ends together (ABB, "Technical reference manual - RAPID Instructions, Functions and Data
  types", MoveAbsJ / MoveJ: axis-wise interpolation, all axes reach the destination at the same time; KUKA System
  Software 8 manual, PTP: synchronised axes; FANUC J and Yaskawa MOVJ: joint interpolation; UR script manual,
  ``movej``: "linear in joint-space"; the writers ``rapid``, ``krl``, ``fanuc_ls``, ``yaskawa_jbi``, ``urscript``
  rely on the same reading for their planned moves). The speed profile along the line is the controller's; the
  path is not.
* **Tool moves** keep the TCP on the line (``linear``) or on the arc through the via point (``circular``) with
  the orientation by slerp, as ``pipeline.program.tool_path`` models them; the joints follow by IK from the
  previous target (``pipeline.program.tool_moves.joint_path_along``, within 0.1 mm and 0.1 deg between samples).
* **Stops**: a move written with no zone (RAPID ``fine``, KRL without approximation, FANUC ``FINE``, Yaskawa
  without ``PL``, URScript ``r = 0``) ends at rest exactly at its target; the path passes exactly through it.
* **Corners**: a move written with a zone leaves its segment where the path enters the zone around its target and
  joins the next segment where it leaves that zone: a TCP sphere of the zone's radius (ABB ``zonedata``
  pzone_tcp, the same manual; KUKA ``$APO.CDIS`` with ``C_DIS``, KSS 8 manual "Approximate positioning":
  approximation starts at the earliest when the TCP is closer than $APO.CDIS to the end point; UR blend radius
  ``r``, UR script manual) or, with ``zone_axis_rad`` (KUKA ``C_PTP``: $APO.CPTP percent of the machine datum
  $APO_DIS_PTP, an axis angle), a box of that half width in joint space. Each cut takes at most half of its
  move (controllers shrink a zone that would overlap the next one; ``pipeline.program.compile.with_capped_zones``
  does the same). Between the two cuts the corner is the
  convex combination ``q(tau) = (1 - w(tau)) A(tau) + w(tau) B(tau)`` of the leaving segment's part inside the
  zone ``A`` and the joining segment's part ``B``, ``w`` the quintic smoothstep (zero first and second
  derivative at both ends): tangent and curvature continuous where it leaves and joins. Every point of the
  corner lies on a joint-space chord between a point of ``A`` and a point of ``B``, so within the convex hull of
  the two neighbouring segments' parts inside the zone, and within ``min(w, 1 - w) |A - B| <= |A - B| / 2`` of
  them (``ControllerMove.hull_bound_rad``). Between two tool moves (a run of lines and arcs joined by zones,
  ``tool_runs``) the corner is rounded on the tool's path instead, as ``pipeline.program.tool_path`` rounds it
  for the certified profile (a C3 blend of the TCP within the zone, at most half of either move): controllers
  blend such corners in Cartesian space (ABB's corner path of MoveL, KUKA's C_DIS approximation of LIN/CIRC, UR's
  blend of ``movel``), and the model then reproduces the certified track.
* **Limits of the model**: the corner shapes of the controllers are not published (ABB: "corner path"; KUKA:
  "approximation contour"; UR: "blend"), nor are FANUC ``CNT`` (a percentage of the deceleration the next move may
  overlap, so the corner grows with speed; the R-30iB corner-region option ``CR`` is in mm; ``fanuc_ls``) and Yaskawa
  ``PL`` levels (distances set by the controller parameters S1CxG033-040; ``read_jbi``): for those, the caller states
  the zone radius it intends and the model holds to it. What the model can stand for is the bound: the corner stays
  inside the zone and within the convex hull of its neighbouring segments. A corner at a joint move is blended in
  joint space, so its TCP may leave the zone sphere slightly (``ControllerMove.corner_tcp_m`` measures it; on the demo
  jobs it stays within the zone). The timed path is the C2 spline through the samples (SAMPLE_STEP_RAD apart;
  TOPP3_SAMPLE_STEP_RAD for the jerk-limited topp3, whose cost grows with the samples; the spline's third derivative
  jumps at every sample, and on the topp3 demo jobs zones at joint corners made the time as written longer than
  exact stops: an analytic C3 corner is the fix). The speed through a corner is the
  time-optimal one within the limits, not the controller's own (which is slower or equal), so ``WrittenTiming`` is a
  lower bound of the written program's cycle time on the controller for its path.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from ...program.model import CIRCULAR, JOINT, LINEAR, Program
from ...program.timing import CarriedLoads, join_profiles, rest_profile, stopped_schedules
from ...program.tool_moves import joint_path_along
from ...program.tool_path import ToolMove, ToolPath
from ...timing import time_path
from ...timing.joint_path import JointPath, path_through_samples
from ...timing.profile import LimitReport, Profile, TimingDetails, certify
from ...timing.schedule import LimitSchedule
from ...timing.tcp import TcpMotion

#: Samples of a joint-space path at most this far apart [rad or m] (and at least MIN_PIECE_SAMPLES a piece).
SAMPLE_STEP_RAD = 0.004
MIN_PIECE_SAMPLES = 8
#: The same for a path timed by topp3 (jerk-limited), whose solver's cost grows with the waypoints.
TOPP3_SAMPLE_STEP_RAD = 0.04
#: Samples of a move's end half where the path's distance to the zone's centre is evaluated.
ZONE_SAMPLES = 400
#: Consecutive samples closer than this [rad or m] are one (a move's kept part between two corners that each take
#: half of it has no length, and its samples, a few 1e-8 apart, left the jerk-limited solver without a profile).
SAME_SAMPLE = 1e-6


@dataclass(frozen=True, eq=False)
class WrittenMove:
    """One move as a controller program writes it: ``kind`` (joint, linear, circular), ``target`` (dof,) the
    joint values the controller reaches [rad or m] (a tool move's: the IK solution the writer chose), ``X_BT``
    (4, 4) [m] the TCP pose (tool moves; None for joint moves: taken from the target), ``via`` (3,) [m] of a
    circular move, ``speed`` (joint: a fraction of the joint speed limits; tool: TCP speed [m/s]), ``zone_m``
    the TCP zone radius [m] at its end and ``zone_axis_rad`` a joint-space zone [rad] (KUKA C_PTP; None: none):
    neither given (0 / None) is an exact stop. ``source``: the program's waypoint the move belongs to (a planned
    move's vertices all carry its end)."""

    kind: str
    target: np.ndarray
    speed: float
    zone_m: float = 0.0
    X_BT: np.ndarray | None = None
    via: np.ndarray | None = None
    zone_axis_rad: float | None = None
    source: int | None = None

    @property
    def has_zone(self) -> bool:
        return self.zone_m > 0.0 or (self.zone_axis_rad is not None and self.zone_axis_rad > 0.0)


@dataclass(frozen=True, eq=False)
class ControllerMove:
    """The modelled motion of written move ``index`` (0-based; it starts at the previous target): ``stops``
    (at rest at its end), its ``zone_m`` / ``zone_axis_rad`` as written, ``cut_out`` and ``cut_in`` the path
    parameters [0, 1] where the corner at its end leaves this move and joins the next (1 and 0 without one),
    ``deviation_rad`` the largest joint-space distance of that corner from the written segments (0 at a stop),
    ``hull_bound_rad`` max |A - B| / 2 over a joint-space corner (module docstring; None for a corner rounded on the
    tool path), ``corner_tcp_m`` the largest TCP
    distance of the corner from the move's target (None at a stop), ``samples`` the indices (into
    ``ControllerPath.q``) of the samples of this move (its kept part and the first half of its corner)."""

    index: int
    move: WrittenMove
    stops: bool
    cut_out: float
    cut_in: float
    deviation_rad: float
    hull_bound_rad: float | None
    corner_tcp_m: float | None
    samples: np.ndarray

    def to_dict(self) -> dict:
        return {"index": self.index, "kind": self.move.kind, "source": self.move.source, "stops": self.stops,
                "zone_m": self.move.zone_m, "zone_axis_rad": self.move.zone_axis_rad,
                "deviation_rad": self.deviation_rad, "hull_bound_rad": self.hull_bound_rad,
                "corner_tcp_m": self.corner_tcp_m}


@dataclass(frozen=True, eq=False)
class ControllerStretch:
    """The path between two stops: ``moves`` (indices of the written moves it carries), ``path`` (the C2
    spline through its samples, ``pipeline.timing.joint_path.path_through_samples``; None when it has no
    length), ``s`` (n,) the samples' path parameters, ``q`` (n, dof) the samples, ``passages`` the s at which
    it passes each of its moves' ends (a corner's middle), ``bounds`` / ``speeds`` the schedule rows (s
    bounds, (joint speed fraction, TCP speed [m/s], TCP accel [m/s^2]; -1: the program's ``tcp_accel_max`` on
    tool moves) per interval)."""

    moves: tuple[int, ...]
    path: JointPath | None
    s: np.ndarray
    q: np.ndarray
    passages: np.ndarray
    bounds: np.ndarray
    speeds: np.ndarray


@dataclass(frozen=True, eq=False)
class ControllerPath:
    """The modelled path of a written program: ``q`` (N, dof) its samples (stretch after stretch, a stop's
    sample once), ``move_of`` (N,) the written move each sample belongs to, ``tcp`` (N, 3) [m], ``moves``
    (ControllerMove per written move), ``stretches``, ``q_start`` where it starts."""

    q_start: np.ndarray
    q: np.ndarray
    move_of: np.ndarray
    tcp: np.ndarray
    moves: tuple[ControllerMove, ...]
    stretches: tuple[ControllerStretch, ...]

    @property
    def stops(self) -> list[int]:
        """Indices of the written moves at whose end the motion rests."""
        return [m.index for m in self.moves if m.stops]

    @property
    def max_deviation_rad(self) -> float:
        return max((m.deviation_rad for m in self.moves), default=0.0)


def written_moves(program: Program, exact_stops: bool = False, pass_through_zone_m: float = 0.0,
                  flow_zone_m: float | None = None) -> list[WrittenMove]:
    """The moves today's writers write for ``program``: a planned move as its planner's vertices, one joint move
    each, every one an exact stop (``Program.exact_stop_at``: at both ends of a planned move); the other moves with
    their zone, an exact stop at the program's stops; a waypoint the program passes through without a zone with
    ``pass_through_zone_m`` (0: an exact stop, as KRL, FANUC FINE and URScript r = 0 write it; RAPID's z0 is
    0.0003). ``exact_stops``: every move an exact stop. ``flow_zone_m`` (None: as today): exact stops only at the
    program's stops, this zone [m] at a planner's inner vertices and at a waypoint passed through without a zone,
    and the program's own zone at the ends of planned moves (what a writer of the certified zones would write
    with the planner's vertices as targets)."""
    written = []
    for move in program.moves:
        stop = move.end in program.stops
        if move.planned is not None:
            vertices = move.planned.waypoints[1:]
            for j, vertex in enumerate(vertices):
                zone = 0.0
                if flow_zone_m is not None and not exact_stops and not (stop and j == len(vertices) - 1):
                    zone = flow_zone_m if j < len(vertices) - 1 else (move.zone or flow_zone_m)
                written.append(WrittenMove(JOINT, np.asarray(vertex, dtype=float), move.speed, zone, source=move.end))
            continue
        if flow_zone_m is not None:
            zone = 0.0 if exact_stops or stop else (move.zone or flow_zone_m)
        else:
            zone = 0.0 if exact_stops or program.exact_stop_at(move) else (move.zone or pass_through_zone_m)
        speed = program.tool_speed(move) / program.speed_scale if move.is_tool_move else move.speed
        written.append(WrittenMove(move.kind, move.target, speed, zone, move.X_BT if move.is_tool_move else None,
                                   move.via, source=move.end))
    return written


def controller_path(robot, q_start: np.ndarray, moves: list[WrittenMove],
                    sample_step_rad: float = SAMPLE_STEP_RAD) -> ControllerPath:
    """The joint path the controller may take for ``moves`` from ``q_start`` (see the module docstring), sampled at
    most ``sample_step_rad`` apart in joint space (the timed path is the C2 spline through the samples)."""
    q_start = np.asarray(q_start, dtype=float)
    n = len(moves)
    info: dict = {}
    runs = tool_runs(moves)
    native = {k for first, last in runs for k in range(first, last)}    # corners rounded on the tool path
    run_at = {first: last for first, last in runs}
    segments: list = [None] * n
    q_from, k = q_start, 0
    while k < n:
        if k in run_at:
            last = run_at[k]
            segments[k: last + 1] = _run_segments(robot, q_from, moves, k, last, info)
            k = last + 1
        else:
            segments[k] = _segment(robot, q_from, moves[k], k)
            k += 1
        q_from = segments[k - 1].q_end      # where the controller is: a tool move's end by IK from its start
    cuts_out, cuts_in = [1.0] * n, [0.0] * n
    for k, move in enumerate(moves[:-1]):
        if move.has_zone and k not in native:
            cuts_out[k] = _cut(robot, segments[k], move, at_end=True)
            cuts_in[k + 1] = _cut(robot, segments[k + 1], move, at_end=False)
    stops = [not m.has_zone for m in moves[:-1]] + [True]
    stretches, first = [], 0
    for k in range(n):
        if not stops[k]:
            continue
        stretches.append(_stretch(robot, segments, moves, list(range(first, k + 1)), cuts_in, cuts_out, native, info,
                                  sample_step_rad))
        first = k + 1
    q, move_of, offset = [q_start[None]], [np.array([0])], 1
    sample_index = {k: [] for k in range(n)}
    for stretch in stretches:
        q.append(stretch.q[1:])
        owners = info[id(stretch)]["owners"][1:]
        move_of.append(owners)
        for j, owner in enumerate(owners):
            sample_index[int(owner)].append(offset + j)
        offset += len(owners)
    q, move_of = np.concatenate(q), np.concatenate(move_of)
    tcp = robot.fk_batch(q)[:, :3, 3]
    controller_moves = []
    for k, move in enumerate(moves):
        corner = info.get(("corner", k))
        controller_moves.append(ControllerMove(
            k, move, stops[k], cuts_out[k], cuts_in[k + 1] if k + 1 < n else 0.0,
            0.0 if corner is None else corner["deviation"], 0.0 if corner is None else corner["hull"],
            None if corner is None else corner["tcp"], np.array(sample_index[k], dtype=int)))
    return ControllerPath(q_start, q, move_of, tcp, tuple(controller_moves), tuple(stretches))


def tool_runs(moves: list[WrittenMove]) -> list[tuple[int, int]]:
    """(first, last) indices of each run of two or more tool moves joined by TCP zones: a controller rounds those
    corners on the tool's path (ABB corner path, KUKA C_DIS approximation of LIN/CIRC, UR ``movel`` blends), which
    the model takes as ``pipeline.program.tool_path`` rounds them (a blend within the zone, along the path)."""
    runs, k = [], 0
    while k < len(moves):
        if moves[k].kind == JOINT:
            k += 1
            continue
        j = k
        while (j + 1 < len(moves) and moves[j + 1].kind != JOINT and moves[j].zone_m > 0.0
               and moves[j].zone_axis_rad is None):
            j += 1
        if j > k:
            runs.append((k, j))
        k = j + 1
    return runs


# -- geometry ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class _Segment:
    """A written move's segment: ``f(s)`` -> (n, dof) for s in [0, 1], its joint-space ``length``, where it ends
    ``q_end``, and ``blend_in`` / ``blend_out``: the s where a corner rounded on the tool path ends / starts on it
    (0 / 1: none)."""

    f: object
    length: float
    q_end: np.ndarray
    blend_in: float = 0.0
    blend_out: float = 1.0


def _segment(robot, q_from: np.ndarray, move: WrittenMove, k: int) -> _Segment:
    target = np.asarray(move.target, dtype=float)
    if move.kind == JOINT:
        delta = target - q_from
        return _Segment(lambda s: q_from + np.atleast_1d(s)[:, None] * delta, float(np.linalg.norm(delta)), target)
    if move.kind not in (LINEAR, CIRCULAR):
        raise ValueError(f"written move {k}: unknown kind {move.kind!r}")
    X_end = move.X_BT if move.X_BT is not None else robot.fk(target)
    tool_path = ToolPath(robot.fk(q_from), [ToolMove(move.kind, X_end, move.via, 0.0)], first_index=k)
    along = joint_path_along(robot, tool_path, q_from, max(move.speed, 1e-6), "slow_down")
    path = along.path
    return _Segment(lambda s: path(np.atleast_1d(np.asarray(s, dtype=float))), float(path.length), along.samples[-1])


def _run_segments(robot, q_from: np.ndarray, moves: list[WrittenMove], first: int, last: int, info: dict) -> list:
    """The segments of tool moves ``first`` .. ``last`` joined by zones: each move's part of the joint path along
    their tool path with its corners rounded (``tool_runs``); the corners' deviation from the unrounded segments
    and their TCP distance from the targets in ``info``."""
    run = moves[first: last + 1]
    X_ends = [m.X_BT if m.X_BT is not None else robot.fk(m.target) for m in run]
    tool_moves = [ToolMove(m.kind, X, m.via, m.zone_m if j < len(run) - 1 else 0.0)
                  for j, (m, X) in enumerate(zip(run, X_ends))]
    tool_path = ToolPath(robot.fk(q_from), tool_moves, first_index=first)
    along = joint_path_along(robot, tool_path, q_from, max(min(m.speed for m in run), 1e-6), "slow_down")
    path, L, starts = along.path, tool_path.length, tool_path.starts
    blends = {int(tool_path.move_of(b.start)[0]): b for b in tool_path.blends}

    def part(lo: float, hi: float):
        return lambda s: path((lo + np.atleast_1d(np.asarray(s, dtype=float)) * (hi - lo)) / L)

    segments = []
    for j in range(len(run)):
        lo, hi = starts[j], starts[j + 1]
        f = part(lo, hi)
        q = f(np.linspace(0.0, 1.0, 64))
        length = float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum())
        before, after = blends.get(first + j - 1), blends.get(first + j)
        segments.append(_Segment(f, length, q[-1], 0.0 if before is None else (before.end - lo) / (hi - lo),
                                 1.0 if after is None else (after.start - lo) / (hi - lo)))
    plain, q_plain = [], q_from                     # the unrounded segments, for the corners' deviation
    for j, move in enumerate(run):
        plain.append(_segment(robot, q_plain, move, first + j))
        q_plain = plain[-1].q_end
    for j, blend in ((j - first, b) for j, b in blends.items()):
        corner = path(np.linspace(blend.start, blend.end, 64) / L)
        a = plain[j].f(np.linspace(0.0, 1.0, 256))
        b = plain[j + 1].f(np.linspace(0.0, 1.0, 256))
        tcp = robot.fk_batch(corner)[:, :3, 3]
        info[("corner", first + j)] = {"deviation": _distance_to_parts(corner, a, b), "hull": None,
                                       "tcp": float(np.linalg.norm(tcp - X_ends[j][:3, 3], axis=1).max())}
    return segments


def _cut(robot, segment: _Segment, move: WrittenMove, at_end: bool) -> float:
    """The path parameter where ``segment`` enters (at its end) or leaves (at its start) the zone of ``move``
    around the corner (``move``'s target, the segment's end or start), at most half the segment."""
    s = np.linspace(1.0, 0.5, ZONE_SAMPLES) if at_end else np.linspace(0.0, 0.5, ZONE_SAMPLES)
    q = segment.f(s)
    if move.zone_axis_rad is not None and move.zone_axis_rad > 0.0:
        distance, radius = np.abs(q - q[0]).max(axis=1), move.zone_axis_rad
    else:
        tcp = robot.fk_batch(q)[:, :3, 3]
        distance, radius = np.linalg.norm(tcp - tcp[0], axis=1), move.zone_m
    beyond = np.flatnonzero(distance >= radius)
    if beyond.size == 0:
        return float(s[-1])
    j = int(beyond[0])
    if j == 0:
        return float(s[0])
    f = (radius - distance[j - 1]) / max(distance[j] - distance[j - 1], 1e-300)
    return float(s[j - 1] + np.clip(f, 0.0, 1.0) * (s[j] - s[j - 1]))


def _count(length: float, step: float) -> int:
    return max(MIN_PIECE_SAMPLES, int(np.ceil(length / step)) + 1)


def smoothstep(t: np.ndarray) -> np.ndarray:
    """The quintic smoothstep 10 t^3 - 15 t^4 + 6 t^5: 0 to 1 with zero first and second derivatives at both ends."""
    return t**3 * (10.0 - 15.0 * t + 6.0 * t**2)


def _stretch(robot, segments, moves, indices, cuts_in, cuts_out, native, info, step: float) -> ControllerStretch:
    """Samples, path and schedule of the stretch of written moves ``indices`` (from a stop to the next)."""
    q_parts, owner_parts, kinds = [], [], []      # kinds: (kind, k, limits of moves): kept parts, corners
    for k in indices:
        segment = segments[k]
        lo, hi = cuts_in[k], cuts_out[k]
        inner = [x for x in (segment.blend_in, segment.blend_out) if lo < x < hi]
        edges = [lo, *inner, hi]
        for a, b in itertools.pairwise(edges):
            n = _count(segment.length * (b - a), step)
            q_parts.append(segment.f(np.linspace(a, b, n)))
            owner_parts.append(np.full(n, k))
            neighbours = ([k - 1] if a < segment.blend_in else []) + ([k + 1] if b > segment.blend_out else [])
            kinds.append(("kept", k, [moves[j] for j in [k, *neighbours]]))
        if k == indices[-1]:
            break
        if k in native:                # a corner rounded on the tool path: in the kept parts already
            kinds[-1] = ("kept_end", *kinds[-1][1:])
            continue
        following = segments[k + 1]
        n = _count(max(segment.length * (1.0 - hi) + following.length * cuts_in[k + 1], 1e-9) * 1.5, step)
        tau = np.linspace(0.0, 1.0, n)
        a = segment.f(hi + tau * (1.0 - hi))
        b = following.f(tau * cuts_in[k + 1])
        w = smoothstep(tau)[:, None]
        corner = (1.0 - w) * a + w * b
        tcp = robot.fk_batch(corner)[:, :3, 3]
        info[("corner", k)] = {"deviation": _distance_to_parts(corner, a, b),
                               "hull": float(np.linalg.norm(a - b, axis=1).max() / 2.0),
                               "tcp": float(np.linalg.norm(tcp - robot.fk(segment.q_end)[:3, 3], axis=1).max())}
        q_parts.append(corner)
        owner_parts.append(np.where(tau <= 0.5, k, k + 1))
        kinds.append(("corner", k, [moves[k], moves[k + 1]]))
    # join the parts (each part's first sample is the previous part's last)
    q, owners, starts, count = [q_parts[0]], [owner_parts[0]], [0], len(q_parts[0])
    for part, owner in zip(q_parts[1:], owner_parts[1:]):
        starts.append(count - 1)
        q.append(part[1:])
        owners.append(owner[1:])
        count += len(part) - 1
    q, owners = np.concatenate(q), np.concatenate(owners)
    ends = [start + len(part) - 1 for start, part in zip(starts, q_parts)]
    chord = np.linalg.norm(np.diff(q, axis=0), axis=1)
    keep = np.concatenate([chord > SAME_SAMPLE, [True]])     # of two samples at one place, the later
    new_index = np.searchsorted(np.flatnonzero(keep), np.arange(len(q)))     # each sample's kept one at or after it
    q, owners = q[keep], owners[keep]
    chord = np.linalg.norm(np.diff(q, axis=0), axis=1)
    total = float(chord.sum())
    s = np.concatenate([[0.0], np.cumsum(chord)]) / total if total > SAME_SAMPLE else np.linspace(0.0, 1.0, len(q))
    s[-1] = 1.0
    path = path_through_samples(s, q) if total > SAME_SAMPLE and len(q) >= 4 else None
    # the schedule: per part its limits; a bound in each corner's middle (the passage of the move it ends)
    rows, passages = [], []
    for (kind, k, limited), start, end in zip(kinds, starts, ends):
        s0, s1 = s[new_index[start]], s[new_index[end]]
        if kind in ("kept", "kept_end"):
            rows.append((s0, s1, *_limits_of(limited)))
            if kind == "kept_end" or (k == indices[-1] and end == ends[-1]):
                passages.append(s1 if kind == "kept_end" else 1.0)
            continue
        middle = s[new_index[(start + end) // 2]]
        speeds = _limits_of(limited)
        rows += [(s0, middle, *speeds), (middle, s1, *speeds)]
        passages.append(middle)
    bounds = np.array([r[0] for r in rows] + [1.0])
    values = np.array([r[2:] for r in rows])
    stretch = ControllerStretch(tuple(indices), path, s, q, np.array(passages), bounds, values)
    info[id(stretch)] = {"owners": owners}
    return stretch


def _limits_of(moves: list[WrittenMove]) -> tuple[float, float, float]:
    """(joint speed fraction, TCP speed [m/s], TCP accel marker) on a part of ``moves``: a joint move its speed
    fraction; tool moves alone their slowest TCP speed (the -1 accel marker: the program's TCP acceleration); a
    corner between a joint move and a tool move the joint move's fraction and no TCP limit (as ``StretchPath``'s
    blends)."""
    joint = [m.speed for m in moves if m.kind == JOINT]
    if joint:
        return min(joint + [1.0]), np.inf, np.inf
    return 1.0, min(m.speed for m in moves), -1.0


def _distance_to_parts(corner: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance of the corner's samples from the polylines through ``a`` and ``b``."""
    return float(np.minimum(point_to_polyline(corner, a), point_to_polyline(corner, b)).max())


def point_to_polyline(points: np.ndarray, line: np.ndarray, chunk: int = 256) -> np.ndarray:
    """The distance (n,) of each point (n, dof) to the polyline through ``line`` (m, dof) (its vertices and the
    straight pieces between them)."""
    points, line = np.atleast_2d(points), np.atleast_2d(line)
    if len(line) == 1:
        return np.linalg.norm(points - line[0], axis=1)
    a, d = line[:-1], np.diff(line, axis=0)
    dd = np.maximum((d * d).sum(axis=1), 1e-300)
    out = np.empty(len(points))
    for i in range(0, len(points), chunk):
        p = points[i: i + chunk]
        t = np.clip(np.einsum("nmj,mj->nm", p[:, None, :] - a[None], d) / dd, 0.0, 1.0)
        nearest = a[None] + t[..., None] * d[None]
        out[i: i + chunk] = np.linalg.norm(p[:, None, :] - nearest, axis=2).min(axis=1)
    return out


# -- timing --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class WrittenDetails(TimingDetails):
    """What timing the written program did: per stretch its moves and ``duration_s``; ``passages_s`` the time
    at which the motion passes (or stops at) the end of each written move."""

    stretches: tuple[dict, ...]
    passages_s: tuple[float, ...]


@dataclass(frozen=True, eq=False)
class WrittenTiming:
    """The cycle time of a written program: ``profile`` (the joined profile, uncertified), ``duration_s``,
    ``passages_s`` (K,) when it passes each written move's end, ``move_durations_s`` (K,)."""

    profile: Profile
    duration_s: float
    passages_s: np.ndarray
    move_durations_s: np.ndarray


def time_written(program: Program, path: ControllerPath, method: str | None = None) -> WrittenTiming:
    """The time-optimal motion along the modelled ``path`` of a written program of ``program`` (its robot,
    limits, safety TCP limit, TCP acceleration on tool moves, speed scale and dt), each stretch from rest to rest,
    by ``method`` (None: the program's own when it follows a path, toppra or topp3; topp3, jerk-limited, for a
    program timed by ruckig, which does not follow a given path)."""
    robot = program.robot
    method = method or {"ruckig": "topp3"}.get(program.timing, program.timing)
    tcp = TcpMotion(robot) if (program.has_tcp_limits or any(m.move.kind != JOINT for m in path.moves)) else None
    accel = np.inf if program.tcp_accel_max is None else program.tcp_accel_max
    profiles, passages, stretches = [], [], []
    offset = 0.0
    last_of = {m.move.source: m.index for m in path.moves}        # a waypoint's last written move
    loads = CarriedLoads(program)
    for stretch in path.stretches:
        if stretch.path is None:            # no motion: the stretch takes no time
            passages += [offset] * len(stretch.moves)
            stretches.append({"moves": list(stretch.moves), "duration_s": 0.0})
            continue
        speeds = stretch.speeds.copy()
        speeds[:, 2] = np.where(speeds[:, 2] < 0.0, accel, speeds[:, 2])
        schedule = LimitSchedule(stretch.bounds, *speeds.T)
        leaving = next((path.moves[i].move.source - 1 for i in stretch.moves if path.moves[i].move.source), 0)
        profile = time_path(robot, stretch.path, method=method, speed_scale=program.speed_scale,
                            limits=program.limits, dt=program.dt, tcp=tcp, schedule=schedule,
                            drake=loads.after(leaving))
        if not profiles and program.rest_at(0) > 0.0:       # waypoint 0's waits, before the first move
            profiles.append(rest_profile(profile, 0, program.rest_at(0), program.dt,
                                         loads.held_torque(profile.q[0], 0)))
            offset += program.rest_at(0)
        bound_times = profile.schedule.bounds
        # passages sit on schedule bounds: their times are exact
        index = np.searchsorted(stretch.bounds, stretch.passages - 1e-12)
        passages += (offset + bound_times[np.clip(index, 0, len(bound_times) - 1)]).tolist()
        stretches.append({"moves": list(stretch.moves), "duration_s": profile.duration})
        profiles.append(profile)
        offset += profile.duration
        source = path.moves[stretch.moves[-1]].move.source
        if source is not None and last_of[source] == stretch.moves[-1] and program.rest_at(source) > 0.0:
            profiles.append(rest_profile(profile, -1, program.rest_at(source), program.dt,
                                         loads.held_torque(profile.q[-1], source)))
            offset += program.rest_at(source)
    details = WrittenDetails(tuple(stretches), tuple(passages))
    joined = join_profiles(profiles, details)
    schedule = stopped_schedules(profiles)
    if schedule is not None:
        joined = dataclasses.replace(joined, schedule=schedule)
    passages = np.array(passages)
    return WrittenTiming(joined, joined.duration, passages, np.diff(np.concatenate([[0.0], passages])))


# -- certificate ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class WrittenCertificate:
    """The certificate of a written program: ``passed`` (limits and, in a cell, clearance), ``limits`` (the
    LimitReport of ``certify`` on the as-written motion, with its ``clearance``), ``min_clearance_m`` (the
    smallest robot-obstacle distance; None outside a cell), ``deviation_rad`` (K,) per written move the largest
    joint-space distance from its modelled samples to the certified profile's path (None without one),
    ``max_deviation_rad``, ``duration_s`` as written and ``certified_duration_s``."""

    passed: bool
    limits: LimitReport
    min_clearance_m: float | None
    deviation_rad: np.ndarray | None
    duration_s: float
    certified_duration_s: float | None

    @property
    def max_deviation_rad(self) -> float | None:
        return None if self.deviation_rad is None else float(self.deviation_rad.max(initial=0.0))

    def to_dict(self) -> dict:
        clearance = self.limits.clearance
        return {"passed": self.passed, "limits_passed": bool(self.limits.worst_ratio <= 1.0 + self.limits.tolerance
                                     and (self.limits.columns is None or self.limits.columns.passed)),
                "worst": str(self.limits), "min_clearance_m": self.min_clearance_m,
                "clearance_passed": None if clearance is None else bool(clearance.passed),
                "deviation_rad": None if self.deviation_rad is None else self.deviation_rad.tolist(),
                "duration_s": self.duration_s, "certified_duration_s": self.certified_duration_s}


def certify_written(program: Program, path: ControllerPath, timing: WrittenTiming, certified: Profile | None = None,
                    scene=None) -> WrittenCertificate:
    """``timing``'s motion certified (``certify``: joint limits, schedule and, with ``scene``, a CollisionModel,
    the clearance), and per written move the largest joint-space distance of its samples from the certified
    profile's path (the polyline through its samples) over the certified motion from two waypoints before the
    move's program waypoint to one after it (``certified.details.passages_s``; the whole profile without them)."""
    report = certify(timing.profile, scene=scene)
    clearance = report.clearance
    deviation = None
    if certified is not None:
        passages = getattr(certified.details, "passages_s", None)
        deviation = np.zeros(len(path.moves))
        for move in path.moves:
            if move.samples.size == 0:
                continue
            window = slice(None)
            if passages is not None and move.move.source is not None:
                j = move.move.source
                t0 = passages[max(j - 2, 0)]
                t1 = passages[min(j + 1, len(passages) - 1)]
                lo = max(int(np.searchsorted(certified.t, t0)) - 1, 0)
                hi = int(np.searchsorted(certified.t, t1)) + 1
                window = slice(lo, hi)
            deviation[move.index] = float(point_to_polyline(path.q[move.samples], certified.q[window]).max())
    return WrittenCertificate(bool(report.passed), report, None if clearance is None else clearance.min_distance_m,
                              deviation, timing.duration_s, None if certified is None else certified.duration)


def written_program_certificate(program: Program, moves: list[WrittenMove], certified: Profile | None = None,
                                scene=None, method: str | None = None):
    """(ControllerPath, WrittenTiming, WrittenCertificate) of ``moves`` written for ``program``, from its first
    waypoint: the three steps in one call (``method`` as ``time_written``; a jerk-limited one, topp3, on samples
    TOPP3_SAMPLE_STEP_RAD apart: its solver's cost grows with the path's waypoints)."""
    method = method or {"ruckig": "topp3"}.get(program.timing, program.timing)
    step = TOPP3_SAMPLE_STEP_RAD if method == "topp3" else SAMPLE_STEP_RAD
    path = controller_path(program.robot, program.waypoints[0].q, moves, step)
    timing = time_written(program, path, method)
    return path, timing, certify_written(program, path, timing, certified, scene)


# -- the certified motion as written ---------------------------------------------------------------------------
#: The largest joint-space distance [rad] of the modelled controller path of a planned move, as written, from the
#: certified profile's path: 0.01 rad (0.57 deg; on a 6-axis arm of about 0.7 m reach a TCP offset of at most a few
#: mm, well inside a cell's clearance margins of 10 mm and more, and far below the planner's own edge tolerance of a
#: straight joint segment). Half of it goes to the joint segments between written targets (their chords), half to
#: the zones at the targets (a corner within the hull of its segments, ``ControllerMove.hull_bound_rad``).
WRITTEN_DEVIATION_RAD = 0.01
#: Share of WRITTEN_DEVIATION_RAD the chords between written targets may take.
CHORD_SHARE = 0.5
#: Share of WRITTEN_DEVIATION_RAD the chords between the written targets of a joint move may take: a flowing curve
#: of curvature k cut into chords of length L within d of it turns by about k L at each target, and a corner at half
#: the chord cuts it by about k L^2 / 4 = 2 d more; a quarter leaves the corners room within the bound.
JOINT_CHORD_SHARE = 0.5
#: Zone [m] at an inner target of a planned move (a point the certified motion flows through), before shrinking:
#: at most half the shorter TCP chord of its two segments.
INNER_ZONE_M = 0.05
#: Inner zones are rounded down to whole mm (as a programmer writes them).
ZONE_STEP_M = 0.001
#: Zone [m] at a waypoint the certified motion passes through without a zone of its own (RAPID's z0: 0.3 mm).
PASS_THROUGH_ZONE_M = 0.0003
#: Zones are halved at most this many times (then dropped: an exact stop) until the written program certifies.
SHRINK_ROUNDS = 6
#: A zone smaller than this [m] is dropped (an exact stop).
SMALLEST_ZONE_M = 0.0005


@dataclass(frozen=True, eq=False)
class WrittenProgram:
    """What a writer writes for a Program with its certified profile (``certified_moves``): ``moves`` (the written
    moves, a planned move as joint targets sampled from the certified path, then its end), the modelled ``path``,
    ``timing`` and ``certificate`` of those moves, ``changes`` (per written move a zone changed or dropped, with its
    reason), ``deviation_bound_rad`` the bound its planned moves were sampled for, ``notes``: further header lines
    of one language (``runner.language_written``: the certificate with the zones FANUC or Yaskawa write)."""

    moves: tuple[WrittenMove, ...]
    path: ControllerPath
    timing: WrittenTiming
    certificate: WrittenCertificate
    changes: tuple[str, ...]
    deviation_bound_rad: float
    bounded: tuple[int, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def bounded_deviation_rad(self) -> float | None:
        """The largest deviation over the written moves the bound holds for (``bounded``: the inner targets of
        planned moves not beside a zone of the program's own, whose corner is the controller's, not the certified
        blend)."""
        d = self.certificate.deviation_rad
        return None if d is None or not self.bounded else float(d[list(self.bounded)].max())

    def of(self, end: int) -> list[WrittenMove]:
        """The written moves of the program's move to waypoint ``end`` (the last: to its target)."""
        return [w for w in self.moves if w.source == end]

    @property
    def exact_stops(self) -> int:
        return sum(not w.has_zone for w in self.moves)

    def header_lines(self) -> list[str]:
        """One or two comment lines: the written program's certificate, clearance, deviation and cycle time."""
        c = self.certificate
        clearance = "" if c.min_clearance_m is None else f", smallest clearance {c.min_clearance_m * 1e3:.1f} mm"
        deviation = "" if c.max_deviation_rad is None else (f", largest deviation from the certified path "
                                                           f"{c.max_deviation_rad:.4f} rad")
        if self.bounded_deviation_rad is not None:
            deviation += (f" ({self.bounded_deviation_rad:.4f} rad away from the job's own zones, bound "
                          f"{self.deviation_bound_rad:g} rad)")
        certified = "" if c.certified_duration_s is None else f" (certified {c.certified_duration_s:.3f} s)"
        lines = [(f"As written (pipeline.outputs.controllers.controller_motion): certificate "
                  f"{'PASSED' if c.passed else 'FAILED'}{clearance}{deviation}; cycle time as written "
                  f"{c.duration_s:.3f} s{certified}; {self.exact_stops} exact stops.")]
        if self.changes:
            lines.append("Changed from the certified motion: " + "; ".join(self.changes))
        return lines + list(self.notes)


def _tcp(robot, q: np.ndarray) -> np.ndarray:
    return robot.fk_batch(np.atleast_2d(q))[:, :3, 3]


def _chord_targets(samples: np.ndarray, tolerance: float) -> list[int]:
    """Indices of ``samples`` (n, dof) to keep, the first and last included, as few as keep every sample within
    ``tolerance`` [rad] of the straight joint segments between consecutive kept ones (greedy: the farthest)."""
    kept, a, n = [0], 0, len(samples)
    while a < n - 1:
        b = a + 1
        while b + 1 < n and point_to_polyline(samples[a: b + 2], samples[[a, b + 1]]).max() <= tolerance:
            b += 1
        kept.append(b)
        a = b
    return kept


def _planned_targets(program: Program, certified: Profile, move, zone_before: float, zone_after: float,
                     tolerance: float) -> list[np.ndarray]:
    """Joint targets (each a sample of ``certified``) of the planned ``move`` between its ends: the certified path's
    samples between its passages of the move's start and end waypoints, outside the zones at both ends (there the
    controller's corner takes over), thinned to as few as keep the joint segments within ``tolerance``."""
    passages = certified.details.passages_s
    t0, t1 = passages[move.end - 1], passages[move.end]
    inside = (certified.t > t0) & (certified.t < t1)
    samples = certified.q[inside]
    if len(samples) == 0:
        return []
    robot = program.robot
    tcp = _tcp(robot, samples)
    start = _tcp(robot, program.targets[move.end - 1])[0]
    end = _tcp(robot, move.target)[0]
    keep = (np.linalg.norm(tcp - start, axis=1) >= zone_before) & (np.linalg.norm(tcp - end, axis=1) >= zone_after)
    samples = samples[keep]
    if len(samples) == 0:
        return []
    # an end the certified motion stops at is on its path: the chords run from and to it
    first = [program.targets[move.end - 1]] if zone_before <= 0.0 else []
    last = [move.target] if zone_after <= 0.0 else []
    points = np.array([*first, *samples, *last])
    kept = [i - len(first) for i in _chord_targets(points, tolerance)]
    return [samples[i] for i in kept if 0 <= i < len(samples)]


def _flow_zone(program: Program, certified: Profile, move, tolerance: float) -> tuple[float, bool]:
    """The zone [m] to write at the end of joint ``move`` where the certified motion flows through its target
    without a zone of the program's own, and whether it is the certified corner's own (the certified path misses
    the target by more than ``tolerance``, as a path of lines with blended corners does: the zone is the TCP
    reach of the blend, the samples around the passage farther than ``tolerance`` from the straight segments, rounded
    up to whole mm) or a flow zone (the path passes the target: INNER_ZONE_M, capped later as an inner target's)."""
    passages = certified.details.passages_s
    j = move.end
    t = passages[j]
    at = certified.q[int(np.argmin(np.abs(certified.t - t)))]
    if np.linalg.norm(at - move.target) <= tolerance or j + 1 >= len(passages):
        return INNER_ZONE_M, False
    a, b, c = program.targets[j - 1], move.target, program.targets[j + 1]
    inside = (certified.t > passages[j - 1]) & (certified.t < passages[j + 1])
    samples, times = certified.q[inside], certified.t[inside]
    off = point_to_polyline(samples, np.array([a, b, c])) > tolerance
    # the run of deviating samples around the passage
    k = int(np.argmin(np.abs(times - t)))
    if not off[k]:
        return INNER_ZONE_M, False
    lo = k
    while lo > 0 and off[lo - 1]:
        lo -= 1
    hi = k
    while hi + 1 < len(off) and off[hi + 1]:
        hi += 1
    reach = float(np.linalg.norm(_tcp(program.robot, samples[lo: hi + 1]) - _tcp(program.robot, b)[0], axis=1).max())
    return float(np.ceil(reach / ZONE_STEP_M - 1e-9)) * ZONE_STEP_M, True


def _at_rest(certified: Profile, t: float) -> bool:
    """Whether the certified motion is at rest (every joint speed within 1e-6) at its sample nearest ``t``."""
    return float(np.abs(certified.qd[int(np.argmin(np.abs(certified.t - t)))]).max()) <= 1e-6


def _departure(program: Program, certified: Profile, move) -> float:
    """The largest joint-space distance [rad] of the certified path between the passages of ``move``'s ends from
    the straight joint segment between its targets."""
    passages = certified.details.passages_s
    samples = certified.q[(certified.t >= passages[move.end - 1]) & (certified.t <= passages[move.end])]
    ends = np.array([program.targets[move.end - 1], move.target])
    return float(point_to_polyline(samples, ends).max()) if len(samples) else 0.0


def _joint_targets(program: Program, certified: Profile, move, zone_before: float, zone_after: float,
                   tolerance: float, departure: float) -> list[np.ndarray]:
    """Joint targets (samples of ``certified``) of the joint ``move`` between its ends, where the certified path
    departs from the straight joint segment between its targets by more than ``departure`` (none where it does not):
    the samples between its passages outside the zones at both ends, thinned (``_chord_targets``) with the move's
    start and end as the chords' first and last points."""
    passages = certified.details.passages_s
    samples = certified.q[(certified.t > passages[move.end - 1]) & (certified.t < passages[move.end])]
    if len(samples) == 0:
        return []
    a, b = program.targets[move.end - 1], move.target
    robot = program.robot
    tcp = _tcp(robot, samples)
    keep = ((np.linalg.norm(tcp - _tcp(robot, a)[0], axis=1) >= zone_before)
            & (np.linalg.norm(tcp - _tcp(robot, b)[0], axis=1) >= zone_after)
            # a target next to an end would be a second target at it
            & (np.linalg.norm(samples - a, axis=1) >= tolerance) & (np.linalg.norm(samples - b, axis=1) >= tolerance))
    samples = samples[keep]
    if len(samples) == 0 or point_to_polyline(samples, np.array([a, b])).max() <= departure:
        return []
    kept = _chord_targets(np.array([a, *samples, b]), tolerance)
    return [samples[i - 1] for i in kept if 1 <= i <= len(samples)]


def certified_moves(program: Program, certified: Profile, scene=None,
                    deviation_rad: float = WRITTEN_DEVIATION_RAD, method: str | None = None) -> WrittenProgram:
    """The moves a writer writes for ``program`` so that the controller follows its ``certified`` profile: a planned
    move as joint targets sampled from the certified path (``_planned_targets``: as few as keep the joint segments
    within CHORD_SHARE x ``deviation_rad``), then its end; zones wherever the certified motion does not stop (the
    program's own; INNER_ZONE_M at the inner targets, at most half the shorter TCP chord beside them;
    PASS_THROUGH_ZONE_M where it passes a waypoint without one), exact stops only at ``program.stops``. A plain joint
    move: joint targets sampled from the certified path (``_joint_targets``: where it departs from the straight
    segment by more than ``deviation_rad``, as few as keep the chords within JOINT_CHORD_SHARE x ``deviation_rad``;
    none for a jerk-limited program, topp3, whose modelled corners cost more time than stops: the move is written
    straight and the departure reported in ``changes``), an exact stop at its target where the certified motion is at
    rest there (``_at_rest``), else the zone of ``_flow_zone``; the zones at the targets it flows through as large as
    the controller's corner can be (the larger TCP reach over the two half segments). The written
    moves are then certified (``written_program_certificate``, in ``scene``): while the certificate fails, or an inner
    target's modelled path deviates more than ``deviation_rad`` from the certified one, the zones at fault are
    halved (after SHRINK_ROUNDS, or below SMALLEST_ZONE_M, dropped), each change recorded with its reason."""
    robot = program.robot
    moves: list[WrittenMove] = []
    inner: set[int] = set()                       # indices of the inner targets of planned moves
    flowing: set[int] = set()                     # targets of joint moves flowed through: zones sized below
    straight: list[str] = []                      # joint moves written straight where the certified path is not
    jerk_limited = (method or {"ruckig": "topp3"}.get(program.timing, program.timing)) == "topp3"
    for move in program.moves:
        stop = move.end in program.stops
        end_zone = 0.0 if stop else (move.zone or PASS_THROUGH_ZONE_M)
        if move.planned is not None:
            before = moves[-1].zone_m if moves else 0.0
            targets = _planned_targets(program, certified, move, before, end_zone, CHORD_SHARE * deviation_rad)
            points = [program.targets[move.end - 1], *targets, move.target]
            chords = np.linalg.norm(np.diff(_tcp(robot, np.array(points)), axis=0), axis=1)
            for i, q in enumerate(targets):
                zone = min(INNER_ZONE_M, 0.5 * float(min(chords[i], chords[i + 1])))
                zone = float(np.floor(zone / ZONE_STEP_M + 1e-9)) * ZONE_STEP_M if zone >= ZONE_STEP_M else zone
                inner.add(len(moves))
                moves.append(WrittenMove(JOINT, np.asarray(q, dtype=float), move.speed, zone, source=move.end))
            moves.append(WrittenMove(JOINT, move.target, move.speed, end_zone, source=move.end))
            continue
        if move.kind == JOINT:
            # the certified motion at rest at the target (ruckig's waypoint to waypoint): an exact stop
            stop = stop or _at_rest(certified, certified.details.passages_s[move.end])
            end_zone = 0.0 if stop else end_zone
            # a joint move as joint targets on the certified path where it departs from the straight segment, its
            # target with a zone where the certified motion flows (the certified corner's reach where the path
            # misses the target, else a flow zone capped as an inner target's)
            own_corner = False
            if not stop and not move.zone:
                end_zone, own_corner = _flow_zone(program, certified, move, CHORD_SHARE * deviation_rad)
            # samples inside a flow zone stay (the certified path passes its target; the corner is sized later)
            before = moves[-1].zone_m if moves and len(moves) - 1 not in inner else 0.0
            after = end_zone if own_corner or move.zone else 0.0
            targets = _joint_targets(program, certified, move, before, after, JOINT_CHORD_SHARE * deviation_rad,
                                     deviation_rad)
            if targets and jerk_limited:
                straight.append(f"move to waypoint {move.end}: written as one joint move; the certified path departs "
                                f"from it by up to {_departure(program, certified, move):.3f} rad (joint targets along "
                                "it, with corners as modelled, cost more than the departure under jerk-limited "
                                "timing)")
                targets = []
            for q in targets:
                inner.add(len(moves))
                flowing.add(len(moves))
                moves.append(WrittenMove(JOINT, np.asarray(q, dtype=float), move.speed, INNER_ZONE_M,
                                         source=move.end))
            if not stop and not move.zone and not own_corner:
                inner.add(len(moves))
                flowing.add(len(moves))
            moves.append(WrittenMove(JOINT, move.target, move.speed, end_zone, source=move.end))
            continue
        speed = program.tool_speed(move) / program.speed_scale if move.is_tool_move else move.speed
        moves.append(WrittenMove(move.kind, move.target, speed, end_zone, move.X_BT if move.is_tool_move else None,
                                 move.via, source=move.end))
    # the zones at the targets of joint moves flowed through: the corner as large as the controller makes it (half
    # of either joint segment): the larger TCP reach from the target over the two half segments, up to whole mm (a
    # wrist's turn moves the TCP little and not along a line: half the TCP chord cut a corner of a few % of a move)
    for k in sorted(flowing):
        w = moves[k]
        if k + 1 >= len(moves):
            continue
        before = moves[k - 1].target if k > 0 else program.targets[0]
        half = np.linspace(0.0, 0.5, 64)[:, None]
        around = np.vstack([w.target + half * (before - w.target), w.target + half * (moves[k + 1].target - w.target)])
        reach = float(np.linalg.norm(_tcp(robot, around) - _tcp(robot, w.target)[0], axis=1).max())
        zone = max(float(np.ceil(reach / ZONE_STEP_M - 1e-9)) * ZONE_STEP_M, ZONE_STEP_M)
        moves[k] = dataclasses.replace(w, zone_m=zone)
    changes: dict[int, str] = {}
    original = [w.zone_m for w in moves]
    for round_ in range(SHRINK_ROUNDS + 1):
        path, timing, certificate = written_program_certificate(program, moves, certified, scene, method)
        at_fault = set()
        if certificate.deviation_rad is not None:
            # move m's samples: the second half of the corner at m - 1, its segment, the first half of its corner;
            # beside a program's own zone the corner is the controller's, not the certified blend (reported, kept)
            for m in np.flatnonzero(certificate.deviation_rad > deviation_rad):
                ends = [j for j in (m - 1, m) if j >= 0]
                if any(moves[j].has_zone and j not in inner for j in ends):
                    continue
                at_fault |= {j for j in ends if j in inner and moves[j].has_zone}
        reason = f"deviation from the certified path over {deviation_rad:.3f} rad"
        if not certificate.passed:
            at_fault = {k for k, w in enumerate(moves) if w.has_zone and k in inner} or \
                       {k for k, w in enumerate(moves) if w.has_zone}
            reason = f"the written program's certificate failed ({certificate.limits})"
        if not at_fault or round_ == SHRINK_ROUNDS:
            break
        for k in at_fault:
            w = moves[k]
            zone = w.zone_m / 2.0
            if zone < SMALLEST_ZONE_M or round_ == SHRINK_ROUNDS - 1:
                zone = 0.0
            moves[k] = dataclasses.replace(w, zone_m=zone)
            changes[k] = reason
    notes = list(straight)
    for k in sorted(changes):
        w = moves[k]
        what = "dropped (an exact stop)" if w.zone_m == 0.0 else f"{original[k] * 1e3:.1f} -> {w.zone_m * 1e3:.1f} mm"
        where = f"target {k + 1} (move to waypoint {w.source})"
        notes.append(f"{where}: zone {what}: {changes[k]}")
    own = {k for k, w in enumerate(moves) if w.has_zone and k not in inner}
    bounded = tuple(k for k in sorted(inner) if k - 1 not in own and k not in own)
    return WrittenProgram(tuple(moves), path, timing, certificate, tuple(notes), deviation_rad, bounded)
