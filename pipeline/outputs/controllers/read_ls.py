"""``read_ls(text, robot) -> dict``: a FANUC ``.ls`` program (what ``fanuc_ls.write_ls`` writes, and what a pendant,
ROBOGUIDE or another tool prints) back to a job document that ``pipeline.program.job.parse_job`` accepts.

The file is parsed with ``grammars/fanuc_ls.lark`` (written from FANUC's R-30iA/R-30iB operator's manuals; keywords
upper case as the controller prints them, any spacing, tabs, CR LF line ends): the whole /ATTR block (OWNER, COMMENT,
PROG_SIZE, CREATE, MODIFIED, FILE_NAME, VERSION, LINE_COUNT, MEMORY_SIZE, PROTECT, TCD, DEFAULT_GROUP, CONTROL_CODE,
LOCAL_REGISTERS, any other ``KEY = value;``), /APPL blocks (skipped), /MN line by line, /POS with point comments
(``P[2:"..."]``) and numbers as the controller prints them (``.000``, ``-.858``). Each /MN instruction is read, or
refused (``ControllerProgramError`` naming the file, the line and the instruction) when it has no static meaning.

* Moves: the first motion line is the job's first waypoint (the move to it starts wherever the robot is, so its
  speed is not a job quantity); ``J`` is a joint move with ``speed`` its ``%``, ``L`` a linear and ``C`` a circular
  move (via point, then end point) with ``speed`` its ``mm/sec`` as m/s. The job's ``speed_scale`` is 1 (but for ``OVERRIDE``,
  below): the speeds are the ones the controller runs. ``ACC100`` (the default acceleration) is read; another ``ACC n`` is refused
  (the job has no acceleration override). ``Offset,PR[i]`` / ``Tool_Offset,PR[i]`` are read where the file gives the
  register's six elements as constants before the move (``PR[i,1]=..`` to ``PR[i,6]=..``) and only shift the
  position (W, P, R 0): the target is moved by (X, Y, Z) in the user frame / the tool frame; otherwise refused.
  Other motion options (INC, Skip, TB, COORD, ...) are refused naming the option.
* Zones: ``FINE`` is zone 0. ``CNTn`` is not a distance: its zone is the one the writer states in the
  ``!zone Z mm CNTn ...`` comment line before the move when that comment names the same n; else it is
  n / 100 x the reach the writer divides by (``fanuc_ls.cnt_value``): for an ``L`` or ``C`` move with a
  TCP acceleration limit given by the caller (``tcp_accel_max``), the deceleration distance v^2 / (2 a)
  at the move's speed, otherwise half the shorter of this move and the next (TCP chords). The writer
  takes n = ceil(100 zone / reach), so below CNT100 this is the largest zone that gives n, at most
  reach / 100 above the zone written; CNT100 stands for every zone from 0.99 reach up and reads as the reach.
  A CNT move whose waypoint has a wait reads as a stop (zone 0; our reading: the program waits there before it reads
  the next move), as the job stops wherever it waits.
* Actions (``pipeline.program.actions``; the instructions after a move are its waypoint's actions, those before the
  first move are waypoint 0's, as the job runs them once the robot is there; the job's description says so):
  ``DO[n]=ON/OFF`` (set), ``DO[n]=PULSE,t sec`` (pulse; ``PULSE`` without a width, a system setting, is refused),
  ``WAIT t(sec)`` (wait), ``WAIT DI[n]=ON/OFF`` (wait for an input, no timeout) and the writer's timed wait:
  ``$WAITTMOUT=k`` (hundredths of a second) then ``WAIT DI[n]=ON TIMEOUT,LBL[x]`` where the program ends in exactly
  ``END ; LBL[x] ; UALM[m] ; ABORT`` (the alarm that stops the program: ``fanuc_ls.timeout_lines``); ``!text``
  after a move is a comment (lines ending in ``+`` continue on the next). Comments before the first move are the
  header (the writer's notes), and a ``!zone`` comment just before a CNT move is that move's zone, not an action.
  A signal is named by the program's own comment for it (``DO[1:gripper_close]``: ``gripper_close``, a pendant's
  ``ON:``/``OFF:`` state prefix dropped) when that is an identifier, else ``do<n>`` / ``di<n>``; the job's
  ``signals`` table maps each to its number (the signals mark, ``settings_mark.with_signal_names``, renames them).
  Robot I/O (``RO[n]``, ``RI[n]``, the end-of-arm connector) is refused: a job's output is written back as
  ``DO[n]``, another signal.
* Points: the GP1 group only (a point with a second group, GP2, is refused naming it; extended axes E1..E3 are
  ignored where 0 and refused otherwise). ``UF`` / ``UT`` must be the same on every point and equal
  ``UFRAME_NUM`` / ``UTOOL_NUM`` where the program selects them (else the controller stops with a frame mismatch).
  User frame 0 is FANUC's world frame; another user frame's data is on the controller, not in the file: it needs
  the caller's ``frame``, else an error naming the line and the number. A Cartesian point is the TCP in the user
  frame, X Y Z [mm], W P R [deg] with R = Rz(R) Ry(P) Rx(W); the world frame is the robot file's fanuc controller
  section's base frame, as the writer applied it (``fanuc_ls.controller_frame``: 330 mm up on the LR Mate
  200iD). Its CONFIG selects the one joint solution (``selection.select_solution``, the robot with its tool),
  whose closed-form branch (``pipeline.model.ik.branches.configuration_labels``) is the waypoint's ``config``
  mapping; the first Cartesian point's joint values are the job's ``start`` (the IK seed of the first pose), so
  its turns (t1, t4, t6) are the ones the file gives. Joint points are J1..J6 [deg] as the pendant shows them,
  turned back into model joint values (``axes.joint_values``: the inverse of ``axes.axis_angles``, FANUC's
  J3 = q3 - q2).
* Tool: ``UT 0`` is the flange (a caller's ``tool`` is not used). Another tool's data lives on the controller, not
  in the file: the caller's ``tool`` (4, 4) [m], else for ``UT 1`` the ``UT 1 = tool x y z w p r`` the writer states
  in its header comment, else an error naming the line and the number; the tool is on the controller's flange frame (the section's
  flange, ``controller.controller_frames``), carried to our end frame.
* An endless outer loop, a ``LBL[n]`` before the first move and ``JMP LBL[n]`` as the last instruction (before
  ``END`` and the timeout pattern), reads as one cycle, said in the job's description.
* Refused, naming the line and the construct: other jumps and labels (``JMP``, ``LBL``), branches (``IF``, ``SELECT``),
  calls of other programs (``CALL``, ``RUN``), register and flag assignments, register speeds and CNT, targets in
  position registers (``PR[i]``: their values are not in the file), ``SKIP CONDITION``, waits on other conditions,
  ``OVERRIDE`` after the first move, timers, and any instruction the grammar does not read.
* ``OVERRIDE=n%`` before the first move is the job's ``speed_scale`` n / 100 (the controller runs every speed at n %
  of the program's).
* Loads: a payload schedule's data are system settings on the controller, not in the file, but the writer states them
  in its loads mark (``settings_mark.loads_mark``: the tool's load, the parts, which parts schedule n carries), read
  back as the job's ``payload`` and ``parts``. ``PAYLOAD[n]`` whose schedule the mark states selects that load: the
  parts it carries that the robot did not are gripped there, those it no longer carries released (grip and release
  actions in its place among the waypoint's actions; the robot starts carrying none). Without the mark's schedule,
  ``PAYLOAD[n]`` before the first move is noted in the job's description (the schedule's data is on the controller)
  and after it refused naming the line: the load changes there to data the file does not hold.

``ControllerProgramError`` names the file, the line or point and what is wrong. ``tool_frame``,
``zone_from_cnt`` and ``pose_waypoint`` are shared with the Yaskawa reader; ``parse_subset`` with the RAPID and
URScript readers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
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
from ...program.actions import INPUT, OUTPUT, SIGNAL_NAME
from .fanuc_ls import CONTINUED, MM, WAITTMOUT_S, controller_frame, controller_pose
from .settings_mark import MarkedLoads, marked_loads

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
            source: str = "<ls>", frame: np.ndarray | None = None) -> dict:
    """The job document of a FANUC ``.ls`` program (module docstring). ``robot``: a Robot, preset name or
    robot file; ``tool``: the selected tool (UT n, n > 0) as X_FT (4, 4) [m] on the controller's flange (None: for
    UT 1 the writer's header comment; else an error); ``tcp_accel_max`` [m/s^2]: the TCP acceleration limit the
    writer rounded CNT over (comment-less CNT); ``source``: the file's name for errors; ``frame``: the selected
    user frame (UF n, n > 0) as X (4, 4) [m] in the controller's world frame (its UFRAME data)."""
    robot, reference = as_robot(robot)
    tree = parse_text("fanuc_ls", text, source)
    positions = dict(map(_position, tree.find_data("position")))
    walk = _Walk(source, marked_loads(text))
    for line, instruction in _mn_lines(tree):
        walk.read(line, instruction)
    walk.finish()
    if not walk.motions:
        raise ControllerProgramError(source, "/MN", "no motion instruction: nothing to read")
    frames = _Frames.of(walk, positions, source)
    X_FT = _tool(robot, frames, tool, walk.header, source)
    tool_robot = robot if X_FT is None else robot_with_tool(robot, X_FT)
    X_B_UF = controller_frame(robot, FANUC)[0] @ _user_frame(frames, frame, source)
    points = [[_point(robot, tool_robot, positions, ref, X_B_UF, walk, motion, source) for ref in motion.refs]
              for motion in walk.motions]
    document = _document(reference, X_FT, walk, points, tcp_accel_max)
    if walk.loads is not None:
        document.update(walk.loads.document(source))
    if walk.signals:
        document["signals"] = {name: {direction: number} for name, (direction, number) in walk.signals.items()}
    return document


@cache
def _instruction_parser() -> Lark:
    """The LALR parser of one /MN instruction's text (``grammars/fanuc_ls.lark``, start symbol ``instruction``)."""
    text = resources.files(__package__).joinpath("grammars", "fanuc_ls.lark").read_text()
    return Lark(text, parser="lalr", start="instruction")


def _mn_lines(tree: Tree) -> list[tuple[int, str]]:
    """(file line, instruction text) of each non-empty /MN line; a C move's continuation line joined to its first."""
    out = []
    for node in tree.iter_subtrees_topdown():
        if node.data not in ("numbered", "arc"):
            continue
        texts = [str(t).strip() for t in node.children if isinstance(t, Token) and t.type == "MN_TEXT"]
        text = " ".join(t for t in texts if t)
        if text:
            out.append((node.meta.line, text))
    return out


def _position(node: Tree) -> tuple[int, dict]:
    """(P index, {line, groups: {GPn: {uf, ut, config text or None, values {axis: number}}}}) of a /POS entry."""
    head = str(node.children[0])
    index = int(re.match(r"P\[(\d+)", head).group(1))
    groups = {}
    for group in node.find_data("group"):
        name, uf, ut = (str(t) for t in group.children[:3])
        config = next(group.find_data("config"), None)
        values = {str(v.children[0]): float(v.children[1]) for v in group.find_data("value")}
        groups[name] = {"uf": int(uf), "ut": int(ut), "values": values, "line": group.meta.line,
                        "config": None if config is None else _config_text(config)}
    return index, {"line": node.meta.line, "groups": groups}


def _config_text(node: Tree) -> str:
    flip, up, front, *turns = (str(t) for t in node.children)
    return f"{flip} {up} {front}, {', '.join(turns)}"


#: Instructions refused by what they begin with (when the grammar does not read them): why each has no static meaning.
REFUSED = (
    (re.compile(r"JMP\b"), "a jump: the path would depend on where the program jumps (no static meaning)"),
    (re.compile(r"LBL\["), "a label, the target of a jump or a loop (no static meaning)"),
    (re.compile(r"(IF|ELSE|ENDIF)\b"), "a branch on a condition known only when the robot runs"),
    (re.compile(r"SELECT\b|=\s*[\d.]+\s*,\s*(JMP|CALL)\b"), "a branch on a register (SELECT)"),
    (re.compile(r"(CALL|RUN)\b"), "a call of another program, which is not in this file"),
    (re.compile(r"SKIP\s+CONDITION\b"), "a skip condition: the move ends where an input changes"),
    (re.compile(r"(FOR|ENDFOR)\b"), "a loop on a register"),
    (re.compile(r"(WAIT\s+)?R[IO]\["), ("robot I/O (the end-of-arm connector): a job's signal is written back as DO[n] / "
     "DI[n], another signal")),
    (re.compile(r"WAIT\b"), "a wait on a condition other than one digital input (a flag, register or expression)"),
    (re.compile(r"(UFRAME|UTOOL)\["), "sets a frame's data from a register or position register"),
    (re.compile(r"(UFRAME_NUM|UTOOL_NUM)"), "selects a frame by a register: its number is not in the file"),
    (re.compile(r"PR\["), "a position register assignment: its value is not in the file"),
    (re.compile(r"(R|SR|AR|F|M)\["), "a register or flag assignment: registers have no static value in the file"),
    (re.compile(r"OVERRIDE\b"), "changes the speed override during the program (read before the first move only)"),
    (re.compile(r"PAYLOAD\["), "selects a payload schedule by a register: its number is not in the file"),
    (re.compile(r"TIMER\["), "a timer"),
    (re.compile(r"UALM\[|ABORT\b|END\b"), ("ends or stops the program before its end (only the timeout pattern "
     "END ; LBL[x] ; UALM[m] ; ABORT at the program's end is read)")),
    (re.compile(r"A\s+P"), "an arc move (A): not read"),
)


def refusal(source: str, line: int, text: str) -> ControllerProgramError:
    """The error for an instruction this reader does not read: the line, the instruction and why."""
    why = next((why for pattern, why in REFUSED if pattern.match(text)), "an instruction this reader does not read")
    return ControllerProgramError(source, f"line {line}", f"{text}: {why}", line=line)


#: A pendant's state prefix in an I/O comment (newer controllers print ``DO[195:OFF:name]``).
_STATE_PREFIX = re.compile(r"^(ON|OFF):")
#: A signal's number and comment in ``DO[1:name]``.
_IO = re.compile(r"[DR][IO]\[(\d+)(?::([^\]]*))?\]")


@dataclass
class _Motion:
    """One motion line: ``kind`` (joint, linear, circular), ``refs`` (P indices: a circular move's via, end),
    ``speed`` (its token text, ``70%`` or ``500mm/sec``), ``termination`` (FINE or CNTn), ``line``, ``offset``
    ((Offset or Tool_Offset, PR index) or None), the ``zone_comments`` just before it and the ``actions`` after it."""

    kind: str
    refs: list[int]
    speed: str
    termination: str
    line: int
    offset: tuple[str, int] | None = None
    zone_comments: list[str] = field(default_factory=list)
    actions: list[dict] = field(default_factory=list)


class _Walk:
    """The /MN instructions in order: motions with their actions, the header comments, the frame selections, the
    position register elements the file sets, the signals (name -> (direction, number)), the timeout pattern and
    the parts held (the writer's ``loads`` mark, or None)."""

    def __init__(self, source: str, loads: MarkedLoads | None = None):
        self.source = source
        self.loads = loads
        self.held: frozenset = frozenset()
        self.motions: list[_Motion] = []
        self.header: list[str] = []
        self.before: list[dict] = []                 # actions before the first motion
        self.selected: dict[str, tuple[int, int]] = {}   # UFRAME_NUM / UTOOL_NUM -> (number, line)
        self.registers: dict[tuple[int, int], float] = {}
        self.signals: dict[str, tuple[str, int]] = {}
        self.waittmout: float | None = None
        self.timed: list[tuple[int, int]] = []       # (line, label) of each timed wait
        self.after_end: list[tuple[int, str, int | None]] | None = None
        self.override = 1.0
        self.notes: list[str] = []
        self.loop: tuple[int, int] | None = None     # the outer loop's label and its line
        self.looped: int | None = None               # the line of the JMP back to it

    @property
    def actions(self) -> list[dict]:
        """Where an action read now belongs: the last motion's waypoint, or before the first motion."""
        return self.motions[-1].actions if self.motions else self.before

    def read(self, line: int, text: str) -> None:
        """Read one /MN instruction (its file ``line`` and text)."""
        try:
            tree = _instruction_parser().parse(text)
        except LarkError:
            raise refusal(self.source, line, text) from None
        node = tree.children[0]
        kind = node.type if isinstance(node, Token) else node.data
        if self.after_end is not None:
            self._after_end(line, text, kind, node)
            return
        if self.looped is not None and kind != "END":
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: after the outer loop's JMP only END "
                                         "and the timeout pattern are read", line=line)
        getattr(self, f"_{kind.lower()}")(line, text, node)

    def _motion(self, line: int, text: str, node: Tree) -> None:
        letter = str(node.children[0])
        targets = [t.children[0] for t in node.children if isinstance(t, Tree) and t.data == "target"]
        if any(t.type == "PR_REF" for t in targets):
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: a target in a position register: its "
                                         "value is on the controller, not in the file", line=line)
        if (letter == "C") != (len(targets) == 2):
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: C takes a via and an end point, J "
                                         "and L one point", line=line)
        speed = self._speed(line, text, letter, next(node.find_data("speed")))
        termination = self._termination(line, text, next(node.find_data("termination")))
        offset = self._options(line, text, list(node.find_data("option")))
        motion = _Motion({"J": "joint", "L": "linear", "C": "circular"}[letter],
                         [int(re.match(r"P\[(\d+)", str(t)).group(1)) for t in targets], speed, termination, line,
                         offset, self._zone_comments(termination))
        self.motions.append(motion)

    def _speed(self, line: int, text: str, letter: str, node: Tree) -> str:
        value, unit = (str(t) for t in node.children)
        if node.children[0].type == "REGISTER":
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: speed {value}{unit} is a register: "
                                         "its value is not in the file", line=line)
        if unit != ("%" if letter == "J" else "mm/sec"):
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: speed unit {unit}: read are % for "
                                         "J and mm/sec for L and C", line=line)
        return f"{value}{unit}"

    def _termination(self, line: int, text: str, node: Tree) -> str:
        token = node.children[0]
        if token.type == "REGISTER" or (token.type == "CNT" and int(str(token)[3:]) > 100):
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: termination CNT {token}: a register "
                                         "or beyond CNT100", line=line)
        return str(token)

    def _options(self, line: int, text: str, options: list[Tree]) -> tuple[str, int] | None:
        """The move's offset (Offset or Tool_Offset, PR index), or None; ACC100 is the default; others refused."""
        offset = None
        for option in options:
            token = option.children[0]
            if token.type == "ACC" and str(token) == "ACC100":
                continue
            if token.type == "OFFSET" and offset is None:
                offset = (str(token), int(re.match(r"PR\[(\d+)", str(option.children[1])).group(1)))
                continue
            why = ("an acceleration override the job cannot express (only ACC100, the default, is read)"
                   if token.type == "ACC" else "a motion option this reader does not read")
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: {token}: {why}", line=line)
        return offset

    def _zone_comments(self, termination: str) -> list[str]:
        """The ``!zone`` comments just before a CNT move (taken out of the previous waypoint's actions)."""
        if not self.motions:
            return self.header
        actions, start = self.actions, len(self.actions)
        while termination != "FINE" and start > 0 and "comment" in actions[start - 1]:
            start -= 1
        for i in range(start, len(actions)):
            if ZONE_COMMENT.search(actions[i]["comment"]):       # the zone comment and its wrapped lines
                taken = [a["comment"] for a in actions[i:]]
                del actions[i:]
                return taken
        return []

    def _comment(self, line: int, text: str, node: Tree) -> None:
        comment = str(node.children[0])[1:].strip()
        if not self.motions:
            self.header.append(comment)
            return
        previous = self.actions[-1] if self.actions else None
        if previous is not None and "comment" in previous and previous["comment"].endswith(CONTINUED):
            previous["comment"] = f"{previous['comment'][:-len(CONTINUED)]} {comment}"
            return
        if comment:
            self.actions.append({"comment": comment})

    def _frame_select(self, line: int, text: str, node: Tree) -> None:
        what, number = (node.children[0], node.children[1])
        if number.type == "REGISTER":
            raise refusal(self.source, line, text)
        self.selected[str(what)] = (int(number), line)

    def _io_set(self, line: int, text: str, node: Tree) -> None:
        name = self._signal(line, text, str(node.children[0]), OUTPUT)
        self.actions.append({"set": name, "value": str(node.children[1]).lower()})

    def _io_pulse(self, line: int, text: str, node: Tree) -> None:
        name = self._signal(line, text, str(node.children[0]), OUTPUT)
        if len(node.children) < 2:
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: a pulse without a width (the "
                                         "controller's default width is a system setting, not in the file)", line=line)
        self.actions.append({"pulse": name, "time": float(node.children[1])})

    def _wait_time(self, line: int, text: str, node: Tree) -> None:
        self.actions.append({"wait": float(node.children[0])})

    def _wait_input(self, line: int, text: str, node: Tree) -> None:
        name = self._signal(line, text, str(node.children[0]), INPUT)
        action = {"wait_input": name, "value": str(node.children[1]).lower()}
        timeout = next(node.find_data("timeout"), None)
        if timeout is not None:
            if self.waittmout is None:
                raise ControllerProgramError(self.source, f"line {line}", f"{text}: a timeout without $WAITTMOUT set "
                                             "before it in the program (its value is on the controller)", line=line)
            self.timed.append((line, _label(timeout.children[0])))
            action["timeout"] = self.waittmout
        self.actions.append(action)

    def _waittmout(self, line: int, text: str, node: Tree) -> None:
        self.waittmout = int(node.children[0]) * WAITTMOUT_S

    def _pr_element(self, line: int, text: str, node: Tree) -> None:
        register, element = (int(v) for v in re.findall(r"\d+", str(node.children[0])))
        self.registers[(register, element)] = float(node.children[1])

    def _override(self, line: int, text: str, node: Tree) -> None:
        """OVERRIDE=n% before the first move: the job's speed_scale n / 100 (module docstring)."""
        percent = int(node.children[0])
        if self.motions or not 1 <= percent <= 100:
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: an override is read before the first "
                                         "move only, 1 to 100 %", line=line)
        self.override = percent / 100.0

    def _payload(self, line: int, text: str, node: Tree) -> None:
        """PAYLOAD[n]: with the mark's schedule n, the grips and releases that make its load; without, before the first
        move noted in the job's description, after it refused (module docstring, "Loads")."""
        n = _label(node.children[0])
        carried = None if self.loads is None else self.loads.schedules.get(n)
        if carried is None and self.motions:
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: selects payload schedule {n} after the "
                                         f"first move: its data is on the controller, not in the file (no dh.payload"
                                         f".{n} mark of dh-pipeline's): the load the robot carries from here is not "
                                         "known", line=line)
        if carried is None:
            self.notes.append(f"{text} selects a payload schedule whose data is on the controller (not read)")
            return
        self.actions.extend({"release": name} for name in sorted(self.held - carried))
        self.actions.extend({"grip": name} for name in sorted(carried - self.held))
        self.held = carried

    def _end(self, line: int, text: str, node) -> None:
        self.after_end = []

    def _label(self, line: int, text: str, node) -> None:
        """A label before the first move opens the program's outer loop (``_jump``); any other is refused."""
        if self.motions or self.loop is not None:
            raise refusal(self.source, line, text)
        self.loop = (_label(node.children[0]), line)

    def _jump(self, line: int, text: str, node) -> None:
        """JMP back to the outer loop's label as the program's last instruction (before END): one cycle."""
        if self.loop is None or _label(node.children[0]) != self.loop[0] or self.looped is not None:
            raise refusal(self.source, line, text)
        self.looped = line

    def _alarm(self, line: int, text: str, node) -> None:
        raise refusal(self.source, line, text)

    _abort = _alarm

    def _after_end(self, line: int, text: str, kind: str, node) -> None:
        """An instruction after END: only the timeout pattern (LBL[x], UALM[m], ABORT) is read."""
        expected = ("label", "alarm", "ABORT")
        if len(self.after_end) >= len(expected) or kind != expected[len(self.after_end)]:
            raise ControllerProgramError(self.source, f"line {line}", f"{text}: after END only the timeout pattern "
                                         "END ; LBL[x] ; UALM[m] ; ABORT is read", line=line)
        number = _label(node.children[0]) if kind == "label" else None
        self.after_end.append((line, kind, number))

    def _signal(self, line: int, text: str, io: str, direction: str) -> str:
        """The name of the signal ``io`` (``DO[1:name]``; module docstring, "Actions"), added to the table."""
        if io.startswith("R"):
            raise refusal(self.source, line, text)
        number, comment = _IO.match(io).groups()
        number = int(number)
        name = _STATE_PREFIX.sub("", (comment or "").strip())
        if not SIGNAL_NAME.match(name) or self.signals.get(name, (direction, number)) != (direction, number):
            name = f"{'do' if direction == OUTPUT else 'di'}{number}"
        for other, entry in self.signals.items():
            if entry == (direction, number):
                return other
        self.signals[name] = (direction, number)
        return name

    def finish(self) -> None:
        """Check the outer loop (its label needs its JMP) and the timeout pattern: every timed wait jumps to the label
        of a complete END ; LBL ; UALM ; ABORT."""
        if self.loop is not None and self.looped is None:
            label, line = self.loop
            raise ControllerProgramError(self.source, f"line {line}", f"LBL[{label}]: a label without the JMP back "
                                         "to it at the program's end (no static meaning)", line=line)
        if self.looped is not None:
            self.notes.append(f"the program's endless loop (LBL[{self.loop[0]}] at line {self.loop[1]}, JMP back at "
                              f"line {self.looped}) reads as one cycle")
        pattern = self.after_end or []
        label = pattern[0][2] if len(pattern) == 3 else None
        for line, target in self.timed:
            if target != label:
                raise ControllerProgramError(self.source, f"line {line}", f"TIMEOUT,LBL[{target}]: the label must be "
                                             "the program's end pattern END ; LBL[x] ; UALM[m] ; ABORT", line=line)
        if pattern and (len(pattern) != 3 or not self.timed):
            line = pattern[0][0]
            raise ControllerProgramError(self.source, f"line {line}", "after END: the timeout pattern is incomplete or "
                                         "no wait jumps to it", line=line)


def _label(token) -> int:
    return int(re.search(r"\d+", str(token)).group(0))


@dataclass(frozen=True)
class _Frames:
    """The user frame and tool numbers the program's points name, with the line that selects or names each."""

    uf: int
    ut: int
    uf_line: int
    ut_line: int

    @classmethod
    def of(cls, walk: _Walk, positions: dict, source: str) -> _Frames:
        """The one UF and UT of every used point, equal to the program's UFRAME_NUM / UTOOL_NUM where selected."""
        used = sorted({ref for motion in walk.motions for ref in motion.refs})
        numbers = {}
        for ref in used:
            group = _gp1(positions, ref, source)
            for key, select in (("uf", "UFRAME_NUM"), ("ut", "UTOOL_NUM")):
                number, line = walk.selected.get(select, (group[key], group["line"]))
                if group[key] != number:
                    raise ControllerProgramError(source, f"P[{ref}]", f"{key.upper()} : {group[key]}, but {select}="
                                                 f"{number}: the controller stops with a frame mismatch",
                                                 line=group["line"])
                if numbers.setdefault(key, (number, line))[0] != number:
                    raise ControllerProgramError(source, f"P[{ref}]", f"{key.upper()} : {number} after "
                                                 f"{key.upper()} : {numbers[key][0]}: one user frame and one tool "
                                                 "per program are read", line=group["line"])
        (uf, uf_line), (ut, ut_line) = numbers.get("uf", (0, 0)), numbers.get("ut", (0, 0))
        return cls(uf, ut, uf_line, ut_line)


def _gp1(positions: dict, ref: int, source: str) -> dict:
    """The GP1 group of P[ref]: ControllerProgramError where the point is missing or has another group."""
    if ref not in positions:
        raise ControllerProgramError(source, f"P[{ref}]", "used in /MN but not defined in /POS")
    position = positions[ref]
    others = sorted(set(position["groups"]) - {"GP1"})
    if others or "GP1" not in position["groups"]:
        raise ControllerProgramError(source, f"P[{ref}]", f"motion group {', '.join(others) or 'GP1 missing'}: only "
                                     "one motion group (GP1) is read (a positioner or a second robot is not)",
                                     line=position["line"])
    return position["groups"]["GP1"]


def _tool(robot, frames: _Frames, tool: np.ndarray | None, header: list[str], source: str) -> np.ndarray | None:
    """X_FT (4, 4) [m] on our end frame of the selected tool (module docstring, "Tool"), or None."""
    if frames.ut == 0:
        return tool_frame(robot, FANUC, np.eye(4), [])
    if tool is None and (frames.ut != 1 or comment_tool(header) is None):
        raise ControllerProgramError(source, f"line {frames.ut_line}", f"tool {frames.ut} (UTOOL_NUM / UT): its data "
                                     "is on the controller, not in the file: give it (read_ls(tool=X_FT))", line=frames.ut_line)
    return tool_frame(robot, FANUC, tool, header)


def _user_frame(frames: _Frames, frame: np.ndarray | None, source: str) -> np.ndarray:
    """The selected user frame (4, 4) [m] in the controller's world frame (UF 0: the identity)."""
    if frames.uf == 0:
        return np.eye(4)
    if frame is None:
        raise ControllerProgramError(source, f"line {frames.uf_line}", f"user frame {frames.uf} (UFRAME_NUM / UF): "
                                     "its data is on the controller, not in the file: give it (read_ls(frame=X))",
                                     line=frames.uf_line)
    return np.asarray(frame, dtype=float)


def _point(robot, tool_robot, positions: dict, ref: int, X_B_UF: np.ndarray, walk: _Walk, motion: _Motion,
           source: str) -> dict:
    """{waypoint: the job's pose or joint fields, q [rad], p [m]: the TCP position, pose} of point P[ref] as
    ``motion`` goes to it (with its offset)."""
    where = f"P[{ref}]"
    group = _gp1(positions, ref, source)
    values = dict(group["values"])
    extended = {axis: v for axis, v in values.items() if axis.startswith("E") or axis in ("J7", "J8", "J9")}
    if any(v != 0.0 for v in extended.values()):
        raise ControllerProgramError(source, where, f"extended axes {extended}: only the arm's six axes are read "
                                     "(an extended axis at 0 is ignored)", line=group["line"])
    if group["config"] is None:
        if motion.offset is not None:
            raise ControllerProgramError(source, f"line {motion.line}", f"{motion.offset[0]} on a joint point "
                                         f"{where}: not read", line=motion.line)
        joints = [values.get(f"J{i}") for i in range(1, 7)]
        if None in joints:
            raise ControllerProgramError(source, where, "a joint point needs J1..J6", line=group["line"])
        q = joint_values(robot, joints, FANUC)
        X = tool_robot.fk(q)
        return {"waypoint": {"joints": [float(v) for v in np.degrees(q)]}, "q": q, "p": X[:3, 3],
                "pose": pose_fields(tool_robot, X, q)}
    missing = [axis for axis in "XYZWPR" if axis not in values]
    if missing:
        raise ControllerProgramError(source, where, f"a Cartesian point without {', '.join(missing)}",
                                     line=group["line"])
    X = controller_pose(X_B_UF, [values[a] for a in "XYZ"], [values[a] for a in "WPR"])
    if motion.offset is not None:
        X = _offset(X, X_B_UF, motion, walk.registers, source)
    try:
        waypoint, q = pose_waypoint(tool_robot, X, group["config"], FANUC, where, source)
    except ControllerProgramError as error:
        raise ControllerProgramError(source, where, error.problem, line=group["line"]) from None
    return {"waypoint": waypoint, "q": q, "p": X[:3, 3], "pose": waypoint}


def _offset(X: np.ndarray, X_B_UF: np.ndarray, motion: _Motion, registers: dict, source: str) -> np.ndarray:
    """The pose X (4, 4) [m] shifted by the motion's Offset (in the user frame) or Tool_Offset (in the tool frame)
    position register, whose six elements the file sets as constants with W = P = R = 0 (module docstring)."""
    kind, index = motion.offset
    elements = [registers.get((index, i)) for i in range(1, 7)]
    if None in elements or any(v != 0.0 for v in elements[3:]):
        raise ControllerProgramError(source, f"line {motion.line}", f"{kind},PR[{index}]: read only where the file "
                                     f"sets PR[{index},1..6] to constants before the move, with W, P, R 0 (got "
                                     f"{elements})", line=motion.line)
    shift = np.array(elements[:3]) / MM
    out = X.copy()
    out[:3, 3] += (X_B_UF[:3, :3] if kind == "Offset" else X[:3, :3]) @ shift
    return out


def _document(reference: str, X_FT, walk: _Walk, points: list[list[dict]], accel: float | None) -> dict:
    """The job document from the motions and their points (module docstring)."""
    moves = walk.motions
    ends = [p[-1] for p in points]
    waypoints = [_first_waypoint(ends[0], walk.before + moves[0].actions)]
    for m in range(1, len(moves)):
        move, end = moves[m], ends[m]
        waypoint = dict(end["waypoint"] if move.kind == "joint" else end["pose"])
        if "joints" not in waypoint:
            waypoint["move"] = move.kind
        if move.kind == "circular":
            waypoint["via"] = {"xyz": [float(v) for v in points[m][0]["p"]]}
        waypoint["speed"] = _speed(move.speed)
        chords = [float(np.linalg.norm(end["p"] - ends[m - 1]["p"]))]
        if m + 1 < len(moves):
            chords.append(float(np.linalg.norm(ends[m + 1]["p"] - end["p"])))
        zone = 0.0 if any(_is_wait(a) for a in move.actions) else _zone(move, accel, chords)
        if zone > 0.0:
            waypoint["zone"] = zone
        if move.actions:
            waypoint["do"] = move.actions
        waypoints.append(waypoint)
    start = ends[0]["q"] if "xyz" in ends[0]["waypoint"] else None
    document = job_document(reference, X_FT, waypoints, start, accel)
    notes = walk.notes + ([("the actions before the program's first move run once the robot is at the first "
                           "waypoint")] if walk.before else [])
    if walk.override != 1.0:
        document["speed_scale"] = walk.override
        notes.append(f"OVERRIDE={walk.override * 100:g}% is the speed scale")
    return {"description": "; ".join(notes), **document} if notes else document


def _is_wait(action: dict) -> bool:
    return "wait" in action or "wait_input" in action


def _first_waypoint(point: dict, actions: list[dict]) -> dict | list:
    """The first waypoint: no move, speed or zone (the motion starts there); its actions."""
    waypoint = point["waypoint"]
    if not actions:
        return waypoint["joints"] if "joints" in waypoint else dict(waypoint)
    return {**waypoint, "do": actions}


def _speed(text: str) -> float:
    """A joint move's speed [%] or a tool move's [m/s] from ``70%`` or ``500mm/sec``."""
    if text.endswith("%"):
        return float(text[:-1])
    return float(text[:-len("mm/sec")]) / MM


def _zone(move: _Motion, accel: float | None, chords: list[float]) -> float:
    """The zone [m] of a move's termination (module docstring)."""
    if move.termination == "FINE":
        return 0.0
    n = int(move.termination[len("CNT"):])
    for line in move.zone_comments:
        match = ZONE_COMMENT.search(line)
        if match is not None and int(match.group(2)) == n:
            return float(match.group(1)) / MM
    speed = None if move.kind == "joint" else _speed(move.speed) * MM
    return zone_from_cnt(n, speed, accel, chords)
