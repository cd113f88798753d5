"""The motion program: one typed, frozen value between a job and its profile.

A ``Program`` holds the robot (its end frame is the TCP when the job has a tool), the tool ``X_FT``,
the cell, the limits the motion keeps, and its moves in order: move k goes from waypoint k to
waypoint k + 1 and ends at ``targets[k + 1]`` (solved joint values). A move is a joint move (to
joint values, straight in joint space or along the job's path shape; in a cell with
``plan: collision_free`` through the planner's ``planned`` vertices) or a tool move (``linear`` or
``circular``: its TCP keeps the line or arc; ``track`` holds the joint path along its run of tool moves
and the IK samples). Each move has its ``speed`` (joint: a fraction of the joint speed limits; tool: a
TCP speed [m/s]) and the ``zone`` [m] at its end (0: an exact stop, except between two joint moves
that a joint path passes through). ``stops`` are the waypoints where the motion is at rest; a
stretch runs from one stop to the next and is timed as one path.
"""

from __future__ import annotations

import dataclasses

from dataclasses import dataclass, field

import numpy as np

from ..cell.cell_file import Cell
from ..cell.planning import PlannedPath
from ..cell.tilt import TiltLimit
from ..cell.tool import Tool
from ..files.robot_spec import Limits
from ..model.robot import Robot
from .actions import Action, Signal, actions_document, held_after, rest_s, signals_document
from .payload import Payload, combined
from .tool_moves import ToolJointPath

JOINT, LINEAR, CIRCULAR = "joint", "linear", "circular"


@dataclass(frozen=True, eq=False)
class WaypointSolution:
    """How waypoint k became joint values: ``q`` [rad or m]; for a pose, the IK method that solved it,
    its errors [m, rad], the number of in-limit solutions it chose from, the target kind and the
    components matched, the configuration asked for, the branch kept and whether that is a change from
    the previous pose waypoint's (None for joint waypoints); ``controller_config`` (vendor, its text) when
    the waypoint named its solution by a controller's configuration data; ``wrist_singular``: the pose has the
    wrist at its singularity, so q4 and q6 were kept nearest the previous waypoint's (``branches.wrist_singular``)."""

    q: np.ndarray
    method: str | None = None
    position_error: float | None = None
    rotation_error: float | None = None
    solutions: int | None = None
    target: str | None = None
    matched: tuple[str, ...] | None = None
    config: dict | None = None
    branch: str | None = None
    branch_changed: bool | None = None
    controller_config: tuple[str, str] | None = None
    wrist_singular: bool | None = None

    def to_dict(self) -> dict:
        return {"q": self.q.tolist(), "given_as": "joints" if self.method is None else "pose",
                "ik_method": self.method, "position_error_m": self.position_error,
                "rotation_error_rad": self.rotation_error, "solutions": self.solutions, "target": self.target,
                "matched": None if self.matched is None else list(self.matched), "config": self.config,
                "branch": self.branch or None, "branch_changed": self.branch_changed,
                "wrist_singular": self.wrist_singular,
                "controller_config": None if self.controller_config is None else dict([self.controller_config])}


@dataclass(frozen=True, eq=False)
class ToolTrack:
    """The joint path of a run of tool moves to waypoints ``first`` .. ``last`` that the TCP follows
    without stopping: ``along`` (its ToolPath, joint path, IK samples and their sigma [m])."""

    first: int
    last: int
    along: ToolJointPath

    def to_dict(self) -> dict:
        along = self.along
        return {"first": self.first, "last": self.last, "length_m": along.tool_path.length,
                "samples": int(len(along.samples)), "max_position_error_m": along.max_position_error,
                "max_rotation_error_rad": along.max_rotation_error,
                "slowest_allowed_tcp_speed_m_s": along.slowest_tcp_speed}


@dataclass(frozen=True, eq=False)
class Move:
    """A move of a program, to waypoint ``end`` from the one before: ``kind`` (joint, linear, circular),
    ``target`` (dof,) [rad or m] and ``X_BT`` (4, 4) [m] where it ends, ``via`` (3,) [m] of a circular
    move, ``speed`` (joint: a fraction in (0, 1] of the joint speed limits; tool: the TCP speed [m/s]),
    ``zone`` [m] at its end, ``planned`` (the planner's vertices of a planned joint move, None
    otherwise), ``track`` (a tool move's run, None for joint moves)."""

    end: int
    kind: str
    target: np.ndarray
    X_BT: np.ndarray
    speed: float
    zone: float
    via: np.ndarray | None = None
    planned: PlannedPath | None = None
    track: ToolTrack | None = None

    @property
    def is_tool_move(self) -> bool:
        return self.kind != JOINT

    @property
    def samples(self) -> np.ndarray | None:
        """The IK samples (n, dof) of a tool move's own part of its track (None for a joint move)."""
        if self.track is None:
            return None
        along = self.track.along
        return along.samples[along.tool_path.move_of(along.sigma) == self.end]

    def to_dict(self) -> dict:
        return {"kind": self.kind, "target": self.target.tolist(), "tcp_xyz_m": self.X_BT[:3, 3].tolist(),
                "speed": self.speed, "speed_unit": "fraction of qd_max" if self.kind == JOINT else "m/s",
                "zone_m": self.zone, "via_m": None if self.via is None else self.via.tolist(),
                "planned": None if self.planned is None else {
                    **self.planned.to_dict(), "vertices_q": self.planned.waypoints.tolist(),
                    "smooth_vertices_q": None if self.planned.smooth_waypoints is None
                    else self.planned.smooth_waypoints.tolist()},
                "track": None if self.track is None else self.track.to_dict()}


@dataclass(frozen=True, eq=False)
class Program:
    """A job compiled into moves (see the module docstring): ``name``, ``robot``, ``tool`` (its X_FT
    (4, 4) [m], identity without one, and its shapes on the flange: ``pipeline.cell.tool.Tool``), ``cell`` (None: none), ``limits`` (the robot's, with the job's safety
    TCP speed limit), ``tcp_accel_max`` [m/s^2] on tool moves (None: not limited), ``speed_scale``,
    ``timing`` method, ``path`` shape, ``dt`` [s], ``waypoints`` (how each was solved), ``moves``,
    ``stops`` (waypoint indices where the motion rests, first and last included), ``plan`` (the job's),
    ``tilt``: the TiltLimit its planned moves keep (``pipeline.cell.tilt``; None: none), ``payload`` the tool's load
    (``pipeline.program.payload.Payload``; None: not given), ``parts`` the parts its grip and release actions name,
    ``job_name`` the job it was compiled from (``name`` may be renamed for a controller;
    every controller program records the job: ``pipeline.files.atomic.job_mark``); ``actions``: per waypoint what
    the controller does once there (``pipeline.program.actions``; () or empty tuples: nothing) and ``signals`` the
    named signals they use."""

    name: str
    robot: Robot
    tool: Tool
    cell: Cell | None
    limits: Limits
    tcp_accel_max: float | None
    speed_scale: float
    timing: str
    path: str | None
    dt: float
    waypoints: tuple[WaypointSolution, ...]
    moves: tuple[Move, ...]
    stops: tuple[int, ...]
    plan: str = "direct"
    tilt: TiltLimit | None = None
    details: dict = field(default_factory=dict)
    payload: Payload | None = None
    job_name: str = ""
    actions: tuple[tuple[Action, ...], ...] = ()
    signals: dict[str, Signal] = field(default_factory=dict)
    parts: dict[str, Payload] = field(default_factory=dict)

    def actions_at(self, k: int) -> tuple[Action, ...]:
        """The actions at waypoint ``k`` (once the robot is there; waypoint 0's before the first move)."""
        return self.actions[k] if k < len(self.actions) else ()

    def rest_at(self, k: int) -> float:
        """How long the motion stands still at waypoint ``k`` for its actions, as timed [s]."""
        return rest_s(self.actions_at(k))

    @property
    def rests(self) -> tuple[float, ...]:
        """Per waypoint, how long the motion stands still there for its actions, as timed [s]."""
        return tuple(self.rest_at(k) for k in range(len(self.moves) + 1))

    @property
    def flange_spec(self):
        """The robot's spec with its end frame at the flange F (the job's tool taken off), where loads are given."""
        return dataclasses.replace(self.robot.spec, X_DnE=self.robot.spec.X_DnE @ np.linalg.inv(self.tool.X_FT))

    def load_after(self, k: int, i: int | None = None) -> Payload | None:
        """What the flange carries once waypoint ``k``'s actions (``i``: up to and including action i) have run: the
        tool's load and the parts held, as one load (None: nothing known to be carried)."""
        return combined([self.payload] + [self.parts[name] for name in held_after(self.actions, k, i)])

    @property
    def loads(self) -> tuple[Payload | None, ...]:
        """Per move, what the flange carries on it (``load_after`` the waypoint it leaves)."""
        return tuple(self.load_after(move.end - 1) for move in self.moves)

    @property
    def has_tcp_limits(self) -> bool:
        """Whether the TCP is limited somewhere: tool moves, or a safety TCP speed limit (the profile then
        carries the TCP's samples)."""
        return self.limits.tcp_speed_max is not None or any(m.is_tool_move for m in self.moves)

    @property
    def targets(self) -> np.ndarray:
        """(K, dof) the joint values of the K waypoints [rad or m]."""
        return np.array([self.waypoints[0].q] + [move.target for move in self.moves])

    def tool_speed(self, move: Move) -> float:
        """The TCP speed [m/s] a tool move runs at: its own, capped by the job's safety TCP speed limit, x the
        speed scale (as the timing applies them, and as every controller program writes it)."""
        speed = move.speed if self.limits.tcp_speed_max is None else min(move.speed, self.limits.tcp_speed_max)
        return speed * self.speed_scale

    def exact_stop_at(self, move: Move) -> bool:
        """Whether a controller program stops exactly at the end of ``move``: a stop of the program, or a
        planned joint move or one leading into it (a controller's corner path there is not a path the
        planner or the clearance certificate checked)."""
        following = self.moves[move.end] if move.end < len(self.moves) else None
        return move.end in self.stops or move.planned is not None or (following is not None and
                                                                       following.planned is not None)

    def stretches(self) -> list[tuple[int, int]]:
        """(first, last) waypoint indices of each stretch between two stops."""
        return list(zip(self.stops[:-1], self.stops[1:]))

    def to_dict(self) -> dict:
        return {"name": self.name, "robot": self.robot.name, "tool_X_FT": self.tool.X_FT.tolist(),
                "cell": None if self.cell is None else self.cell.name, "speed_scale": self.speed_scale,
                "tcp_speed_limit_m_s": self.limits.tcp_speed_max, "tcp_accel_max_m_s2": self.tcp_accel_max,
                "timing": self.timing, "path": self.path, "plan": self.plan, "stops": list(self.stops),
                "plan_tilt_max_deg": None if self.tilt is None else float(np.degrees(self.tilt.max_rad)),
                "waypoints": [w.to_dict() for w in self.waypoints], "moves": [m.to_dict() for m in self.moves],
                "actions": {str(k): actions_document(a) for k, a in enumerate(self.actions) if a},
                "signals": signals_document(self.signals),
                "payload": None if self.payload is None else self.payload.to_document(1.0),
                "parts": {name: part.to_document(1.0) for name, part in self.parts.items()}}


def program_arrays(program: Program) -> dict[str, np.ndarray]:
    """The program as NPZ arrays: ``program_targets`` (K, dof) [rad or m], ``program_move_kinds`` (K - 1,),
    ``program_speeds`` (K - 1,) (joint: fraction of qd_max, tool: m/s), ``program_zones_m`` (K - 1,),
    ``program_stops`` (waypoint indices), and per planned move k ``program_planned_<k>`` (vertices, dof) and,
    for a detour, ``program_planned_smooth_<k>`` (the vertices its spline goes through)."""
    arrays = {"program_targets": program.targets, "program_move_kinds": np.array([m.kind for m in program.moves]),
              "program_speeds": np.array([m.speed for m in program.moves]),
              "program_zones_m": np.array([m.zone for m in program.moves]), "program_stops": np.array(program.stops)}
    arrays.update({f"program_planned_{m.end}": m.planned.waypoints for m in program.moves if m.planned is not None})
    arrays.update({f"program_planned_smooth_{m.end}": m.planned.smooth_waypoints for m in program.moves
                   if m.planned is not None and m.planned.smooth_waypoints is not None})
    return arrays
