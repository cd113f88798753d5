"""``read_jbi(text, robot) -> dict``: a Yaskawa INFORM job (``.jbi``: what ``yaskawa_jbi.write_jbi`` writes, and what
pendants and other tools save) back to a job document that ``pipeline.program.job.parse_job`` accepts.

The file's structure is parsed with ``grammars/yaskawa_jbi.lark`` (NX100 "Data Transmission Function" HW0481924
section 4.1 "Job Data Format", DX100 156191-1CD section 4.1, the Motoman knowledge base's "Inform header" article):
``//NAME`` (up to 32 characters), ``//POS`` (``///NPOS``, ``///USER``, ``///TOOL``, ``///POSTYPE``, ``///PULSE``,
``///RECTAN``, ``///RCONF``, points), an optional ``//ARGINFO`` (the arguments of a called job: no motion meaning),
``//INST``'s header lines in any order and with or without ``///COMM`` (``///DATE``, ``///COMM``, ``///ATTR``,
``///FRAME``/``////FRAME``: the frame the pendant shows, not the points' frame; ``///GROUP1``, ``///LVARS``), then
one instruction per line, indented with tabs or spaces or not, CR LF or LF. ``ControllerProgramError`` names the
file, the line and the construct of what is refused.

* Groups: ``///GROUP1 RB1`` only: a base axis (BS1), a station (ST1), a second group are refused naming the line.
* Points: ``///POSTYPE ROBOT`` and ``BASE`` (the same frame without a base axis) Cartesian data ``X,Y,Z,Rx,Ry,Rz`` [mm,
  deg], R = Rz Ry Rx (DX100 manual section 4.3), in the robot frame, the robot file's yaskawa controller section's base
  frame (``fanuc_ls.controller_frame``: 330 mm up on the GP7); the ``///RCONF`` in force (its first six fields:
  Flip, Upper/Lower arm, Front/Rear, R, T, S >= 180) selects the one joint solution. ``USER`` data (``///USER n``)
  need the user frame n: the caller's ``frame`` (4, 4) [m] in the robot frame, else refused naming the line and n.
  ``PULSE`` data are encoder pulses: axis angle [deg] = pulses / the caller's ``pulses_per_degree`` (6 values, the
  controller's pulse ratios, sign included), else refused naming the point; a MOVJ to a pulse point is a joint
  waypoint, a MOVL/MOVC to one the pose of its joints with their configuration. ``TOOL``/``MTOOL`` data are refused.
  Position variables ``Pnnnnn`` are read when the file gives their value in //POS and no instruction sets them.
* Tool: ``///TOOL 0`` is the flange; ``///TOOL n`` (n > 0) is tool file n on the controller: the caller's ``tool``
  (4, 4) [m] on the controller's flange, else the ``TOOL 1 = tool x y z rx ry rz`` the writer states in its header
  comments (n = 1), else refused naming the line and n (never silently the flange).
* Moves: ``MOVJ pt VJ=v`` (joint move, speed v %), ``MOVL pt V=v`` (linear, mm/s as m/s), three ``MOVC`` (an arc:
  start, via, end; ``FPT`` on the end; a start away from where the previous move ends is a linear move to it first:
  INFORM reaches it on a line), each with ``PL=n`` (no PL, PL=0: zone 0; PL=n: level n's distance in ``pl_mm``, the
  writer's table unless the caller gives the controller's S1CxG033..S1CxG040). The first motion instruction is the
  job's first waypoint (its speed is not a job quantity). Refused naming the tag: ``ACC=``/``DEC=`` (an acceleration
  ratio the job has no field for), ``NWAIT``, ``UNTIL``, ``+MOV`` (a coordinated group), base/station points, a
  speed or point given by a variable; ``MOVS``, ``IMOV``, ``SMOV*`` and the like are refused naming the instruction.
* Actions (``pipeline.program.actions``) after a move belong to the waypoint it reaches; those before the first
  move run at the first waypoint (said in the job's description): ``DOUT OT#(n) ON/OFF`` (set output ``do<n>``),
  ``PULSE OT#(n) T=t`` (pulse; without T= the controller's default length: refused), ``TIMER T=t`` (wait),
  ``WAIT IN#(n)=ON/OFF`` (wait for input ``di<n>``, no timeout); ``WAIT IN#(n)=ON T=t`` followed by ``PAUSE IF
  IN#(n)=OFF`` (the writer's pattern: the job stops when the input did not come) is a wait with timeout t; a
  ``WAIT ... T=`` without it is refused (the job goes on after t whether or not the input came). Comments after the
  first move are comment actions, except the writer's ``'zone .. mm PLn`` lines; comments before it are the header.
  The job's ``signals`` table names each number used (``do1: {output: 1}``); ``read_program`` renames them as the
  writer's mark says.
* Loads: the writer's loads mark in the header (``settings_mark.loads_mark``) is the job's ``payload`` and ``parts``,
  and its comment lines at a grip or release (``'dh.grip=box``, ``'dh.release=box``, each followed by ``'ARM control:
  load n from here``: ``yaskawa_jbi.LOAD_CHANGE``) are grip and release actions; a part the mark does not state is
  refused naming the line. Nothing else in a job changes the load (the tool file's data are on the controller).
* Refused naming the line and the construct: ``JUMP`` and ``*LABEL`` (jumps and loops), ``IF``/``IFTHEN``/
  ``IFTHENEXP``/``ELSE``/``ENDIF``/``SWITCH`` and other branches, ``CALL``/``RET`` (another job), ``PAUSE``,
  ``TSYNC`` (a synchronisation with another task), ``SKILLSND`` (a command to another program), a wait on an output
  or a group, a value given by a variable, an instruction setting a position variable (SET, SETE, CNVRT, GETS, ...),
  and every instruction this reader does not know. Setting another variable (``SET I025 1``) is skipped, and said
  in the description: nothing read from the job uses a variable (those uses are refused).
* An endless loop around the whole job (a label first, ``JUMP`` to it without ``IF`` last) reads as one cycle, said
  in the job's description.
* A job without motion instruction (``MOVJ``/``MOVL``/``MOVC``) is refused: a job of actions alone has no pose to
  run them at.
"""

from __future__ import annotations

import re

import numpy as np
from lark import Tree

from ...model.robot import robot_with_tool
from ...model.vendors.axes import YASKAWA
from ...model.vendors.configuration import configurations
from .fanuc_ls import MM, controller_frame, controller_pose
from .read_ls import (ControllerProgramError, as_robot, comment_tool, job_document, parse_text, pose_fields,
                      pose_waypoint, tool_frame)
from .settings_mark import MarkedLoads, marked_loads
from .yaskawa_jbi import LOAD_CHANGE, PL_MM

#: An arc's first MOVC point is the previous move's end when they agree within these [mm, deg] (the file's rounding).
SAME_POINT_MM = 0.001 + 1e-9
SAME_ANGLE_DEG = 0.01 + 1e-9
#: The writer's zone comment before a move with PL (``yaskawa_jbi._instructions``).
ZONE_COMMENT = re.compile(r"zone \d+(\.\d+)?mm PL[0-8]")
NUMBER = r"\d+(?:\.\d*)?|\.\d+"
MOTION = re.compile(r"(MOVJ|MOVL|MOVC)\s+(\S+)(.*)")
POINT_REF = re.compile(r"(C|P)(\d{3,5})")
DOUT = re.compile(r"DOUT\s+OT#\((\d+)\)\s+(ON|OFF)")
PULSE = re.compile(rf"PULSE\s+OT#\((\d+)\)(?:\s+T=({NUMBER}))?")
TIMER = re.compile(rf"TIMER\s+T=({NUMBER})")
WAIT = re.compile(rf"WAIT\s+IN#\((\d+)\)\s*=\s*(ON|OFF)(?:\s+T=({NUMBER}))?")
PAUSE_IF = re.compile(r"PAUSE\s+IF\s+IN#\((\d+)\)\s*=\s*(ON|OFF)")
#: The writer's comment lines at a grip or release (module docstring, "Loads").
LOAD_ACTION = re.compile(r"dh\.(grip|release)=([A-Za-z][A-Za-z0-9_]{0,31})")
LOAD_LINE = re.compile("'\\s*" + re.escape(LOAD_CHANGE).replace(re.escape("{n}"), r"\d+"))
#: Instructions that assign a variable: the first argument is the variable set.
ASSIGNMENTS = ("SET", "SETE", "GETE", "GETS", "GETARG", "CNVRT", "ADD", "SUB", "MUL", "DIV", "INC", "DEC", "AND",
               "OR", "NOT", "XOR", "CLEAR", "DIN", "MFRAME", "GETPOS", "SETREG", "GETREG")
POSITION_VARIABLE = re.compile(r"L?(P|BP|EX|PX)X?\d|L?P\[|L?(P|BP|EX)X?\[")
BRANCH = "a branch on a condition known only when the job runs"
#: Why an instruction (its first word) is refused.
REFUSED = {
    "JUMP": "a jump has no static meaning (a loop or a branch taken when the job runs)",
    "IF": BRANCH, "IFTHEN": BRANCH, "IFTHENEXP": BRANCH,
    "ELSEIF": "a branch", "ELSEIFEXP": "a branch", "ELSE": "a branch", "ENDIF": "a branch",
    "SWITCH": "a branch", "CASE": "a branch", "DEFAULT": "a branch", "ENDSWITCH": "a branch",
    "WHILE": "a loop", "WHILEEXP": "a loop", "ENDWHILE": "a loop", "FOR": "a loop", "NEXT": "a loop",
    "CALL": "calls another job, whose motion and actions are not in this file",
    "RET": "returns to a calling job (a branch in a called job)",
    "PAUSE": "the job stops until an operator restarts it", "HOLD": "the job stops until an operator restarts it",
    "TSYNC": "synchronises with another task: when it goes on is known only when the cell runs",
    "SKILLSND": "sends a command to another program (a skill): its effect is not in this file",
}


def read_jbi(text: str, robot, tool: np.ndarray | None = None, pl_mm=PL_MM, source: str = "<jbi>",
             frame: np.ndarray | None = None, pulses_per_degree=None) -> dict:
    """The job document of a Yaskawa ``.jbi`` job (module docstring). ``robot``: a Robot, preset name or robot file;
    ``tool``: the tool file the job selects (``///TOOL n``, n > 0) on the controller's flange (4, 4) [m] (None: the
    writer's header comment, else refused); ``pl_mm`` the PL1..PL8 distances [mm]; ``source``: the file's name for
    errors; ``frame``: the user frame of ``///USER n`` in the robot frame (4, 4) [m]; ``pulses_per_degree``: per axis,
    the pulses of one degree (pulse data)."""
    robot, reference = as_robot(robot)
    tree = parse_text("yaskawa_jbi", text, source)
    _check_groups(tree, source)
    points = _points(tree)
    statements = [(token.line, str(token).strip()) for token in
                  (node.children[0] for node in tree.find_data("instruction"))]
    items, header_comments, notes = _items(statements, source)
    loads = marked_loads(text)
    _check_parts(items, loads, source)
    instructions = [item for item in items if item["kind"] == "motion"]
    if not instructions:
        raise ControllerProgramError(source, "//INST", "no motion instruction (MOVJ, MOVL, MOVC): a job of actions "
                                     "alone has no pose to run them at", line=statements[0][0])
    used = [_point(points, i, source) for i in instructions]
    X_FT = _tool(robot, used, tool, header_comments, source)
    tool_robot = robot if X_FT is None else robot_with_tool(robot, X_FT)
    context = (robot, tool_robot, controller_frame(robot, YASKAWA)[0], frame, pulses_per_degree, source)
    solved = {name: _solve(points[name], context) for name in dict.fromkeys(p["name"] for p in used)}
    moves = _moves(instructions, points, source)
    actions = _actions(items, moves, source)
    first = moves[0]
    waypoints = [_first_waypoint(solved[first["points"][-1]])]
    waypoints += [_waypoint(move, solved, pl_mm, source) for move in moves[1:]]
    signals = {}
    for k, listed in actions.items():
        if listed:
            waypoints[k]["do"] = [entry for entry, _ in listed]
            signals.update(signal for _, signal in listed if signal)
    document = job_document(reference, X_FT, waypoints, solved[first["points"][-1]]["q"], None)
    if loads is not None:
        document.update(loads.document(source))
    if signals:
        document["signals"] = dict(sorted(signals.items()))
    if notes:
        document["description"] = "Read from a Yaskawa job: " + "; ".join(notes) + "."
    return document


def _check_groups(tree: Tree, source: str) -> None:
    """ControllerProgramError unless the job moves ///GROUP1 RB1 alone."""
    for node in tree.find_data("group"):
        names = [str(t) for t in node.children[1:]]
        if str(node.children[0]) != "///GROUP1" or names != ["RB1"]:
            raise ControllerProgramError(source, f"{node.children[0]} {','.join(names)}", "only a robot alone "
                                         "(///GROUP1 RB1) is read; a base axis, station or second group moves axes the "
                                         "job has no model of", line=node.meta.line)


def _points(tree: Tree) -> dict[str, dict]:
    """Point name (``C00001``, ``P00025``, ``BC00000``, ...) -> {values, postype, rconf (six fields) or None, user,
    tool (number, line), line}, with the ///POSTYPE, ///RCONF, ///USER and ///TOOL in force where it is given."""
    points, state = {}, {"postype": None, "rconf": None, "user": None, "tool": (0, None)}
    for node in next(tree.find_data("pos")).children:
        if not isinstance(node, Tree):
            continue
        if node.data == "postype":
            state["postype"] = str(node.children[0])
        elif node.data == "rconf":
            state["rconf"] = tuple(int(t) for t in node.children[:6])
        elif node.data == "user":
            state["user"] = (int(node.children[0]), node.meta.line)
        elif node.data == "tool":
            state["tool"] = (int(node.children[0]), node.meta.line)
        elif node.data == "point":
            name, *values = (str(t) for t in node.children)
            points[_canonical(name)] = {"name": _canonical(name), "values": [float(v) for v in values],
                                        "line": node.meta.line, **state}
    return points


def _canonical(name: str) -> str:
    """A point's name with five digits (``P025`` in an instruction is ``P00025`` in //POS)."""
    match = re.fullmatch(r"([A-Z]+)(\d+)", name)
    return f"{match.group(1)}{int(match.group(2)):05d}" if match else name


def _items(statements: list[tuple[int, str]], source: str) -> tuple[list[dict], list[str], list[str]]:
    """(the instructions between NOP and END as items {kind: motion | action | skip, line, ...}, the comments before
    the first move, notes for the description)."""
    if not statements or statements[0][1] != "NOP":
        line = statements[0][0] if statements else None
        raise ControllerProgramError(source, "//INST", "the first instruction must be NOP", line=line)
    if statements[-1][1] != "END":
        raise ControllerProgramError(source, statements[-1][1], "the last instruction must be END",
                                     line=statements[-1][0])
    items, header, skipped, k = [], [], 0, 1
    body, notes = _one_cycle(statements[1:-1])
    while k <= len(body):
        line, text = body[k - 1]
        item, consumed = _item(line, text, body[k:], source)
        k += consumed
        if item["kind"] == "comment" and not any(i["kind"] == "motion" for i in items):
            header.append(item["comment"])
            continue
        if item["kind"] == "skip":
            skipped += item.get("assignment", 0)
            continue
        items.append(item)
    notes += [f"{skipped} assignment(s) of variables skipped (nothing read uses a variable)"] if skipped else []
    first_move = next((n for n, i in enumerate(items) if i["kind"] == "motion"), len(items))
    if any(i["kind"] == "action" and i["action"] for i in items[:first_move]):
        notes.append("the actions before the first move run at the first waypoint")
    return items, header, notes


def _one_cycle(body: list[tuple[int, str]]) -> tuple[list[tuple[int, str]], list[str]]:
    """(the instructions, notes): an endless loop around the whole job (``*L`` first, ``JUMP *L`` without IF last)
    is one cycle: both lines dropped and said; any other jump or label is refused where it stands."""
    if len(body) >= 2 and re.fullmatch(r"\*\S+", body[0][1]) and body[-1][1] == f"JUMP {body[0][1]}":
        label = body[0][1]
        return body[1:-1], [f"the endless loop around the whole job ({label} ... JUMP {label}) read as one cycle"]
    return body, []


def _item(line: int, text: str, following: list[tuple[int, str]], source: str) -> tuple[dict, int]:
    """(one instruction as an item, how many lines it takes: a WAIT with its PAUSE IF check takes two)."""
    if text.startswith("'"):
        comment = text[1:].strip()
        if ZONE_COMMENT.fullmatch(comment):
            return {"kind": "skip"}, 1
        if load := LOAD_ACTION.fullmatch(comment):
            said = 2 if following and LOAD_LINE.fullmatch(following[0][1]) else 1
            return {**_action_item(line, {load.group(1): load.group(2)}, None), "text": text}, said
        return {"kind": "comment", "comment": comment, "text": text, "line": line,
                "action": ({"comment": comment}, None)}, 1
    if text == "NOP":
        return {"kind": "skip"}, 1
    word = text.split()[0]
    if word.startswith("*"):
        _refuse(source, line, text, "a label: the target of a jump")
    if word in ("MOVJ", "MOVL", "MOVC"):
        return _motion(line, text, source), 1
    if word in ("DOUT", "PULSE", "TIMER", "WAIT"):
        item, consumed = _action(line, text, following, source)
        return {**item, "text": text}, consumed
    if word in ASSIGNMENTS:
        target = text.split()[1] if len(text.split()) > 1 else ""
        if POSITION_VARIABLE.match(target) or target.startswith("$"):
            _refuse(source, line, text, f"sets {target}, a position or system variable a move may read")
        return {"kind": "skip", "assignment": 1, "line": line, "variable": target}, 1
    if word in REFUSED:
        _refuse(source, line, text, REFUSED[word])
    _refuse(source, line, text, "an instruction this reader does not read (its effect on the motion is not known)")


def _check_parts(items: list[dict], loads: MarkedLoads | None, source: str) -> None:
    """ControllerProgramError naming the line of a grip or release whose part the loads mark does not state."""
    for item in items:
        entry = item["action"][0] if item["kind"] == "action" else {}
        part = entry.get("grip", entry.get("release"))
        if part is not None and (loads is None or part not in loads.parts):
            _refuse(source, item["line"], item["text"], f"part {part}: its load is not in the header's loads mark "
                    "(dh.part.N=name with its dh.part.N.m ...): what the robot carries from here is not known")


def _refuse(source: str, line: int, text: str, why: str):
    raise ControllerProgramError(source, text, why, line=line)


def _motion(line: int, text: str, source: str) -> dict:
    """A MOVJ / MOVL / MOVC line: {kind motion, move (movj, movl, movc), point, speed, pl, fpt, line}."""
    match = MOTION.fullmatch(text)
    word, point, rest = match.group(1), match.group(2), match.group(3).split()
    if not POINT_REF.fullmatch(point):
        _refuse(source, line, text, f"{point}: a target given by a variable, or not a C or P point")
    speed_tag = "VJ" if word == "MOVJ" else "V"
    item = {"kind": "motion", "move": word.lower(), "point": _canonical(point), "speed": None, "pl": None,
            "fpt": False, "line": line}
    for tag in rest:
        key, _, value = tag.partition("=")
        if key == speed_tag and re.fullmatch(NUMBER, value):
            item["speed"] = float(value)
        elif key == "PL" and re.fullmatch(r"\d+", value):
            item["pl"] = int(value)
        elif tag == "FPT" and word == "MOVC":
            item["fpt"] = True
        elif key in ("ACC", "DEC"):
            _refuse(source, line, text, f"{tag}: a per-move acceleration ratio; the job has no field for it (the "
                    "motion would be timed at another acceleration)")
        else:
            _refuse(source, line, text, f"{tag}: not read (a coordinated group, a base or station point, a speed, "
                    f"position level or condition given otherwise than {speed_tag}=number and PL=n)")
    if item["speed"] is None:
        _refuse(source, line, text, f"no {speed_tag}= speed")
    return item


def _action(line: int, text: str, following: list[tuple[int, str]], source: str) -> tuple[dict, int]:
    """A DOUT / PULSE / TIMER / WAIT line (with the PAUSE IF after a WAIT with T=) as an action item."""
    if match := DOUT.fullmatch(text):
        n = int(match.group(1))
        return _action_item(line, {"set": f"do{n}", "value": match.group(2).lower()}, (f"do{n}", {"output": n})), 1
    if match := PULSE.fullmatch(text):
        if match.group(2) is None:
            _refuse(source, line, text, "a pulse without T= lasts the controller's default time, not in the file")
        n = int(match.group(1))
        return _action_item(line, {"pulse": f"do{n}", "time": float(match.group(2))}, (f"do{n}", {"output": n})), 1
    if match := TIMER.fullmatch(text):
        return _action_item(line, {"wait": float(match.group(1))}, None), 1
    if match := WAIT.fullmatch(text):
        n, value = int(match.group(1)), match.group(2)
        entry = {"wait_input": f"di{n}", "value": value.lower()}
        if match.group(3) is None:
            return _action_item(line, entry, (f"di{n}", {"input": n})), 1
        check = PAUSE_IF.fullmatch(following[0][1]) if following else None
        if check is None or int(check.group(1)) != n or check.group(2) == value:
            _refuse(source, line, text, "after T= the job goes on whether or not the input came: no static meaning "
                    f"(followed by PAUSE IF IN#({n})={'OFF' if value == 'ON' else 'ON'} it is a wait with a timeout)")
        entry["timeout"] = float(match.group(3))
        return _action_item(line, entry, (f"di{n}", {"input": n})), 2
    _refuse(source, line, text, "not read: an output group, a wait on an output or a variable, or a time given by a "
            "variable (read: DOUT OT#(n) ON/OFF, PULSE OT#(n) T=t, TIMER T=t, WAIT IN#(n)=ON/OFF [T=t])")


def _action_item(line: int, entry: dict, signal) -> dict:
    return {"kind": "action", "line": line, "action": (entry, signal)}


def _point(points: dict, instruction: dict, source: str) -> dict:
    """The //POS data of a motion instruction's point, or ControllerProgramError naming the line."""
    name = instruction["point"]
    if name not in points:
        where = "//POS" if name.startswith("C") else "//POS (a position variable's value lives on the controller)"
        raise ControllerProgramError(source, name, f"not in {where}", line=instruction["line"])
    return points[name]


def _tool(robot, used: list[dict], tool, header_comments: list[str], source: str):
    """X_FT of the one ///TOOL the moves' points use (module docstring), or ControllerProgramError."""
    numbers = {p["tool"][0]: p["tool"][1] for p in used}
    if len(numbers) > 1:
        raise ControllerProgramError(source, "///TOOL", f"the points use tools {sorted(numbers)}: a job has one tool")
    (number, line), = numbers.items()
    if number == 0:
        return tool_frame(robot, YASKAWA, None, [])
    if tool is None and (number != 1 or comment_tool(header_comments) is None):
        raise ControllerProgramError(source, f"///TOOL {number}", f"tool file {number}'s data is on the controller, "
                                     "not in the file: give it (read_jbi's tool), never taken as the flange", line=line)
    return tool_frame(robot, YASKAWA, tool, header_comments)


def _solve(point: dict, context) -> dict:
    """{fields (a pose waypoint's), joints [deg] (pulse data), q (6,) [rad]} of a point (module docstring)."""
    robot, tool_robot, X_B_base, frame, pulses_per_degree, source = context
    where = point["name"]
    postype = point["postype"]
    if postype == "PULSE":
        if pulses_per_degree is None:
            raise ControllerProgramError(source, where, "pulse data need the robot's pulses per degree of each axis "
                                         "(read_jbi's pulses_per_degree)", line=point["line"])
        joints = np.asarray(point["values"][:6], dtype=float) / np.asarray(pulses_per_degree, dtype=float)
        q = np.radians(joints)
        config = tuple(int(v) for v in configurations(robot, q, YASKAWA))
        return {"fields": pose_fields(tool_robot, tool_robot.fk(q), q, (YASKAWA, config)),
                "joints": [float(v) for v in joints], "q": q, "raw": point}
    if postype not in ("ROBOT", "BASE", "USER"):
        raise ControllerProgramError(source, where, f"///POSTYPE {postype} data are not read (ROBOT, BASE, USER "
                                     "and PULSE are)", line=point["line"])
    X = controller_pose(np.eye(4), point["values"][:3], point["values"][3:6])
    if postype == "USER":
        number, user_line = point["user"] or (None, point["line"])
        if frame is None:
            raise ControllerProgramError(source, f"///USER {number}", f"user frame {number}'s data is on the "
                                         "controller, not in the file: give it (read_jbi's frame)", line=user_line)
        X = np.asarray(frame, dtype=float) @ X
    fields, q = pose_waypoint(tool_robot, X_B_base @ X, point["rconf"], YASKAWA, point["name"], source)
    return {"fields": fields, "joints": None, "q": q, "raw": point}


def _moves(instructions: list[dict], points: dict, source: str) -> list[dict]:
    """The moves: {kind (joint, linear, circular), points (names; an arc's via and end), speed, pl, line, items
    (the indices of the instructions it covers)}."""
    moves, k = [], 0
    while k < len(instructions):
        first = instructions[k]
        if first["move"] != "movc":
            kind = "joint" if first["move"] == "movj" else "linear"
            moves.append({**first, "kind": kind, "points": [first["point"]], "last": first["line"]})
            k += 1
            continue
        if moves and not _same_point(points[first["point"]], points[moves[-1]["points"][-1]]):
            moves.append({**first, "kind": "linear", "points": [first["point"]], "last": first["line"]})  # P0 -> P1
        moves.append(_arc(instructions[k:k + 3], source))
        k += 3
    return moves


def _same_point(a: dict, b: dict) -> bool:
    """Whether two points are one within the file's rounding (0.001 mm and 0.01 deg; pulse data: equal)."""
    if a["postype"] != b["postype"] or a["user"] != b["user"]:
        return False
    if a["postype"] == "PULSE":
        return a["values"] == b["values"]
    return (float(np.abs(np.subtract(a["values"][:3], b["values"][:3])).max()) <= SAME_POINT_MM
            and float(np.abs(np.subtract(a["values"][3:6], b["values"][3:6])).max()) <= SAME_ANGLE_DEG)


def _arc(three: list[dict], source: str) -> dict:
    """A circular move from three MOVC instructions (the first where the previous move ends)."""
    if len(three) < 3 or any(i["move"] != "movc" for i in three):
        raise ControllerProgramError(source, f"MOVC {three[0]['point']}", "an arc is three MOVC points (start, via, "
                                     "end) in a row", line=three[0]["line"])
    return {**three[2], "kind": "circular", "points": [three[1]["point"], three[2]["point"]],
            "first": three[0]["line"], "last": three[2]["line"]}


def _actions(items: list[dict], moves: list[dict], source: str) -> dict[int, list]:
    """Waypoint index -> its actions [(document entry, (signal name, entry) or None)]: those after a move's last
    instruction belong to the waypoint it reaches, those before the first move to the first waypoint; an action
    inside an arc (between its MOVC lines) is refused."""
    ends = [move["last"] for move in moves]
    starts = [move.get("first", move["last"]) for move in moves]
    actions = {k: [] for k in range(len(moves))}
    for item in items:
        if item["kind"] == "motion":
            continue
        k = max((n for n, end in enumerate(ends) if end < item["line"]), default=0)
        if k + 1 < len(moves) and starts[k + 1] < item["line"]:
            _refuse(source, item["line"], item["text"], "an action inside an arc (between its MOVC points) has no "
                    "waypoint")
        actions[k].append(item["action"])
    return actions


def _first_waypoint(point: dict) -> dict:
    """The first waypoint: the joints of pulse data, else the pose."""
    return {"joints": point["joints"]} if point["joints"] is not None else dict(point["fields"])


def _waypoint(move: dict, solved: dict, pl_mm, source: str) -> dict:
    """The job waypoint a move goes to: its pose and branch (a joint move to pulse data: its joints), move kind,
    via, speed [% or m/s] and zone [m]."""
    end = solved[move["points"][-1]]
    if move["kind"] == "joint" and end["joints"] is not None:
        waypoint = {"joints": end["joints"]}
    else:
        waypoint = {**end["fields"], "move": move["kind"]}
    if move["kind"] == "circular":
        waypoint["via"] = {"xyz": list(solved[move["points"][0]]["fields"]["xyz"])}
    waypoint["speed"] = move["speed"] if move["kind"] == "joint" else move["speed"] / MM
    level = move["pl"] or 0
    if level > len(pl_mm):
        raise ControllerProgramError(source, f"PL={level}", f"the table has {len(pl_mm)} levels", line=move["line"])
    if level:
        waypoint["zone"] = float(pl_mm[level - 1]) / MM
    return waypoint
