"""``read_rapid(text, robot) -> dict``: an ABB RAPID module (``.mod``) of the subset ``write_rapid`` writes, and what
RobotStudio and the pendant write with static motion, read back into a job document (a mapping
``pipeline.program.job.parse_job`` accepts).

The module is parsed with ``grammars/rapid.lark`` (package data; the RAPID kernel manual's lexical rules: RAPID is
not case-sensitive, ``!`` comments, free spacing, tabs and line breaks, CR LF, no newline needed at the end;
identifiers compared without case), so a program a pendant or RobotStudio wrote in that subset reads the same. What
is read, and the RAPID facts it follows (ABB, "Technical reference manual - RAPID Instructions, Functions and Data
types", the entries named; "Technical reference manual - RAPID kernel" for the statements):

* A file header before MODULE (``%%% VERSION:1 LANGUAGE:ENGLISH %%%``, ``FILE_HEADER``: ABB's RobotWare system
  modules, RobotWare Machining FC and RoboDK write it) is nothing; a file starting ``%%%`` otherwise is refused.
* The procedure ``main`` (or the module's only procedure). A call of another parameterless procedure of the module
  (``Path_10;``) is that procedure's body in its place (RobotStudio's ``main`` calling ``Path_10``); a ``FOR i FROM
  a TO b [STEP s] DO ... ENDFOR`` over numbers is its body that many times (refused when the body uses ``i``); a
  ``WHILE TRUE DO ... ENDWHILE`` that ends ``main`` (the endless production loop) reads as one cycle, which the
  job's ``description`` says; a ``RETURN`` that ends a procedure, and a ``Stop`` or ``EXIT`` that ends the program,
  are nothing (elsewhere they are refused). Data declared in a procedure is read as
  the module's; a ``RECORD`` (a data type) declares nothing read.
* Instructions: ``ConfJ``/``ConfL`` ``\\On`` (the default) or ``\\Off`` (below),
  ``MoveAbsJ``, ``MoveJ``, ``MoveL``, ``MoveC`` (\\NoEOffs and \\WObj read, \\ID and the like ignored), and the
  actions below. Each move is one waypoint, the first move's target the job's first waypoint (no move into it;
  ``write_rapid``'s approach ``MoveAbsJ j0``); a move to where the robot already is (the same joint values, as when
  one RobotStudio path ends where the next begins, or a MoveL to the TCP pose the move before reached,
  ``SAME_POSE_M``) adds no waypoint: the one before stops if either move does.
  Targets are declared data or inline aggregates.
* Actions (``pipeline.program.actions``), each on the waypoint of the move before it (before the first move: on
  waypoint 0, where the job starts): ``SetDO sig, 1|0`` (\\Sync read), ``Set sig`` / ``Reset sig`` -> set on/off;
  ``PulseDO [\\PLength:=t,] sig`` -> pulse of t [s] (0.2 s without \\PLength, the manual's default); ``WaitTime
  [\\InPos,] t`` -> wait t [s] (t = 0: nothing but the exact stop); ``WaitDI sig, 1|0 [\\MaxTime:=t]`` -> wait for the
  input, timeout t [s] (without \\TimeFlag the controller stops the program with ERR_WAIT_MAXTIME, the job's
  timeout; with \\TimeFlag the program goes on and branches: refused); a comment line ``! text`` in a procedure ->
  a comment (one of at most ``MAX_COMMENT_CHARS``, split when longer; a comment with quotes or other characters a job
  comment cannot hold is left out). A waypoint with a wait is an exact stop (its zone is dropped: the robot stands
  still to wait). Signals are RAPID names (configured on the controller): ``signals: {name: {output|input: N}}`` with
  N from the writer's mark (``settings_mark.signals_mark``, ``dh.signal.name=out1``) when it names the signal, else
  null. The first spelling of a name is kept (RAPID names ignore case).
* ``jointtarget`` [robax, extax] -> a joint waypoint: robax [deg] through the inverse of the ABB axis map of
  ``pipeline.model.vendors.axes`` (q = (angle - offset) x direction).
* ``robtarget`` [trans, rot, robconf, extax] -> a pose waypoint: trans [mm] -> m, rot the unit quaternion
  [q1 (scalar), q2, q3, q4] (normalised), in the work object's frame mapped to the robot's base frame; robconf
  (confdata [cf1, cf4, cf6, cfx]) selects the one closed-form solution it names
  (``pipeline.model.vendors.selection``, the robot with the module's tool), whose branch label
  (``pipeline.model.ik.branches.configuration_labels``) is written as the waypoint's ``config``. extax is ignored.
  With the configuration not monitored (ABB, "Technical reference manual - RAPID Instructions, Functions and Data
  types", ConfL and ConfJ: with \\Off the robot moves to the programmed position and orientation with the closest
  possible axis configuration, the written confdata not being kept) after the first move: a ``MoveL``/``MoveC``
  after ``ConfL \\Off`` reaches the solution its path leads to from the joint values before (followed along the
  TCP's path, ``_Reader.followed``; refused where the path passes a singularity so closely that which wrist follows
  has no static meaning), a ``MoveJ`` after ``ConfJ \\Off`` the solution nearest the joint values before (refused
  when two are about as near); the waypoint's ``controller_config`` is then that solution's confdata. The first
  move's confdata names the job's start either way.
* Aggregates may hold declared data by name (``[[300,-200,610],[0.5,0.5,0.5,0.5],conf,extj]`` with ``VAR confdata
  conf := [0,0,0,0]``, as the Robots plugin writes): the names are replaced by their values (an assignment, which
  could change them, is refused); a name without a declared value is refused.
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
  A tool the module does not declare (RobotStudio keeps tools in the task's ``CalibData`` module) is an error naming
  its line and name unless the caller passes its tframe: ``tool`` (4, 4) [m] on the controller's tool0.
  tload (loaddata [mass kg, cog [x,y,z] mm in tool0, aom the quaternion of the principal axes of the inertia at
  the cog, ix, iy, iz the principal moments kg m^2]: RAPID Instructions manual, "loaddata", "tooldata") -> the job's
  ``payload`` in the flange frame (inertia = aom diag(ix, iy, iz) aom^T); none for a tload of mass 0 or less, or
  for exactly ``write_rapid``'s PLACEHOLDER_LOAD (1 kg at tool0's origin, no inertia: the job gave no payload; a
  real tool's centre of gravity is not exactly at the flange).
* ``GripLoad <loaddata>`` ("GripLoad": the payload the tool holds, cog and aom in the TOOL frame) -> the ``grip``
  of the part of that name (the loaddata's name as first written; its data in the flange frame in the job's
  ``parts``), on the waypoint of the move before it, after the ``release`` of the part held before (GripLoad
  replaces the payload); ``GripLoad load0`` -> the ``release`` of the part held. A loaddata the module does not
  declare with a value (a task's other module, the controller's) is an error naming the line and the name.
  ``wobjdata`` [robhold, ufprog, ufmec, uframe, oframe]: targets are in uframe x oframe, in the controller's world
  frame; ``base_in_world`` (4, 4) [m] is our base frame in that world (default: the world is the section's base
  frame, as with ``wobj0``; ``write_rapid``'s ``wobj_base`` has uframe = the controller's base frame in the cell,
  so pass our base's pose in the cell).

What has no static meaning is a ``RapidReadError`` naming the file (``source``), the line and the construct, found
before parsing so that the first one in the file is named: ``IF``, ``TEST``, ``GOTO`` and labels, ``WHILE`` on a
condition, ``FOR`` over bounds that are not numbers, an assignment, ``WaitUntil``, ``RETURN`` before the end of a
procedure, ``TRAP`` routines and ``CONNECT`` (interrupts), ``FUNC``, procedures with parameters, error
handlers (``ERROR``, ``BACKWARD``, ``UNDO``); after parsing, before any target is solved: a ``WHILE TRUE`` that is not
the end of ``main``, a call of a routine the module does not hold, and the known instructions that act at run time
(``REFUSED_INSTRUCTIONS``: interrupts, path control such as ``StopMove``/``ClearPath``, sockets, multi-move
synchronisation, externally guided motion, ``Stop``, pendant I/O); then targets whose confdata names no solution.

The document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``waypoints`` (with
``do`` lists), ``signals``, and ``description`` for a loop read as one cycle.
"""

from __future__ import annotations

import json
import math
import re
import textwrap
from dataclasses import dataclass, field

import lark
import numpy as np

from ...errors import ConfigurationNotFoundError, FileFormatError
from ...files.branch_names import label_parts
from ...files.poses import pose_to_quaternion_position, quaternion_position_to_pose
from ...model.ik.branches import configuration_labels
from ...model.robot import Robot, robot_with_tool
from ...model.vendors.axes import ABB, joint_values
from ...model.vendors.configuration import configurations, format_configuration
from ...model.vendors.controller import controller_frames
from ...model.vendors.selection import pose_solutions, select_solution
from ...program.actions import COMMENT, GRIP, INPUT, MAX_COMMENT_CHARS, OUTPUT, PULSE, RELEASE, SET, WAIT, WAIT_INPUT
from ...program.payload import Payload, expressed_in
from ...program.tool_path import ToolMove, ToolPath
from .rapid import NO_LOAD, PLACEHOLDER_LOAD
from .read_ls import as_robot, parse_subset
from .settings_mark import SIGNAL_MARK

MOVES = ("moveabsj", "movej", "movel", "movec")
CONFIG_INSTRUCTIONS = ("confj", "confl", "pathacclim")
ACTION_INSTRUCTIONS = ("setdo", "set", "reset", "pulsedo", "waittime", "waitdi")
#: Instructions that change the load the tool holds (module docstring, "GripLoad").
LOAD_INSTRUCTIONS = ("gripload",)
#: Instructions that end the program: read as nothing where they are its last step.
ENDING_INSTRUCTIONS = ("stop", "exit")
#: Predefined data (RAPID Instructions manual, "speeddata", "zonedata"): vN is N mm/s, zN is N mm, z0 and fine 0.
PREDEFINED_SPEEDS = frozenset((5, 10, 20, 30, 40, 50, 60, 80, 100, 150, 200, 300, 400, 500, 600, 800, 1000, 1500,
                               2000, 2500, 3000, 4000, 5000, 6000, 7000))
PREDEFINED_ZONES = frozenset((0, 1, 5, 10, 15, 20, 30, 40, 50, 60, 80, 100, 150, 200))
#: PulseDO's pulse without \PLength [s] (RAPID Instructions manual, PulseDO: "a 0.2 s pulse").
DEFAULT_PULSE_S = 0.2
#: A move this close to where the robot is goes nowhere: joint values [rad]; a MoveL's TCP [m], [rad] (below the
#: 0.001 mm and 1e-6 quaternion rounding of written modules).
SAME_JOINTS_RAD, SAME_POSE_M, SAME_POSE_RAD = 1e-9, 1e-7, 1e-7
#: A linear move with the configuration unmonitored (ConfL \Off) is followed in steps of at most FOLLOW_STEP_M [m]
#: of path, a step whose joints jump more than FOLLOW_JUMP_RAD [rad] halved down to FOLLOW_MIN_STEP_M [m] (then
#: refused: a singularity). A joint move's nearest solution (ConfJ \Off) is refused when another lies within
#: NEAREST_MARGIN times its joint distance.
FOLLOW_STEP_M, FOLLOW_JUMP_RAD, FOLLOW_MIN_STEP_M, NEAREST_MARGIN = 1e-3, 0.05, 1e-6, 3.0
#: A FOR loop is flattened up to this many turns (a larger count is refused, not unrolled).
MAX_FOR_TURNS = 1000
#: The source named in errors when the caller names none (the reader gets text, not a file).
SOURCE = "<rapid>"
#: Instructions that act at run time, by lower-case name or name prefix (``*``): why they are refused.
REFUSED_INSTRUCTIONS = {
    ("isignal*", "idelete", "ienable", "idisable", "isleep", "iwatch", "itimer", "ipers", "ierror"):
        "an interrupt instruction: interrupts run TRAP routines on events, which has no static meaning",
    ("stopmove", "startmove", "startmoveretry", "stopmovereset", "clearpath", "storepath", "restopath"):
        "path control: it stops, restarts or clears the motion at run time, which has no static meaning",
    ("socket*",): "socket communication: driver code, whose motion comes from outside the file",
    ("egm*",): "externally guided motion: driver code, whose motion comes from outside the file",
    ("syncmoveon", "syncmoveoff", "waitsynctask", "syncmoveundo"):
        "multi-move synchronisation with other tasks, which a job of one robot has no word for",
    ("stop", "exit", "exitcycle", "break", "systemstopaction"): "it stops the program where it stands",
    ("tpwrite", "tperase", "tpreadfk", "tpreadnum", "tpshow", "errwrite"):
        "FlexPendant I/O, which a job has no word for",
    ("setao", "setgo", "waitai", "waitao", "waitgi", "waitgo"):
        "an analog or group signal, which a job's actions (digital signals on or off) have no word for",
}
#: Statements refused before parsing (first word of a line in lower case, outside comments and strings): why.
REFUSED_KEYWORDS = {
    "if": "a branch on a condition has no static meaning",
    "test": "a branch on a value has no static meaning",
    "goto": "a jump has no static meaning",
    "trap": "an interrupt routine runs on events, not in the program's order",
    "connect": "interrupts run TRAP routines on events, not in the program's order",
    "func": "a function computes values at run time",
    "alias": "a data type alias is not read",
    "error": "an error handler runs on errors, not in the program's order",
    "backward": "a backward handler runs when stepping backwards, not in the program's order",
    "undo": "an undo handler runs on aborts, not in the program's order",
    "raise": "an error raised at run time has no static meaning",
    "waituntil": "it waits on an expression, which is not read (WaitDI signal, value is)",
}
#: The file header before MODULE: ``%%%``, ``VERSION:n``, ``LANGUAGE:name``, ``%%%`` (its fields on lines of their own
#: or not: spaces and line breaks are free). ABB's own RobotWare system modules begin so (CAL_AX, MOTCOM, CALPEND as a
#: RobotStudio virtual controller holds them, e.g. in rparak/ABB-RobotStudio-Tutorial-Simple
#: STEP_4/Solution_1_Pick_obj_1.rspag, INTERNAL/RAPID/PRG1), as do RobotWare Machining FC's exported modules
#: ("generated by RobotWare Machining FC V3.000", rparak/VInRoS_ABB_RS BACKUP/120-101618_BACKUP_2024-06-25/HOME/
#: MachiningFC) and RoboDK's ABB post processor (RoboDK/Industrial-Robots-VSCode examples/Program.mod); a RAPID
#: summary names it the file header, giving the file format's version and the language of the texts
#: (https://student-notes.net/rapid-programming-language-essentials, "Header File"). It says nothing the program
#: does: read as nothing.
FILE_HEADER = re.compile(r"\A\s*%%%\s*VERSION\s*:\s*\d+\s*LANGUAGE\s*:\s*[A-Za-z][A-Za-z_-]*\s*%%%[ \t]*(?=\r?\n|\Z)")
#: A line's first statement word; a label (``name:``); an assignment (``x :=``, ``p.trans.z :=``, ``a{i} :=``).
_FIRST_WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_LABEL = re.compile(r"[A-Za-z][A-Za-z0-9_]*\s*:(?!=)")
_ASSIGNMENT = re.compile(r"[A-Za-z][A-Za-z0-9_]*(\{[^}]*\})?(\.[A-Za-z][A-Za-z0-9_]*)*\s*:=")
_SCOPE = re.compile(r"^(LOCAL|TASK)\s+", re.IGNORECASE)
_PROC_HEADER = re.compile(r"PROC\s+[A-Za-z][A-Za-z0-9_]*\s*\(\s*([^)\s][^)]*)?\)", re.IGNORECASE)
_WHILE_TRUE = re.compile(r"WHILE\s+TRUE\s+DO\b", re.IGNORECASE)
_FOR_CONSTANT = re.compile(r"FOR\s+[A-Za-z][A-Za-z0-9_]*\s+FROM\s+[-+]?[\d.]+(E[-+]?\d+)?\s+TO\s+[-+]?[\d.]+(E[-+]?\d+)?"
                           r"(\s+STEP\s+[-+]?[\d.]+(E[-+]?\d+)?)?\s+DO\b", re.IGNORECASE)
#: A comment (outside strings): ``!`` to the end of the line.
_STRING_OR_COMMENT = re.compile(r'"[^"\n]*"|!([^\n]*)')


class RapidReadError(FileFormatError):
    """A RAPID module outside the subset read here, or with data that does not fit (field: the construct, the
    instruction or the data name)."""


class _Name(str):
    """An identifier in a RAPID value (RAPID compares identifiers without case)."""


@dataclass
class _Data:
    """A module's declarations by lower-case name: (data type, value as nested lists of floats, bools, strings)."""

    source: str
    values: dict = field(default_factory=dict)

    def get(self, value, datatype: str, where: str, line: int | None = None):
        """The value of ``value`` (a _Name of declared data or an inline aggregate) as ``datatype``."""
        if isinstance(value, _Name):
            known = self.values.get(value.lower())
            if known is None or known[0] != datatype or known[1] is None:
                raise RapidReadError(self.source, where, f"no {datatype} named {value} is declared with a value in "
                                     "the module", value, line=line)
            return self.resolved(known[1], where, line)
        return self.resolved(value, where, line)

    def resolved(self, value, where: str, line: int | None):
        """``value`` with the names of declared data within an aggregate replaced by their values (a component may
        be data: ``[[300,-200,610],[0.5,0.5,0.5,0.5],conf,extj]`` with ``VAR confdata conf := [0,0,0,0]``; an
        assignment, the only way such a value changes, is refused)."""
        if isinstance(value, list):
            return [self.resolved(v, where, line) for v in value]
        if isinstance(value, _Name):
            known = self.values.get(value.lower())
            if known is None or known[1] is None:
                raise RapidReadError(self.source, where, f"{value} in an aggregate: no data of that name is "
                                     "declared with a value in the module", value, line=line)
            return self.resolved(known[1], where, line)
        return value


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


@dataclass(frozen=True)
class _Call:
    """One instruction: its name, required arguments and optional ones (lower-case name -> value or None)."""

    name: str
    required: list
    optional: dict
    line: int | None


@dataclass(frozen=True)
class _Comment:
    """A comment in a procedure: its text (without ``!``)."""

    text: str


def read_rapid(text: str, robot, base_in_world: np.ndarray | None = None, *, source: str = SOURCE,
               tool: np.ndarray | None = None) -> dict:
    """The job document of a RAPID module ``text`` (module docstring) for ``robot`` (a preset name or robot file
    path, written into the document as given, or a Robot); ``base_in_world`` (4, 4) [m]: our base frame in the
    controller's world frame (None: the world is the robot file's abb controller section's base frame, our base
    frame without one); ``source`` names the file in errors; ``tool`` (4, 4) [m]: the tframe, on the controller's
    tool0, of a tool the module uses but does not declare. RapidReadError names what cannot be read."""
    text = _without_file_header(text, source)
    _refuse_statements(text, source)
    tree = _Values().transform(parse_subset("rapid", "RAPID", text, RapidReadError, source))
    module = tree.children[0]
    data = _declarations(module, source)
    routines = {str(node.children[0]).lower(): node for node in module.children
                if isinstance(node, lark.Tree) and node.data == "routine"}
    flattener = _Flattener(routines, _comments(text), source)
    steps = flattener.entry()
    robot_model, reference = as_robot(robot)
    base_in_world = (np.linalg.inv(controller_frames(robot_model, ABB)[0]) if base_in_world is None
                     else np.asarray(base_in_world))
    reader = _Reader(robot_model, data, base_in_world, source, tool)
    for k, step in enumerate(steps):
        _refuse_call(step, source, last=k == len(steps) - 1)
    for k, step in enumerate(steps):
        reader.step(step, last=k == len(steps) - 1)
    document = reader.document(reference, _marked_numbers(text))
    calls = [step for step in steps if isinstance(step, _Call)]
    accel = _path_acceleration(calls)
    if accel is not None:
        document["tcp_accel_max"] = accel
    if flattener.cycle is not None:
        routine, line = flattener.cycle
        document["description"] = (f"one cycle of the endless WHILE TRUE loop of {routine} ({source}:{line}), "
                                   "read from the RAPID module")
    return document


def _without_file_header(text: str, source: str) -> str:
    """``text`` with its file header (``FILE_HEADER``: ``%%%``, ``VERSION:n``, ``LANGUAGE:name``, ``%%%``) blanked,
    line breaks kept so that lines keep their numbers; RapidReadError naming the line of the first ``%%%`` when the
    file starts with ``%%%`` but not with such a header."""
    if not text.lstrip().startswith("%%%"):
        return text
    header = FILE_HEADER.match(text)
    if header is None:
        line = text[:text.index("%%%")].count("\n") + 1
        raise RapidReadError(source, "%%%", "a file header is %%%, VERSION:n, LANGUAGE:name, %%% before MODULE",
                             line=line)
    return re.sub(r"[^\r\n]", "", header.group(0)) + text[header.end():]


def _refuse_call(step, source: str, last: bool) -> None:
    """RapidReadError for an instruction that is neither a move, a setting, an action nor (``last``: the program's
    last step) ``Stop`` or ``EXIT``: checked for every step before any target is solved, so that the first such
    instruction is named whatever the targets are."""
    if not isinstance(step, _Call):
        return
    name = step.name.lower()
    if name in MOVES or name in ACTION_INSTRUCTIONS or name in CONFIG_INSTRUCTIONS or name in LOAD_INSTRUCTIONS or (
            last and name in ENDING_INSTRUCTIONS):
        return
    reason = _refusal(step.name) or ("a call of a routine the module does not hold has no static meaning (read "
                                     "here: MoveAbsJ, MoveJ, MoveL, MoveC, ConfJ, ConfL, PathAccLim, SetDO, "
                                     "Set, Reset, PulseDO, WaitTime, WaitDI, GripLoad and the module's procedures)")
    raise RapidReadError(source, step.name, reason, line=step.line)


def _code_lines(text: str) -> list[str]:
    """The lines of ``text`` without comments, strings emptied (``""``)."""
    return [_STRING_OR_COMMENT.sub(lambda m: "" if m.group(0).startswith("!") else '""', line)
            for line in text.splitlines()]


def _refuse_statements(text: str, source: str) -> None:
    """RapidReadError naming the first line whose statement has no static meaning (module docstring)."""
    lines = _code_lines(text)
    for number, line in enumerate(lines, start=1):
        code = _SCOPE.sub("", line.strip())
        word = _FIRST_WORD.match(code)
        if word is None:
            continue
        reason = _refused_line(code, word.group(0).lower(), lines[number:])
        if reason is not None:
            raise RapidReadError(source, code.split()[0].rstrip(";:"), reason, line=number)


def _refused_line(code: str, word: str, rest: list[str]) -> str | None:
    """Why the statement starting ``code`` (a line without comments; ``word`` its first word in lower case; ``rest``
    the lines after it) has no static meaning, or None."""
    if word in REFUSED_KEYWORDS:
        return REFUSED_KEYWORDS[word]
    if word == "while" and not _WHILE_TRUE.match(code):
        return "WHILE on a condition: a loop on a variable has no static meaning"
    if word == "for" and not _FOR_CONSTANT.match(code):
        return "FOR over bounds that are not numbers: a loop on a variable has no static meaning"
    if word == "proc" and (header := _PROC_HEADER.match(code)) and header.group(1):
        return "a procedure with parameters: its targets are computed at run time, which has no static meaning"
    if word == "return" and next((r.strip().upper() for r in rest if r.strip()), "")[:7] != "ENDPROC":
        return "RETURN before the end of its procedure is a jump, which has no static meaning"
    if _ASSIGNMENT.match(code) and word not in ("const", "pers", "var"):
        return "an assignment: the program computes with variables, which has no static meaning"
    if _LABEL.match(code) and not _ASSIGNMENT.match(code):
        return "a label (a GOTO target): jumps have no static meaning"
    return None


def _comments(text: str) -> list[tuple[int, _Comment]]:
    """(character offset, comment) of every ``!`` comment outside strings, in order."""
    return [(match.start(), _Comment(match.group(1).strip())) for match in _STRING_OR_COMMENT.finditer(text)
            if match.group(0).startswith("!")]


def _declarations(module: lark.Tree, source: str) -> _Data:
    """The module's data, and the data declared in its procedures (read as the module's)."""
    data = _Data(source)
    nodes = [n for n in module.children if isinstance(n, lark.Tree)]
    nodes += [d for n in nodes if n.data == "routine" for d in n.children
              if isinstance(d, lark.Tree) and d.data == "declaration"]
    for node in nodes:
        if node.data == "declaration":
            _, datatype, name, *rest = node.children
            value = [v for v in rest if not (isinstance(v, lark.Tree) and v.data == "dimensions")]
            data.values[str(name).lower()] = (str(datatype).lower(), value[0] if value else None)
    return data


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


def _statements(node: lark.Tree) -> list[lark.Tree]:
    """The statements of a routine or loop body, in order."""
    return [c for c in node.children if isinstance(c, lark.Tree) and c.data in ("call", "while_true", "for_loop")]


class _Flattener:
    """The entry routine's instructions and comments in the order they run: module procedures inlined, FOR loops over
    numbers unrolled, an ending WHILE TRUE read once (``cycle``: (routine, line) of that loop)."""

    def __init__(self, routines: dict, comments: list[tuple[int, _Comment]], source: str):
        self.routines, self.comments, self.source = routines, comments, source
        self.cycle: tuple[str, int] | None = None

    def entry(self) -> list:
        routines = self.routines
        routine = routines.get("main") or (next(iter(routines.values())) if len(routines) == 1 else None)
        if routine is None:
            raise RapidReadError(self.source, "PROC", f"no procedure main among {sorted(routines) or 'none'}")
        return self.routine(routine, (str(routine.children[0]).lower(),), entry=True)

    def routine(self, node: lark.Tree, stack: tuple[str, ...], entry: bool = False) -> list:
        statements = _statements(node)
        declarations = [c for c in node.children if isinstance(c, lark.Tree) and c.data == "declaration"]
        start = (declarations[-1] if declarations else node.children[0])
        start_pos = start.meta.end_pos if isinstance(start, lark.Tree) else start.end_pos
        if entry and statements and statements[-1].data == "while_true":
            self.cycle = (str(node.children[0]), statements[-1].meta.line)
        return self.body(statements, start_pos, node.meta.end_pos, stack, top=entry)

    def body(self, statements: list, start_pos: int, end_pos: int, stack: tuple[str, ...], top: bool = False) -> list:
        """The steps of ``statements`` with the comments between ``start_pos`` and ``end_pos`` (character offsets)
        that stand between them; ``top``: the entry routine's own body (where the ending WHILE TRUE may stand)."""
        out, cursor = [], start_pos
        for k, node in enumerate(statements):
            out += self.comments_between(cursor, node.meta.start_pos)
            last = top and k == len(statements) - 1
            out += self.statement(node, stack, ending_loop=last)
            cursor = node.meta.end_pos
        return out + self.comments_between(cursor, end_pos)

    def comments_between(self, start_pos: int, end_pos: int) -> list[_Comment]:
        return [comment for pos, comment in self.comments if start_pos <= pos < end_pos]

    def statement(self, node: lark.Tree, stack: tuple[str, ...], ending_loop: bool) -> list:
        line = node.meta.line
        if node.data == "while_true":
            if not ending_loop:
                raise RapidReadError(self.source, "WHILE TRUE", "an endless loop reads as one cycle only where it ends "
                                     "main (the production loop); here it would repeat what follows it, or run "
                                     "inside a procedure or another loop", line=line)
            return self.body(_statements(node), node.meta.start_pos, node.meta.end_pos, stack)
        if node.data == "for_loop":
            return self.for_loop(node, stack)
        call = _call(node)
        name = call.name.lower()
        if name == "return":
            return []
        if name not in self.routines:
            return [call]
        if call.required or call.optional:
            raise RapidReadError(self.source, call.name, "a call of a procedure of the module with arguments has no "
                                 "static meaning", line=line)
        if name in stack:
            raise RapidReadError(self.source, call.name, f"a recursive call (through {' -> '.join(stack)}) has no "
                                 "static meaning", line=line)
        return self.routine(self.routines[name], (*stack, name))

    def for_loop(self, node: lark.Tree, stack: tuple[str, ...]) -> list:
        """A FOR over numbers: its body once per turn; refused when the body uses the loop variable."""
        variable, *numbers = [c for c in node.children if not isinstance(c, lark.Tree)]
        first, last, *step = (float(v) for v in numbers)
        step = step[0] if step else (1.0 if last >= first else -1.0)
        turns = math.floor((last - first) / step + 1e-9) + 1 if step != 0.0 else 0
        where = f"FOR {variable}"
        if not all(float(v).is_integer() for v in (first, last, step)) or step == 0.0 or turns > MAX_FOR_TURNS:
            raise RapidReadError(self.source, where, f"a loop of integer bounds and step, at most {MAX_FOR_TURNS} "
                                 "turns, is read", line=node.meta.line)
        if _uses(node, str(variable).lower()):
            raise RapidReadError(self.source, where, f"the body uses the loop variable {variable}: what it moves to "
                                 "changes at run time, which has no static meaning", line=node.meta.line)
        body = self.body(_statements(node), node.meta.start_pos, node.meta.end_pos, stack)
        return body * max(turns, 0)


def _uses(node, name: str) -> bool:
    """Whether the identifier ``name`` (lower case) stands in a value within ``node`` (names of instructions and
    optional arguments are tokens, not values)."""
    if isinstance(node, _Name):
        return node.lower() == name
    if isinstance(node, list):
        return any(_uses(v, name) for v in node)
    if isinstance(node, lark.Tree):
        return any(_uses(c, name) for c in node.children)
    return False


def _marked_numbers(text: str) -> dict[str, tuple[str, int]]:
    """Signal name (lower case) -> (direction, number) that the writer's mark names (``settings_mark.signals_mark``)."""
    return {name.lower(): (OUTPUT if direction == "out" else INPUT, int(number))
            for name, direction, number in SIGNAL_MARK.findall(text)}


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


def _refusal(name: str) -> str | None:
    """Why a known run-time instruction (REFUSED_INSTRUCTIONS) is refused, or None."""
    lower = name.lower()
    for names, reason in REFUSED_INSTRUCTIONS.items():
        if any(lower == n or (n.endswith("*") and lower.startswith(n[:-1])) for n in names):
            return reason
    return None


class _Reader:
    """Targets, speeds and zones of the moves, in order, with the tool and the previous joint values; the actions on
    the waypoints and the signals they name."""

    def __init__(self, robot: Robot, data: _Data, base_in_world: np.ndarray, source: str, tool: np.ndarray | None):
        self.robot, self.data, self.base_in_world, self.source, self.tool = robot, data, base_in_world, source, tool
        self.tool_name: str | None = None
        self.X_FT = controller_frames(robot, ABB)[1]          # tool0: the controller's, on our end frame
        self.q_previous: np.ndarray | None = None
        self.waypoints: list[dict] = []
        self.before_first: list[dict] = []                    # actions before the first move: waypoint 0's
        self.stops: set[int] = set()                          # waypoints where a WaitTime \InPos, 0 stops
        self.signals: dict[str, tuple[str, str]] = {}         # lower-case name -> (name as first written, direction)
        self.monitored = {"confj": True, "confl": True}       # ConfJ/ConfL \On, the controller's default
        self.tload: tuple | None = None                       # (loaddata value, line) of the tool's load
        self.parts: dict[str, tuple[str, list, int | None]] = {}  # lower-case name -> (name, loaddata, line)
        self.held: str | None = None                          # lower-case name of the part GripLoad connected

    def step(self, step, last: bool = False) -> None:
        """Read one instruction or comment (module docstring); ``last``: the program's last step, where ``Stop`` or
        ``EXIT`` only ends what ends there anyway."""
        if last and isinstance(step, _Call) and step.name.lower() in ENDING_INSTRUCTIONS:
            return
        if isinstance(step, _Comment):
            for text in _comment_texts(step.text):
                self.add_action({COMMENT: text})
            return
        name = step.name.lower()
        if name in MOVES:
            waypoint = self.waypoint(step)
            if waypoint is not None:
                self.waypoints.append(waypoint)
        elif name in ("confj", "confl"):
            self.monitored[name] = self.switch(step)
        elif name in LOAD_INSTRUCTIONS:
            self.grip_load(step)
        elif name in ACTION_INSTRUCTIONS:
            action = self.action(step)
            if action is not None:
                self.add_action(action)
            elif self.waypoints:
                self.stops.add(len(self.waypoints) - 1)
        else:
            _refuse_call(step, self.source, last)

    def add_action(self, action: dict) -> None:
        (self.waypoints[-1].setdefault("do", []) if self.waypoints else self.before_first).append(action)

    def grip_load(self, call: _Call) -> None:
        """``GripLoad <loaddata>``: the release of the part held, then the grip of this one; ``GripLoad load0``: the
        release (module docstring); RapidReadError naming the line for a loaddata not declared in the module."""
        self.arguments(call, 1, ())
        value = call.required[0]
        if not isinstance(value, _Name):
            raise RapidReadError(self.source, call.name, "takes the name of a loaddata here", value, line=call.line)
        key = value.lower()
        if key != NO_LOAD:
            known = self.data.values.get(key)
            if known is None or known[0] != "loaddata" or known[1] is None:
                raise RapidReadError(self.source, f"GripLoad {value}", f"no loaddata named {value} is declared with a "
                                     "value in the module: the part's load is not in the file", line=call.line)
            self.parts.setdefault(key, (str(value), self.data.resolved(known[1], call.name, call.line), call.line))
        if key == self.held:
            return
        if self.held is not None:
            self.add_action({RELEASE: self.parts[self.held][0]})
        self.held = None if key == NO_LOAD else key
        if self.held is not None:
            self.add_action({GRIP: self.parts[key][0]})

    def action(self, call: _Call) -> dict | None:
        """The action of SetDO, Set, Reset, PulseDO, WaitTime or WaitDI (None: WaitTime of 0 s, only a stop)."""
        name = call.name.lower()
        if name in ("set", "reset"):
            self.arguments(call, 1, ())
            return {SET: self.signal(call.required[0], OUTPUT, call), "value": "on" if name == "set" else "off"}
        if name == "setdo":
            self.arguments(call, 2, ("sync",))
            return {SET: self.signal(call.required[0], OUTPUT, call), "value": self.on_off(call.required[1], call)}
        if name == "pulsedo":
            self.arguments(call, 1, ("plength",))
            length = call.optional.get("plength", DEFAULT_PULSE_S)
            return {PULSE: self.signal(call.required[0], OUTPUT, call), "time": self.seconds(length, call, "PLength")}
        if name == "waittime":
            self.arguments(call, 1, ("inpos",))
            seconds = self.seconds(call.required[0], call, "time", zero=True)
            return {WAIT: seconds} if seconds > 0.0 else None
        self.arguments(call, 2, ("maxtime",))
        action = {WAIT_INPUT: self.signal(call.required[0], INPUT, call), "value": self.on_off(call.required[1], call)}
        if "maxtime" in call.optional:
            action["timeout"] = self.seconds(call.optional["maxtime"], call, "MaxTime")
        return action

    def arguments(self, call: _Call, count: int, optional: tuple[str, ...]) -> None:
        """RapidReadError unless ``call`` has ``count`` required arguments and only the ``optional`` ones."""
        if len(call.required) != count:
            raise RapidReadError(self.source, call.name, f"takes {count} argument{'s' * (count > 1)} here",
                                 line=call.line)
        for key in call.optional:
            if key not in optional:
                reason = ("\\TimeFlag: after the longest wait the program goes on with a flag to branch on, which has "
                          "no static meaning" if key == "timeflag" else
                          f"\\{key} is not read here (read: {', '.join(optional) or 'none'})")
                raise RapidReadError(self.source, call.name, reason, line=call.line)

    def signal(self, value, direction: str, call: _Call) -> str:
        """The signal's name (the first spelling of it), the same direction wherever it is used."""
        if not isinstance(value, _Name) or len(value) > 32:
            raise RapidReadError(self.source, call.name, "a signal is a RAPID name of at most 32 characters", value,
                                 line=call.line)
        name, known = self.signals.setdefault(value.lower(), (str(value), direction))
        if known != direction:
            raise RapidReadError(self.source, call.name, f"signal {value} is used as a digital {known} before and as "
                                 f"a digital {direction} here", line=call.line)
        return name

    def on_off(self, value, call: _Call) -> str:
        """A dionum (0 or 1, or the predefined low/high) -> off/on."""
        words = {0.0: "off", 1.0: "on", "low": "off", "high": "on"}
        key = value.lower() if isinstance(value, _Name) else value
        if isinstance(key, bool) or key not in words:
            raise RapidReadError(self.source, call.name, "a digital value is 0 or 1", value, line=call.line)
        return words[key]

    def seconds(self, value, call: _Call, what: str, zero: bool = False) -> float:
        """A time [s]: a number above 0 (``zero``: at least 0)."""
        if not isinstance(value, float) or isinstance(value, bool) or value < 0.0 or (value == 0.0 and not zero):
            raise RapidReadError(self.source, f"{call.name} {what}", "a time is a number of seconds above 0", value,
                                 line=call.line)
        return value

    def waypoint(self, call: _Call) -> dict | None:
        """The waypoint of a move; None for a move to where the robot already is (the waypoint before, which stops
        there if either move ends in a stop)."""
        kind = call.name.lower()
        count = 5 if kind == "movec" else 4
        if len(call.required) != count:
            raise RapidReadError(self.source, call.name, f"takes {count} arguments here (target{'s' * (count - 4)}, "
                                 "speed, zone, tool)", line=call.line)
        self.use_tool(call)
        *targets, speed, zone, _ = call.required
        if kind == "moveabsj":
            q = self.joint_target(targets[0], call)
            waypoint = {"joints": [round(float(v), 10) for v in np.degrees(q)]}
        else:
            X, q, confdata = self.robtarget(targets[-1], call)
            waypoint = self.pose_waypoint(X, q, confdata)
            waypoint["move"] = {"movej": "joint", "movel": "linear", "movec": "circular"}[kind]
            if kind == "movec":
                X_via = self.pose(self.data.get(targets[0], "robtarget", call.name, call.line), call)
                waypoint["via"] = {"xyz": X_via[:3, 3].tolist()}
        first = self.q_previous is None
        if not first and self.at_previous(kind, q):
            previous = self.waypoints[-1]
            if "zone" in previous:
                previous["zone"] = min(previous["zone"], self.zone(zone, call))
            return None
        if not first:
            self.add_speed(waypoint, kind, speed, call, q)
            waypoint["zone"] = self.zone(zone, call)
        self.q_previous = q
        return waypoint

    def at_previous(self, kind: str, q: np.ndarray) -> bool:
        """Whether a move to joint values q (6,) [rad] goes where the robot already is: the same joint values, or
        for a MoveL the same TCP pose within SAME_POSE_M and SAME_POSE_RAD (RobotStudio's first MoveL to the pose
        the MoveAbsJ home before it reached)."""
        if np.allclose(q, self.q_previous, rtol=0.0, atol=SAME_JOINTS_RAD):
            return True
        if kind != "movel":
            return False
        X_previous, X = self.robot_tool.fk(self.q_previous), self.robot_tool.fk(q)
        turn = np.clip((np.trace(X_previous[:3, :3].T @ X[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)
        return (float(np.linalg.norm(X[:3, 3] - X_previous[:3, 3])) <= SAME_POSE_M
                and math.acos(turn) <= SAME_POSE_RAD)

    def use_tool(self, call: _Call) -> None:
        name = call.required[-1]
        if self.tool_name is not None and name.lower() != self.tool_name.lower():
            raise RapidReadError(self.source, call.name, f"uses tool {name}, the moves before {self.tool_name}: a job "
                                 "has one tool", line=call.line)
        if self.tool_name is None:
            self.tool_name = name
            if name.lower() != "tool0":
                self.X_FT = controller_frames(self.robot, ABB)[1] @ self.tool_frame(name, call)     # tframe: on tool0
            self.robot_tool = robot_with_tool(self.robot, self.X_FT)

    def tool_frame(self, name, call: _Call) -> np.ndarray:
        """tframe (4, 4) [m] of the tooldata ``name``: the module's, else the caller's ``tool``."""
        known = self.data.values.get(str(name).lower())
        if (known is None or known[1] is None) and self.tool is not None:
            return np.asarray(self.tool, dtype=float)
        if known is None or known[1] is None:
            raise RapidReadError(self.source, call.name, f"tool {name}: no tooldata of that name is declared with a "
                                 "value in the module (RobotStudio keeps tools in the task's CalibData module): pass "
                                 "its tframe as tool (4, 4) [m]", line=call.line)
        robhold, tframe, tload = self.data.get(name, "tooldata", call.name, call.line)
        if not robhold:
            raise RapidReadError(self.source, str(name), "is a stationary tool (robhold FALSE): not read here",
                                 line=call.line)
        if tload != json.loads(PLACEHOLDER_LOAD):
            self.tload = (tload, call.line)
        return _frame(tframe, self.source)

    def joint_target(self, value, call: _Call) -> np.ndarray:
        robax = np.array(self.data.get(value, "jointtarget", call.name, call.line)[0], dtype=float)
        return joint_values(self.robot, robax, ABB)

    def pose(self, target, call: _Call) -> np.ndarray:
        """A robtarget's TCP pose (4, 4) [m] in the robot's base frame."""
        X_WO = self.work_object(call)
        return np.linalg.inv(self.base_in_world) @ X_WO @ _frame(target[:2], self.source)

    def work_object(self, call: _Call) -> np.ndarray:
        name = call.optional.get("wobj")
        if name is None or str(name).lower() == "wobj0":
            return np.eye(4)
        robhold, _, _, uframe, oframe = self.data.get(name, "wobjdata", call.name, call.line)
        if robhold:
            raise RapidReadError(self.source, str(name), "is held by the robot (robhold TRUE): not read here",
                                 line=call.line)
        return _frame(uframe, self.source) @ _frame(oframe, self.source)

    def switch(self, call: _Call) -> bool:
        """ConfJ/ConfL ``\\On`` (True: the configuration is monitored) or ``\\Off`` (False)."""
        if call.required or sorted(call.optional) not in (["on"], ["off"]) or any(call.optional.values()):
            raise RapidReadError(self.source, call.name, "takes \\On or \\Off", line=call.line)
        return "on" in call.optional

    def robtarget(self, value, call: _Call) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
        """(TCP pose (4, 4) [m], joint values (6,) [rad], their confdata): the solution the robtarget's confdata
        selects; with the configuration not monitored after a first move (ABB, RAPID Instructions, ConfL/ConfJ: the
        robot moves to the programmed position and orientation with the closest possible axis configuration), for
        MoveL/MoveC after ConfL \\Off the solution the path leads to (``followed``), for MoveJ after ConfJ \\Off the
        one nearest the joint values before (``nearest``)."""
        target = self.data.get(value, "robtarget", call.name, call.line)
        X = self.pose(target, call)
        where = str(value) if isinstance(value, _Name) else f"{call.name} target"     # a name, or inline
        kind = call.name.lower()
        if not self.monitored["confj" if kind == "movej" else "confl"] and self.q_previous is not None:
            q = (self.nearest(pose_solutions(self.robot_tool, X[None])[0], self.q_previous, where, call)
                 if kind == "movej"
                 else self.followed(X, self.via(call), where, call))
            return X, q, tuple(int(c) for c in configurations(self.robot_tool, q, ABB))
        confdata = tuple(int(c) for c in target[2])
        try:
            return X, select_solution(self.robot_tool, X, confdata, ABB), confdata
        except ConfigurationNotFoundError as exc:
            raise RapidReadError(self.source, where, str(exc), line=call.line) from None

    def via(self, call: _Call) -> np.ndarray | None:
        """A MoveC's CirPoint position (3,) [m] in the base frame; None for other moves."""
        if call.name.lower() != "movec":
            return None
        return self.pose(self.data.get(call.required[0], "robtarget", call.name, call.line), call)[:3, 3]

    def followed(self, X: np.ndarray, via: np.ndarray | None, where: str, call: _Call) -> np.ndarray:
        """The joint values (6,) [rad] a linear (or, through ``via``, circular) move to the TCP pose X (4, 4) [m]
        reaches from the joint values before, the configuration unmonitored: the in-limit solution followed
        continuously along the TCP's path (``pipeline.program.tool_path``) in steps of at most FOLLOW_STEP_M,
        each the solution nearest the one before, a step whose joints jump more than FOLLOW_JUMP_RAD halved
        until they do not (``step_along``)."""
        q = self.q_previous
        X_start = self.robot_tool.fk(q)
        if np.allclose(X_start, X, rtol=0.0, atol=SAME_POSE_M) and via is None:
            return q
        path = ToolPath(X_start, [ToolMove("circular" if via is not None else "linear", X, via)])
        sigmas = np.linspace(0.0, path.length, max(1, math.ceil(path.length / FOLLOW_STEP_M)) + 1)
        for k, solutions in enumerate(pose_solutions(self.robot_tool, path.poses(sigmas[1:]))):
            q = self.step_along(path, sigmas[k], sigmas[k + 1], q, solutions, where, call)
        return q

    def step_along(self, path: ToolPath, sigma_a: float, sigma_b: float, q_a: np.ndarray, solutions: np.ndarray,
                   where: str, call: _Call) -> np.ndarray:
        """The solution at path length sigma_b [m] (of ``solutions`` (K, 6) [rad] there) that continues q_a (6,)
        [rad] at sigma_a: the nearest, where it lies within FOLLOW_JUMP_RAD; else the step is halved. RapidReadError
        where a step of FOLLOW_MIN_STEP_M still jumps (the path passes a singularity so near that axes 4 and 6
        would turn half a turn on it, or leaves the reach): which configuration follows has no static meaning."""
        gaps = np.abs(solutions - q_a).max(axis=1) if len(solutions) else np.array([np.inf])
        if gaps.min() <= FOLLOW_JUMP_RAD:
            return solutions[int(np.argmin(gaps))]
        if sigma_b - sigma_a <= FOLLOW_MIN_STEP_M:
            raise RapidReadError(self.source, where, "with the configuration not monitored (ConfL \\Off) the path to "
                                 "this target passes a singularity (or leaves the reach) at "
                                 f"{1e3 * sigma_a:.3f} mm along it: which configuration the controller continues "
                                 "with has no static meaning", line=call.line)
        middle = (sigma_a + sigma_b) / 2.0
        q_m = self.step_along(path, sigma_a, middle, q_a, pose_solutions(self.robot_tool, path.poses([middle]))[0],
                              where, call)
        return self.step_along(path, middle, sigma_b, q_m, solutions, where, call)

    def nearest(self, solutions: np.ndarray, q_near: np.ndarray, where: str, call: _Call) -> np.ndarray:
        """Of a pose's in-limit solutions (K, 6) [rad] the one nearest q_near (6,) [rad] (smallest largest joint
        difference), as ConfJ \\Off leaves a MoveJ. RapidReadError when there is none, or when another is nearly as
        near (within NEAREST_MARGIN times as far): which one the controller takes then has no static meaning."""
        gaps = np.sort(np.abs(solutions - q_near).max(axis=1)) if len(solutions) else np.array([])
        if not len(gaps) or (len(gaps) > 1 and gaps[1] <= NEAREST_MARGIN * gaps[0]):
            reason = ("no in-limit IK solution reaches the pose" if not len(gaps) else
                      "two configurations are about as near the joint values before")
            raise RapidReadError(self.source, where, f"with the configuration not monitored ({call.name} after "
                                 f"ConfJ/ConfL \\Off): {reason}, so which one the controller takes has no static "
                                 "meaning", line=call.line)
        return solutions[int(np.argmin(np.abs(solutions - q_near).max(axis=1)))]

    def pose_waypoint(self, X: np.ndarray, q: np.ndarray, confdata) -> dict:
        """The pose waypoint of X (4, 4) [m]: its branch (of q (6,) [rad]) and ``controller_config`` the confdata
        of q (the job solves it as the controller does, the quadrants of axes 4 and 6 too)."""
        quaternion, position = pose_to_quaternion_position(X)
        label = configuration_labels(self.robot_tool, q[None])[0]
        waypoint = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if label:
            waypoint["config"] = label_parts(label)
        waypoint["controller_config"] = {ABB: format_configuration(ABB, confdata)}
        return waypoint

    def add_speed(self, waypoint: dict, kind: str, speed, call: _Call, q: np.ndarray) -> None:
        if kind in ("moveabsj", "movej"):
            seconds = call.optional.get("t")
            if seconds is not None and not isinstance(seconds, float):
                raise RapidReadError(self.source, f"{call.name} \\T", "a move time must be a number [s]", seconds,
                                     line=call.line)
            if seconds is not None and seconds > 0.0:
                step = np.abs(q - self.q_previous) / self.robot.limits.qd_max
                percent = min(100.0, 100.0 * float(step.max()) / seconds)
                if percent > 0.0:
                    waypoint["speed"] = percent
            return
        if "t" in call.optional:
            raise RapidReadError(self.source, call.name, "a tool move timed by \\T has no TCP speed to read",
                                 line=call.line)
        v_tcp = call.optional.get("v")
        waypoint["speed"] = (self.tcp_speed(speed, call) if v_tcp is None else float(v_tcp)) / 1e3

    def tcp_speed(self, speed, call: _Call) -> float:
        """v_tcp [mm/s] of a speeddata."""
        if isinstance(speed, _Name) and speed.lower() not in self.data.values:
            digits = speed.lower().removeprefix("v")
            if digits.isdigit() and int(digits) in PREDEFINED_SPEEDS:
                return float(digits)
        return float(self.data.get(speed, "speeddata", call.name, call.line)[0])

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
        value = self.data.get(zone, "zonedata", call.name, call.line)
        if value[0]:
            return 0.0
        return float(value[1] if override is None else override) / 1e3

    def document(self, robot: str, numbers: dict[str, tuple[str, int]]) -> dict:
        """The job document; ``numbers``: signal name (lower case) -> (direction, number) the writer's mark names."""
        waypoints = self.waypoints
        if not waypoints:
            raise RapidReadError(self.source, "main", "the procedure has no move instruction")
        if self.before_first:
            waypoints[0]["do"] = self.before_first + waypoints[0].get("do", [])
        for k, waypoint in enumerate(waypoints):
            if k == len(waypoints) - 1 or k in self.stops or any(
                    WAIT in a or WAIT_INPUT in a for a in waypoint.get("do", ())):
                waypoint.pop("zone", None)          # the program ends, or stands still to wait, there
        doc = {"robot": str(robot), "length_unit": "m", "angle_unit": "deg", "waypoints": waypoints}
        if not np.allclose(self.X_FT, np.eye(4), atol=1e-12):
            quaternion, position = pose_to_quaternion_position(self.X_FT)
            doc["tool"] = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if self.signals:
            doc["signals"] = {name: {direction: numbers[key][1] if numbers.get(key, (None,))[0] == direction
                                     else None} for key, (name, direction) in self.signals.items()}
        if self.tload is not None:
            payload = self.load(*self.tload, controller_frames(self.robot, ABB)[1], f"{self.tool_name} tload")
            if payload is not None:
                doc["payload"] = payload.to_document(1.0)
        parts = {name: self.load(value, line, self.X_FT, f"loaddata {name}")
                 for name, value, line in self.parts.values()}
        for name, part in parts.items():
            if part is None:
                raise RapidReadError(self.source, f"loaddata {name}", "a part's mass must be above 0 kg",
                                     line=self.parts[name.lower()][2])
        if parts:
            doc["parts"] = {name: part.to_document(1.0) for name, part in parts.items()}
        return doc

    def load(self, value, line: int | None, X_FA: np.ndarray, what: str) -> Payload | None:
        """The load (in the flange frame) of a loaddata ``value`` [mass, cog mm, aom, ix, iy, iz] stated in frame A,
        X_FA (4, 4) [m] A's pose in the flange frame; None for a mass of 0 or less (no load). RapidReadError naming
        ``what`` and the line where the value is not a loaddata."""
        shape = (isinstance(value, list) and len(value) == 6 and isinstance(value[1], list) and len(value[1]) == 3
                 and isinstance(value[2], list) and len(value[2]) == 4)
        flat = [value[0], *value[1], *value[2], *value[3:]] if shape else []
        if not shape or not all(isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v) for v in flat):
            raise RapidReadError(self.source, what, "a loaddata is [mass, [x, y, z], [q1, q2, q3, q4], ix, iy, iz] "
                                 "of numbers", value, line=line)
        if value[0] <= 0.0:
            return None
        aom = _frame([[0.0, 0.0, 0.0], value[2]], self.source)[:3, :3]
        inertia = aom @ np.diag(value[3:]) @ aom.T
        local = Payload(float(value[0]), np.array(value[1]) / 1e3, inertia, f"{self.source}: {what}",
                        what.split()[-1] if what.startswith("loaddata") else "tool")
        return expressed_in(local, X_FA)


def _comment_texts(text: str) -> list[str]:
    """A comment's text as job comments: split into lines of at most MAX_COMMENT_CHARS; none when empty or holding
    what a job comment cannot (quotes, characters that do not print)."""
    if not text or any(c in text for c in "\"'") or not text.isprintable():
        return []
    return textwrap.wrap(text, MAX_COMMENT_CHARS, break_long_words=True)


def _frame(pose, source: str) -> np.ndarray:
    """A RAPID pose [[x, y, z] mm, [q1, q2, q3, q4]] -> (4, 4) [m], the quaternion normalised."""
    position, quaternion = np.array(pose[0], dtype=float), np.array(pose[1], dtype=float)
    norm = float(np.linalg.norm(quaternion))
    if not math.isfinite(norm) or norm < 0.5:
        raise RapidReadError(source, "pose", "a quaternion of a pose is not near unit length", pose[1])
    return quaternion_position_to_pose(quaternion / norm, position / 1e3)
