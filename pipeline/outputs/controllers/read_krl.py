"""``read_krl(src, dat, robot) -> dict``: a KUKA KRL program (its ``.src`` and ``.dat`` texts) of the subset
``write_krl`` writes, read back into a job document (a mapping ``pipeline.program.job.parse_job`` accepts).

Both files are parsed with ``grammars/krl.lark`` (package data; KUKA System Software 8.x expert programming,
"Names", "Comments", "Data types", "Motion programming": keywords and names are not case-sensitive, ``;``
comments and ``;FOLD`` lines, free spacing, the editor's ``&ACCESS``/``&REL``/``&PARAM`` lines), so a program a
pendant wrote in that subset reads the same. What is read, and the KRL facts it follows:

* The .dat's ``DECL E6POS``/``POS``/``E6AXIS``/``AXIS``/``FRAME`` points by name (names are not case-sensitive).
* The .src's statements in order: assignments to system variables are kept as the current settings (the
  last one before a motion counts), and each ``PTP``/``LIN``/``CIRC`` is one waypoint; the first motion (the
  BCO run to the start) is the job's first waypoint, without a move, speed or zone.
* ``E6AXIS``/``AXIS`` {A1..A6} [deg] -> a joint waypoint through the inverse of the KUKA axis map of
  ``pipeline.model.vendors.axes`` (q = (angle - offset) x direction); a LIN or CIRC to one becomes the pose of
  those joint values (our forward kinematics with the tool) with their branch.
* ``E6POS``/``POS``/``FRAME`` {X, Y, Z [mm], A, B, C [deg]} -> a pose waypoint, R = Rz(A) Ry(B) Rx(C) ("Orientation
  angles A, B, C"). Its Status and Turn (decimal or bit constants 'B...') select the one closed-form
  solution they name (``pipeline.model.vendors.selection``, the robot with the program's tool), whose branch
  label (``pipeline.model.ik.branches.configuration_labels``) is the waypoint's ``config``. Where two 2 pi variants of
  one branch share S and T (Turn is a sign per axis: an axis of more than +-180 deg has two of one sign; the
  controller ignores S and T on LIN and CIRC), their common branch is the config. A FRAME (no S, T) has none.
  The first waypoint's selected joint values are the job's ``start`` (the IK seed), which fixes its 2 pi variant.
* Moves: ``PTP`` joint, ``LIN`` linear, ``CIRC aux, end`` circular with the auxiliary point's position as ``via``
  (KRL uses neither its orientation nor its S and T).
* Speeds ("$VEL_AXIS", "$VEL"): a PTP's ``$VEL_AXIS[1..6]`` [% of the axes' maximum speeds], equal on the six
  axes -> ``speed`` [%]; a LIN's or CIRC's ``$VEL.CP`` [m/s] -> ``speed`` [m/s]. ``$ACC.CP`` [m/s^2], when a number
  and the program has tool moves -> ``tcp_accel_max``.
* Zones ("Approximate positioning"): ``C_DIS`` -> ``zone`` = ``$APO.CDIS`` [mm -> m]; no approximation parameter
  -> 0 (an exact stop). A PTP's ``C_PTP`` (alone or with ``C_DIS``, as ``write_krl`` writes for a KR C2) is a
  percentage of an axis angle, no distance: it is read only with ``$APO.CDIS`` set, whose distance is the zone.
  ``C_VEL``, ``C_ORI`` (a speed, an angle: no distance) are refused.
* ``$TOOL`` {X, Y, Z, A, B, C} (the TCP in the flange frame) -> the job's ``tool``; ``$BASE`` must be ``$ROBROOT``
  (targets in the robot's base frame); $ROBROOT and $FLANGE are where the robot file's kuka controller section
  puts them in our base and end frames (``model.vendors.controller``; ours without one) and ``$IPO_MODE`` ``#BASE`` (a robot-held tool) where they are set.

The document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``start``,
``tcp_accel_max``, ``waypoints``. Anything else (another statement, a missing point, a speed that is not a
number) is a ``KrlReadError`` naming the file, the line and the statement or point.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import lark
import numpy as np

from ...errors import ConfigurationNotFoundError, FileFormatError
from ...files.branch_names import label_parts
from ...files.poses import pose_to_quaternion_position
from ...model.ik import solve_ik_batch
from ...model.ik.branches import configuration_labels
from ...model.ik.result import limit_variants
from ...model.robot import Robot, load_robot, robot_with_tool
from ...model.vendors.axes import KUKA, axis_map
from ...model.vendors.configuration import configurations
from ...model.vendors.controller import controller_frames
from ...model.vendors.selection import select_solution
from .krl import abc_rotation
from .read_ls import grammar_parser

MOVE_KINDS = {"ptp": "joint", "lin": "linear", "circ": "circular"}
AXIS_TYPES, POSE_TYPES = ("E6AXIS", "AXIS"), ("E6POS", "POS", "FRAME")
#: What a program may set these system variables to (KSS "System variables"), where it sets them.
REQUIRED_SETTINGS = {"$BASE": "$ROBROOT", "$IPO_MODE": "#BASE"}


class KrlReadError(FileFormatError):
    """A KRL program outside the subset read here, or with data that does not fit (``field``: the statement,
    system variable or point name; ``line`` where known)."""


@dataclass(frozen=True)
class _Point:
    """A .dat point: its type (upper case), components (upper-case name -> number) and declaration line."""

    type: str
    values: dict
    line: int | None


@dataclass(frozen=True)
class _Motion:
    """A motion of the .src with the settings in force: kind (ptp, lin, circ), target and aux point names,
    approximation parameters (upper case), line, and the system variables set before it (name -> value)."""

    kind: str
    target: str
    aux: str | None
    approx: tuple[str, ...]
    line: int | None
    settings: dict


def parse_krl(text: str, part: str, source: str) -> lark.Tree:
    """The ``src`` or ``dat`` (``part``) node of a KRL text; KrlReadError at the line that does not parse."""
    try:
        node = grammar_parser("krl").parse(text).children[0]
    except lark.exceptions.UnexpectedInput as exc:
        raise KrlReadError(source, "syntax", str(exc).splitlines()[0] + " (not KRL of the subset read here)",
                           line=exc.line) from None
    if node.data != part:
        raise KrlReadError(source, part, f"a .{part} file holds DEF{'DAT' * (part == 'dat')} ... END"
                           f"{'DAT' * (part == 'dat')}, this one is a .{node.data}")
    return node


def read_krl(src: str, dat: str, robot, src_name: str = "<src>", dat_name: str = "<dat>") -> dict:
    """The job document (module docstring) of the .src text ``src`` and .dat text ``dat`` for ``robot`` (a preset
    name or robot file path, written into the document as given); ``src_name``, ``dat_name`` name the files
    in errors. KrlReadError names what cannot be read."""
    points = _points(parse_krl(dat, "dat", dat_name))
    motions = _motions(parse_krl(src, "src", src_name), src_name)
    if not motions:
        raise KrlReadError(src_name, "DEF", "the program has no motion (PTP, LIN, CIRC)")
    reader = _Reader(load_robot(robot), points, src_name, dat_name)
    reader.use_tool(motions)
    waypoints = [reader.waypoint(motion, k == 0) for k, motion in enumerate(motions)]
    return reader.document(str(robot), waypoints, motions)


def load_krl(path: str | Path, robot) -> dict:
    """``read_krl`` of the files ``path`` with the suffixes .src and .dat (e.g. ``PICK.src`` and ``PICK.dat``)."""
    path = Path(path)
    src, dat = path.with_suffix(".src"), path.with_suffix(".dat")
    return read_krl(src.read_text(), dat.read_text(), robot, str(src), str(dat))


def _line(node) -> int | None:
    return getattr(node, "line", None) if isinstance(node, lark.Token) else (
        None if node.meta.empty else node.meta.line)


def _number(node) -> float:
    """A ``number`` node or a bit constant token ('B101') -> its value."""
    if isinstance(node, lark.Token):
        return float(int(str(node)[2:-1], 2))
    return float(node.children[0])


def _aggregate(node: lark.Tree) -> dict:
    return {str(c.children[0]).upper(): _number(c.children[1]) for c in node.children}


def _points(dat: lark.Tree) -> dict[str, _Point]:
    """The .dat's declarations by upper-case name."""
    out = {}
    for decl in dat.find_data("decl"):
        kind, name, aggregate = decl.children
        out[str(name).upper()] = _Point(str(kind).upper(), _aggregate(aggregate), _line(decl))
    return out


def _value(node):
    """An assigned value: a number, a component mapping, or the text of a system variable or enumeration."""
    if isinstance(node, lark.Token):
        return str(node).upper()
    if node.data == "number":
        return _number(node)
    if node.data == "aggregate":
        return _aggregate(node)
    return _sysvar(node)


def _sysvar(node: lark.Tree) -> str:
    """``$VEL.CP``, ``$VEL_AXIS[1]``: the upper-case text of a system variable."""
    name, *rest = node.children
    text = str(name).upper()
    for part in rest:
        text += f"[{int(part)}]" if part.type == "INT" else f".{str(part).upper()}"
    return text


def _motions(src: lark.Tree, source: str) -> list[_Motion]:
    """The motions in order, each with the system variables set before it."""
    settings, motions = {}, []
    for statement in src.children[1:]:
        if statement.data == "assignment":
            target, value = statement.children
            name = _sysvar(target)
            settings[name] = _value(value)
            wanted = REQUIRED_SETTINGS.get(name)
            if wanted is not None and settings[name] != wanted:
                raise KrlReadError(source, name, f"must be {wanted} in the subset read here (targets in the robot's "
                                   "base frame, a tool on the flange)", value=settings[name], line=_line(statement))
            continue
        node = statement.children[0]
        names = [str(c).upper() for c in node.children if isinstance(c, lark.Token)]
        approx = tuple(str(t).upper() for c in node.children if isinstance(c, lark.Tree) for t in c.children)
        motions.append(_Motion(node.data, names[-1], names[0] if len(names) == 2 else None, approx, _line(node),
                               dict(settings)))
    return motions


class _Reader:
    """The waypoints of the motions, with the robot, its tool and the .dat's points."""

    def __init__(self, robot: Robot, points: dict, src_name: str, dat_name: str):
        self.robot, self.points, self.src_name, self.dat_name = robot, points, src_name, dat_name
        self.X_FT = np.eye(4)
        self.robot_tool = robot
        self.start: np.ndarray | None = None

    def fail(self, motion: _Motion, field: str, problem: str, value=None):
        raise KrlReadError(self.src_name, field, problem, value=value, line=motion.line)

    def use_tool(self, motions: list[_Motion]) -> None:
        """The tool $TOOL of the first motion; every motion must use it (a job has one tool)."""
        tool = motions[0].settings.get("$TOOL")
        for motion in motions:
            if motion.settings.get("$TOOL") != tool:
                self.fail(motion, "$TOOL", "differs from the first motion's: a job has one tool")
        if tool is None:
            return
        if not isinstance(tool, dict):
            self.fail(motions[0], "$TOOL", "must be a frame {X, Y, Z, A, B, C} here (a tool data set is not read)",
                      tool)
        self.X_FT = controller_frames(self.robot, KUKA)[1] @ self.frame(tool, motions[0], "$TOOL")
        self.robot_tool = robot_with_tool(self.robot, self.X_FT)

    def frame(self, values: dict, motion: _Motion, name: str) -> np.ndarray:
        """The pose (4, 4) [m] of components X, Y, Z [mm], A, B, C [deg]."""
        missing = [k for k in "XYZABC" if k not in values]
        if missing:
            self.fail(motion, name, f"has no {', '.join(missing)}: a frame needs X, Y, Z, A, B, C")
        X = np.eye(4)
        X[:3, :3] = abc_rotation(values["A"], values["B"], values["C"])
        X[:3, 3] = np.array([values["X"], values["Y"], values["Z"]]) / 1000.0
        return X

    def in_base(self, X: np.ndarray) -> np.ndarray:
        """A pose (4, 4) [m] in $ROBROOT (the robot file's kuka controller base frame) -> in our base frame."""
        return controller_frames(self.robot, KUKA)[0] @ X

    def point(self, name: str, motion: _Motion) -> _Point:
        point = self.points.get(name)
        if point is None:
            self.fail(motion, name, f"is not declared in the .dat ({self.dat_name}) as E6POS, POS, E6AXIS, AXIS or "
                      "FRAME")
        return point

    def joints(self, point: _Point, name: str, motion: _Motion) -> np.ndarray:
        """The joint values (6,) [rad] of an E6AXIS / AXIS point (the inverse KUKA axis map)."""
        missing = [f"A{i}" for i in range(1, 7) if f"A{i}" not in point.values]
        if missing:
            self.fail(motion, name, f"has no {', '.join(missing)}: an axis point needs A1..A6")
        mapping = axis_map(self.robot, KUKA)
        angles = np.array([point.values[f"A{i}"] for i in range(1, 7)])
        return np.radians((angles - np.array(mapping.offset)) * np.array(mapping.direction))

    def waypoint(self, motion: _Motion, first: bool) -> dict | list:
        """One motion's waypoint (module docstring)."""
        if first and motion.approx:
            self.fail(motion, motion.approx[0], "the first motion is where the job starts: it ends at rest there")
        point = self.point(motion.target, motion)
        if point.type in AXIS_TYPES:
            q = self.joints(point, motion.target, motion)
            if motion.kind == "ptp":
                joints = [round(float(v), 10) for v in np.degrees(q)]
                if first:
                    return joints
                return {"joints": joints, **self.speed_and_zone(motion)}
            waypoint = self.pose_waypoint(self.robot_tool.fk(q), configuration_labels(self.robot_tool, q[None])[0])
        else:
            X = self.in_base(self.frame(point.values, motion, motion.target))
            waypoint = self.pose_waypoint(X, self.branch(X, point, motion, first))
        if first:
            return waypoint
        waypoint["move"] = MOVE_KINDS[motion.kind]
        if motion.aux is not None:
            aux = self.point(motion.aux, motion)
            if aux.type not in POSE_TYPES:
                self.fail(motion, motion.aux, f"is an {aux.type}: a CIRC's auxiliary point here is a FRAME, POS or "
                          "E6POS")
            waypoint["via"] = {"xyz": self.in_base(self.frame(aux.values, motion, motion.aux))[:3, 3].tolist()}
        return {**waypoint, **self.speed_and_zone(motion)}

    def pose_waypoint(self, X: np.ndarray, label: str) -> dict:
        quaternion, position = pose_to_quaternion_position(X)
        waypoint = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if label:
            waypoint["config"] = label_parts(label)
        return waypoint

    def branch(self, X: np.ndarray, point: _Point, motion: _Motion, first: bool) -> str:
        """The branch label of pose X (4, 4) [m] with the point's S and T ("" without them): the one solution
        ``select_solution`` picks, or, where 2 pi variants share S and T, their common branch."""
        if "S" not in point.values or "T" not in point.values:
            return ""
        status_turn = (int(point.values["S"]), int(point.values["T"]))
        try:
            q = select_solution(self.robot_tool, X, status_turn, KUKA)
        except ConfigurationNotFoundError as exc:
            labels = self.labels_with(X, status_turn)
            if len(labels) != 1:
                self.fail(motion, motion.target, str(exc))
            return labels.pop()
        if first:
            self.start = q
        return configuration_labels(self.robot_tool, q[None])[0]

    def labels_with(self, X: np.ndarray, status_turn: tuple[int, int]) -> set[str]:
        """The branch labels of every in-limit solution and 2 pi variant of X with this Status and Turn."""
        robot = self.robot_tool
        Q = np.array([s.q for s in solve_ik_batch(robot, X[None], method="analytic")[0].solutions]).reshape(-1, 6)
        shifted, valid = limit_variants(Q, robot.revolute_mask, robot.limits.q_min, robot.limits.q_max)
        Q = shifted[valid]
        Q = Q[(configurations(robot, Q, KUKA) == status_turn).all(axis=1)] if len(Q) else Q
        return set(configuration_labels(robot, Q)) if len(Q) else set()

    def speed_and_zone(self, motion: _Motion) -> dict:
        """``speed`` ($VEL_AXIS [%] of a PTP, $VEL.CP [m/s] of a LIN or CIRC) and ``zone`` [m] (C_DIS)."""
        out = {"speed": self.speed(motion)}
        allowed = ("C_DIS", "C_PTP") if motion.kind == "ptp" else ("C_DIS",)
        extra = [a for a in motion.approx if a not in allowed]
        if extra:
            self.fail(motion, extra[0], "is not read here: only C_DIS (an approximation distance, $APO.CDIS [mm]), "
                      "or C_PTP on a PTP with $APO.CDIS set, gives a zone")
        if motion.approx:
            cdis = motion.settings.get("$APO.CDIS")
            if not isinstance(cdis, float) or cdis <= 0.0:
                self.fail(motion, "$APO.CDIS", f"must be set to a positive distance [mm] before a motion with "
                          f"{' '.join(motion.approx)}", cdis)
            out["zone"] = cdis / 1000.0
        return out

    def speed(self, motion: _Motion) -> float:
        if motion.kind != "ptp":
            cp = motion.settings.get("$VEL.CP")
            if not isinstance(cp, float) or cp <= 0.0:
                self.fail(motion, "$VEL.CP", "must be set to a positive TCP speed [m/s] before a LIN or CIRC", cp)
            return cp
        percents = [motion.settings.get(f"$VEL_AXIS[{i}]") for i in range(1, 7)]
        if not all(isinstance(p, float) for p in percents) or len(set(percents)) != 1 or not 0 < percents[0] <= 100:
            self.fail(motion, "$VEL_AXIS", "must be set to one percentage in (0, 100] on all six axes before a PTP "
                      "(a job's joint move has one fraction of the axes' speed limits)", percents)
        return percents[0]

    def document(self, robot: str, waypoints: list, motions: list[_Motion]) -> dict:
        doc = {"robot": robot, "length_unit": "m", "angle_unit": "deg", "waypoints": waypoints}
        if not np.allclose(self.X_FT, np.eye(4), atol=1e-12):
            quaternion, position = pose_to_quaternion_position(self.X_FT)
            doc["tool"] = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if self.start is not None:
            doc["start"] = [round(float(v), 10) for v in np.degrees(self.start)]
        accel = motions[-1].settings.get("$ACC.CP")
        if isinstance(accel, float) and accel > 0.0 and any(m.kind != "ptp" for m in motions[1:]):
            doc["tcp_accel_max"] = accel
        return doc
