"""``read_urscript(text, robot) -> dict``: a URScript program (``.script``) of the subset ``write_urscript`` writes,
read back into a job document (a mapping ``pipeline.program.job.parse_job`` accepts).

The program is parsed with ``grammars/urscript.lark`` (package data, also the writer's syntax check; UR's Script
Manual, e-Series SW 5.x: ``#`` comments, blank lines, ``global``/``local`` variables, positional and keyword
arguments), so a program of that subset written by hand or exported by PolyScope reads the same. What is read, and
the URScript facts it follows ("Module motion" of the Script Manual, the functions named):

* The native moves: the body of ``def native_moves()`` when the program has one (``write_urscript`` with a
  profile), else the program's own body. The servoj replay (``def certified_replay()``, and the ``if`` that
  chooses between the two) is SKIPPED: it is the certified profile sampled every controller period, not a list
  of waypoints. Statements read: ``set_tcp(pose)`` (the job's ``tool``, set before the first move), variable
  assignments (``global p1 = p[...]``, used by name in the moves), ``movej``, ``movel``, ``movec``,
  ``set_payload(m, cog)`` (the job's ``payload``: mass [kg], centre of mass [m]); any other call is a
  ``UrscriptReadError`` naming it. After the program's ``end`` one call of the program itself may follow (the
  writer's trailing ``name()``); a call of another name is refused.
* Arguments by position or keyword, as the manual orders them: ``movej(q, a, v, t, r)``, ``movel(pose, a, v, t,
  r)``, ``movec(pose_via, pose_to, a, v, r, mode)``; ``t`` (a move time) is refused, ``mode`` must be 0 (the
  orientation interpolated from start to target, as the writer's).
* Each move is one waypoint; the first move's target is the job's first waypoint (no move into it: the writer's
  approach ``movej`` at the manual's default a and v).
* Targets: a joint vector q [rad] -> a joint waypoint (``joints`` [deg]). A pose ``p[x, y, z, rx, ry, rz]`` (m,
  rotation vector [rad]) of the TCP in the base frame -> a pose waypoint (xyz [m], unit quaternion [w, x, y, z]).
  URScript has NO configuration data: the controller moves to a pose with the joint solution nearest its current
  joint values, so the branch read is the one of the in-limit closed-form solution (2 pi variants included) of
  the robot with the program's tool nearest (largest joint difference) the previous target's joint values, and
  is written as the waypoint's ``config`` (``pipeline.model.ik.branches.configuration_labels``).
* Move kinds: ``movej`` joint (a pose target included), ``movel`` linear, ``movec`` circular with ``via`` the via
  pose's position (the manual: movec does not use the via pose's rotation).
* Speeds: ``movej``'s v [rad/s] is the leading axis's speed -> ``speed`` = 100 x v / (the smallest joint speed
  limit) % (at most 100); ``movel``/``movec``'s v [m/s] -> ``speed`` [m/s]; the largest a [m/s^2] of the tool
  moves -> ``tcp_accel_max`` [m/s^2] (the job has one TCP acceleration limit; joint moves' a is not read: the
  job's joint moves run at the robot's acceleration limits).
* Zones: the blend radius r [m] -> ``zone`` [m] (0 an exact stop); the last waypoint's zone is 0 (the program ends
  at rest there).

The document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``waypoints``.
"""

from __future__ import annotations

from dataclasses import dataclass

import lark
import numpy as np
from scipy.spatial.transform import Rotation

from ...errors import FileFormatError
from ...files.branch_names import label_parts
from ...model.ik import solve_ik_batch
from ...model.ik.branches import configuration_labels
from ...model.ik.result import limit_variants
from ...model.robot import Robot, load_robot, robot_with_tool
from .read_ls import parse_subset

#: Each move's parameters in the Script Manual's order.
PARAMETERS = {"movej": ("q", "a", "v", "t", "r"), "movel": ("pose", "a", "v", "t", "r"),
              "movec": ("pose_via", "pose_to", "a", "v", "r", "mode")}
#: The manual's defaults [rad/s^2, rad/s; m/s^2, m/s] where a move leaves a and v out.
DEFAULTS = {"movej": {"a": 1.4, "v": 1.05, "r": 0.0}, "movel": {"a": 1.2, "v": 0.25, "r": 0.0},
            "movec": {"a": 1.2, "v": 0.25, "r": 0.0, "mode": 0.0}}
#: The functions of write_urscript's replay, skipped.
REPLAY = ("certified_replay",)
#: The source named in errors (the reader gets text, not a file).
SOURCE = "<urscript>"


class UrscriptReadError(FileFormatError):
    """A URScript program outside the subset read here (field: the statement or argument)."""


@dataclass(frozen=True)
class Pose:
    """A URScript pose p[x, y, z, rx, ry, rz] (m, rotation vector [rad])."""

    values: tuple[float, ...]

    def matrix(self) -> np.ndarray:
        X = np.eye(4)
        X[:3, :3] = Rotation.from_rotvec(self.values[3:]).as_matrix()
        X[:3, 3] = self.values[:3]
        return X


class _Values(lark.Transformer):
    """Parse tree values -> Python: numbers as float, lists, Pose, booleans, variable names as _Variable."""

    def number(self, children):
        return float(children[0])

    def boolean(self, children):
        return children[0] == "True"

    def list(self, children):
        return [child for child in children if child is not None]

    def pose(self, children):
        return Pose(tuple(children[1:]))

    def variable(self, children):
        return _Variable(children[0])


class _Variable(str):
    """A variable name used as a value."""


def read_urscript(text: str, robot: str) -> dict:
    """The job document of a URScript program ``text`` (module docstring) for ``robot`` (a preset name or robot
    file path, written into the document as given). UrscriptReadError names what cannot be read."""
    program = _Values().transform(parse_subset("urscript", "URScript", text, UrscriptReadError, SOURCE)).children[0]
    body = program.children[1]
    run = program.children[2] if len(program.children) > 2 else None
    if run is not None and str(run.children[0]) != str(program.children[0]):
        raise UrscriptReadError(SOURCE, f"{run.children[0]}()", f"after the program: only its own call "
                                f"{program.children[0]}() is read", line=run.meta.line)
    functions = {str(node.children[0]): node.children[1] for node in body.children
                 if isinstance(node, lark.Tree) and node.data == "function_def"}
    reader = _Reader(load_robot(robot))
    reader.statements(body, replay_choice="native_moves" in functions)
    if "native_moves" in functions:
        reader.statements(functions["native_moves"], replay_choice=False)
    if not reader.waypoints:
        raise UrscriptReadError(SOURCE, "moves", "the program has no movej, movel or movec")
    return reader.document(robot)


class _Reader:
    """The statements' tool, variables and waypoints, in order, with the previous target's joint values."""

    def __init__(self, robot: Robot):
        self.robot = robot
        self.X_FT = np.eye(4)
        self.variables: dict[str, object] = {}
        self.waypoints: list[dict] = []
        self.q_previous: np.ndarray | None = None
        self.tcp_accel: list[float] = []
        self.payload: dict | None = None

    def statements(self, body: lark.Tree, replay_choice: bool) -> None:
        """Read a body's statements; ``replay_choice``: the body chooses between native_moves and the replay
        with an ``if`` (skipped)."""
        for node in body.children:
            if node.data == "assignment":
                self.variables[str(node.children[-2])] = node.children[-1]
            elif node.data == "call":
                self.call(node)
            elif node.data == "function_def" and str(node.children[0]) not in REPLAY + ("native_moves",):
                raise UrscriptReadError(SOURCE, f"def {node.children[0]}", "is not a function of the subset read "
                                        "here (native_moves, certified_replay)", line=node.meta.line)
            elif node.data == "if_block" and not replay_choice:
                raise UrscriptReadError(SOURCE, "if", "is read only as write_urscript's choice between native_moves "
                                        "and certified_replay", line=node.meta.line)

    def call(self, node: lark.Tree) -> None:
        name = str(node.children[0])
        arguments = [] if node.children[1] is None else node.children[1].children
        if name == "set_tcp":
            if self.waypoints:
                raise UrscriptReadError(SOURCE, name, "after the first move: a job has one tool", line=node.meta.line)
            self.X_FT = self.pose(arguments[0], name).matrix()
        elif name == "set_payload" and len(arguments) == 2 and isinstance(arguments[1], list):
            mass, com = self.resolve(arguments[0], name), [self.resolve(v, name) for v in arguments[1]]
            self.payload = {"mass": mass, "com": com}
        elif name in PARAMETERS:
            self.move(name, self.arguments(name, arguments, node.meta.line), node.meta.line)
        else:
            raise UrscriptReadError(SOURCE, name, "is not a function of the subset read here (set_tcp, set_payload "
                                    "(m, [x, y, z]), movej, movel, movec)", line=node.meta.line)

    def arguments(self, name: str, arguments: list, line: int) -> dict:
        """The move's arguments by parameter name (the manual's defaults for those left out)."""
        out = dict(DEFAULTS[name])
        positional = [a for a in arguments if not (isinstance(a, lark.Tree) and a.data == "keyword")]
        if len(positional) > len(PARAMETERS[name]):
            raise UrscriptReadError(SOURCE, name, f"takes at most {len(PARAMETERS[name])} arguments", line=line)
        out.update(zip(PARAMETERS[name], positional))
        for keyword in arguments[len(positional):]:
            key = str(keyword.children[0])
            if key not in PARAMETERS[name]:
                raise UrscriptReadError(SOURCE, f"{name}({key}=...)", f"{name} has no parameter {key}", line=line)
            out[key] = keyword.children[1]
        out = {key: self.resolve(value, name) for key, value in out.items()}
        if out.get("t", 0.0) != 0.0:
            raise UrscriptReadError(SOURCE, f"{name}(t=...)", "a move given a time has no speed to read", line=line)
        if out.get("mode", 0.0) != 0.0:
            raise UrscriptReadError(SOURCE, f"{name}(mode=...)", "only mode 0 (orientation interpolated from the start "
                                    "to the target) is read", line=line)
        return out

    def resolve(self, value, where: str):
        """A value, a variable replaced by its value."""
        if isinstance(value, _Variable):
            if value not in self.variables:
                raise UrscriptReadError(SOURCE, where, f"uses the variable {value}, not assigned before", value)
            return self.variables[value]
        return value

    def pose(self, value, where: str) -> Pose:
        value = self.resolve(value, where)
        if not isinstance(value, Pose):
            raise UrscriptReadError(SOURCE, where, "needs a pose p[x, y, z, rx, ry, rz]", value)
        return value

    def move(self, name: str, arguments: dict, line: int) -> None:
        target = arguments["pose_to" if name == "movec" else "pose" if name == "movel" else "q"]
        if isinstance(target, Pose):
            waypoint, q = self.pose_waypoint(target.matrix())
            waypoint["move"] = {"movej": "joint", "movel": "linear", "movec": "circular"}[name]
        elif name == "movej" and isinstance(target, list) and len(target) == self.robot.dof:
            q = np.array(target, dtype=float)
            waypoint = {"joints": [round(float(v), 10) for v in np.degrees(q)]}
        else:
            raise UrscriptReadError(SOURCE, name, f"needs a pose{' or a joint vector' * (name == 'movej')}", target,
                                    line=line)
        if name == "movec":
            waypoint["via"] = {"xyz": list(self.pose(arguments["pose_via"], name).values[:3])}
        if self.q_previous is not None:
            self.add_speed(waypoint, name, arguments)
            waypoint["zone"] = float(arguments["r"])
        self.q_previous = q
        self.waypoints.append(waypoint)

    def pose_waypoint(self, X: np.ndarray) -> tuple[dict, np.ndarray]:
        """(pose waypoint of TCP pose X (4, 4) [m] with the branch nearest the previous target, its joint values)."""
        robot = robot_with_tool(self.robot, self.X_FT)
        result = solve_ik_batch(robot, X[None], method="analytic")[0]
        solutions = np.array([s.q for s in result.solutions]).reshape(-1, robot.dof)
        shifted, valid = limit_variants(solutions, robot.revolute_mask, robot.limits.q_min, robot.limits.q_max)
        candidates = shifted[valid]
        if not len(candidates):
            raise UrscriptReadError(SOURCE, "pose", "has no in-limit joint solution for this robot and tool",
                                    [round(float(v), 6) for v in X[:3, 3]])
        previous = np.zeros(robot.dof) if self.q_previous is None else self.q_previous
        q = candidates[int(np.argmin(np.abs(candidates - previous).max(axis=1)))]
        quaternion = Rotation.from_matrix(X[:3, :3]).as_quat()            # x, y, z, w
        waypoint = {"xyz": X[:3, 3].tolist(), "quaternion": [float(quaternion[3]), *map(float, quaternion[:3])]}
        label = configuration_labels(robot, q[None])[0]
        if label:
            waypoint["config"] = label_parts(label)
        return waypoint, q

    def add_speed(self, waypoint: dict, name: str, arguments: dict) -> None:
        if name == "movej":
            percent = 100.0 * float(arguments["v"]) / float(np.min(self.robot.limits.qd_max))
            waypoint["speed"] = min(100.0, percent)
        else:
            waypoint["speed"] = float(arguments["v"])
            self.tcp_accel.append(float(arguments["a"]))

    def document(self, robot: str) -> dict:
        self.waypoints[-1].pop("zone", None)
        doc = {"robot": str(robot), "length_unit": "m", "angle_unit": "deg", "waypoints": self.waypoints}
        if self.tcp_accel:
            doc["tcp_accel_max"] = max(self.tcp_accel)
        if self.payload is not None:
            doc["payload"] = self.payload
        if not np.allclose(self.X_FT, np.eye(4), atol=1e-12):
            quaternion = Rotation.from_matrix(self.X_FT[:3, :3]).as_quat()
            doc["tool"] = {"xyz": self.X_FT[:3, 3].tolist(),
                           "quaternion": [float(quaternion[3]), *map(float, quaternion[:3])]}
        return doc
