"""A lower bound of a program's cycle time, from its moves before any timing.

For each stretch between two stops, the larger of
(a) the slowest joint's shortest rest-to-rest time for the change of its value from stop to stop
    (through the waypoints the joint path passes exactly, between two joint moves without a zone: where a
    joint turns back at one, it rests there, so each monotone run of it counts from rest to rest),
    under its speed and acceleration limits (x speed scale, x its square; the speed limits also x the
    largest speed fraction of the stretch's moves, a tool move's counting 1), obstacles ignored (a
    triangular or trapezoidal speed profile: 2 sqrt(d / a) when d < v^2 / a, else d / v + v / a); and
(b) the TCP's shortest time along the parts of its lines and arcs it must follow (each tool move's
    track less the zones at its ends, at most half of it each) at the move's speed and the TCP
    acceleration: from rest where the part begins at a stop, to rest where it ends at one, free speed
    (up to the move's) where it meets a zone.
No motion through the same stops can be faster; the cycle-time report sets the profile beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ProfileSizeError
from .compile import move_speed
from .job import Job
from .model import Program


@dataclass(frozen=True)
class StretchBound:
    """The bound of stretch ``first`` .. ``last`` (waypoints): ``joints_s`` (a), ``tcp_s`` (b),
    ``bound_s`` the larger [s], and ``joint`` (index) that sets (a)."""

    first: int
    last: int
    joints_s: float
    tcp_s: float
    joint: int

    @property
    def bound_s(self) -> float:
        return max(self.joints_s, self.tcp_s)

    def to_dict(self) -> dict:
        return {"first": self.first, "last": self.last, "joints_s": self.joints_s, "tcp_s": self.tcp_s,
                "bound_s": self.bound_s, "joint": self.joint}


@dataclass(frozen=True)
class LowerBound:
    """The program's lower bound: per stretch, the waits of its actions ``rests_s`` [s] (no motion is shorter), and
    ``total_s`` [s]."""

    stretches: tuple[StretchBound, ...]
    rests_s: float = 0.0

    @property
    def total_s(self) -> float:
        return float(sum(s.bound_s for s in self.stretches)) + self.rests_s

    @property
    def tcp_s(self) -> float:
        return float(sum(s.tcp_s for s in self.stretches))

    @property
    def joints_s(self) -> float:
        return float(sum(s.joints_s for s in self.stretches))

    def to_dict(self) -> dict:
        return {"total_s": self.total_s, "rests_s": self.rests_s, "stretches": [s.to_dict() for s in self.stretches]}


def rest_to_rest_time(distance: np.ndarray, v_max: np.ndarray, a_max: np.ndarray | None) -> np.ndarray:
    """Shortest time [s] to cover ``distance`` (>= 0) from rest to rest at speed <= v_max and (when
    given) acceleration <= a_max, elementwise."""
    distance = np.abs(np.asarray(distance, dtype=float))
    if a_max is None:
        return distance / v_max
    return np.where(distance < v_max**2 / a_max, 2.0 * np.sqrt(distance / a_max), distance / v_max + v_max / a_max)


def follow_time(length: float, speed: float, accel: float | None, from_rest: bool, to_rest: bool) -> float:
    """Shortest time [s] along ``length`` [m] at speed <= ``speed`` and acceleration <= ``accel``
    (None: unlimited), starting and/or ending at rest or at any speed up to ``speed``."""
    if length <= 0.0:
        return 0.0
    if accel is None or not (from_rest or to_rest):
        return length / speed
    if from_rest and to_rest:
        return float(rest_to_rest_time(length, speed, accel))
    ramp = speed**2 / (2.0 * accel)             # length to reach the speed from rest
    return math.sqrt(2.0 * length / accel) if length < ramp else length / speed + speed / (2.0 * accel)


def lower_bound(program: Program) -> LowerBound:
    """The program's lower bound (see the module docstring)."""
    limits, scale = program.limits, program.speed_scale
    qd_max = limits.qd_max * scale
    qdd_max = None if limits.qdd_max is None else limits.qdd_max * scale**2
    accel = None if program.tcp_accel_max is None else program.tcp_accel_max * scale**2
    targets = program.targets
    stretches = []
    for first, last in program.stretches():
        fastest = max(1.0 if m.is_tool_move else m.speed for m in program.moves[first: last])
        times = _joint_times(targets[_passed_exactly(program, first, last)], qd_max * fastest, qdd_max)
        tcp = sum(_tool_part_time(program, k, first, last, accel, scale) for k in range(first, last))
        stretches.append(StretchBound(first, last, float(times.max()), float(tcp), int(np.argmax(times))))
    return LowerBound(tuple(stretches), float(sum(program.rests)))


def _passed_exactly(program: Program, first: int, last: int) -> list[int]:
    """The waypoints of stretch first .. last the motion passes exactly: its stops, and the zone-less
    waypoints between two unplanned joint moves (the joint path goes through them)."""
    moves = program.moves
    inner = [k for k in range(first + 1, last) if moves[k - 1].zone <= 0.0
             and all(m.kind == "joint" and m.planned is None for m in (moves[k - 1], moves[k]))]
    return [first, *inner, last]


def _joint_times(points: np.ndarray, qd_max: np.ndarray, qdd_max: np.ndarray | None) -> np.ndarray:
    """Per joint, the shortest time [s] through ``points`` (k, dof) in order, starting and ending at rest:
    where a joint turns back at a point it passes exactly its speed is zero there, so each of its monotone
    runs between such turns takes at least the rest-to-rest time of the run's distance."""
    times = np.zeros(points.shape[1])
    for j, values in enumerate(points.T):
        steps = np.diff(values)
        steps = steps[steps != 0.0]
        turns = np.flatnonzero(np.sign(steps[1:]) != np.sign(steps[:-1])) + 1
        runs = [float(np.abs(run).sum()) for run in np.split(steps, turns)] if steps.size else [0.0]
        times[j] = float(np.sum(rest_to_rest_time(np.array(runs), qd_max[j], None if qdd_max is None else qdd_max[j])))
    return times


def _tool_part_time(program: Program, k: int, first: int, last: int, accel: float | None, scale: float) -> float:
    """(b) for move k (to waypoint k + 1) of a stretch first .. last: 0 for a joint move."""
    move = program.moves[k]
    if not move.is_tool_move:
        return 0.0
    tool_path = move.track.along.tool_path
    index = [s.index for s in tool_path.segments].index(move.end)
    length = float(tool_path.starts[index + 1] - tool_path.starts[index])
    zone_before = 0.0 if k == first else program.moves[k - 1].zone
    zone_after = 0.0 if k + 1 == last else move.zone
    followed = length - min(zone_before, length / 2.0) - min(zone_after, length / 2.0)
    return follow_time(followed, move.speed * scale, accel, from_rest=k == first, to_rest=k + 1 == last)


def check_duration(job: Job, bound: LowerBound, max_samples: int, max_duration_s: float) -> None:
    """Refuse, before timing, a job whose duration is bounded from below (``bound``, the program's
    ``lower_bound``) by more samples of ``dt`` than ``max_samples`` (ProfileSizeError, as timing would,
    but at once) or by more than ``max_duration_s`` [s] (a JobFileError); both name the field that sets
    the bound (tcp_speed_max for the tool moves, or speed_scale for the joints' speeds)."""
    from ..timing.toppra_backend import check_sample_count

    if job.has_tool_moves and bound.tcp_s >= bound.joints_s:
        speed = min(move_speed(job, w) for w in job.waypoints[1:] if w.is_tool_move) * job.speed_scale
        field = "tcp_speed_max"
        why = (f"its tool moves take at least {bound.tcp_s:.4g} s at their TCP speeds (the slowest at "
               f"{speed * 1e3:.4g} mm/s: tcp_speed_max, or a move's own speed, x speed_scale). Is tcp_speed_max in "
               "the job's length_unit per second?")
    else:
        field, why = "speed_scale", f"its joint moves take {bound.joints_s:.4g} s at the robot's qd_max x speed_scale"
    try:
        check_sample_count(bound.total_s, job.dt, max_samples)
    except ProfileSizeError as exc:
        raise ProfileSizeError(f"{job.source}: {exc} (at least, found before timing: {job.location((field,))}: "
                               f"{why})") from None
    if bound.total_s > max_duration_s:
        raise job.error((field,), f"the job would last at least {bound.total_s:.4g} s, longer than "
                        f"{max_duration_s:g} s (run --max-duration raises the limit): {why}")
