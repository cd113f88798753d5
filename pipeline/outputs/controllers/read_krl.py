"""``read_krl(src, dat, robot) -> dict``: a KUKA KRL program (its ``.src`` and ``.dat`` texts), as ``write_krl`` writes
it or as a KR C4 pendant's inline forms write it, read back into a job document (a mapping
``pipeline.program.job.parse_job`` accepts).

Both files are parsed with ``grammars/krl.lark`` (package data; KUKA System Software 8.x, Operating and Programming
Instructions for System Integrators, "Programming for user group Expert / KRL syntax", and its chapters on inline
forms and the basis package: keywords and names are not case-sensitive, ``;`` comments and ``;FOLD`` lines, free
spacing, the editor's ``&ACCESS``/``&REL``/``&PARAM`` lines). What is read, and the KRL facts it follows:

* A .src may come without a .dat (RoboDK's KUKA posts write the .src alone, every target an aggregate in it): no
  declarations but the .src's own.
* The .dat's (and the .src's) ``DECL E6POS``/``POS``/``E6AXIS``/``AXIS``/``FRAME`` points and ``FDAT``/``PDAT``/``LDAT``
  records by name (not case-sensitive), ``SIGNAL name $OUT[n]`` / ``$IN[n]`` names; other declarations (INT, REAL,
  BOOL, the pendant's LAST_BASIS ...), ``EXT`` declarations (``EXT BAS (...)``) and the ``EXTERNAL DECLARATIONS`` and
  ``INI`` folds are read past. ``PTP HOME`` / ``XHOME`` without a declaration is KSS's default home of
  ``$config.dat``, {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0} (``HOME``; a cell's own home may differ).
* The main routine (the first DEF) in order: each ``PTP``/``LIN``/``CIRC`` to a point name or an aggregate
  (``PTP {A1 0, A2 -90, ...}``) is one waypoint; the first motion (the BCO run to the start) is the job's first
  waypoint, without a move, speed or zone. A ``PTP $AXIS_ACT`` before every other motion (RoboDK's "Quickly skip
  BCO" fold: a PTP to the axis angles the robot has, $AXIS_ACT, which moves nothing and completes the BCO run
  ("Block coincidence (BCO)", "$AXIS_ACT") is read past: the next motion is still the first waypoint. Calls of parameterless routines of the same file are read in place; a FOR
  over constants is flattened (its variable may index system variables: ``$VEL_AXIS[I]``); the KSS 8 motion inline
  forms' ``SET_CD_PARAMS``/``USE_CD_PARAMS`` (collision detection data sets) are read past; an outermost endless
  ``LOOP ... ENDLOOP`` that ends the main routine reads as one cycle (the job's description says so).
* Speeds ("$VEL_AXIS", "$VEL", the basis package): a PTP's ``$VEL_AXIS[1..6]`` [% of the axes' maximum speeds],
  equal on the six axes, or the inline form's ``BAS(#PTP_PARAMS, v)`` / ``BAS(#VEL_PTP, v)`` -> ``speed`` [%]; a LIN's
  or CIRC's ``$VEL.CP`` [m/s] or ``BAS(#CP_PARAMS, v)`` / ``BAS(#VEL_CP, v)`` -> ``speed`` [m/s]; ``BAS(#PTP_DAT)`` /
  ``BAS(#CP_DAT)`` take PDAT_ACT's / LDAT_ACT's VEL. A motion without a speed set before it in the file (e.g. a LIN
  after ``BAS(#INITMOV,0)`` alone, whose speed is the controller's $config.dat default) is refused naming its line.
  ``$ACC.CP`` [m/s^2], when a number and the program has tool moves -> ``tcp_accel_max``.
* Zones ("Approximate positioning"): ``C_DIS`` (or an inline form's ``C_DIS C_DIS``) -> ``zone`` = ``$APO.CDIS``
  [mm -> m], which ``BAS(#PTP_PARAMS)`` / ``BAS(#CP_PARAMS)`` set from PDAT_ACT's / LDAT_ACT's ``APO_DIST``; a PTP's
  ``C_PTP`` (alone or with ``C_DIS``) is read with that distance (a PDAT with ``APO_MODE #CPTP`` gives a percentage,
  no distance: refused); no approximation parameter -> 0. ``C_VEL``, ``C_ORI`` (a speed, an angle) are refused. A
  waypoint followed by a statement that stops the advance run (an output without CONTINUE before it, PULSE, WAIT)
  is an exact stop: the controller cannot approximate there.
* Tool and base: ``$TOOL`` {X, Y, Z, A, B, C} (the TCP on the flange), or a tool number (``FDAT_ACT``'s ``TOOL_NO``
  of an inline form, ``BAS(#TOOL, n)``, ``$TOOL = TOOL_DATA[n]``): 0 is the flange; another number needs its data,
  the reader's ``tool`` keyword (X_FT (4, 4) [m]), else a KrlReadError names the line and number. The base:
  ``$BASE = $ROBROOT``/``$WORLD``/``$NULLFRAME`` or number 0 (``BASE_NO 0``) is the robot's base frame ($WORLD is
  taken as $ROBROOT, KSS's default for a floor-mounted robot), ``$BASE = {X ...}`` a frame in it, another number needs
  the ``frame`` keyword (the user frame in the robot base frame (4, 4) [m]). $ROBROOT and $FLANGE are where the robot
  file's kuka controller section puts them (``model.vendors.controller``; ours without one); ``$IPO_MODE`` /
  ``IPO_FRAME`` must be ``#BASE`` (a robot-held tool). A job has one tool: every motion that uses it must have the
  same.
* Targets: ``E6AXIS``/``AXIS`` {A1..A6} [deg] -> a joint waypoint through the inverse of the KUKA axis map of
  ``pipeline.model.vendors.axes`` (q = (angle - offset) x direction); a LIN or CIRC to one becomes the pose of those
  joint values. ``E6POS``/``POS``/``FRAME`` {X, Y, Z [mm], A, B, C [deg]} -> a pose waypoint, R = Rz(A) Ry(B) Rx(C);
  its Status and Turn (decimal or bit constants 'B...') select the one closed-form solution they name
  (``pipeline.model.vendors.selection``), whose branch label is the waypoint's ``config`` (where two 2 pi variants of
  one branch share S and T, their common branch). The first waypoint's selected joint values are the job's
  ``start``. ``CIRC aux, end``: the auxiliary point's position is the ``via``.
* Actions (``pipeline.program.actions``), attached to the waypoint of the motion before them (before the first
  motion: to the first waypoint): ``$OUT[n] = TRUE/FALSE`` or a SIGNAL output's name -> ``set``; ``PULSE($OUT[n],
  TRUE, t)`` -> ``pulse`` (a PULSE of FALSE is refused); ``WAIT SEC t`` -> ``wait``; ``WAIT FOR $IN[n]`` / ``NOT
  $IN[n]`` / ``$IN[n] == TRUE`` / a SIGNAL input's name -> ``wait_input`` without timeout (KRL's WAIT FOR has none),
  and exactly ``write_krl``'s timeout pattern (``WAIT FOR <input> OR ($TIMER[n] > ms)`` then ``IF <not input> THEN
  HALT ENDIF``; the $TIMER / $TIMER_STOP assignments around it are read past) -> ``wait_input`` with ``timeout``;
  ``TRIGGER WHEN DISTANCE=1 DELAY=0 DO`` an output or PULSE (``write_krl``'s outputs at an approximated waypoint) ->
  that action for the waypoint of the motion after it, before that waypoint's other actions, without an exact stop;
  full-line ``;`` comments after the first motion (not fold lines) and the pendant's comment inline form (``;FOLD ;
  text;%{PE}...%CCOMMENT``) -> ``comment``. The pendant's OUT, PULSE, WAIT and
  WAIT FOR inline forms are these statements inside their folds (CONTINUE before an output: set in the advance run).
  Numbered signals are named ``do<n>`` / ``di<n>`` (a SIGNAL's own name where the file declares one) in the
  document's ``signals``; ``read_program`` renames them by the header's signals mark.
* Load ("$LOAD", the TOTAL on the flange: ``write_krl``'s module docstring): ``$LOAD = {M, CM {X, Y, Z, A, B, C},
  J {X, Y, Z}}`` and the partial ``$LOAD.M = m``, ``$LOAD.CM = {...}``, ``$LOAD.J = {...}`` (what ``write_krl``
  wrote before, and what tools write; a component not assigned keeps its value, none assigned is 0: CM at the
  flange, J 0 a point mass); consecutive assignments are one load. M [kg], CM [mm] in $FLANGE with A, B, C [deg]
  the principal axes (R = Rz(A) Ry(B) Rx(C)), J [kg m^2] the principal moments: inertia R diag(J) R^T. The load in
  force at the first motion is the job's ``payload`` (the tool's; none with M 0 or no $LOAD). After the first
  motion, on the waypoint of the motion before, in its place among the actions: a load of more mass than the
  previous one is the ``grip`` of a part named ``part1``, ``part2``... whose data (the job's ``parts``) is the
  difference (``payload.removed``); a load equal to an earlier one (within LOAD_MATCH) is the ``release`` of the
  parts gripped since (the last gripped first); any other is a KrlReadError naming the line.

What has no static meaning is a ``KrlReadError`` naming the file, the line and the construct: a loop on a condition
(WHILE, REPEAT) or a LOOP other than the outermost one, IF (but the timeout pattern), SWITCH, GOTO, an INTERRUPT other
than the INI fold's stop handler (``... DO IR_STOPM ( )``), HALT, EKI_ (Ethernet KRL) and RSI_ (RobotSensorInterface)
calls, a TRIGGER other than the one above, a call of a routine not in the file or with parameters, an assignment
to a program variable, a motion to a live position ($POS_ACT, $AXIS_ACT ...) but the one above, a WAIT FOR on a
function's result (RoboDK's message lines ``WAIT FOR StrClear($LOOP_MSG[])``), as is anything else outside the
grammar, a missing point or a speed that is not a number.

The document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``start``,
``tcp_accel_max``, ``signals``, ``waypoints`` (with ``do`` lists), ``description`` where a LOOP was read as one cycle.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
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
from ...program.actions import COMMENT, GRIP, INPUT, MAX_COMMENT_CHARS, OUTPUT, PULSE, RELEASE, SET, WAIT, WAIT_INPUT
from ...program.payload import MASS_TOLERANCE_KG, Payload, expressed_in, removed, same_load
from .krl import abc_rotation
from .settings_mark import PART_NAME

MOVE_KINDS = {"ptp": "joint", "lin": "linear", "circ": "circular"}
AXIS_TYPES, POSE_TYPES = ("E6AXIS", "AXIS"), ("E6POS", "POS", "FRAME")
#: KSS's default home ($config.dat XHOME) [deg], for ``PTP HOME`` / ``PTP XHOME`` without a declaration in the file.
HOME = {"A1": 0.0, "A2": -90.0, "A3": 90.0, "A4": 0.0, "A5": 0.0, "A6": 0.0}
HOME_NAMES = ("HOME", "XHOME")
#: Base frames that are the robot's base (KSS's default $WORLD = $ROBROOT; $NULLFRAME: no offset).
ROBOT_BASES = ("$ROBROOT", "$WORLD", "$NULLFRAME")
#: System variables holding where the robot is when the statement runs (a live position).
LIVE_POSITIONS = ("$POS_ACT", "$AXIS_ACT", "$POS_ACT_MES", "$AXIS_ACT_MEAS")
#: The INI fold's interrupt routine for the stop message: read past (it has no motion meaning).
STOP_HANDLER = "IR_STOPM"
#: Basis-package commands read past: they set what the file does not hold (machine data defaults, accelerations).
IGNORED_BAS = ("#INITMOV", "#ACC_PTP", "#ACC_CP", "#ACC_ORI")
#: Basis-package routines of KSS 8's motion inline forms read past: the collision detection's data set (no motion).
IGNORED_CALLS = ("SET_CD_PARAMS", "USE_CD_PARAMS")
#: A pendant's comment inline form: the text is in the fold line (``;FOLD ; text;%{PE}...%CCOMMENT...``).
COMMENT_FOLD = re.compile(r";\s*FOLD\s*;\s*(.*?)\s*;\s*%\{PE\}.*%CCOMMENT", re.IGNORECASE)
#: Statements of a refused construct, by their first word (upper case) -> what it is (the KrlReadError's problem).
REFUSED_WORDS = {
    "WHILE": "a loop on a condition has no static meaning: how often it runs is known only when the robot runs",
    "ENDWHILE": "a loop on a condition has no static meaning",
    "REPEAT": "a loop on a condition has no static meaning: how often it runs is known only when the robot runs",
    "UNTIL": "a loop on a condition has no static meaning",
    "ELSE": "a branch has no static meaning: which way it goes is known only when the robot runs",
    "SWITCH": "a branch has no static meaning: which case runs is known only when the robot runs",
    "CASE": "a branch has no static meaning", "DEFAULT": "a branch has no static meaning",
    "GOTO": "a jump has no static meaning", "EXIT": "leaving a loop has no static meaning",
    "INTERRUPT": "an interrupt has no static meaning: when it fires is known only when the robot runs",
    "TRIGGER": "a path-triggered action is read only at the end point (TRIGGER WHEN DISTANCE=1 DELAY=0 DO an output "
               "or PULSE): other switching points depend on the controller's path",
    "DEFFCT": "a function has no static meaning here", "RETURN": "a return from a routine is not read",
    "BRAKE": "BRAKE belongs to an interrupt routine: no static meaning",
}
_WORD = re.compile(r"[A-Za-z_$][A-Za-z0-9_$]*")
#: The load's components read (module docstring, "Load"): the whole structure's and each partial assignment's.
LOAD_FIELDS = {"$LOAD": ("M", "CM", "J"), "$LOAD.M": ("M",), "$LOAD.CM": ("CM",), "$LOAD.J": ("J",)}
#: Two loads are the same within these: mass [kg], centre of mass [m], inertia [kg m^2] (above what a file's rounding
#: of 0.001 kg, 0.001 mm and 1e-6 kg m^2 leaves of one load written twice).
LOAD_MATCH = (1e-3, 1e-5, 1e-5)


class KrlReadError(FileFormatError):
    """A KRL program outside what is read here, or with data that does not fit (``field``: the statement, system
    variable or point name; ``line`` where known)."""


@dataclass(frozen=True)
class _Point:
    """A declared or written point or record: its type (upper case, None for an untyped aggregate), components
    (upper-case name -> number, text, bool or nested dict) and line."""

    type: str | None
    values: dict
    line: int | None


@dataclass(frozen=True)
class _Frame:
    """A tool or base selection: ``number`` (0: the flange / the robot's base) or ``values`` (a frame's X, Y, Z, A, B,
    C), or neither (``unknown``: the name of a record the file does not hold); ``line`` where it was selected."""

    number: int | None = None
    values: dict | None = None
    unknown: str | None = None
    line: int | None = None


@dataclass(frozen=True)
class _Motion:
    """A motion with the settings in force: kind (ptp, lin, circ), target and aux points, approximation parameters
    (upper case), line, the system variables set before it (name -> value), the tool and base selected, and PDAT_ACT
    (its APO_MODE matters for C_PTP)."""

    kind: str
    target: _Point
    target_name: str
    aux: _Point | None
    aux_name: str | None
    approx: tuple[str, ...]
    line: int | None
    settings: dict
    tool: _Frame
    base: _Frame
    pdat: _Point | None


def _refusal(text: str) -> str:
    """What a statement outside the grammar is (module docstring), from its text."""
    upper = text.upper()
    if "EKI_" in upper:
        return "an EKI_ (Ethernet KRL) call exchanges data with another computer: driver code has no static meaning"
    if "RSI_" in upper:
        return "an RSI_ (RobotSensorInterface) call corrects the motion from a sensor: no static meaning"
    words = [w.upper() for w in _WORD.findall(text)]
    if words[:1] in (["DEF"], ["DEFDAT"], ["GLOBAL"]) and any(len(w) > 24 for w in words):
        return "a name has at most 24 characters in KRL (\"Names\")"
    for word in words[:3]:
        if word in REFUSED_WORDS:
            return REFUSED_WORDS[word]
    if "$LOOP_MSG" in words:
        return ("a WAIT FOR on a function's result (RoboDK's message lines: StrClear($LOOP_MSG[])): known only when "
                "the robot runs")
    if any(w in LIVE_POSITIONS for w in words):
        return "a live position ($POS_ACT, $AXIS_ACT) is known only when the robot runs"
    return "not KRL of the subset read here (statements, points and folds of the module docstring)"


def parse_krl(text: str, part: str, source: str) -> lark.Tree:
    """The ``src`` or ``dat`` (``part``) node of a KRL text; KrlReadError at the line that does not parse, naming its
    construct."""
    try:
        node = _parser().parse(text).children[0]
    except lark.exceptions.UnexpectedInput as exc:
        lines = text.splitlines()
        line = getattr(exc, "line", None)
        statement = lines[line - 1].split(";")[0].strip() if line and 0 < line <= len(lines) else ""
        raise KrlReadError(source, statement or "syntax", _refusal(statement) if statement else
                           str(exc).splitlines()[0], line=line) from None
    if node.data != part:
        raise KrlReadError(source, part, f"a .{part} file holds DEF{'DAT' * (part == 'dat')} ... END"
                           f"{'DAT' * (part == 'dat')}, this one is a .{node.data}")
    return node


_PARSER: list = []


def _parser() -> lark.Lark:
    """The LALR parser of ``grammars/krl.lark``, built once per process; its trees carry line numbers."""
    if not _PARSER:
        from importlib import resources
        text = resources.files(__package__).joinpath("grammars", "krl.lark").read_text()
        _PARSER.append(lark.Lark(text, parser="lalr", propagate_positions=True))
    return _PARSER[0]


def read_krl(src: str, dat: str | None, robot, src_name: str = "<src>", dat_name: str = "<dat>",
             tool: np.ndarray | None = None, frame: np.ndarray | None = None) -> dict:
    """The job document (module docstring) of the .src text ``src`` and .dat text ``dat`` (None or blank: a .src
    without a .dat, as RoboDK's KUKA posts write it) for ``robot`` (a preset name or robot file path, written into the
    document as given); ``src_name``, ``dat_name`` name the files in errors; ``tool``: X_FT (4, 4) [m] of the tool the
    program selects by a number other than 0; ``frame``: the user frame (4, 4) [m] in the robot's base frame that a
    base number other than 0 selects. KrlReadError names what cannot be read."""
    tree = parse_krl(src, "src", src_name)
    data = _Data() if dat is None or not dat.strip() else _Data.of(parse_krl(dat, "dat", dat_name))
    program = _Program(tree, src, data, src_name, has_dat=dat is not None and bool(dat.strip()))
    program.run()
    if not program.motions:
        raise KrlReadError(src_name, "DEF", "the program has no motion (PTP, LIN, CIRC)")
    reader = _Reader(load_robot(robot), src_name, dat_name, tool, frame)
    reader.use_tool(program.motions)
    waypoints = [reader.waypoint(motion, k == 0, k in program.stops) for k, motion in enumerate(program.motions)]
    waypoints = [_with_actions(w, program.actions.get(k, [])) for k, w in enumerate(waypoints)]
    return reader.document(str(robot), waypoints, program)


def load_krl(path: str | Path, robot, tool: np.ndarray | None = None, frame: np.ndarray | None = None) -> dict:
    """``read_krl`` of the files ``path`` with the suffixes .src and .dat (e.g. ``PICK.src`` and ``PICK.dat``)."""
    path = Path(path)
    src, dat = path.with_suffix(".src"), path.with_suffix(".dat")
    return read_krl(src.read_text(), dat.read_text(), robot, str(src), str(dat), tool, frame)


def _with_actions(waypoint, actions: list[dict]):
    """A waypoint with its ``do`` list (a joint list becomes ``{joints: ...}`` to carry it)."""
    if not actions:
        return waypoint
    if isinstance(waypoint, list):
        return {"joints": waypoint, "do": actions}
    return {**waypoint, "do": actions}


def _is_load(name: str) -> bool:
    """Whether the system variable ``name`` is $LOAD or a component of it (not $LOAD_A1.. the loads on the arm)."""
    return name == "$LOAD" or name.startswith("$LOAD.")


def _line(node) -> int | None:
    return getattr(node, "line", None) if isinstance(node, lark.Token) else (
        None if node.meta.empty else node.meta.line)


def _number(node) -> float:
    """A ``number`` node or a bit constant token ('B101') -> its value."""
    if isinstance(node, lark.Token):
        return float(int(str(node)[2:-1], 2))
    return float(node.children[0])


def _component_value(node):
    """An aggregate component's value: a number, bool, enumeration or string text, or a nested mapping."""
    if isinstance(node, lark.Tree):
        return _aggregate(node).values if node.data == "aggregate" else _number(node)
    if node.type == "BITS":
        return _number(node)
    if node.type == "BOOL":
        return str(node).upper() == "TRUE"
    if node.type == "STRING":
        return str(node)[1:-1].strip()
    return str(node).upper()


def _aggregate(node: lark.Tree, line: int | None = None) -> _Point:
    """An aggregate -> a _Point of its type prefix ({FRAME: ...}, else None) and its components."""
    children = list(node.children)
    kind = str(children.pop(0)).upper() if children and isinstance(children[0], lark.Token) else None
    values = {str(c.children[0]).upper(): _component_value(c.children[-1]) for c in children}
    return _Point(kind, values, line if line is not None else _line(node))


def _text(node, env: dict) -> str:
    """``$VEL.CP``, ``$VEL_AXIS[1]``, ``TOOL_DATA[2]``: the upper-case text of a system variable or variable, a FOR
    variable in an index replaced by its value (``env``)."""
    name, *rest = node.children
    text = str(name).upper()
    for part in rest:
        if part.data == "field":
            text += f".{str(part.children[0]).upper()}"
            continue
        index = part.children[0]
        if index is None:
            text += "[]"
        elif index.type == "INT":
            text += f"[{int(index)}]"
        else:
            text += f"[{env.get(str(index).upper(), str(index).upper())}]"
    return text


def _value(node, env: dict):
    """An assigned value: a number, bool, enumeration (#X) or text, a _Point of an aggregate, or the text of a
    (system) variable."""
    if isinstance(node, lark.Token):
        return _component_value(node)
    if node.data == "number":
        return _number(node)
    if node.data == "aggregate":
        return _aggregate(node)
    return _text(node, env)


def _indexed(text: str, names: tuple[str, ...]) -> int | None:
    """n of ``NAME[n]`` for NAME in ``names`` (``TOOL_DATA[2]`` -> 2), else None."""
    match = re.fullmatch(r"([A-Z_]+)\[(\d+)\]", text)
    return int(match[2]) if match and match[1] in names else None


@dataclass
class _Data:
    """The declarations of a file: points and records by upper-case name, SIGNAL names -> (direction, number)."""

    points: dict = field(default_factory=dict)
    signals: dict = field(default_factory=dict)

    @classmethod
    def of(cls, node: lark.Tree) -> _Data:
        data = cls()
        for child in node.children:
            if isinstance(child, lark.Tree):
                data.add(child, {})
        return data

    def add(self, node: lark.Tree, env: dict) -> None:
        """Take a ``decl``, ``signal_decl`` or a .dat assignment to a point (``P[1]={...}``)."""
        if node.data == "decl":
            kind = str(node.children[0]).upper()
            names = [c for c in node.children[1:] if isinstance(c, lark.Tree) and c.data == "decl_name"]
            value = node.children[-1]
            if isinstance(value, lark.Tree) and value.data == "aggregate" and len(names) == 1:
                point = _aggregate(value, _line(node))
                self.points[str(names[0].children[0]).upper()] = replace(point, type=kind)
        elif node.data == "signal_decl":
            name, first, last = node.children
            self.signals[str(name).upper()] = (_text(first, env), None if last is None else _text(last, env),
                                               _line(node))
        elif node.data == "assignment" and isinstance(node.children[1], lark.Tree) \
                and node.children[1].data == "aggregate" and node.children[0].data == "variable":
            name = _text(node.children[0], env)
            base = re.sub(r"\[.*", "", name)
            kind = next((p.type for k, p in self.points.items() if k == base), None)
            self.points[name] = replace(_aggregate(node.children[1], _line(node)), type=kind)


@dataclass
class _Program:
    """The main routine of a .src walked in order (module docstring): its motions, each waypoint's actions (``do``
    entries), the waypoints where the advance run stops, the signals used and the LOOP read as one cycle."""

    tree: lark.Tree
    text: str
    data: _Data
    source: str
    motions: list = field(default_factory=list)
    actions: dict = field(default_factory=dict)
    stops: set = field(default_factory=set)
    signals: dict = field(default_factory=dict)
    loop_line: int | None = None
    settings: dict = field(default_factory=dict)
    records: dict = field(default_factory=dict)
    tool: _Frame = field(default_factory=_Frame)
    base: _Frame = field(default_factory=_Frame)
    interrupts: set = field(default_factory=set)
    timed: tuple | None = None
    in_advance: bool = False
    triggered: list | None = None
    pending: list = field(default_factory=list)
    calls: tuple = ()
    has_dat: bool = True
    load: dict = field(default_factory=dict)
    load_line: int | None = None
    tool_load: Payload | None = None
    loads: list = field(default_factory=list)
    held: list = field(default_factory=list)
    parts: dict = field(default_factory=dict)

    def fail(self, node, field_name: str, problem: str, value=None):
        raise KrlReadError(self.source, field_name, problem, value=value, line=_line(node) if node is not None else None)

    def run(self) -> None:
        """Walk the main routine (the first DEF)."""
        routines = {str(r.children[0].children[0]).upper(): r for r in self.tree.children}
        self.routines = routines
        main = self.tree.children[0]
        items = self.items(main)
        self.walk(items, {}, top=True)
        self.load_changed()

    def items(self, routine: lark.Tree) -> list:
        """A routine's statements and its full-line comments (not fold lines), in line order."""
        start, end = routine.meta.line, routine.meta.end_line
        lines = self.text.splitlines()
        comments = []
        for number in range(start + 1, min(end, len(lines)) + 1):
            text = lines[number - 1].strip()
            pendant = COMMENT_FOLD.match(text)
            if pendant:
                comments.append((number, pendant[1]))
            elif text.startswith(";") and not re.match(r";\s*(END)?FOLD\b", text, re.IGNORECASE):
                comments.append((number, text[1:].strip()))
        statements = [(_line(s), s) for s in routine.children[1:]]
        return [item for _, item in sorted(comments + statements, key=lambda pair: pair[0])]

    def walk(self, items: list, env: dict, top: bool = False) -> None:
        """Read ``items`` in order, blocks flattened (module docstring)."""
        i = 0
        while i < len(items):
            item = items[i]
            if not self.is_load(item, env):
                self.load_changed()
            if isinstance(item, str):
                self.comment(item)
                i += 1
                continue
            kind = item.data
            if kind in ("for_start", "loop_start", "if_start"):
                end = self.block_end(items, i)
                body = items[i + 1:end]
                if kind == "for_start":
                    self.for_loop(item, body, env)
                elif kind == "loop_start":
                    self.loop(item, items, end, body, env, top)
                else:
                    self.if_block(item, body, env)
                i = end + 1
                continue
            if kind in ("for_end", "loop_end", "if_end"):
                self.fail(item, kind.split("_")[0].upper(), f"END{kind.split('_')[0].upper()} without its start")
            self.statement(item, env)
            i += 1

    def block_end(self, items: list, i: int) -> int:
        """The index of the end of the block that starts at items[i]."""
        start = items[i].data
        end_kind, depth = start.replace("_start", "_end"), 0
        for j in range(i, len(items)):
            if isinstance(items[j], str):
                continue
            depth += items[j].data == start
            depth -= items[j].data == end_kind
            if depth == 0:
                return j
        self.fail(items[i], start.split("_")[0].upper(), f"has no END{start.split('_')[0].upper()}")

    def for_loop(self, node, body: list, env: dict) -> None:
        """A FOR over constants, flattened: its body once per value, the variable's value in indices."""
        name, first, last, step = node.children
        first, last = _number(first), _number(last)
        step = 1.0 if step is None else _number(step)
        if step == 0 or any(v != int(v) for v in (first, last, step)):
            self.fail(node, "FOR", "a FOR over whole-number constants with a step other than 0 is read", step)
        values = range(int(first), int(last) + (1 if step > 0 else -1), int(step))
        for value in values:
            self.walk(body, {**env, str(name).upper(): value})

    def loop(self, node, items: list, end: int, body: list, env: dict, top: bool) -> None:
        """The outermost endless LOOP that ends the main routine: one cycle; any other LOOP is refused."""
        after = [item for item in items[end + 1:] if not isinstance(item, str)]
        if not top or after or self.loop_line is not None:
            self.fail(node, "LOOP", "only an outermost endless LOOP ending the main routine is read (as one cycle); "
                      "this one repeats a part of the program an unknown number of times")
        self.loop_line = _line(node)
        self.walk(body, env)

    def if_block(self, node, body: list, env: dict) -> None:
        """IF: only the timeout pattern of ``write_krl`` (module docstring)."""
        statements = [item for item in body if not isinstance(item, str)]
        condition = self.input_test(node.children[0], env)
        if self.timed is None or condition is None or len(statements) != 1 or statements[0].data != "halt" \
                or condition != (self.timed[0], not self.timed[1]):
            self.fail(node, "IF", "a branch on an input or a variable has no static meaning (only the timeout "
                      "pattern WAIT FOR <input> OR ($TIMER[n] > ms), IF <not input> THEN HALT ENDIF is read)")
        self.timed = None

    def statement(self, node, env: dict) -> None:
        """One statement (module docstring)."""
        handler = getattr(self, f"on_{node.data}", None)
        if handler is None:
            self.fail(node, node.data.upper(), _refusal(self.line_text(node)))
        handler(node, env)
        if node.data != "continue_stmt":
            self.in_advance = False

    def line_text(self, node) -> str:
        line = _line(node)
        return self.text.splitlines()[line - 1].split(";")[0].strip() if line else ""

    # ---- statements
    def on_assignment(self, node, env: dict) -> None:
        target, value = node.children
        name = _text(target, env)
        value = _value(value, env)
        if target.data == "sysvar":
            self.system_variable(node, name, value)
        else:
            self.variable(node, name, value)

    def system_variable(self, node, name: str, value) -> None:
        """An assignment to a system variable: an output, the timer of the timeout pattern, the tool or base, or a
        setting kept for the motions after it."""
        if re.fullmatch(r"\$OUT\[\d+\]", name):
            self.output(node, name, value)
        elif re.fullmatch(r"\$TIMER(_STOP)?\[\d+\]", name):
            return
        elif name == "$TOOL":
            self.tool = self.frame_of(node, value, "$TOOL", ("TOOL_DATA",))
        elif name == "$BASE":
            self.base = self.frame_of(node, value, "$BASE", ("BASE_DATA",))
        elif name == "$IPO_MODE" and value != "#BASE":
            self.fail(node, name, "must be #BASE here (a robot-held tool; #TCP is an external tool)", value)
        elif _is_load(name):
            self.assign_load(node, name, value)
        else:
            self.settings[name] = value

    # ---- the load (module docstring, "Load")
    def is_load(self, item, env: dict) -> bool:
        """Whether ``item`` (a statement or comment) assigns $LOAD or one of its components."""
        return (isinstance(item, lark.Tree) and item.data == "assignment" and item.children[0].data == "sysvar"
                and _is_load(_text(item.children[0], env)))

    def assign_load(self, node, name: str, value) -> None:
        """A $LOAD assignment: its components kept for the load change it is part of (``load_changed``)."""
        fields = LOAD_FIELDS.get(name)
        if fields is None:
            self.fail(node, name, f"is not read (read: {', '.join(LOAD_FIELDS)})", value)
        values = value.values if isinstance(value, _Point) and len(fields) > 1 else {fields[0]: value}
        for key, component in values.items():
            if key not in fields:
                self.fail(node, name, f"has no component {key} (read: {', '.join(fields)})", value)
            wanted = float if key == "M" else dict
            if not isinstance(component.values if isinstance(component, _Point) else component, wanted):
                self.fail(node, f"{name} {key}" if len(fields) > 1 else name,
                          "must be a number [kg]" if key == "M" else "must be an aggregate {X, Y, Z...}", component)
            self.load[key] = component.values if isinstance(component, _Point) else component
        self.load_line = self.load_line or _line(node)

    def current_load(self) -> Payload | None:
        """The load the components assigned so far make, in $FLANGE (None: M 0 or none assigned)."""
        mass = self.load.get("M", 0.0)
        if mass <= MASS_TOLERANCE_KG:
            return None
        cm, j = self.load.get("CM", {}), self.load.get("J", {})
        for key, part in (("CM", cm), ("J", j)):
            if any(not isinstance(v, float) for v in part.values()):
                raise KrlReadError(self.source, f"$LOAD.{key}", "must hold numbers", value=part, line=self.load_line)
        R = abc_rotation(cm.get("A", 0.0), cm.get("B", 0.0), cm.get("C", 0.0))
        inertia = R @ np.diag([j.get(k, 0.0) for k in "XYZ"]) @ R.T
        com = np.array([cm.get(k, 0.0) for k in "XYZ"]) / 1000.0
        return Payload(float(mass), com, inertia, f"{self.source}:{self.load_line} $LOAD")

    def load_changed(self) -> None:
        """The load assignments since the last change, read (module docstring, "Load"): before the first motion the
        tool's load, after it a grip or release on the last motion's waypoint."""
        if self.load_line is None:
            return
        line, new = self.load_line, self.current_load()
        self.load_line = None
        if not self.motions:
            self.tool_load = new
            return
        if not self.loads:
            self.loads = [self.tool_load]
        earlier = next((i for i, load in enumerate(self.loads) if same_load(load, new, *LOAD_MATCH)), None)
        if earlier is not None:
            for name in reversed(self.held[earlier:]):
                self.actions.setdefault(len(self.motions) - 1, []).append({RELEASE: name})
            del self.loads[earlier + 1:], self.held[earlier:]
            return
        previous = self.loads[-1]
        name = PART_NAME.format(len(self.parts) + 1)
        part = None if new is None or new.mass <= (0.0 if previous is None else previous.mass) + LOAD_MATCH[0] else (
            Payload(new.mass, new.com, new.inertia, new.source, name) if previous is None else
            removed(new, previous, name))
        if part is None:
            raise KrlReadError(self.source, "$LOAD", "a load after the first motion is read as a part gripped (more "
                               "mass than the load before) or released (back to an earlier load); this one is "
                               "neither", line=line)
        self.parts[name] = part
        self.loads.append(new)
        self.held.append(name)
        self.actions.setdefault(len(self.motions) - 1, []).append({GRIP: name})
        self.stops.add(len(self.motions) - 1)

    def frame_of(self, node, value, name: str, tables: tuple[str, ...]) -> _Frame:
        """The tool or base a $TOOL / $BASE assignment selects."""
        if isinstance(value, _Point):
            return _Frame(values=value.values, line=_line(node))
        if value in ROBOT_BASES or (name == "$TOOL" and value == "$NULLFRAME"):
            return _Frame(number=0, line=_line(node))
        number = _indexed(value, tables) if isinstance(value, str) else None
        if number is None:
            self.fail(node, name, f"must be a frame {{X, Y, Z, A, B, C}}, {' or '.join(tables)}[n] or the robot's base",
                      value)
        return _Frame(number=number, line=_line(node))

    def variable(self, node, name: str, value) -> None:
        """PDAT_ACT / LDAT_ACT / FDAT_ACT (an inline form's data), or a SIGNAL output's name."""
        if name in ("PDAT_ACT", "LDAT_ACT", "FDAT_ACT"):
            record = value if isinstance(value, _Point) else self.data.points.get(value)
            self.records[name] = record
            if name == "FDAT_ACT":
                self.select_frames(node, record, value)
            return
        if name in self.data.signals:
            self.output(node, name, value)
            return
        self.fail(node, name, "an assignment to a program variable is not read (its value matters only when the "
                  "robot runs); read are system variables, PDAT_ACT, LDAT_ACT, FDAT_ACT and SIGNAL outputs", value)

    def select_frames(self, node, record: _Point | None, name) -> None:
        """FDAT_ACT's TOOL_NO and BASE_NO (an FDAT the file does not hold, e.g. $config.dat's FHOME: unknown)."""
        if record is None:
            self.tool = self.base = _Frame(unknown=str(name), line=_line(node))
            return
        if record.values.get("IPO_FRAME", "#BASE") != "#BASE":
            self.fail(node, "IPO_FRAME", "must be #BASE here (a robot-held tool)", record.values.get("IPO_FRAME"))
        self.tool = _Frame(number=int(record.values.get("TOOL_NO", 0)), line=_line(node))
        self.base = _Frame(number=int(record.values.get("BASE_NO", 0)), line=_line(node))

    def on_motion(self, node, env: dict) -> None:
        motion = node.children[0]
        points = [c for c in motion.children if not (isinstance(c, lark.Tree) and c.data == "approx")]
        approx = tuple(str(t).upper() for c in motion.children if isinstance(c, lark.Tree) and c.data == "approx"
                       for t in c.children)
        if any(isinstance(p, lark.Token) and p.type == "SYSNAME" for p in points):
            self.live_motion(node, motion, approx)
            return
        target, target_name = self.point(points[-1], node)
        aux, aux_name = self.point(points[0], node) if len(points) == 2 else (None, None)
        self.motions.append(_Motion(motion.data, target, target_name, aux, aux_name, approx, _line(node),
                                    dict(self.settings), self.tool, self.base, self.records.get("PDAT_ACT")))
        if self.pending:
            self.actions.setdefault(len(self.motions) - 1, []).extend(self.pending)
            self.pending = []

    def live_motion(self, node, motion: lark.Tree, approx: tuple) -> None:
        """``PTP $AXIS_ACT`` before every other motion, exact: read past (module docstring); any other motion to a
        system variable is refused."""
        text = self.line_text(node)
        first = not self.motions and motion.data == "ptp" and not approx
        if first and str(motion.children[0]).upper() == "$AXIS_ACT":
            return
        self.fail(node, text, _refusal(text) if any(w in text.upper() for w in LIVE_POSITIONS) else
                  "a motion to a system variable is read only as PTP $AXIS_ACT before every other motion")

    def point(self, node, statement) -> tuple[_Point, str]:
        """A motion's point and its name (an aggregate's text)."""
        if isinstance(node, lark.Tree):
            return _aggregate(node, _line(statement)), self.line_text(statement).split(None, 1)[-1]
        name = str(node).upper()
        point = self.data.points.get(name)
        if point is None and name in HOME_NAMES:
            point = _Point("E6AXIS", dict(HOME), _line(statement))
        if point is None:
            where = "in the .dat (nor the .src)" if self.has_dat else "in the .src, and no .dat is beside it"
            self.fail(statement, name, f"is not declared as E6POS, POS, E6AXIS, AXIS or FRAME {where}")
        return point, name

    def on_bas_call(self, node, env: dict) -> None:
        """BAS(#command, value) of the inline forms (module docstring)."""
        command, argument = node.children
        command = str(command).upper()
        value = None if argument is None else _number(argument)
        if command in IGNORED_BAS:
            return
        if command in ("#PTP_PARAMS", "#VEL_PTP", "#PTP_DAT"):
            self.ptp_params(node, command, value)
        elif command in ("#CP_PARAMS", "#VEL_CP", "#CP_DAT"):
            self.cp_params(node, command, value)
        elif command in ("#TOOL", "#BASE"):
            frame = _Frame(number=int(value or 0), line=_line(node))
            setattr(self, command[1:].lower(), frame)
        elif command == "#FRAMES":
            self.select_frames(node, self.records.get("FDAT_ACT"), "FDAT_ACT")
        else:
            self.fail(node, f"BAS({command})", "is not read here (read: #INITMOV, #PTP_PARAMS, #CP_PARAMS, #VEL_PTP, "
                      "#VEL_CP, #PTP_DAT, #CP_DAT, #TOOL, #BASE, #FRAMES, #ACC_*)")

    def ptp_params(self, node, command: str, value: float | None) -> None:
        """The PTP speed [%] (the argument, or PDAT_ACT's VEL for #PTP_DAT) and, for the parameters of an inline form,
        PDAT_ACT's APO_DIST as $APO.CDIS."""
        pdat = self.records.get("PDAT_ACT")
        if command == "#PTP_DAT":
            value = self.record_value(pdat, "VEL")
        for i in range(1, 7):
            self.settings[f"$VEL_AXIS[{i}]"] = value
        if command != "#VEL_PTP" and pdat is not None and "APO_DIST" in pdat.values:
            self.settings["$APO.CDIS"] = pdat.values["APO_DIST"]

    def cp_params(self, node, command: str, value: float | None) -> None:
        """The CP speed [m/s] (the argument, or LDAT_ACT's VEL for #CP_DAT) and LDAT_ACT's APO_DIST as $APO.CDIS."""
        ldat = self.records.get("LDAT_ACT")
        if command == "#CP_DAT":
            value = self.record_value(ldat, "VEL")
        self.settings["$VEL.CP"] = value
        if command != "#VEL_CP" and ldat is not None and "APO_DIST" in ldat.values:
            self.settings["$APO.CDIS"] = ldat.values["APO_DIST"]

    @staticmethod
    def record_value(record: _Point | None, key: str) -> float | None:
        """A record's number ``key``; None where the file does not hold the record (e.g. $config.dat's PDEFAULT):
        a motion that needs it is refused naming its line."""
        value = None if record is None else record.values.get(key)
        return value if isinstance(value, float) else None

    def on_wait_sec(self, node, env: dict) -> None:
        time_s = _number(node.children[0])
        if time_s <= 0.0:
            return
        self.add_action(node, {WAIT: round(time_s, 6)})

    def on_wait_for(self, node, env: dict) -> None:
        """WAIT FOR <input test> [OR ($TIMER[n] > ms)] (module docstring)."""
        condition, timeout = node.children[0], None
        if condition.data == "disjunction":
            test, timer = condition.children
            timeout = self.timer_limit(timer, env)
            condition = test if timeout is not None else condition
        wanted = self.input_test(condition, env)
        if wanted is None:
            self.fail(node, "WAIT FOR", "only a wait for one digital input ($IN[n], NOT $IN[n], $IN[n] == TRUE or a "
                      "SIGNAL input), optionally OR ($TIMER[n] > ms), is read", self.line_text(node))
        signal = self.signal(node, wanted[0], INPUT)
        action = {WAIT_INPUT: signal, "value": "on" if wanted[1] else "off"}
        if timeout is not None:
            action["timeout"] = timeout
            self.timed = wanted
        self.add_action(node, action)

    def timer_limit(self, node, env: dict) -> float | None:
        """ms / 1000 [s] of ``$TIMER[n] > ms``, else None."""
        if node.data != "compare" or str(node.children[1]) != ">" or not isinstance(node.children[0], lark.Tree) \
                or node.children[0].data != "sysvar":
            return None
        if not re.fullmatch(r"\$TIMER\[\d+\]", _text(node.children[0], env)):
            return None
        limit = node.children[2]
        return _number(limit) / 1000.0 if isinstance(limit, lark.Tree) and limit.data == "number" else None

    def input_test(self, node, env: dict) -> tuple[str, bool] | None:
        """(input, value) of a test of one input: ``$IN[n]``, ``NOT ...``, ``... == TRUE``, a SIGNAL name; else None."""
        if isinstance(node, lark.Tree) and node.data == "negation":
            inner = self.input_test(node.children[0], env)
            return None if inner is None else (inner[0], not inner[1])
        if isinstance(node, lark.Tree) and node.data == "compare":
            left, op, right = node.children
            inner = self.input_test(left, env)
            if inner is None or not isinstance(right, lark.Token) or right.type != "BOOL" or str(op) not in ("==",
                                                                                                         "<>"):
                return None
            value = (str(right).upper() == "TRUE") == (str(op) == "==")
            return inner[0], inner[1] == value
        if isinstance(node, lark.Tree) and node.data in ("sysvar", "variable"):
            name = _text(node, env)
            if re.fullmatch(r"\$IN\[\d+\]", name) or name in self.data.signals:
                return name, True
        return None

    def on_pulse(self, node, env: dict) -> None:
        target, level, time_s = node.children
        if str(level).upper() != "TRUE":
            self.fail(node, "PULSE", "a pulse of FALSE (an output off for a time) is not an action of a job", level)
        name = _text(target, env)
        self.add_action(node, {PULSE: self.signal(node, name, OUTPUT), "time": round(_number(time_s), 6)},
                        stops=not self.in_advance)

    def output(self, node, name: str, value) -> None:
        if not isinstance(value, bool):
            self.fail(node, name, "an output is set to TRUE or FALSE here", value)
        advance = self.in_advance
        self.add_action(node, {SET: self.signal(node, name, OUTPUT), "value": "on" if value else "off"},
                        stops=not advance)

    def signal(self, node, name: str, direction: str) -> str:
        """The document's name of ``$OUT[n]``/``$IN[n]`` (do<n>/di<n>) or a SIGNAL's, entered in ``signals``."""
        declared = self.data.signals.get(name)
        if declared is not None:
            port, last, _ = declared
            if last is not None:
                self.fail(node, name, "a SIGNAL of several bits (TO) is not a digital signal of a job")
            label, text = name.lower(), port
        else:
            label, text = None, name
        match = re.fullmatch(r"\$(OUT|IN)\[(\d+)\]", text)
        if match is None or (match[1] == "OUT") != (direction == OUTPUT):
            self.fail(node, name, f"must be a digital {direction} ($OUT[n] / $IN[n] or a SIGNAL of one)", text)
        number = int(match[2])
        label = label or f"{'do' if direction == OUTPUT else 'di'}{number}"
        self.signals[label] = {direction: number}
        return label

    def add_action(self, node, action: dict, stops: bool = True) -> None:
        """``action`` for the waypoint of the last motion (the first waypoint before any), or, inside a TRIGGER, for
        the next motion's; ``stops``: the advance run stops there, so that waypoint is an exact stop."""
        if self.triggered is not None:
            self.triggered.append(action)
            return
        k = max(len(self.motions) - 1, 0)
        self.actions.setdefault(k, []).append(action)
        if stops and self.motions:
            self.stops.add(k)

    def comment(self, text: str) -> None:
        """A full-line comment after the first motion -> a comment action (quotes dropped, at most
        MAX_COMMENT_CHARS)."""
        text = text.replace('"', "").replace("'", "").strip()[:MAX_COMMENT_CHARS].strip()
        if self.motions and text and text.isprintable():
            self.actions.setdefault(len(self.motions) - 1, []).append({COMMENT: text})

    def on_trigger(self, node, env: dict) -> None:
        """TRIGGER WHEN DISTANCE=1 DELAY=0 DO <output or PULSE>: an action of the next motion's waypoint, switched
        in the middle of its approximation contour (no exact stop)."""
        where, distance, delay, statement, _ = node.children
        if str(where).upper() != "DISTANCE" or _number(distance) != 1.0 or _number(delay) != 0.0 \
                or statement.data == "call":
            self.fail(node, "TRIGGER", REFUSED_WORDS["TRIGGER"], self.line_text(node))
        self.triggered = []
        try:
            handler = self.on_pulse if statement.data == "pulse" else self.on_assignment
            handler(statement, env)
            if not self.triggered or any(SET not in a and PULSE not in a for a in self.triggered):
                self.fail(node, "TRIGGER", REFUSED_WORDS["TRIGGER"], self.line_text(node))
            self.pending += self.triggered
        finally:
            self.triggered = None

    def on_halt(self, node, env: dict) -> None:
        self.fail(node, "HALT", "the program stops until the operator starts it again: no static meaning (read only "
                  "in the timeout pattern of a WAIT FOR)")

    def on_continue_stmt(self, node, env: dict) -> None:
        self.in_advance = True

    def on_interrupt_decl(self, node, env: dict) -> None:
        number, _, routine = node.children
        if str(routine).upper() != STOP_HANDLER:
            self.fail(node, "INTERRUPT", REFUSED_WORDS["INTERRUPT"] + f" (read past: only the INI fold's "
                      f"{STOP_HANDLER} stop handler)", str(routine))
        self.interrupts.add(int(number))

    def on_interrupt_on(self, node, env: dict) -> None:
        if int(node.children[0]) not in self.interrupts:
            self.fail(node, "INTERRUPT", REFUSED_WORDS["INTERRUPT"], int(node.children[0]))

    def on_decl(self, node, env: dict) -> None:
        self.data.add(node, env)

    def on_signal_decl(self, node, env: dict) -> None:
        self.data.add(node, env)

    def on_ext_decl(self, node, env: dict) -> None:
        return

    def on_call(self, node, env: dict) -> None:
        """A call of a parameterless routine of the file, read in place; any other call is refused."""
        name = str(node.children[0]).upper()
        if name in IGNORED_CALLS:
            return
        routine = self.routines.get(name)
        args = [c for c in node.children[1:] if c is not None]
        if routine is None or args or routine.children[0].children[1:] != [None] or name in self.calls:
            problem = ("a call of a routine not in the file has no static meaning here (its motions are elsewhere)"
                       if routine is None else "a call with parameters, or a recursive call, is not read")
            self.fail(node, f"{name}()", _refusal(name) if name.startswith(("EKI_", "RSI_")) else problem)
        self.calls += (name,)
        self.walk(self.items(routine), env)
        self.calls = self.calls[:-1]


class _Reader:
    """The waypoints of the motions, with the robot, its tool and the caller's tool and frame."""

    def __init__(self, robot: Robot, src_name: str, dat_name: str, tool: np.ndarray | None,
                 frame: np.ndarray | None):
        self.robot, self.src_name, self.dat_name = robot, src_name, dat_name
        self.given_tool, self.given_frame = tool, frame
        self.X_FT = np.eye(4)
        self.robot_tool = robot
        self.start: np.ndarray | None = None
        self.numbers = {"tool": set(), "frame": set()}

    def fail(self, motion: _Motion, field_name: str, problem: str, value=None):
        raise KrlReadError(self.src_name, field_name, problem, value=value, line=motion.line)

    def use_tool(self, motions: list[_Motion]) -> None:
        """The tool of the motions that use it (pose targets, LIN and CIRC); all the same (a job has one tool)."""
        found = None
        for motion in motions:
            if motion.kind == "ptp" and motion.target.type in AXIS_TYPES:
                continue
            X = self.tool_pose(motion)
            if found is not None and not np.allclose(X, found, atol=1e-12):
                self.fail(motion, "$TOOL", "differs from an earlier motion's: a job has one tool")
            found = X
        if found is not None:
            self.X_FT = found
            self.robot_tool = robot_with_tool(self.robot, found)

    def tool_pose(self, motion: _Motion) -> np.ndarray:
        """X_FT (4, 4) [m] of the motion's tool selection."""
        tool = motion.tool
        if tool.values is not None:
            return controller_frames(self.robot, KUKA)[1] @ self.frame(tool.values, motion, "$TOOL")
        if tool.unknown is not None:
            self.fail(motion, tool.unknown, "selects a tool the file does not hold (FDAT_ACT of a record not in the "
                      ".dat): a pose target needs its tool")
        if not tool.number:
            return controller_frames(self.robot, KUKA)[1]
        return self.given(motion, tool, "tool", self.given_tool, "X_FT of the tool, (4, 4) [m]")

    def base_pose(self, motion: _Motion) -> np.ndarray:
        """The motion's base frame (4, 4) [m] in $ROBROOT."""
        base = motion.base
        if base.values is not None:
            return self.frame(base.values, motion, "$BASE")
        if base.unknown is not None:
            self.fail(motion, base.unknown, "selects a base the file does not hold (FDAT_ACT of a record not in the "
                      ".dat): a pose target needs its base")
        if not base.number:
            return np.eye(4)
        return self.given(motion, base, "frame", self.given_frame, "the user frame in the robot's base frame, (4, 4) "
                          "[m]")

    def given(self, motion: _Motion, selection: _Frame, keyword: str, value, what: str) -> np.ndarray:
        """The caller's ``tool`` / ``frame`` for a selection by number (one number per program)."""
        self.numbers[keyword].add(selection.number)
        if value is None:
            raise KrlReadError(self.src_name, f"{keyword} {selection.number}", f"the program selects {keyword} "
                               f"number {selection.number}, whose data is on the controller, not in the file: pass "
                               f"it ({keyword}= {what})", line=selection.line or motion.line)
        if len(self.numbers[keyword]) > 1:
            self.fail(motion, keyword, f"the program selects {keyword} numbers {sorted(self.numbers[keyword])}: one "
                      f"{keyword} is read")
        return np.asarray(value, dtype=float)

    def frame(self, values: dict, motion: _Motion, name: str) -> np.ndarray:
        """The pose (4, 4) [m] of components X, Y, Z [mm], A, B, C [deg]."""
        missing = [k for k in "XYZABC" if not isinstance(values.get(k), float)]
        if missing:
            self.fail(motion, name, f"has no number {', '.join(missing)}: a frame needs X, Y, Z, A, B, C (a partial "
                      "aggregate takes the rest from where the robot is)")
        X = np.eye(4)
        X[:3, :3] = abc_rotation(values["A"], values["B"], values["C"])
        X[:3, 3] = np.array([values["X"], values["Y"], values["Z"]]) / 1000.0
        return X

    def in_base(self, X: np.ndarray, motion: _Motion) -> np.ndarray:
        """A pose (4, 4) [m] in the motion's base -> in our base frame."""
        return controller_frames(self.robot, KUKA)[0] @ self.base_pose(motion) @ X

    def joints(self, point: _Point, name: str, motion: _Motion) -> np.ndarray:
        """The joint values (6,) [rad] of an E6AXIS / AXIS point (the inverse KUKA axis map)."""
        missing = [f"A{i}" for i in range(1, 7) if not isinstance(point.values.get(f"A{i}"), float)]
        if missing:
            self.fail(motion, name, f"has no {', '.join(missing)}: an axis point needs A1..A6 (a partial aggregate "
                      "takes the rest from where the robot is)")
        mapping = axis_map(self.robot, KUKA)
        angles = np.array([point.values[f"A{i}"] for i in range(1, 7)])
        return np.radians((angles - np.array(mapping.offset)) * np.array(mapping.direction))

    def point_type(self, point: _Point, name: str, motion: _Motion) -> str:
        """The point's type: declared, or from its components (A1.. an axis point, X.. a pose)."""
        if point.type in AXIS_TYPES + POSE_TYPES:
            return point.type
        if point.type is None and "A1" in point.values:
            return "E6AXIS"
        if point.type is None and "X" in point.values:
            return "E6POS"
        self.fail(motion, name, f"is a {point.type or 'aggregate'}: a target is an E6POS, POS, E6AXIS, AXIS or FRAME")

    def waypoint(self, motion: _Motion, first: bool, stops: bool) -> dict | list:
        """One motion's waypoint (module docstring); ``stops``: the advance run stops after it (an exact stop)."""
        if first and motion.approx:
            self.fail(motion, motion.approx[0], "the first motion is where the job starts: it ends at rest there")
        kind = self.point_type(motion.target, motion.target_name, motion)
        if kind in AXIS_TYPES:
            q = self.joints(motion.target, motion.target_name, motion)
            if motion.kind == "ptp":
                joints = [round(float(v), 10) for v in np.degrees(q)]
                if first:
                    return joints
                return {"joints": joints, **self.speed_and_zone(motion, stops)}
            waypoint = self.pose_waypoint(self.robot_tool.fk(q), configuration_labels(self.robot_tool, q[None])[0])
        else:
            X = self.in_base(self.frame(motion.target.values, motion, motion.target_name), motion)
            waypoint = self.pose_waypoint(X, self.branch(X, motion.target, motion, first))
        if first:
            return waypoint
        waypoint["move"] = MOVE_KINDS[motion.kind]
        if motion.aux is not None:
            if self.point_type(motion.aux, motion.aux_name, motion) not in POSE_TYPES:
                self.fail(motion, motion.aux_name, "is an axis point: a CIRC's auxiliary point here is a FRAME, POS or "
                          "E6POS")
            aux = self.in_base(self.frame(motion.aux.values, motion, motion.aux_name), motion)
            waypoint["via"] = {"xyz": aux[:3, 3].tolist()}
        return {**waypoint, **self.speed_and_zone(motion, stops)}

    def pose_waypoint(self, X: np.ndarray, label: str) -> dict:
        quaternion, position = pose_to_quaternion_position(X)
        waypoint = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if label:
            waypoint["config"] = label_parts(label)
        return waypoint

    def branch(self, X: np.ndarray, point: _Point, motion: _Motion, first: bool) -> str:
        """The branch label of pose X (4, 4) [m] with the point's S and T ("" without them): the one solution
        ``select_solution`` picks, or, where 2 pi variants share S and T, their common branch."""
        if not isinstance(point.values.get("S"), float) or not isinstance(point.values.get("T"), float):
            return ""
        status_turn = (int(point.values["S"]), int(point.values["T"]))
        try:
            q = select_solution(self.robot_tool, X, status_turn, KUKA)
        except ConfigurationNotFoundError as exc:
            labels = self.labels_with(X, status_turn)
            if len(labels) != 1:
                self.fail(motion, motion.target_name, str(exc))
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

    def speed_and_zone(self, motion: _Motion, stops: bool) -> dict:
        """``speed`` ($VEL_AXIS [%] of a PTP, $VEL.CP [m/s] of a LIN or CIRC) and ``zone`` [m] (C_DIS; 0 where the
        advance run stops after the motion)."""
        out = {"speed": self.speed(motion)}
        allowed = ("C_DIS", "C_PTP") if motion.kind == "ptp" else ("C_DIS",)
        extra = [a for a in motion.approx if a not in allowed]
        if extra:
            self.fail(motion, extra[0], "is not read here: only C_DIS (an approximation distance, $APO.CDIS [mm]), "
                      "or C_PTP on a PTP with $APO.CDIS set, gives a zone")
        if motion.approx and not stops:
            if "C_PTP" in motion.approx and motion.pdat is not None and motion.pdat.values.get("APO_MODE") == "#CPTP":
                self.fail(motion, "APO_MODE", "#CPTP: the PDAT's APO_DIST is a percentage of $APO_DIS_PTP, no "
                          "distance")
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
                self.fail(motion, "$VEL.CP", "must be set to a positive TCP speed [m/s] before a LIN or CIRC (by "
                          "$VEL.CP or BAS(#CP_PARAMS, v)); without it the speed is the controller's default, which "
                          "the file does not hold", cp)
            return cp
        percents = [motion.settings.get(f"$VEL_AXIS[{i}]") for i in range(1, 7)]
        if not all(isinstance(p, float) for p in percents) or len(set(percents)) != 1 or not 0 < percents[0] <= 100:
            self.fail(motion, "$VEL_AXIS", "must be set to one percentage in (0, 100] on all six axes before a PTP "
                      "(by $VEL_AXIS[i] or BAS(#PTP_PARAMS, v)); a job's joint move has one fraction of the axes' "
                      "speed limits", percents)
        return percents[0]

    def document(self, robot: str, waypoints: list, program: _Program) -> dict:
        doc = {"robot": robot, "length_unit": "m", "angle_unit": "deg", "waypoints": waypoints}
        if not np.allclose(self.X_FT, np.eye(4), atol=1e-12):
            quaternion, position = pose_to_quaternion_position(self.X_FT)
            doc["tool"] = {"xyz": position.tolist(), "quaternion": quaternion.tolist()}
        if self.start is not None:
            doc["start"] = [round(float(v), 10) for v in np.degrees(self.start)]
        accel = program.motions[-1].settings.get("$ACC.CP")
        if isinstance(accel, float) and accel > 0.0 and any(m.kind != "ptp" for m in program.motions[1:]):
            doc["tcp_accel_max"] = accel
        if program.signals:
            doc["signals"] = dict(program.signals)
        X_F_flange = controller_frames(self.robot, KUKA)[1]
        if program.tool_load is not None:
            doc["payload"] = expressed_in(program.tool_load, X_F_flange).to_document(1.0)
        if program.parts:
            doc["parts"] = {name: expressed_in(part, X_F_flange).to_document(1.0)
                            for name, part in program.parts.items()}
        if program.loop_line is not None:
            doc["description"] = (f"{Path(self.src_name).name}: one cycle of its endless LOOP (line "
                                  f"{program.loop_line}), read by dh-pipeline")
        return doc
