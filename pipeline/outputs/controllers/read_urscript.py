"""``read_urscript(text, robot, source) -> dict``: a URScript program (``.script``), as ``write_urscript`` writes it
or as PolyScope exports it, read back into a job document (a mapping ``pipeline.program.job.parse_job`` accepts).

The program is parsed with ``grammars/urscript.lark`` (package data, also the writer's syntax check; UR's Script
Manual, e-Series SW 5.x). Its statements are then read in order as a static program: what they fix (literal values,
variables assigned from them, arithmetic, indexing, ``pose_trans``/``pose_inv``/``rpy2rotvec``/``rotvec2rpy``/
``d2r``/``r2d`` of such values) is evaluated; what has no static meaning is a ``UrscriptReadError`` naming the
file, the line and the construct (the line's text). What is read (the Script Manual's "Module motion" and
"Module interfaces" for the functions named):

* Moves, one waypoint each (the first move's target is the job's first waypoint, no move into it: the writer's
  approach ``movej`` at the manual's default a and v): ``movej(q, a, v, t, r)``, ``movel(pose, a, v, t, r)``,
  ``movep(pose, a, v, r)`` (a process move: read as a linear move, its constant TCP speed v), ``movec(pose_via,
  pose_to, a, v, r, mode)``, arguments by position or keyword (the manual's defaults for those left out); ``t`` (a
  move time) is refused, ``mode`` must be 0 (the orientation interpolated from start to target, as the writer's).
* Targets: a joint vector q [rad] -> a joint waypoint (``joints`` [deg]). A pose ``p[x, y, z, rx, ry, rz]`` (m,
  rotation vector [rad]) of the TCP in the base frame -> a pose waypoint (xyz [m], unit quaternion [w, x, y, z]);
  ``get_inverse_kin(pose, qnear=q)`` (PolyScope's ``movej`` to a waypoint: ``Waypoint_1_p`` / ``Waypoint_1_q``
  globals) -> the pose, its branch the in-limit solution nearest q. URScript has NO configuration data: the
  controller moves to a pose with the joint solution nearest its current joint values, so a plain pose's branch is
  the one of the in-limit closed-form solution (2 pi variants included) of the robot with the program's tool nearest
  (largest joint difference) the previous target's joint values, written as the waypoint's ``config``
  (``pipeline.model.ik.branches.configuration_labels``). ``movec``'s via is the via pose's position (the manual:
  movec does not use its rotation).
* Speeds: ``movej``'s v [rad/s] is the leading axis's speed -> ``speed`` = 100 x v / (the smallest joint speed
  limit) % (at most 100); a tool move's v [m/s] -> ``speed`` [m/s]; the largest a [m/s^2] of the tool moves ->
  ``tcp_accel_max`` (joint moves' a is not read: the job's joint moves run at the robot's acceleration limits).
  Zones: the blend radius r [m] -> ``zone`` [m] (0 an exact stop); the last waypoint's zone is 0.
* The tool: ``set_tcp(pose)`` (the job's ``tool``; a different one after the first move is refused). The payload
  (``pipeline.program.payload``), as ``write_urscript`` writes it: ``set_target_payload(m, cog, inertia,
  transition_time)`` (SW 5.10 and later) or ``set_payload(m[, cog])`` (the older function, PolyScope's own; inertia
  0), m [kg] >= 0, cog [m] from the flange (none given: [0, 0, 0]), inertia [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2]
  about it; each the TOTAL the flange carries. The last one before the first move is the tool's load (``payload``;
  mass 0: none). After it, one with a larger mass grips a part (``part1``, ``part2``, ... in ``parts``, a ``grip``
  action at the last move's waypoint): the part is the difference (``payload.removed``; a point mass when the
  statement gives no inertia; the name of an equal part gripped before and released, if any), and one back to a
  total carried before (mass, cog and, where given, inertia within LOAD_TOLERANCE) releases the parts gripped since,
  the last first; the same total again changes nothing. Any other change (a smaller mass that is no earlier total,
  e.g. below the tool's load; a difference whose inertia is no body's) is refused, naming the line.
* Actions (``pipeline.program.actions``), at the waypoint of the last move before them (before the first move: at
  waypoint 0): ``set_standard_digital_out(n, b)`` (also ``set_digital_out``), ``set_configurable_digital_out(n, b)``,
  ``set_tool_digital_out(n, b)`` -> set of output ``do<n>``, ``conf_do<n>``, ``tool_do<n>`` (job numbers n, 8 + n,
  16 + n: ``urscript.IO_BANKS``); ``sleep(t)`` -> a wait of t [s]; ``run dh_pulse_N()`` of a thread that is exactly
  (set on, sleep t, set off) -> a pulse of t [s]; PolyScope's Wait node ``while (not(get_standard_digital_in(n) ==
  True)): sync() end`` (also configurable and tool inputs: ``di<n>``, ``conf_di<n>``, ``tool_di<n>``) -> a wait for
  the input without a timeout, and exactly the writer's timeout pattern (``urscript.wait_input_lines``) -> with its
  timeout [s]; a full-line ``# text`` after the first move -> a comment (``comment_text``: PolyScope's quotes
  ``# 'text'`` and other quotes dropped, at most MAX_COMMENT_CHARS characters, as a job's comment holds). The
  ``signals`` table numbers each signal.
* Skipped (named in the job's ``description``): PolyScope's installation settings (``SETUP_CALLS``: gravity,
  safety transition, I/O domains, tool communication, ...), register writes and log messages (``SKIPPED_CALLS``:
  no motion, nothing a job holds), threads that do not move the robot (PolyScope's ``step_count`` thread,
  fieldbus/URCap threads) and their ``run``, function definitions (a call of one is refused), assignments of
  values that are not static (``rpc_factory(...)``: refused only where a move, the tool or an action uses them),
  ``$ n "..."`` markers, ``sync()``. An endless outer loop ``while (True):`` as the program's last statement
  (PolyScope's "Loop forever") is read as one cycle; a loop on a condition the program fixes (PolyScope's "Loop n
  times": ``Loop_1 = 0``, ``while (Loop_1 < n): ... Loop_1 = Loop_1 + 1 end``) is flattened, turn by turn (one
  whose turn leaves its condition's variables as they were, or longer than MAX_TURNS, is refused); ``halt`` ends the
  program. ``write_urscript``'s servoj replay
  (``def certified_replay()`` and the ``if`` choosing it) is skipped: the body of ``def native_moves()`` is read.
* Refused, naming line and construct: ``if`` (even on a variable the program fixes: in a loop forever its
  branches differ from cycle to cycle, e.g. a state machine), ``while`` on an input or a variable that is not
  static (other than the wait patterns),
  a call of a function the program defines or of any other function (socket, rpc, fieldbus method calls,
  ``popup``), ``servoj``/``speedj`` and the like, threads that move the robot, ``kill``, ``return``, ``break``.

After the program's ``end`` one call of the program itself may follow (the writer's trailing ``name()``). The
document: ``robot`` as the caller names it, ``length_unit`` m, ``angle_unit`` deg, ``tool``, ``waypoints``,
``signals`` where actions use them, ``description`` where something was skipped.
"""

from __future__ import annotations

import math
import operator
import re
from dataclasses import dataclass

import lark
import numpy as np
from scipy.spatial.transform import Rotation

from ...errors import FileFormatError
from ...files.arrays import inertia_matrix
from ...files.branch_names import label_parts
from ...model.ik import solve_ik_batch
from ...model.ik.branches import configuration_labels
from ...model.ik.result import limit_variants
from ...model.robot import Robot, robot_with_tool
from ...program.actions import MAX_COMMENT_CHARS
from ...program.payload import Payload, physical_inertia_problem, removed, same_load
from .read_ls import as_robot, parse_subset
from .settings_mark import PART_NAME
from .urscript import IO_BANKS, PULSE_THREAD, WAITED

#: Each move's parameters in the Script Manual's order.
PARAMETERS = {"movej": ("q", "a", "v", "t", "r"), "movel": ("pose", "a", "v", "t", "r"),
              "movep": ("pose", "a", "v", "r"), "movec": ("pose_via", "pose_to", "a", "v", "r", "mode")}
#: The manual's defaults [rad/s^2, rad/s; m/s^2, m/s; m] where a move leaves them out.
DEFAULTS = {"movej": {"a": 1.4, "v": 1.05, "t": 0.0, "r": 0.0}, "movel": {"a": 1.2, "v": 0.25, "t": 0.0, "r": 0.0},
            "movep": {"a": 1.2, "v": 0.25, "r": 0.0}, "movec": {"a": 1.2, "v": 0.25, "r": 0.0, "mode": 0.0}}
MOVE_KINDS = {"movej": "joint", "movel": "linear", "movep": "linear", "movec": "circular"}
#: Calls that move the robot other than the moves read (refused; a thread holding one is refused).
MOTION_CALLS = frozenset({"movej", "movel", "movep", "movec", "servoj", "servoc", "speedj", "speedl", "stopj", "stopl",
                          "force_mode", "freedrive_mode", "teach_mode", "path_offset_enable", "track_conveyor_linear",
                          "track_conveyor_circular"})
#: PolyScope's installation settings at a program's start: no motion, nothing a job holds (skipped).
SETUP_CALLS = frozenset({
    "set_gravity", "set_safety_mode_transition_hardness", "set_standard_analog_input_domain",
    "set_tool_analog_input_domain", "set_analog_outputdomain", "set_input_actions_to_default",
    "set_runstate_standard_digital_outputs", "set_runstate_standard_digital_output_to_value",
    "set_runstate_configurable_digital_outputs", "set_runstate_tool_digital_outputs",
    "set_runstate_configurable_digital_output_to_value", "set_runstate_tool_digital_output_to_value",
    "set_tool_communication", "set_tool_output_mode", "set_tool_digital_output_mode", "set_tool_voltage",
    "motion_version_set", "tool_wrench_limit_disable", "modbus_add_signal", "modbus_set_signal_update_frequency",
    "modbus_set_runstate_dependent_choice", "set_configurable_digital_input_action",
    "set_standard_digital_input_action", "set_tool_digital_input_action", "set_gravity_compensation"})
#: Calls with no motion and nothing a job holds, skipped and named: register writes (fieldbus/RTDE), log messages.
SKIPPED_CALLS = frozenset({"write_output_integer_register", "write_output_float_register",
                           "write_output_boolean_register", "textmsg"})
#: Functions evaluated on static values.
STATIC_FUNCTIONS = ("pose_trans", "pose_inv", "rpy2rotvec", "rotvec2rpy", "d2r", "r2d", "get_inverse_kin")
#: The functions of write_urscript's replay, skipped.
REPLAY, NATIVE = "certified_replay", "native_moves"
#: Digital outputs and inputs by function: (the job's first number of the bank, the reader's name prefix).
OUTPUTS = {f"set_{bank}_digital_out": (first, prefix) for first, _, bank, prefix in IO_BANKS}
OUTPUTS["set_digital_out"] = OUTPUTS["set_standard_digital_out"]
INPUTS = {f"get_{bank}_digital_in": (first, prefix) for first, _, bank, prefix in IO_BANKS}
INPUTS["get_digital_in"] = INPUTS["get_standard_digital_in"]
_NUMBER = r"-?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_IN = rf"({'|'.join(INPUTS)})\((\d+)\)"
#: PolyScope's Wait node for an input, and write_urscript's wait with a timeout (urscript.wait_input_lines).
WAIT_PATTERN = re.compile(rf"while \(?not ?\({_IN} == (True|False)\)\)?:\nsync\(\)\nend")
TIMEOUT_PATTERN = re.compile(
    rf"while \(not\({_IN} == (True|False)\)\):\nif \({WAITED} >= ({_NUMBER})\):\npopup\(\"[^\"\n]*\", \"Timeout\", "
    rf"False, True, False\)\nhalt\nend\nsleep\(({_NUMBER})\)\n{WAITED} = {WAITED} \+ ({_NUMBER})\nend")
#: write_urscript's pulse thread: set on, sleep, set off.
PULSE_PATTERN = re.compile(rf"thread ({PULSE_THREAD}\d+)\(\):\n({'|'.join(OUTPUTS)})\((\d+), True\)\n"
                           rf"sleep\(({_NUMBER})\)\n\2\(\3, False\)\nend")
#: The longest construct text an error names [characters].
CONSTRUCT_CHARS = 80
#: The operators on numbers and the comparisons (URScript's % as C's fmod).
ARITHMETIC = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv, "%": math.fmod}
COMPARISONS = {"==": operator.eq, "!=": operator.ne, "<": operator.lt, "<=": operator.le, ">": operator.gt,
               ">=": operator.ge}
#: The most turns a loop the program fixes is read for (PolyScope's "Loop n times" flattened).
MAX_TURNS = 1000
#: set_payload's and set_target_payload's parameters in the Script Manual's order.
PAYLOAD_PARAMETERS = {"set_payload": ("m", "cog"), "set_target_payload": ("m", "cog", "inertia", "transition_time")}
#: Two loads are the same total within this: mass [kg], centre of mass [m], inertia [kg m^2] (PolyScope writes 6
#: decimals).
LOAD_TOLERANCE = 1e-6
#: A part's mass [kg], centre of mass [m] and inertia [kg m^2] are rounded to this many decimals (the difference of
#: two totals written to 9 decimals carries errors of some 1e-9).
PART_DECIMALS = 8


class UrscriptReadError(FileFormatError):
    """A URScript program outside what is read here (field: the construct, e.g. the statement's text)."""


@dataclass(frozen=True)
class Pose:
    """A URScript pose p[x, y, z, rx, ry, rz] (m, rotation vector [rad])."""

    values: tuple[float, ...]

    def matrix(self) -> np.ndarray:
        """The pose as a (4, 4) transform [m]."""
        X = np.eye(4)
        X[:3, :3] = Rotation.from_rotvec(self.values[3:]).as_matrix()
        X[:3, 3] = self.values[:3]
        return X

    @staticmethod
    def of(X: np.ndarray) -> Pose:
        return Pose((*map(float, X[:3, 3]), *map(float, Rotation.from_matrix(X[:3, :3]).as_rotvec())))


@dataclass(frozen=True)
class IkTarget:
    """``get_inverse_kin(pose, qnear=q)``: the pose, reached with the joint solution nearest ``qnear`` [rad]."""

    pose: Pose
    qnear: tuple[float, ...] | None


@dataclass(frozen=True)
class Unknown:
    """A value that is not static (``why``), assigned at ``line``."""

    why: str
    line: int


class _NotStatic(Exception):
    """An expression without a static value."""


def read_urscript(text: str, robot, source: str = "<urscript>") -> dict:
    """The job document of a URScript program ``text`` (module docstring) for ``robot`` (a preset name, robot file
    path or Robot, named in the document as given); ``source`` names the file in errors. UrscriptReadError names
    what cannot be read."""
    tree = parse_subset("urscript", "URScript", without_replay_samples(text), UrscriptReadError, source)
    program = tree.children[0]
    name, body = str(program.children[0]), program.children[1]
    run = program.children[2] if len(program.children) > 2 else None
    if run is not None and str(run.children[0]) != name:
        raise UrscriptReadError(source, f"{run.children[0]}()", f"after the program: only its own call {name}() is "
                                "read", line=run.meta.line)
    robot_model, robot_name = as_robot(robot)
    reader = _Reader(robot_model, text, source)
    reader.program(body, program.meta.end_line)
    if not reader.waypoints:
        raise UrscriptReadError(source, "moves", "the program has no movej, movel, movep or movec")
    return reader.document(robot_name)


def without_replay_samples(text: str) -> str:
    """``text`` with the servoj lines of ``def certified_replay()`` blank (the replay is skipped: its thousands of
    samples need no parsing); the line numbers stay."""
    lines = text.splitlines(keepends=True)
    start = next((i for i, line in enumerate(lines) if line.strip() == f"def {REPLAY}():"), None)
    if start is None:
        return text
    indent = len(lines[start]) - len(lines[start].lstrip())
    for i in range(start + 1, len(lines)):
        stripped = lines[i].strip()
        if stripped == "end" and len(lines[i]) - len(lines[i].lstrip()) == indent:
            break
        if stripped.startswith("servoj("):
            lines[i] = "\n"
    return "".join(lines)


class _Reader:
    """The program's statements read in order: its tool, variables, waypoints and actions, the previous target's
    joint values, and what was skipped."""

    def __init__(self, robot: Robot, text: str, source: str):
        self.robot, self.source = robot, source
        self.lines = text.splitlines()
        self.comments = {i + 1: line.strip()[1:].strip() for i, line in enumerate(self.lines)
                         if line.strip().startswith("#")}
        self.X_FT: np.ndarray | None = None
        self.variables: dict[str, object] = {}
        self.functions: dict[str, lark.Tree] = {}
        self.threads: set[str] = set()
        self.pulses: dict[str, tuple[str, int, float]] = {}
        self.waypoints: list[dict] = []
        self.pending: list[dict] = []
        self.signals: dict[str, dict] = {}
        self.q_previous: np.ndarray | None = None
        self.tcp_accel: list[float] = []
        self.carried: list[tuple[str | None, Payload | None]] = [(None, None)]
        self.parts: dict[str, Payload] = {}
        self.skipped: dict[str, list] = {}
        self.skipped_calls: dict[str, list[int]] = {}
        self.cursor = 0
        self.halted = False

    # -- statements ---------------------------------------------------------------------------------------------

    def program(self, body: lark.Tree, last_line: int) -> None:
        """Read the program's body (its ``end`` at or before ``last_line``); an endless ``while (True):`` as its last
        statement is read as one cycle."""
        end = max((i for i in range(1, min(last_line, len(self.lines)) + 1) if self.lines[i - 1].strip() == "end"),
                  default=last_line)
        statements = body.children
        last = statements[-1] if statements else None
        if last is not None and last.data == "while_block" and self.is_true(last.children[0]):
            self.statements(statements[:-1], last.meta.line)
            self.note("loop", f"one cycle of the endless loop 'while (True):' at line {last.meta.line}")
            self.cursor = last.meta.line
            self.statements(last.children[1].children, last.meta.end_line)
        else:
            self.statements(statements, end)

    def statements(self, statements: list, end: int) -> None:
        """Read ``statements`` in order, then the comments before line ``end`` (their block's ``end``)."""
        for node in statements:
            if self.halted:
                return
            self.take_comments(node.meta.line)
            self.statement(node)
            self.cursor = max(self.cursor, node.meta.end_line)
        self.take_comments(end)

    def statement(self, node: lark.Tree) -> None:
        kind = node.data
        if kind == "function_def":
            self.define(node)
        elif kind == "thread_def":
            self.thread(node)
        elif kind == "run_thread":
            self.run_thread(node)
        elif kind == "assignment":
            self.assignment(node)
        elif kind == "expr_statement":
            self.expression_statement(node)
        elif kind == "if_block":
            self.if_block(node)
        elif kind == "while_block":
            self.while_block(node)
        elif kind == "halt":
            self.halted = True
            self.note("halt", f"halt at line {node.meta.line} ends the program")
        else:
            self.refuse(node, "has no static meaning in the program's flow")

    def take_comments(self, before: int) -> None:
        """Full-line comments between the last statement read and line ``before``: comment actions after the first
        move (before it: the program's header)."""
        for line in range(self.cursor + 1, before):
            text = comment_text(self.comments.get(line, ""))
            if text and self.waypoints:
                self.action({"comment": text})

    def define(self, node: lark.Tree) -> None:
        name = str(node.children[0])
        self.functions[name] = node
        if name not in (REPLAY, NATIVE):
            self.note("functions", name)

    def thread(self, node: lark.Tree) -> None:
        name = str(node.children[0])
        pulse = PULSE_PATTERN.fullmatch(self.block_text(node))
        if pulse is not None:
            first, prefix = OUTPUTS[pulse.group(2)]
            self.pulses[name] = (f"{prefix}do{pulse.group(3)}", first + int(pulse.group(3)), float(pulse.group(4)))
            return
        moving = self.motion_in(node)
        if moving is not None:
            raise UrscriptReadError(self.source, self.construct(node), f"a thread that moves the robot "
                                    f"({moving.children[0]}, line {moving.meta.line}) runs beside the program: no "
                                    "static motion", line=node.meta.line)
        self.threads.add(name)
        self.note("threads", name)

    def run_thread(self, node: lark.Tree) -> None:
        name = str(node.children[0])
        if name in self.pulses:
            signal, number, time_s = self.pulses[name]
            self.use_signal(signal, "output", number)
            self.action({"pulse": signal, "time": time_s})
        elif name not in self.threads:
            self.refuse(node, f"runs {name}, not a thread defined before it")

    def assignment(self, node: lark.Tree) -> None:
        value = node.children[-1]
        if isinstance(value, lark.Tree) and value.data == "run_thread":
            self.run_thread(value)
            result = Unknown(f"the handle of thread {value.children[0]}", node.meta.line)
        else:
            try:
                result = self.value(value)
            except _NotStatic as exc:
                result = Unknown(str(exc), node.meta.line)
        self.store(node.children[-2], result, node)

    def store(self, target: lark.Tree, value, node: lark.Tree) -> None:
        """Assign ``value`` to a variable or to an element of a list or pose variable."""
        if target.data == "variable":
            self.variables[str(target.children[0])] = value
            return
        if target.data == "index" and target.children[0].data == "variable":
            name = str(target.children[0].children[0])
            try:
                whole, index = self.value(target.children[0]), self.value(target.children[1])
                self.variables[name] = _with_element(whole, index, value)
            except _NotStatic as exc:
                self.variables[name] = Unknown(str(exc), node.meta.line)
            return
        self.refuse(node, "assigns to something other than a variable or its element")

    def expression_statement(self, node: lark.Tree) -> None:
        call = node.children[0]
        if not isinstance(call, lark.Tree) or call.data != "call":
            what = "calls a method of an object (rpc, fieldbus)" if getattr(call, "data", "") == "method_call" else \
                "is an expression, not a call"
            self.refuse(node, f"{what}: no static meaning")
        self.call(call, node)

    def if_block(self, node: lark.Tree) -> None:
        condition = node.children[0]
        if (condition.data == "variable" and str(condition.children[0]) == "use_certified_replay"
                and NATIVE in self.functions):
            native = self.functions[NATIVE]
            self.cursor = native.meta.line
            self.statements(native.children[-1].children, native.meta.end_line)
            return
        self.refuse(node, "a branch on a variable or an input has no static meaning")

    def while_block(self, node: lark.Tree) -> None:
        text = self.block_text(node)
        plain, timed = WAIT_PATTERN.fullmatch(text), TIMEOUT_PATTERN.fullmatch(text)
        found = plain or timed
        if found is None:
            self.flatten(node)
            return
        first, prefix = INPUTS[found.group(1)]
        signal = f"{prefix}di{found.group(2)}"
        self.use_signal(signal, "input", first + int(found.group(2)))
        action = {"wait_input": signal, "value": "on" if found.group(3) == "True" else "off"}
        if timed is not None:
            action["timeout"] = float(timed.group(4))
        self.action(action)

    def flatten(self, node: lark.Tree) -> None:
        """A loop on a condition the program fixes (PolyScope's "Loop n times": ``Loop_1 = 0``, ``while (Loop_1 <
        n): ... Loop_1 = Loop_1 + 1 end``), read turn by turn while its condition holds (at most MAX_TURNS turns)."""
        condition, body = node.children
        names = {str(v.children[0]) for v in condition.find_data("variable")}
        turns = 0
        while self.condition(condition, node):
            before = {name: self.variables.get(name) for name in names}
            turns += 1
            self.cursor = node.meta.line
            self.statements(body.children, node.meta.end_line)
            if self.halted:
                break
            if turns > MAX_TURNS or before == {name: self.variables.get(name) for name in names}:
                self.refuse(node, f"a loop that does not end (its condition's variables unchanged by a turn, or more "
                            f"than {MAX_TURNS} turns; read: an endless loop as the program's last statement)")
        self.note("loops", f"line {node.meta.line} ({turns} turn{'s' * (turns != 1)})")

    def condition(self, condition: lark.Tree, node: lark.Tree) -> bool:
        """The value of a loop's condition the program fixes, else refused."""
        try:
            value = self.value(condition)
        except _NotStatic as exc:
            self.refuse(node, f"a loop on a variable or an input has no static meaning ({exc}; read: a loop on a "
                        "counter the program fixes, the wait for an input 'while (not(get_standard_digital_in(n) == "
                        "True)): sync() end', an endless outer loop)")
        if not isinstance(value, bool):
            self.refuse(node, f"a loop's condition is {value!r}, not True or False")
        return value

    # -- calls --------------------------------------------------------------------------------------------------

    def call(self, call: lark.Tree, node: lark.Tree) -> None:
        name = str(call.children[0])
        if name == "sync":
            return
        if name in SETUP_CALLS:
            self.note("settings", name)
        elif name in SKIPPED_CALLS:
            self.skipped_calls.setdefault(name, []).append(node.meta.line)
        elif name in PARAMETERS:
            self.move(name, self.arguments(name, call, node), node)
        elif name == "set_tcp":
            self.set_tcp(self.first(call, node), node)
        elif name in PAYLOAD_PARAMETERS:
            self.set_payload(self.payload_arguments(name, call, node), node)
        elif name in OUTPUTS:
            self.output(name, self.static(call, node), node)
        elif name == "sleep":
            self.action({"wait": self.number(self.first(call, node), node)})
        elif name in self.functions:
            self.refuse(node, f"calls {name}, a function the program defines: its body is not read as static motion")
        else:
            self.refuse(node, f"{name} is not a function read here (moves, set_tcp, set_payload, digital outputs, "
                        "sleep, the wait for an input)")

    def static(self, call: lark.Tree, node: lark.Tree) -> list:
        """A call's positional argument values (static, else refused)."""
        arguments = [] if call.children[1] is None else call.children[1].children
        try:
            return [self.value(a) for a in arguments if not (isinstance(a, lark.Tree) and a.data == "keyword")]
        except _NotStatic as exc:
            self.refuse(node, f"an argument has no static value: {exc}")

    def first(self, call: lark.Tree, node: lark.Tree):
        """A call's first argument value (static, else refused)."""
        values = self.static(call, node)
        if not values:
            self.refuse(node, "needs an argument")
        return values[0]

    def arguments(self, name: str, call: lark.Tree, node: lark.Tree) -> dict:
        """The move's arguments by parameter name (the manual's defaults for those left out)."""
        line = node.meta.line
        arguments = [] if call.children[1] is None else call.children[1].children
        out = dict(DEFAULTS[name])
        positional = [a for a in arguments if not (isinstance(a, lark.Tree) and a.data == "keyword")]
        if len(positional) > len(PARAMETERS[name]):
            raise UrscriptReadError(self.source, name, f"takes at most {len(PARAMETERS[name])} arguments", line=line)
        try:
            out.update(zip(PARAMETERS[name], (self.value(a) for a in positional)))
            for keyword in (a for a in arguments if isinstance(a, lark.Tree) and a.data == "keyword"):
                key = str(keyword.children[0])
                if key not in PARAMETERS[name]:
                    raise UrscriptReadError(self.source, f"{name}({key}=...)", f"{name} has no parameter {key}",
                                            line=line)
                out[key] = self.value(keyword.children[1])
        except _NotStatic as exc:
            self.refuse(node, f"a move's argument has no static value: {exc}")
        if out.get("t", 0.0) != 0.0:
            raise UrscriptReadError(self.source, f"{name}(t=...)", "a move given a time has no speed to read",
                                    line=line)
        if out.get("mode", 0.0) != 0.0:
            raise UrscriptReadError(self.source, f"{name}(mode=...)", "only mode 0 (orientation interpolated from the "
                                    "start to the target) is read", line=line)
        return out

    def set_tcp(self, value, node: lark.Tree) -> None:
        if not isinstance(value, Pose):
            self.refuse(node, "needs a pose p[x, y, z, rx, ry, rz]")
        X = value.matrix()
        if self.waypoints and not np.allclose(X, self.tool(), atol=1e-12):
            self.refuse(node, "sets another tool after the first move: a job has one tool")
        self.X_FT = X

    def tool(self) -> np.ndarray:
        return np.eye(4) if self.X_FT is None else self.X_FT

    def payload_arguments(self, name: str, call: lark.Tree, node: lark.Tree) -> dict:
        """set_payload's or set_target_payload's static arguments by parameter name (PAYLOAD_PARAMETERS)."""
        arguments = [] if call.children[1] is None else call.children[1].children
        positional = [a for a in arguments if not (isinstance(a, lark.Tree) and a.data == "keyword")]
        keywords = {str(a.children[0]): a.children[1] for a in arguments
                    if isinstance(a, lark.Tree) and a.data == "keyword"}
        if len(positional) > len(PAYLOAD_PARAMETERS[name]) or not set(keywords) <= set(PAYLOAD_PARAMETERS[name]):
            self.refuse(node, f"{name} takes {', '.join(PAYLOAD_PARAMETERS[name])}")
        try:
            return {key: self.value(a) for key, a in [*zip(PAYLOAD_PARAMETERS[name], positional), *keywords.items()]}
        except _NotStatic as exc:
            self.refuse(node, f"an argument has no static value: {exc}")

    def set_payload(self, arguments: dict, node: lark.Tree) -> None:
        """The total the flange carries (module docstring): before the first move the tool's load, after it a grip or
        a release."""
        mass, com, six = arguments.get("m"), arguments.get("cog", [0.0, 0.0, 0.0]), arguments.get("inertia")
        if (not isinstance(mass, float) or not math.isfinite(mass) or mass < 0.0 or not _vector3(com)
                or not (six is None or (isinstance(six, list) and len(six) == 6
                                        and all(isinstance(v, float) for v in six)))):
            self.refuse(node, "needs a mass [kg] >= 0, a centre of mass [x, y, z] [m] and, for set_target_payload, "
                        "an inertia [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2]")
        inertia = np.zeros((3, 3)) if six is None else inertia_matrix(six)
        problem = physical_inertia_problem(inertia)
        if problem is not None:
            self.refuse(node, f"the inertia is no body's: {problem}")
        load = Payload(mass, np.array(com, dtype=float), inertia) if mass > 0.0 else None
        if not self.waypoints:
            self.carried = [(None, load)]
            return
        if _same_load(load, self.carried[-1][1], six is not None):
            return
        if _mass(load) > _mass(self.carried[-1][1]) + LOAD_TOLERANCE:
            self.grip(load, six is not None, node)
        else:
            self.release(load, six is not None, node)

    def grip(self, total: Payload, with_inertia: bool, node: lark.Tree) -> None:
        """A grip: the part is what ``total`` adds to the load carried."""
        before = self.carried[-1][1]
        part = total if before is None else removed(total, before, "part")
        inertia = np.round(part.inertia, PART_DECIMALS) if with_inertia else np.zeros((3, 3))
        part = Payload(round(part.mass, PART_DECIMALS), np.round(part.com, PART_DECIMALS) + 0.0, inertia + 0.0)
        problem = physical_inertia_problem(part.inertia)
        if problem is not None:
            self.refuse(node, f"the part it adds ({part.mass:.6g} kg to the {_mass(before):.6g} kg carried) has no "
                        f"body's inertia: {problem}")
        held = {name for name, _ in self.carried}
        name = next((n for n, p in self.parts.items() if n not in held and _same_load(p, part, True)),
                    PART_NAME.format(len(self.parts) + 1))
        self.parts[name] = part
        self.carried.append((name, total))
        self.action({"grip": name})

    def release(self, total: Payload | None, with_inertia: bool, node: lark.Tree) -> None:
        """A release: back to a total carried before; the parts gripped since are released, the last first."""
        earlier = [i for i, (_, load) in enumerate(self.carried[:-1]) if _same_load(total, load, with_inertia)]
        if not earlier:
            loads = ", ".join(f"{_mass(load):.6g} kg" for _, load in self.carried)
            self.refuse(node, f"sets {_mass(total):.6g} kg: neither more than the {_mass(self.carried[-1][1]):.6g} kg "
                        f"carried (a grip) nor a load carried before ({loads}; the first the tool's, set before the "
                        "first move: a release) - not read as parts gripped and released")
        for name, _ in reversed(self.carried[earlier[-1] + 1:]):
            self.action({"release": name})
        del self.carried[earlier[-1] + 1:]

    def output(self, name: str, values: list, node: lark.Tree) -> None:
        if len(values) != 2 or not isinstance(values[1], bool) or not _is_index(values[0]):
            self.refuse(node, "needs an output number and True or False")
        first, prefix = OUTPUTS[name]
        signal = f"{prefix}do{int(values[0])}"
        self.use_signal(signal, "output", first + int(values[0]))
        self.action({"set": signal, "value": "on" if values[1] else "off"})

    # -- moves --------------------------------------------------------------------------------------------------

    def move(self, name: str, arguments: dict, node: lark.Tree) -> None:
        target = arguments["pose_to" if name == "movec" else "q" if name == "movej" else "pose"]
        if isinstance(target, (Pose, IkTarget)) and (name == "movej" or isinstance(target, Pose)):
            pose, near = (target, None) if isinstance(target, Pose) else (target.pose, target.qnear)
            waypoint, q = self.pose_waypoint(pose.matrix(), near, node)
            waypoint["move"] = MOVE_KINDS[name]
        elif (name == "movej" and isinstance(target, list) and len(target) == self.robot.dof
              and all(isinstance(v, float) for v in target)):
            q = np.array(target, dtype=float)
            waypoint = {"joints": [round(float(v), 10) for v in np.degrees(q)]}
        else:
            self.refuse(node, f"needs a pose{' or a joint vector' * (name == 'movej')} target")
        if name == "movec":
            via = arguments["pose_via"]
            if not isinstance(via, Pose):
                self.refuse(node, "needs a via pose")
            waypoint["via"] = {"xyz": list(via.values[:3])}
        if self.q_previous is not None:
            self.add_speed(waypoint, name, arguments)
            waypoint["zone"] = float(arguments["r"])
        self.q_previous = q
        if not self.waypoints and self.pending:
            waypoint["do"] = self.pending
        self.waypoints.append(waypoint)

    def pose_waypoint(self, X: np.ndarray, near, node: lark.Tree) -> tuple[dict, np.ndarray]:
        """(pose waypoint of TCP pose X (4, 4) [m] with the branch nearest ``near`` (else the previous target), its
        joint values)."""
        robot = robot_with_tool(self.robot, self.tool())
        result = solve_ik_batch(robot, X[None], method="analytic")[0]
        solutions = np.array([s.q for s in result.solutions]).reshape(-1, robot.dof)
        shifted, valid = limit_variants(solutions, robot.revolute_mask, robot.limits.q_min, robot.limits.q_max)
        candidates = shifted[valid]
        if not len(candidates):
            raise UrscriptReadError(self.source, self.construct(node), f"the pose has no in-limit joint solution for "
                                    f"{self.robot.name} and the program's tool",
                                    [round(float(v), 6) for v in X[:3, 3]], line=node.meta.line)
        previous = (np.array(near, dtype=float) if near is not None else
                    np.zeros(robot.dof) if self.q_previous is None else self.q_previous)
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

    # -- actions and notes --------------------------------------------------------------------------------------

    def action(self, action: dict) -> None:
        """An action at the last move's waypoint (before the first move: waypoint 0's)."""
        if self.waypoints:
            self.waypoints[-1].setdefault("do", []).append(action)
        else:
            self.pending.append(action)

    def use_signal(self, name: str, direction: str, number: int) -> None:
        self.signals[name] = {direction: number}

    def note(self, kind: str, what: str) -> None:
        """Something skipped (``kind``), for the description."""
        entries = self.skipped.setdefault(kind, [])
        if what not in entries:
            entries.append(what)

    def description(self) -> str | None:
        """What the reader skipped, in words (None: nothing)."""
        words = {"loop": "read {}", "loops": "flattened the loops on fixed counters at {}", "halt": "{}",
                 "threads": "skipped threads that do not move the robot: {}",
                 "functions": "skipped function definitions (not called): {}",
                 "calls": "skipped calls without motion: {}", "settings": "skipped installation settings: {}"}
        for name, lines in self.skipped_calls.items():
            self.note("calls", f"{name} (line{'s' * (len(lines) > 1)} {', '.join(map(str, lines))})")
        parts = [words[kind].format(", ".join(entries)) for kind, entries in self.skipped.items()]
        return "URScript program read by dh-pipeline: " + "; ".join(parts) if parts else None

    def document(self, robot: str) -> dict:
        self.waypoints[-1].pop("zone", None)
        doc = {"robot": str(robot), "length_unit": "m", "angle_unit": "deg", "waypoints": self.waypoints}
        description = self.description()
        if description:
            doc["description"] = description
        if self.tcp_accel:
            doc["tcp_accel_max"] = max(self.tcp_accel)
        if self.carried[0][1] is not None:
            doc["payload"] = self.carried[0][1].to_document(1.0)
        if self.parts:
            doc["parts"] = {name: part.to_document(1.0) for name, part in self.parts.items()}
        if self.signals:
            doc["signals"] = self.signals
        if not np.allclose(self.tool(), np.eye(4), atol=1e-12):
            quaternion = Rotation.from_matrix(self.X_FT[:3, :3]).as_quat()
            doc["tool"] = {"xyz": self.X_FT[:3, 3].tolist(),
                           "quaternion": [float(quaternion[3]), *map(float, quaternion[:3])]}
        return doc

    # -- values -------------------------------------------------------------------------------------------------

    def value(self, node):
        """The static value of an expression (numbers as float, bool, str, list, Pose, IkTarget), or _NotStatic."""
        kind = node.data
        if kind == "number":
            return float(node.children[0])
        if kind == "boolean":
            return str(node.children[0]) == "True"
        if kind == "string":
            return str(node.children[0])[1:-1]
        if kind in ("numbers", "pose_numbers"):
            values = [float(v) for v in str(node.children[0]).lstrip("p")[1:-1].split(",")]
            return values if kind == "numbers" else self.pose_of(values)
        if kind == "list":
            return [self.value(child) for child in node.children if child is not None]
        if kind == "pose":
            return self.pose_of([self.value(child) for child in node.children[1:]])
        if kind == "variable":
            return self.variable(str(node.children[0]))
        if kind == "neg":
            return -self.float_of(self.value(node.children[0]))
        if kind == "binary":
            return _arithmetic(self.value(node.children[0]), str(node.children[1]), self.value(node.children[2]))
        if kind == "compare":
            return _compare(self.value(node.children[0]), str(node.children[1]), self.value(node.children[2]))
        if kind == "not_":
            return not self.value(node.children[0])
        if kind == "boolean_op":
            left, op, right = self.value(node.children[0]), str(node.children[1]), self.value(node.children[2])
            return bool(left) != bool(right) if op == "xor" else (left and right if op == "and" else left or right)
        if kind == "index":
            return _element(self.value(node.children[0]), self.value(node.children[1]))
        if kind == "call":
            return self.function(node)
        raise _NotStatic(f"{kind.replace('_', ' ')} is not a static value")

    def pose_of(self, values: list) -> Pose:
        if len(values) != 6 or not all(isinstance(v, float) for v in values):
            raise _NotStatic("a pose is p[x, y, z, rx, ry, rz] of six numbers")
        return Pose(tuple(values))

    def variable(self, name: str):
        if name not in self.variables:
            raise _NotStatic(f"{name} is not assigned before")
        value = self.variables[name]
        if isinstance(value, Unknown):
            raise _NotStatic(f"{name} (assigned at line {value.line}) is not static: {value.why}")
        return value

    def function(self, node: lark.Tree):
        """A static function of static arguments (STATIC_FUNCTIONS)."""
        name = str(node.children[0])
        if name not in STATIC_FUNCTIONS:
            raise _NotStatic(f"{name}() is not a static function")
        arguments = [] if node.children[1] is None else node.children[1].children
        positional = [self.value(a) for a in arguments if not (isinstance(a, lark.Tree) and a.data == "keyword")]
        keywords = {str(a.children[0]): self.value(a.children[1]) for a in arguments
                    if isinstance(a, lark.Tree) and a.data == "keyword"}
        return _static_function(name, positional, keywords)

    def is_true(self, node) -> bool:
        return node.data == "boolean" and str(node.children[0]) == "True"

    def float_of(self, value) -> float:
        if isinstance(value, bool) or not isinstance(value, float):
            raise _NotStatic(f"{value!r} is not a number")
        return value

    def number(self, value, node: lark.Tree) -> float:
        if isinstance(value, bool) or not isinstance(value, float) or not math.isfinite(value):
            self.refuse(node, "needs a number")
        return value

    # -- the program's text -------------------------------------------------------------------------------------

    def block_text(self, node: lark.Tree) -> str:
        """A block's lines, stripped, without blank lines, comments and markers (for the fixed patterns)."""
        lines = (line.strip() for line in self.lines[node.meta.line - 1:node.meta.end_line])
        return "\n".join(line for line in lines if line and not line.startswith(("#", "$")))

    def construct(self, node: lark.Tree) -> str:
        """The construct an error names: the text of ``node``'s first line (a block's without its colon)."""
        text = self.lines[node.meta.line - 1].strip().removesuffix(":")
        return text if len(text) <= CONSTRUCT_CHARS else text[:CONSTRUCT_CHARS - 3] + "..."

    def refuse(self, node: lark.Tree, problem: str):
        raise UrscriptReadError(self.source, self.construct(node), problem, line=node.meta.line)

    def motion_in(self, node: lark.Tree):
        """The first call in ``node`` that moves the robot, or None."""
        for call in node.find_data("call"):
            if str(call.children[0]) in MOTION_CALLS:
                return call
        return None


def comment_text(text: str) -> str:
    """A comment's text as a job's comment action holds it: PolyScope's Comment node quotes (``# 'text'``) and any
    other quote or unprintable character dropped, at most MAX_COMMENT_CHARS characters."""
    if len(text) > 1 and text[0] == text[-1] == "'":
        text = text[1:-1]
    text = "".join(c for c in text if c.isprintable() and c not in "\"'").strip()
    return text[:MAX_COMMENT_CHARS].rstrip()


def _is_index(value) -> bool:
    return isinstance(value, float) and value >= 0 and value == int(value)


def _element(whole, index):
    if not _is_index(index):
        raise _NotStatic(f"index {index!r} is not a whole number")
    items = whole.values if isinstance(whole, Pose) else whole
    if not isinstance(items, (list, tuple)) or int(index) >= len(items):
        raise _NotStatic(f"index {int(index)} is outside {whole!r}")
    return items[int(index)]


def _with_element(whole, index, value):
    """``whole`` (a list or Pose) with element ``index`` replaced by ``value``."""
    if isinstance(value, Unknown):
        raise _NotStatic(value.why)
    _element(whole, index)
    items = list(whole.values if isinstance(whole, Pose) else whole)
    items[int(index)] = value
    return Pose(tuple(items)) if isinstance(whole, Pose) else items


def _arithmetic(left, op: str, right):
    if isinstance(left, str) or isinstance(right, str) or not all(isinstance(v, float) for v in (left, right)):
        raise _NotStatic(f"{op} of {left!r} and {right!r} is not read")
    if op in "/%" and right == 0.0:
        raise _NotStatic(f"{op} by zero")
    return ARITHMETIC[op](left, right)


def _compare(left, op: str, right) -> bool:
    if type(left) is not type(right) or isinstance(left, (list, Pose)):
        raise _NotStatic(f"{left!r} {op} {right!r} is not read")
    return COMPARISONS[op](left, right)


def _static_function(name: str, positional: list, keywords: dict):
    """``name`` (STATIC_FUNCTIONS) of static arguments, as the Script Manual defines it."""
    if name == "get_inverse_kin":
        qnear = keywords.get("qnear", positional[1] if len(positional) > 1 else None)
        if not positional or not isinstance(positional[0], Pose) or not (qnear is None or isinstance(qnear, list)):
            raise _NotStatic("get_inverse_kin needs a pose and qnear a joint vector")
        return IkTarget(positional[0], None if qnear is None else tuple(qnear))
    if name == "pose_trans" and len(positional) == 2 and all(isinstance(p, Pose) for p in positional):
        return Pose.of(positional[0].matrix() @ positional[1].matrix())
    if name == "pose_inv" and len(positional) == 1 and isinstance(positional[0], Pose):
        return Pose.of(np.linalg.inv(positional[0].matrix()))
    if name in ("rpy2rotvec", "rotvec2rpy") and len(positional) == 1 and _vector3(positional[0]):
        if name == "rpy2rotvec":        # roll, pitch, yaw about the fixed x, y, z axes
            return [float(v) for v in Rotation.from_euler("xyz", positional[0]).as_rotvec()]
        return [float(v) for v in Rotation.from_rotvec(positional[0]).as_euler("xyz")]
    if name in ("d2r", "r2d") and len(positional) == 1 and isinstance(positional[0], float):
        return math.radians(positional[0]) if name == "d2r" else math.degrees(positional[0])
    raise _NotStatic(f"{name} of these arguments is not read")


def _mass(load: Payload | None) -> float:
    """A load's mass [kg] (None: 0)."""
    return 0.0 if load is None else load.mass


def _same_load(a: Payload | None, b: Payload | None, with_inertia: bool) -> bool:
    """Whether two loads are one total within LOAD_TOLERANCE (None: nothing; the inertia only ``with_inertia``)."""
    return same_load(a, b, LOAD_TOLERANCE, LOAD_TOLERANCE, LOAD_TOLERANCE if with_inertia else None)


def _vector3(value) -> bool:
    return isinstance(value, list) and len(value) == 3 and all(isinstance(v, float) for v in value)
