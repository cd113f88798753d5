"""``read_ls(text, robot) -> dict``: a FANUC ``.ls`` program (the subset ``fanuc_ls.write_ls`` writes, also as
a pendant or ROBOGUIDE prints it) back to a job document that ``pipeline.program.job.parse_job`` accepts.

The file is parsed with ``grammars/fanuc_ls.lark`` (written from FANUC's R-30iA/R-30iB operator's manuals:
"Motion instructions", "Position data", "Program header information"; keywords upper case as the manuals
and the controller print them, any spacing, tabs, CR LF line ends, ``!`` comments anywhere in /MN). Then:

* Moves: the first motion line is the job's first waypoint (the move to it starts wherever the robot is,
  so its speed is not a job quantity); ``J`` is a joint move with ``speed`` its ``%``, ``L`` a linear and
  ``C`` a circular move (via point, then end point) with ``speed`` its ``mm/sec`` as m/s. The job's
  ``speed_scale`` is 1: the speeds are the ones the controller runs.
* Zones: ``FINE`` is zone 0. ``CNTn`` is not a distance: its zone is the one the writer states in the
  ``!zone Z mm CNTn ...`` comment line before the move when that comment names the same n; else it is
  n / 100 x the reach the writer divides by (``fanuc_ls.cnt_value``): for an ``L`` or ``C`` move with a
  TCP acceleration limit given by the caller (``tcp_accel_max``), the deceleration distance v^2 / (2 a)
  at the move's speed, otherwise half the shorter of this move and the next (TCP chords). The writer
  takes n = ceil(100 zone / reach), so below CNT100 this is the largest zone that gives n, at most
  reach / 100 above the zone written; CNT100 stands for every zone from 0.99 reach up and reads as the reach.
* Points: ``UF : 0`` only (user frame 0 is FANUC's world frame; another user frame's data is on the
  controller, not in the file). A Cartesian point is the TCP in the world frame, X Y Z [mm], W P R [deg]
  with R = Rz(R) Ry(P) Rx(W); the world frame is the robot file's fanuc controller section's base frame, as
  the writer applied it (``fanuc_ls.controller_frame``: 330 mm up on the LR Mate 200iD). Its CONFIG selects
  the one joint solution (``selection.select_solution``, the robot with its tool), whose closed-form branch
  (``pipeline.model.ik.branches.configuration_labels``) is the waypoint's ``config`` mapping; the first
  Cartesian point's joint values are the job's ``start`` (the IK seed of the first pose), so its turns
  (t1, t4, t6) are the ones the file gives. Joint points are J1..J6 [deg] as the pendant shows them, turned
  back into model joint values (``axes.joint_values``: the inverse of ``axes.axis_angles``, FANUC's J3 = q3 - q2).
* Tool: UT's data lives on the controller, not in the file: the caller's ``tool`` (4, 4) [m], else the
  ``UT 1 = tool x y z w p r`` the writer states in its header comment, else none; both on the controller's
  flange frame (the section's flange, ``controller.controller_frames``), carried to our end frame.

``ControllerProgramError`` names the file, the line or point and what is wrong. ``tool_frame``,
``zone_from_cnt`` and ``pose_waypoint`` are shared with the Yaskawa reader.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

import numpy as np
from lark import Lark, Token, Tree
from lark.exceptions import LarkError, UnexpectedInput

from ...errors import ConfigurationNotFoundError, FileFormatError
from ...files.poses import pose_to_quaternion_position, rotation_to_rpy, rpy_position_to_pose
from ...model.ik.branches import configuration_labels
from ...model.robot import Robot, load_robot, robot_with_tool
from ...model.vendors.axes import FANUC, joint_values
from ...model.vendors.configuration import format_configuration, parse_configuration
from ...model.vendors.controller import controller_frames
from ...model.vendors.selection import select_solution
from .fanuc_ls import MM, controller_frame, controller_pose

#: The writer's zone comment (``fanuc_ls._zone_comment``): zone [mm] and CNT n.
ZONE_COMMENT = re.compile(r"zone\s+(\d+(?:\.\d+)?)\s*mm\s+CNT\s*(\d+)", re.IGNORECASE)
#: The writer's tool statement in its header comment: x y z [mm] and three angles [deg].
TOOL_COMMENT = re.compile(r"tool\s+((?:-?\d+(?:\.\d+)?\s+){5}-?\d+(?:\.\d+)?)")


class ControllerProgramError(FileFormatError):
    """A controller program that the reader cannot read: ``source`` the file, ``field`` the line, move
    or point, ``problem`` what is wrong."""


@cache
def grammar_parser(name: str) -> Lark:
    """The LALR parser of ``grammars/<name>.lark`` (package data), built once per process; its trees
    carry line numbers (for messages)."""
    text = resources.files(__package__).joinpath("grammars", f"{name}.lark").read_text()
    return Lark(text, parser="lalr", propagate_positions=True)


def parse_subset(grammar: str, language: str, text: str, error_type, source: str) -> Tree:
    """The parse tree of ``text`` by ``grammars/<grammar>.lark``, or ``error_type`` (a FileFormatError) naming
    ``source``, field ``syntax`` and the line where lark stops: "not ``language`` of the subset read here"."""
    try:
        return grammar_parser(grammar).parse(text)
    except UnexpectedInput as exc:
        raise error_type(source, "syntax", f"not {language} of the subset read here: {exc}".splitlines()[0],
                         line=exc.line) from None


def parse_text(name: str, text: str, source: str) -> Tree:
    """The parse tree of ``text`` by grammar ``name``, or ControllerProgramError at the line lark stops."""
    try:
        return grammar_parser(name).parse(text if text.endswith("\n") else text + "\n")
    except UnexpectedInput as error:
        raise ControllerProgramError(source, f"line {error.line}", "not in the subset this reader reads: "
                                     f"{str(error).splitlines()[0]}", line=error.line) from None
    except LarkError as error:
        raise ControllerProgramError(source, "file", f"not in the subset this reader reads: {error}") from None


def as_robot(robot) -> tuple[Robot, str]:
    """(the Robot, how the job names it): a Robot (its name: a preset's), or a preset name or robot file
    (loaded; the job names it as given)."""
    if isinstance(robot, Robot):
        return robot, robot.name
    return load_robot(robot), str(robot)


def tool_frame(robot, vendor: str, tool: np.ndarray | None, comments: list[str]) -> np.ndarray | None:
    """X_FT (4, 4) [m] on our end frame of the controller's tool data on its flange frame: ``tool`` (4, 4) [m],
    else the writer's header comment (``comment_tool``), else none (the flange); None for our end frame."""
    X = tool if tool is not None else comment_tool(comments)
    X_FT = controller_frames(robot, vendor)[1] @ (np.eye(4) if X is None else X)
    return None if np.allclose(X_FT, np.eye(4), atol=1e-12) else X_FT


def comment_tool(comments: list[str]) -> np.ndarray | None:
    """X_FT (4, 4) [m] from the writer's ``tool x y z a b c`` (mm, rotations about fixed x, y, z [deg]) in
    its header comment lines (joined: the writer wraps them), or None."""
    match = TOOL_COMMENT.search(" ".join(comments))
    if match is None:
        return None
    values = np.array([float(v) for v in match.group(1).split()])
    return rpy_position_to_pose(np.radians(values[3:]), values[:3] / MM)


def zone_from_cnt(n: int, speed_mm_s: float | None, accel: float | None, chords: list[float]) -> float:
    """The zone [m] of CNT n without the writer's comment (module docstring): n / 100 x the deceleration
    distance at ``speed_mm_s`` [mm/s] under ``accel`` [m/s^2] for a tool move (speed given) with an
    acceleration limit, else x half the shorter of the neighbouring TCP ``chords`` [m]."""
    if speed_mm_s is not None and accel:
        reach = (speed_mm_s / MM) ** 2 / (2.0 * accel)
    else:
        reach = min(chords) / 2.0
    return n / 100.0 * reach


def pose_waypoint(tool_robot, X_BT: np.ndarray, config, vendor: str, where: str,
                  source: str) -> tuple[dict, np.ndarray]:
    """(the job waypoint of TCP pose X_BT (4, 4) [m, our base frame] with vendor configuration ``config``
    (``pose_fields``), the joint values q (6,) [rad] it selects)."""
    try:
        q = select_solution(tool_robot, X_BT, config, vendor)
    except ConfigurationNotFoundError as error:
        raise ControllerProgramError(source, where, str(error)) from None
    return pose_fields(tool_robot, X_BT, q, (vendor, config)), q


def pose_fields(tool_robot, X_BT: np.ndarray, q, controller: tuple | None = None) -> dict:
    """A pose waypoint's fields: xyz [m] and quaternion [w, x, y, z] of X_BT (4, 4), config: the branch of
    q (6,) [rad] as a mapping (``configuration_labels``' "shoulder front, elbow up, wrist noflip"), and with
    ``controller`` (vendor, its configuration fields) the ``controller_config`` the program wrote: the job then
    solves the pose as the controller does (the turns of axes 4 and 6 too, which the branch does not name)."""
    quaternion, p = pose_to_quaternion_position(X_BT)
    branch = dict(part.split(" ") for part in configuration_labels(tool_robot, q)[0].split(", "))
    fields = {"xyz": [float(v) for v in p], "quaternion": [float(v) for v in quaternion], "config": branch}
    if controller is not None:
        vendor, config = controller
        fields["controller_config"] = {vendor: format_configuration(vendor, parse_configuration(vendor, config))}
    return fields


def job_document(reference: str, X_FT: np.ndarray | None, waypoints: list[dict], start,
                 accel: float | None) -> dict:
    """The job document (module docstring) of read waypoints: ``reference`` the robot's preset name or
    file, ``start`` (6,) [rad] or None."""
    doc = {"robot": reference, "length_unit": "m", "angle_unit": "deg", "speed_scale": 1.0}
    if X_FT is not None and not np.allclose(X_FT, np.eye(4), atol=1e-12):
        doc["tool"] = {"xyz": [float(v) for v in X_FT[:3, 3]],
                       "rpy": [float(v) for v in np.degrees(rotation_to_rpy(X_FT[:3, :3]))]}
    if accel:
        doc["tcp_accel_max"] = float(accel)
    if start is not None:
        doc["start"] = [float(v) for v in np.degrees(start)]
    doc["waypoints"] = waypoints
    return doc


def read_ls(text: str, robot, tool: np.ndarray | None = None, tcp_accel_max: float | None = None,
            source: str = "<ls>") -> dict:
    """The job document of a FANUC ``.ls`` program (module docstring). ``robot``: a Robot, preset name or
    robot file; ``tool``: UT 1 as X_FT (4, 4) [m] (None: the writer's header comment, else none);
    ``tcp_accel_max`` [m/s^2]: the TCP acceleration limit the writer rounded CNT over (comment-less CNT);
    ``source``: the file's name for errors."""
    robot, reference = as_robot(robot)
    tree = parse_text("fanuc_ls", text, source)
    positions = {index: data for index, data in map(_position, tree.find_data("position"))}
    moves, comments, header = _motions(tree)
    X_FT = tool_frame(robot, FANUC, tool, header)
    tool_robot = robot if X_FT is None else robot_with_tool(robot, X_FT)
    X_B_base = controller_frame(robot, FANUC)[0]
    points = [_point(robot, tool_robot, positions, ref, X_B_base, source) for move in moves for ref in move["refs"]]
    return _document(reference, X_FT, moves, comments, points, tcp_accel_max)


def _motions(tree: Tree) -> tuple[list[dict], list[list[str]], list[str]]:
    """(each motion line as {kind, refs (P indices), speed (token text), termination}, the comment lines
    just before each motion, the comments before the first motion)."""
    moves, comments, pending, header = [], [], [], None
    for statement in tree.find_data("statement"):
        node = statement.children[0]
        if node.data == "comment":
            pending.append(str(node.children[0])[1:])
            continue
        if node.data == "frame_select":         # UFRAME_NUM / UTOOL_NUM: the frames the points name
            continue
        header = pending if header is None else header
        refs = [int(ref.children[0]) for ref in node.find_data("point_ref")]
        speed, termination = node.children[-2], node.children[-1].children[0]
        kind = {"joint_move": "joint", "linear_move": "linear", "circular_move": "circular"}[node.data]
        moves.append({"kind": kind, "refs": refs, "speed": str(speed), "termination": str(termination),
                      "line": speed.line})
        comments.append(pending if pending is not header else [])
        pending = []
    return moves, comments, header or []


def _position(node: Tree) -> tuple[int, dict]:
    """(P index, {uf, config text, xyz [mm], wpr [deg]} or {uf, joints [deg]}) of a /POS entry."""
    index = int(node.children[0])
    frames = next(node.find_data("frames"))
    data = {"uf": int(frames.children[0]), "line": node.children[0].line}
    cartesian = next(node.find_data("cartesian"), None)
    if cartesian is None:
        data["joints"] = [float(j.children[1]) for j in node.find_data("joint")]
        return index, data
    flip, up, front, *turns = (str(t) for t in next(cartesian.find_data("config")).children)
    data["config"] = f"{flip} {up} {front}, {', '.join(turns)}"
    data["xyz"] = [float(t) for t in next(cartesian.find_data("xyz")).children if isinstance(t, Token)]
    data["wpr"] = [float(t) for t in next(cartesian.find_data("wpr")).children if isinstance(t, Token)]
    return index, data


def _point(robot, tool_robot, positions: dict, ref: int, X_B_base: np.ndarray, source: str) -> dict:
    """{waypoint: the job's pose or joint fields, q [rad], p [m]: the TCP position} of point P[ref]."""
    where = f"P[{ref}]"
    if ref not in positions:
        raise ControllerProgramError(source, where, "used in /MN but not defined in /POS")
    data = positions[ref]
    if data["uf"] != 0:
        raise ControllerProgramError(source, where, "user frame UF {uf}: only UF 0 (the world frame) is read; "
                                     "another user frame's data is on the controller, not in the file".format(**data),
                                     line=data["line"])
    if "joints" in data:
        q = joint_values(robot, data["joints"], FANUC)
        return {"waypoint": {"joints": [float(v) for v in np.degrees(q)]}, "q": q, "p": tool_robot.fk(q)[:3, 3],
                "pose": pose_fields(tool_robot, tool_robot.fk(q), q)}
    X = controller_pose(X_B_base, data["xyz"], data["wpr"])
    waypoint, q = pose_waypoint(tool_robot, X, data["config"], FANUC, where, source)
    return {"waypoint": waypoint, "q": q, "p": X[:3, 3], "pose": waypoint}


def _document(reference: str, X_FT, moves: list[dict], comments: list[list[str]], points: list[dict],
              accel: float | None) -> dict:
    """The job document from the motion lines and their points (in the order the lines use them)."""
    ends, k = [], 0
    for move in moves:
        k += len(move["refs"])
        ends.append(k - 1)
    waypoints = [_first_waypoint(points[0])]
    for m in range(1, len(moves)):
        move, end = moves[m], points[ends[m]]
        waypoint = dict(end["waypoint"] if move["kind"] == "joint" else end["pose"])
        if "joints" not in waypoint:
            waypoint["move"] = move["kind"]
        if move["kind"] == "circular":
            waypoint["via"] = {"xyz": [float(v) for v in points[ends[m] - 1]["p"]]}
        waypoint["speed"] = _speed(move["speed"])
        chords = [float(np.linalg.norm(end["p"] - points[ends[m - 1]]["p"]))]
        if m + 1 < len(moves):
            chords.append(float(np.linalg.norm(points[ends[m + 1]]["p"] - end["p"])))
        zone = _zone(move, comments[m], accel, chords)
        if zone > 0.0:
            waypoint["zone"] = zone
        waypoints.append(waypoint)
    start = points[0]["q"] if "xyz" in points[0]["waypoint"] else None
    return job_document(reference, X_FT, waypoints, start, accel)


def _first_waypoint(point: dict) -> dict | list:
    """The first waypoint: no move, speed or zone (the motion starts there)."""
    waypoint = point["waypoint"]
    return waypoint["joints"] if "joints" in waypoint else dict(waypoint)


def _speed(text: str) -> float:
    """A joint move's speed [%] or a tool move's [m/s] from ``70%`` or ``500mm/sec``."""
    if text.endswith("%"):
        return float(text[:-1])
    return float(text[:-len("mm/sec")]) / MM


def _zone(move: dict, comments: list[str], accel: float | None, chords: list[float]) -> float:
    """The zone [m] of a move's termination (module docstring)."""
    termination = move["termination"]
    if termination == "FINE":
        return 0.0
    n = int(termination[len("CNT"):])
    for line in comments:
        match = ZONE_COMMENT.search(line)
        if match is not None and int(match.group(2)) == n:
            return float(match.group(1)) / MM
    speed = None if move["kind"] == "joint" else _speed(move["speed"]) * MM
    return zone_from_cnt(n, speed, accel, chords)
