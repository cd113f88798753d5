"""``read_rapid(text, robot) -> dict``: an ABB RAPID module (``.mod``) of the subset ``write_rapid`` writes, read
back into a job document (a mapping ``pipeline.program.job.parse_job`` accepts).

The module is parsed with ``grammars/rapid.lark`` (package data; the RAPID kernel manual's lexical rules: RAPID is
not case-sensitive, ``!`` comments, free spacing and line breaks; identifiers compared without case), so a
program a pendant or RobotStudio wrote in that subset reads the same. What is read, and the RAPID facts it follows
(ABB, "Technical reference manual - RAPID Instructions, Functions and Data types", the entries named):

* The procedure ``main`` (or the module's only procedure): ``ConfJ``/``ConfL`` (\\On or \\Off: the confdata is read
  either way, it names the branch), ``MoveAbsJ``, ``MoveJ``, ``MoveL``, ``MoveC``; any other instruction is a
  ``RapidReadError`` naming it. Each move is one waypoint, the first move's target the job's first waypoint (no
  move into it; ``write_rapid``'s approach ``MoveAbsJ j0``). Targets are declared data or inline aggregates.
* ``jointtarget`` [robax, extax] -> a joint waypoint: robax [deg] through the inverse of the ABB axis map of
  ``pipeline.model.vendors.axes`` (q = (angle - offset) x direction).
* ``robtarget`` [trans, rot, robconf, extax] -> a pose waypoint: trans [mm] -> m, rot the unit quaternion
  [q1 (scalar), q2, q3, q4] (normalised), in the work object's frame mapped to the robot's base frame; robconf
  (confdata [cf1, cf4, cf6, cfx]) selects the one closed-form solution it names
  (``pipeline.model.vendors.selection``, the robot with the module's tool), whose branch label
  (``pipeline.model.ik.branches.configuration_labels``) is written as the waypoint's ``config``. extax is ignored.
* Move kinds: ``MoveAbsJ``/``MoveJ`` joint, ``MoveL`` linear, ``MoveC`` circular with the CirPoint's position as
  ``via`` (its orientation and confdata are not the job's: RAPID uses them only for the way of reorientation).
* Speeds: a tool move's ``speeddata`` v_tcp [mm/s] (a declared one, or the predefined vN = N mm/s) -> ``speed``
  [m/s]; \\V:= overrides v_tcp. A joint move timed by \\T:=T [s] (``write_rapid``'s ``vmax \\T``) -> ``speed`` =
  100 x max_i |dq_i| / (qd_max_i T) % of the joint speed limits, at most 100 (T was rounded up to 0.1 ms, so
  this is at most 0.1 ms / T below the written fraction); a joint move without \\T gets no speed (the job's default,
  its full joint speed): a speeddata bounds a joint move's TCP speed, which a job's joint move does not take.
* Zones: ``fine`` (and any zonedata with finep TRUE) -> 0; ``z0`` -> 0 (``write_rapid`` writes it where the program
  passes a waypoint without a zone; its 0.3 mm corner is the controller's); predefined zN -> N mm; a declared
  zonedata -> its pzone_tcp [mm]; \\Z:= overrides pzone_tcp; all -> ``zone`` [m]. The last waypoint's zone is 0
  (the program ends at rest there).
* ``PathAccLim TRUE\\AccMax:=A, TRUE\\DecelMax:=D`` [m/s^2] (``write_rapid`` writes the job's TCP acceleration
  limit so) -> ``tcp_accel_max`` (the smaller); without it the job has none.
* ``tooldata`` [robhold, tframe, tload]: every move must use one tool; tframe [mm, quaternion] -> the job's ``tool``
  (none for ``tool0`` or an identity tframe), tframe being on the controller's tool0 (the robot file's abb
  controller section's flange, ``controller.controller_frames``); robhold FALSE (a stationary tool) is refused.
  ``wobjdata`` [robhold, ufprog, ufmec, uframe, oframe]: targets are in uframe x oframe, in the controller's world
  frame; ``base_in_world`` (4, 4) [m] is our base frame in that world (default: the world is the section's base
  frame, as with ``wobj0``; ``write_rapid``'s ``wobj_base`` has uframe = the controller's base frame in the cell,
  so pass our base's pose in the cell).

The document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``waypoints``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import lark
import numpy as np

from ...errors import ConfigurationNotFoundError, FileFormatError
from ...files.branch_names import label_parts
from ...files.poses import pose_to_quaternion_position, quaternion_position_to_pose
from ...model.ik.branches import configuration_labels
from ...model.robot import Robot, load_robot, robot_with_tool
from ...model.vendors.axes import ABB, joint_values
from ...model.vendors.configuration import format_configuration
from ...model.vendors.controller import controller_frames
from ...model.vendors.selection import select_solution
from .read_ls import parse_subset

MOVES = ("moveabsj", "movej", "movel", "movec")
CONFIG_INSTRUCTIONS = ("confj", "confl", "pathacclim")
#: Predefined data (RAPID Instructions manual, "speeddata", "zonedata"): vN is N mm/s, zN is N mm, z0 and fine 0.
PREDEFINED_SPEEDS = frozenset((5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000, 1500,
                               2000, 2500, 3000, 4000, 5000, 6000, 7000))
PREDEFINED_ZONES = frozenset((0, 1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200))
#: The source named in errors (the reader gets text, not a file).
SOURCE = "<rapid>"


class RapidReadError(FileFormatError):
    """A RAPID module outside the subset read here, or with data that does not fit (field: the instruction
    or the data name)."""


@dataclass
class _Data:
    """A module's declarations by lower-case name: (data type, value as nested lists of floats, bools, strings)."""

    values: dict = field(default_factory=dict)

    def get(self, value, datatype: str, where: str):
        """The value of ``value`` (a _Name of declared data or an inline aggregate) as ``datatype``."""
        if isinstance(value, _Name):
            known = self.values.get(value.lower())
            if known is None or known[0] != datatype or known[1] is None:
                raise RapidReadError(SOURCE, where, f"no {datatype} named {value} is declared with a value in the "
                                     "module", value)
            return known[1]
        return value


class _Name(str):
    """An identifier in a RAPID value (RAPID compares identifiers without case)."""


class _Values(lark.Transformer):
    """Parse tree values -> Python: numbers as float, aggregates as lists, names as _Name."""

    def number(self, children):
        sign = -1.0 if len(children) == 2 and children[0] == "-" else 1.0
        return sign * float(children[-1])

    def boolean(self, children):
        return children[0].upper() == "TRUE"

    def string(self, children):
        return str(children[0])[1:-1]

    def name(self, children):
        return _Name(children[0])

    def aggregate(self, children):
        return list(children)


def read_rapid(text: str, robot: str, base_in_world: np.ndarray | None = None) -> dict:
    """The job document of a RAPID module ``text`` (module docstring) for ``robot`` (a preset name or robot file
    path, written into the document as given); ``base_in_world`` (4, 4) [m]: our base frame in the
    controller's world frame (None: the world is the robot file's abb controller section's base frame, our base
    frame without one). RapidReadError names what cannot be read."""
    tree = _Values().transform(parse_subset("rapid", "RAPID", text, RapidReadError, SOURCE))
    module = tree.children[0]
    data = _declarations(module)
    calls = _main_calls(module)
    robot_model = load_robot(robot)
    base_in_world = (np.linalg.inv(controller_frames(robot_model, ABB)[0]) if base_in_world is None
                     else np.asarray(base_in_world))
    reader = _Reader(robot_model, data, base_in_world)
    waypoints = [reader.waypoint(call) for call in calls if call.name.lower() in MOVES]
    if not waypoints:
        raise RapidReadError(SOURCE, "main", "the procedure has no move instruction")
    document = reader.document(robot, waypoints)
    accel = _path_acceleration(calls)
    if accel is not None:
        document["tcp_accel_max"] = accel
    return document


def _path_acceleration(calls: list) -> float | None:
    """The TCP acceleration limit [m/s^2] of ``PathAccLim TRUE\\AccMax:=A, TRUE\\DecelMax:=D`` (the smaller of A and D
    that are set; of several PathAccLim the last counts: the subset has one limit per job), None without one."""
    accel = None
    for call in calls:
        if call.name.lower() != "pathacclim":
            continue
        limits = [float(call.optional[key]) for flag, key in zip(call.required, ("accmax", "decelmax"))
                  if flag is True and isinstance(call.optional.get(key), float) and call.optional[key] > 0.0]
        accel = min(limits) if limits else None
    return accel


@dataclass(frozen=True)
class _Call:
    """One instruction: its name, required arguments and optional ones (lower-case name -> value or None)."""

    name: str
    required: list
    optional: dict
    line: int | None


def _declarations(module: lark.Tree) -> _Data:
    data = _Data()
    for node in module.children:
        if isinstance(node, lark.Tree) and node.data == "declaration":
            _, datatype, name, *value = node.children
            data.values[str(name).lower()] = (str(datatype).lower(), value[0] if value else None)
    return data


def _main_calls(module: lark.Tree) -> list[_Call]:
    """The instructions of ``main`` (or the only procedure); RapidReadError for one outside the subset."""
    routines = {str(node.children[0]).lower(): node for node in module.children
                if isinstance(node, lark.Tree) and node.data == "routine"}
    routine = routines.get("main") or (next(iter(routines.values())) if len(routines) == 1 else None)
    if routine is None:
        raise RapidReadError(SOURCE, "PROC", f"no procedure main among {sorted(routines) or 'none'}")
    calls = [_call(node) for node in routine.children[1:]]
    for call in calls:
        if call.name.lower() not in MOVES + CONFIG_INSTRUCTIONS:
            raise RapidReadError(SOURCE, call.name, "is not an instruction of the subset read here (MoveAbsJ, "
                                 "MoveJ, MoveL, MoveC, ConfJ, ConfL, PathAccLim)", line=call.line)
    return calls


def _call(node: lark.Tree) -> _Call:
    name, *rest = node.children
    required, optional = [], {}
    for argument in (rest[0].children if rest else []):
        for part in argument.children:
            if isinstance(part, lark.Tree) and part.data == "optional":
                optional[str(part.children[0]).lower()] = part.children[1] if len(part.children) > 1 else None
            else:
                required.append(part)
    return _Call(str(name), required, optional, node.meta.line if not node.meta.empty else None)


class _Reader:
    """Targets, speeds and zones of the moves, in order, with the tool and the previous joint values."""

    def __init__(self, robot: Robot, data: _Data, base_in_world: np.ndarray):
        self.robot, self.data, self.base_in_world = robot, data, base_in_world
        self.tool_name: str | None = None
        self.X_FT = controller_frames(robot, ABB)[1]          # tool0: the controller's, on our end frame
        self.q_previous: np.ndarray | None = None

    def waypoint(self, call: _Call) -> dict:
        kind = call.name.lower()
        count = 5 if kind == "movec" else 4
        if len(call.required) != count:
            raise RapidReadError(SOURCE, call.name, f"takes {count} arguments here (target{'s' * (count - 4)}, "
                                 "speed, zone, tool)", line=call.line)
        self.use_tool(call)
        *targets, speed, zone, _ = call.required
        if kind == "moveabsj":
            q = self.joint_target(targets[0], call)
            waypoint = {"joints": [round(float(v), 10) for v in np.degrees(q)]}
        else:
            X, q = self.robtarget(targets[-1], call)
            waypoint = self.pose_waypoint(X, q, self.data.get(targets[-1], "robtarget", call.name)[2])
            waypoint["move"] = {"movej": "joint", "movel": "linear", "movec": "circular"}[kind]
            if kind == "movec":
                X_via = self.pose(self.data.get(targets[0], "robtarget", call.name), call)
                waypoint["via"] = {"xyz": X_via[:3, 3].tolist()}
        first = self.q_previous is None
        if not first:
            self.add_speed(waypoint, kind, speed, call, q)
            waypoint["zone"] = self.zone(zone, call)
        self.q_previous = q
        return waypoint

    def use_tool(self, call: _Call) -> None:
        name = call.required[-1]
        if self.tool_name is not None and name.lower() != self.tool_name.lower():
            raise RapidReadError(SOURCE, call.name, f"uses tool {name}, the moves before {self.tool_name}: a job has "
                                 "one tool", line=call.line)
        if self.tool_name is None:
            self.tool_name = name
            if name.lower() != "tool0":
                robhold, tframe, _ = self.data.get(name, "tooldata", call.name)
                if not robhold:
                    raise RapidReadError(SOURCE, name, "is a stationary tool (robhold FALSE): not read here")
                self.X_FT = controller_frames(self.robot, ABB)[1] @ _frame(tframe)     # tframe: on tool0
            self.robot_tool = robot_with_tool(self.robot, self.X_FT)

    def joint_target(self, value, call: _Call) -> np.ndarray:
        robax = np.array(self.data.get(value, "jointtarget", call.name)[0], dtype=float)
        return joint_values(self.robot, robax, ABB)

    def pose(self, target, call: _Call) -> np.ndarray:
        """A robtarget's TCP pose (4, 4) [m] in the robot's base frame."""
        X_WO = self.work_object(call)
        return np.linalg.inv(self.base_in_world) @ X_WO @ _frame(target[:2])

    def work_object(self, call: _Call) -> np.ndarray:
        name = call.optional.get("wobj")
        if name is None or str(name).lower() == "wobj0":
            return np.eye(4)
        robhold, _, _, uframe, oframe = self.data.get(name, "wobjdata", call.name)
        if robhold:
            raise RapidReadError(SOURCE, str(name), "is held by the robot (robhold TRUE): not read here")
        return _frame(uframe) @ _frame(oframe)

    def robtarget(self, value, call: _Call) -> tuple[np.ndarray, np.ndarray]:
        """(TCP pose (4, 4) [m], joint values (6,) [rad] its confdata selects)."""
        target = self.data.get(value, "robtarget", call.name)
        X = self.pose(target, call)
        try:
            return X, select_solution(self.robot_tool, X, [int(c) for c in target[2]], ABB)
        except ConfigurationNotFoundError as exc:
            raise RapidReadError(SOURCE, str(value), str(exc), line=call.line) from None

    def pose_waypoint(self, X: np.ndarray, q: np.ndarray, confdata) -> dict:
        """The pose waypoint of X (4, 4) [m]: its branch (of q (6,) [rad]) and ``controller_config`` the
        robtarget's confdata (the job solves it as the controller does, the quadrants of axes 4 and 6 too)."""
        quaternion, position = pose_to_quaternion_position(X)
        label = configuration_labels(self.robot_tool, q[None])[0]
        waypoint = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if label:
            waypoint["config"] = label_parts(label)
        waypoint["controller_config"] = {ABB: format_configuration(ABB, tuple(int(c) for c in confdata))}
        return waypoint

    def add_speed(self, waypoint: dict, kind: str, speed, call: _Call, q: np.ndarray) -> None:
        if kind in ("moveabsj", "movej"):
            seconds = call.optional.get("t")
            if seconds is not None and not isinstance(seconds, float):
                raise RapidReadError(SOURCE, f"{call.name} \\T", "a move time must be a number [s]", seconds,
                                     line=call.line)
            if seconds is not None and seconds > 0.0:
                step = np.abs(q - self.q_previous) / self.robot.limits.qd_max
                percent = min(100.0, 100.0 * float(step.max()) / seconds)
                if percent > 0.0:
                    waypoint["speed"] = percent
            return
        if "t" in call.optional:
            raise RapidReadError(SOURCE, call.name, "a tool move timed by \\T has no TCP speed to read", line=call.line)
        v_tcp = call.optional.get("v")
        waypoint["speed"] = (self.tcp_speed(speed, call) if v_tcp is None else float(v_tcp)) / 1e3

    def tcp_speed(self, speed, call: _Call) -> float:
        """v_tcp [mm/s] of a speeddata."""
        if isinstance(speed, _Name) and speed.lower() not in self.data.values:
            digits = speed.lower().removeprefix("v")
            if digits.isdigit() and int(digits) in PREDEFINED_SPEEDS:
                return float(digits)
        return float(self.data.get(speed, "speeddata", call.name)[0])

    def zone(self, zone, call: _Call) -> float:
        """pzone_tcp [m] of a zonedata (0 at fine and z0)."""
        override = call.optional.get("z")
        if isinstance(zone, _Name) and zone.lower() not in self.data.values:
            name = zone.lower()
            digits = name.removeprefix("z")
            if name == "fine":
                return 0.0
            if digits.isdigit() and int(digits) in PREDEFINED_ZONES:
                return float(digits if override is None else override) / 1e3
        value = self.data.get(zone, "zonedata", call.name)
        if value[0]:
            return 0.0
        return float(value[1] if override is None else override) / 1e3

    def document(self, robot: str, waypoints: list[dict]) -> dict:
        waypoints[-1].pop("zone", None)
        doc = {"robot": str(robot), "length_unit": "m", "angle_unit": "deg", "waypoints": waypoints}
        if not np.allclose(self.X_FT, np.eye(4), atol=1e-12):
            quaternion, position = pose_to_quaternion_position(self.X_FT)
            doc["tool"] = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        return doc


def _frame(pose) -> np.ndarray:
    """A RAPID pose [[x, y, z] mm, [q1, q2, q3, q4]] -> (4, 4) [m], the quaternion normalised."""
    position, quaternion = np.array(pose[0], dtype=float), np.array(pose[1], dtype=float)
    norm = float(np.linalg.norm(quaternion))
    if not math.isfinite(norm) or norm < 0.5:
        raise RapidReadError(SOURCE, "pose", "a quaternion of a pose is not near unit length", pose[1])
    return quaternion_position_to_pose(quaternion / norm, position / 1e3)
