"""``read_jbi(text, robot) -> dict``: a Yaskawa INFORM job (``.jbi``, the subset ``yaskawa_jbi.write_jbi``
writes, also as a controller saves it) back to a job document that ``pipeline.program.job.parse_job`` accepts.

The file is parsed with ``grammars/yaskawa_jbi.lark`` (written from Yaskawa's NX100 "Data Transmission
Function" manual HW0481924 section 4.1 "Job Data Format" and the DX100 manual 156191-1CD section 4.1; keywords
upper case as the manuals give them, any spacing, CR LF line ends, ``'`` comments between instructions). Then:

* Points: ``///POSTYPE ROBOT`` Cartesian data, ``Cxxxxx=X,Y,Z,Rx,Ry,Rz``: the TCP in the robot frame in mm and
  deg, R = Rz Ry Rx (rotations about the fixed x, y, z axes, DX100 manual section 4.3); the robot frame is the
  robot file's yaskawa controller section's base frame, as the writer applied it (``fanuc_ls.controller_frame``:
  330 mm up on the GP7). The ``///RCONF`` in force (its first six fields: Flip, Upper/Lower arm, Front/Rear,
  R, T, S >= 180) selects the one joint solution (``selection.select_solution``), whose closed-form branch
  is the waypoint's ``config``; the first point's joint values are the job's ``start``.
* Moves: the first motion instruction is the job's first waypoint (its speed is not a job quantity);
  ``MOVJ`` is a joint move with ``speed`` its ``VJ=`` [%], ``MOVL`` a linear move with ``V=`` [mm/s, as m/s],
  and three ``MOVC`` a circular move: INFORM defines an arc by three points, the second the via point, the third
  the end (``FPT`` on it: the next MOVC starts a new arc); the controller reaches the first on a straight line, so
  a first point away from where the previous move ends (beyond the file's 0.001 mm) is a linear move to it (with
  its speed and PL) before the arc. Speed and PL of an arc are its third point's.
* Zones: no ``PL`` or ``PL=0`` is zone 0 (the controller positions on the point); ``PL=n`` is the distance
  of level n in ``pl_mm`` (the writer's table ``yaskawa_jbi.PL_MM`` unless the caller gives the
  controller's S1CxG033..S1CxG040 values): the controller rounds by the level's distance, not by the zone
  the writer's ``'zone`` comment states (a zone between two levels was written as the lower one).
* Tool: ``///TOOL n``'s data lives on the controller: the caller's ``tool`` (4, 4) [m], else the
  ``TOOL 1 = tool x y z rx ry rz`` the writer states in its header comments, else none; both on the
  controller's flange frame (the section's flange), carried to our end frame (``read_ls.tool_frame``).

``read_ls.ControllerProgramError`` names the file, the instruction or point and what is wrong.
"""

from __future__ import annotations

import numpy as np
from lark import Tree

from ...model.robot import robot_with_tool
from ...model.vendors.axes import YASKAWA
from .fanuc_ls import MM, controller_frame, controller_pose
from .read_ls import ControllerProgramError, as_robot, job_document, parse_text, pose_waypoint, tool_frame
from .yaskawa_jbi import PL_MM

#: An arc's first MOVC point is the previous move's end when they agree within these [mm, deg] (the file's rounding).
SAME_POINT_MM = 0.001 + 1e-9
SAME_ANGLE_DEG = 0.01 + 1e-9


def read_jbi(text: str, robot, tool: np.ndarray | None = None, pl_mm=PL_MM, source: str = "<jbi>") -> dict:
    """The job document of a Yaskawa ``.jbi`` job (module docstring). ``robot``: a Robot, preset name or
    robot file; ``tool``: TOOL 1 on the controller's flange (4, 4) [m] (None: the writer's header comment, else
    none); ``pl_mm``
    the PL1..PL8 distances [mm]; ``source``: the file's name for errors."""
    robot, reference = as_robot(robot)
    tree = parse_text("yaskawa_jbi", text, source)
    points = _points(tree)
    instructions, comments = _instructions(tree)
    X_FT = tool_frame(robot, YASKAWA, tool, comments)
    tool_robot = robot if X_FT is None else robot_with_tool(robot, X_FT)
    X_B_base = controller_frame(robot, YASKAWA)[0]
    moves = _moves(instructions, points, source)
    solved = {}
    for name in {name for move in moves for name in move["points"]}:
        data = points[name]
        X = controller_pose(X_B_base, data["xyz"], data["angles"])
        solved[name] = pose_waypoint(tool_robot, X, data["rconf"], YASKAWA, name, source)
    waypoints = [dict(solved[moves[0]["points"][-1]][0])]
    for move in moves[1:]:
        waypoints.append(_waypoint(move, solved, pl_mm, source))
    return job_document(reference, X_FT, waypoints, solved[moves[0]["points"][-1]][1], None)


def _points(tree: Tree) -> dict[str, dict]:
    """Point name -> {rconf (its six fields), xyz [mm], angles [deg]} from //POS."""
    points, rconf = {}, None
    for item in next(tree.find_data("pos")).find_data("point_data"):
        node = item.children[0]
        if node.data == "rconf":
            rconf = tuple(int(t) for t in node.children[:6])
            continue
        name, *values = (str(t) for t in node.children)
        points[name] = {"rconf": rconf, "xyz": [float(v) for v in values[:3]],
                        "angles": [float(v) for v in values[3:]], "line": node.children[0].line}
    return points


def _instructions(tree: Tree) -> tuple[list[dict], list[str]]:
    """(each motion instruction as {kind, point, speed, pl (None: none), fpt, line}, the comment texts
    before the first motion)."""
    instructions, header = [], []
    for statement in tree.find_data("statement"):
        node = statement.children[0]
        if node.data == "comment":
            if not instructions:
                header.append(str(node.children[0])[1:])
            continue
        pl = next(node.find_data("pl"), None)
        instructions.append({"kind": node.data, "point": str(node.children[0]), "speed": float(node.children[1]),
                             "pl": None if pl is None else int(pl.children[0]),
                             "fpt": next(node.find_data("fpt"), None) is not None, "line": node.children[0].line})
    return instructions, header


def _moves(instructions: list[dict], points: dict, source: str) -> list[dict]:
    """The moves: {kind (joint, linear, circular), points (names; an arc's via and end), speed, pl, line}."""
    if not instructions:
        raise ControllerProgramError(source, "//INST", "no motion instruction")
    moves, k = [], 0
    while k < len(instructions):
        first = instructions[k]
        if first["point"] not in points:
            raise ControllerProgramError(source, f"line {first['line']}", f"{first['point']} is not in //POS",
                                         line=first["line"])
        if first["kind"] != "movc":
            kind = "joint" if first["kind"] == "movj" else "linear"
            moves.append({**first, "kind": kind, "points": [first["point"]]})
            k += 1
            continue
        if moves and not _same_point(points[first["point"]], points[moves[-1]["points"][-1]]):
            moves.append({**first, "kind": "linear", "points": [first["point"]]})    # P0 -> P1 on a line
        moves.append(_arc(instructions[k:k + 3], points, source))
        k += 3
    return moves


def _same_point(a: dict, b: dict) -> bool:
    """Whether two points are one within the file's 0.001 mm and 0.01 deg."""
    return (float(np.abs(np.subtract(a["xyz"], b["xyz"])).max()) <= SAME_POINT_MM
            and float(np.abs(np.subtract(a["angles"], b["angles"])).max()) <= SAME_ANGLE_DEG)


def _arc(three: list[dict], points: dict, source: str) -> dict:
    """A circular move from three MOVC instructions (the first where the previous move ends)."""
    line = f"line {three[0]['line']}"
    if len(three) < 3 or any(i["kind"] != "movc" for i in three):
        raise ControllerProgramError(source, line, "an arc is three MOVC points (start, via, end) in a row",
                                     line=three[0]["line"])
    missing = [i["point"] for i in three if i["point"] not in points]
    if missing:
        raise ControllerProgramError(source, line, f"{', '.join(missing)} not in //POS", line=three[0]["line"])
    return {**three[2], "kind": "circular", "points": [three[1]["point"], three[2]["point"]]}


def _waypoint(move: dict, solved: dict, pl_mm, source: str) -> dict:
    """The job waypoint a move goes to: its pose and branch, move kind, via, speed [% or m/s] and zone [m]."""
    waypoint = {**solved[move["points"][-1]][0], "move": move["kind"]}
    if move["kind"] == "circular":
        waypoint["via"] = {"xyz": list(solved[move["points"][0]][0]["xyz"])}
    waypoint["speed"] = move["speed"] if move["kind"] == "joint" else move["speed"] / MM
    level = move["pl"] or 0
    if level > len(pl_mm):
        raise ControllerProgramError(source, f"line {move['line']}", f"PL={level}: the table has {len(pl_mm)} levels",
                                     line=move["line"])
    if level:
        waypoint["zone"] = float(pl_mm[level - 1]) / MM
    return waypoint
