"""``write_rapid(program, module_name) -> str``: a compiled Program as an ABB RAPID module (``.mod``).

What it writes, and the RAPID facts it follows (ABB, "Technical reference manual - RAPID Instructions,
Functions and Data types", the entries named; "Technical reference manual - RAPID kernel" for names):

* ``tooldata`` (robhold, tframe, tload): tframe is the job's tool X_FT [mm, quaternion]; tload ``[mass, cog, aom,
  ix, iy, iz]`` is the job's payload ("loaddata": mass [kg] to 0.001 kg, cog the centre of gravity [mm] in the
  wrist frame tool0 to 0.001 mm, aom the orientation of the principal axes of its inertia at the cog in tool0 as a
  quaternion to 1e-6, ix, iy, iz its principal moments [kg m^2] to 1e-6; ``payload.principal_axes``: aom
  [1,0,0,0] and the diagonal for a diagonal inertia, ``[1,0,0,0],0,0,0`` for a point mass); without a payload the
  load (1 kg at the flange) is a PLACEHOLDER the header says to replace (``read_rapid`` reads it back as no
  payload).
* Parts (``grip``/``release`` actions, "GripLoad"): in its place among the waypoint's actions a grip or release
  writes ``GripLoad <name>;`` with <name> a ``LOCAL PERS loaddata`` of the parts held from there on (the part's
  name; several parts held at once: one combined load named by their names joined with ``_``), its cog [mm] and aom
  in the TOOL frame (the tframe's, as GripLoad's payload is the load the tool holds) and its principal moments, or
  ``GripLoad load0;`` (the predefined no load) when no part is held any more. Parts without a job payload: the tload
  stays the PLACEHOLDER and the parts' loads are still written (the header says so). A part whose name is also a
  name the module declares or uses is an OutputError.
* Scope (RAPID kernel manual, "Data declarations", "Routine declarations": a module's data and routines are
  global to the task unless declared ``LOCAL``): every data declaration is ``LOCAL``, so two written modules
  never clash in one task; the entry routine is global and named ``main_<module>`` (cut to 32 characters), unique
  per module: run it with "PP to Routine", or call it from the task's own ``main``. The module name is never a
  name the module declares (``names``: a job ``tool_job`` becomes module ``P_tool_job``).
* The header records the job (``job=NAME``, ``pipeline.files.atomic.job_mark``).
* Frames: the controller's base frame and tool0 are the robot file's abb controller section's (``controller.
  controller_frames``; our base and end frames without one): robtargets are in its base frame, tframe is the
  tool on its tool0, and a header line says where they come from (``controller.frames_words``).
* ``wobjdata``: without a cell, or with the robot's base at the cell's origin, ``wobj0`` (targets in the
  controller's base frame). Otherwise a work object whose user frame is the controller's base frame in the
  cell (X_WB X_B_base), so that the targets stay in that frame: the controller's base frame (system
  parameters) must then be that pose in its world frame, as in the cell.
* ``robtarget`` [trans, rot, robconf, extax]: the TCP in the work object, position [mm] rounded to 0.001 mm,
  orientation as the unit quaternion [q1 (scalar), q2, q3, q4] with q1 >= 0 rounded to 1e-6, ``confdata``
  [cf1, cf4, cf6, cfx] (``pipeline.model.vendors.configuration``; the axis map of ``pipeline.model.vendors.axes``
  named in the header) of the move's target joint values, unless an axis sits on a quadrant boundary that
  the rounding moves it across (``written_configuration``); external axes 9E9 (none).
* ``jointtarget`` [robax, extax]: axis angles [deg] rounded to 0.0001 deg, for ``MoveAbsJ``.
* Moves: the start is reached by ``MoveAbsJ`` at ``v100``, an approach that is not part of the program.
  A joint move to joint values is ``MoveAbsJ`` (the joint values themselves, no configuration needed); a
  joint move to a pose is ``MoveJ`` to a robtarget; ``MoveL``; ``MoveC`` with the program's via point as
  CirPoint (its orientation and confdata where the program's track passes it; RAPID uses the CirPoint's
  orientation only to choose the way of reorientation). A planned joint move passes its planner vertices
  by ``MoveAbsJ ... fine`` each: axis interpolation is straight in joint space, the segments the planner
  checked. With the certified motion (``written``: ``controller_motion.certified_moves``, what ``program``
  writes) a planned move is ``MoveAbsJ`` to joint targets sampled from the certified path instead, each with a
  zone, and ``fine`` stands only where the certified motion stops; the header carries the written program's
  certificate, smallest clearance, largest deviation and cycle time as written.
* ``speeddata`` [v_tcp, v_ori, v_leax, v_reax]: a tool move's TCP speed (x the job's speed scale, capped by
  its safety TCP limit) [mm/s] as v_tcp, the rest (500 deg/s, 5000 mm/s, 1000 deg/s) as in every predefined
  speeddata v5..v7000. A joint move runs at a fraction s of the joint speed limits; RAPID has no such
  speed, so it is written as ``vmax \\T:=T`` (\\T: the total time of the move, which replaces the
  speeddata): T = max_i |dq_i| / (s x speed scale x qd_max_i) [s], rounded up to 0.1 ms, the time the leading
  axis needs at that speed without accelerating. The controller adds its own acceleration and keeps its
  own axis limits, so the move takes at least that long.
* ``PathAccLim TRUE\\AccMax:=A, TRUE\\DecelMax:=A`` [m/s^2] after the approach, for a program with tool moves and
  a TCP acceleration limit: A = the job's ``tcp_accel_max`` x the speed scale squared (``path_acceleration``; the
  certified timing's; ``read_rapid`` reads it back as ``tcp_accel_max``: without it a read-back job's tool moves
  accelerated freely and its cycle time came out below the certified one).
* ``zonedata`` [finep, pzone_tcp, pzone_ori, pzone_eax, zone_ori, zone_leax, zone_reax]: ``fine`` at the
  program's stops and at both ends of a planned joint move (``Program.exact_stop_at``); a zone of R mm as pzone_tcp = R with the other fields in the ratios of the predefined
  z10..z200 (1.5 R mm for pzone_ori, pzone_eax, zone_leax; 0.15 R deg for zone_ori, zone_reax); ``z0`` (the
  smallest fly-by zone, 0.3 mm) at a waypoint the program passes through without a zone.
* Actions (``pipeline.program.actions``) right after the last move written into their waypoint (waypoint 0's
  after the approach ``MoveAbsJ j0`` and ``PathAccLim``, before the first move), in the RAPID Instructions manual's
  words: a set ``SetDO sig, 1;`` / ``SetDO sig, 0;`` ("SetDO"); a pulse ``PulseDO \\PLength:=t, sig;`` (t [s],
  "PulseDO": the program goes on while the output is high); a wait ``WaitTime \\InPos, t;`` ("WaitTime": \\InPos
  starts the time once the robot stands still in position; its waypoint ends in ``fine``, the job's exact stop); a
  wait for an input ``WaitDI sig, 1;`` with ``\\MaxTime:=t`` for a timeout ("WaitDI": without \\TimeFlag the
  controller stops the program with ERR_WAIT_MAXTIME once t [s] pass, the job's timeout; the move before it ends in
  ``fine``, so the robot is at the point); a comment ``! text``. Real programs write the same (e.g. RobotStudio's
  ``PulseDO``/``WaitTime`` in rparak/ABB-RobotStudio-Tutorial-Simple, ``PulseDO \\PLength:=2.0, WeldStarted;`` and
  ``WaitDI di, 1 \\MaxTime:=...`` in controller backups found by the code search). A RAPID signal is a name
  configured on the controller (EIO): the job's signal name is written as it is (a RAPID identifier, not a reserved
  word, not a name of the module's data, else OutputError naming the signal); its number, where the job gives one, is not RAPID's, so it rides in the
  header's signals mark (``settings_mark.signals_mark``) for ``read_rapid`` to keep.
* ``ConfJ \\On`` and ``ConfL \\On``: the controller keeps the written configurations (its default after
  loading, written out so that a changed default cannot pick another branch).
* Names: identifiers of at most 32 characters, letters, digits and underscores, starting with a letter,
  not a reserved word (``names.RESERVED_WORDS``).
"""

from __future__ import annotations

import math
import re
import textwrap

import numpy as np

from ...errors import OutputError
from ...files.atomic import WRITTEN_BY, job_mark
from ...files.poses import pose_to_quaternion_position, quaternion_position_to_pose
from ...model.vendors import selection
from ...model.vendors.axes import ABB, axis_angles
from ...model.vendors.configuration import format_configuration
from ...model.vendors.controller import controller_frames, frames_words, tool_on_flange
from ...program.actions import COMMENT, GRIP, PULSE, RELEASE, SET, WAIT, WAIT_INPUT, Action, held_after
from ...program.model import CIRCULAR, JOINT, LINEAR, Move, Program
from ...program.payload import Payload, combined, expressed_in, principal_axes
from .controller_motion import PASS_THROUGH_ZONE_M, WrittenProgram
from .lint import RAPID, lint
from .names import RESERVED_WORDS
from .settings_mark import settings_mark, signals_mark

IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}$")
#: v_ori [deg/s], v_leax [mm/s], v_reax [deg/s] of every predefined speeddata v5..v7000.
SPEED_REST = (500.0, 5000.0, 1000.0)
#: The predefined z10..z200 zones' pzone_ori, pzone_eax, zone_leax [mm] and zone_ori, zone_reax [deg] per mm.
ZONE_MM_RATIO, ZONE_DEG_PER_MM = 1.5, 0.15
EXTERNAL_AXES = "[9E9,9E9,9E9,9E9,9E9,9E9]"
TOOL, WOBJ = "tool_job", "wobj_base"
APPROACH_SPEED = "v100"
#: Decimals written: positions [mm], quaternions, joint angles [deg], speeds [mm/s], masses [kg], inertias [kg m^2].
MM, QUATERNION, DEG, SPEED, KG, INERTIA = 3, 6, 4, 3, 3, 6
#: The tload written without a job payload (module docstring): 1 kg at the flange, a PLACEHOLDER; no load (GripLoad).
PLACEHOLDER_LOAD, NO_LOAD = "[1,[0,0,0],[1,0,0,0],0,0,0]", "load0"
#: \\T is rounded up to 0.1 ms (1 ms took up to 7 % off the 14 ms joint moves between a planned move's targets).
TIME_STEP_S = 1e-4
#: The written pose's joint values must lie this close to the program's [rad] (``written_configuration``).
WRITTEN_JOINTS_RAD = 1e-3
#: Header comment lines are wrapped to this many characters; the declarations are written in this order.
COMMENT_WIDTH = 96
DATA_ORDER = {datatype: k for k, datatype in enumerate(("tooldata", "wobjdata", "loaddata", "speeddata", "zonedata",
                                                        "jointtarget", "robtarget"))}
#: How each data type is declared: tool, work object and load data persistent (as RobotStudio declares them), the rest
#: constants; all LOCAL to the module (module docstring, "Scope").
STORAGE = {"tooldata": "LOCAL PERS", "wobjdata": "LOCAL PERS", "loaddata": "LOCAL PERS", "speeddata": "LOCAL CONST",
           "zonedata": "LOCAL CONST", "jointtarget": "LOCAL CONST", "robtarget": "LOCAL CONST"}
#: Predefined data the module writes (RAPID Instructions manual, speeddata, zonedata, tooldata, wobjdata, loaddata).
PREDEFINED_NAMES = ("vmax", APPROACH_SPEED, "fine", "z0", "tool0", "wobj0", NO_LOAD)
#: The global entry routine's name is this prefix and the module's name (module docstring, "Scope").
ENTRY_PREFIX = "main_"


def write_rapid(program: Program, module_name: str, written: WrittenProgram | None = None) -> str:
    """The RAPID module text of ``program`` (see the module docstring), named ``module_name`` (a RAPID
    identifier). OutputError names what cannot be written (a bad name, a robot without 6 joints); ``lint``
    runs first on the name, the header comments and the confdata of the robtargets (ControllerLintError).
    ``written`` (``controller_motion.certified_moves``): the certified motion, its targets and zones (a planned
    move as MoveAbsJ to joint targets on the certified path, zones wherever it does not stop) and its certificate
    in the header; None: the planner's vertices with exact stops (``Program.exact_stop_at``)."""
    check_identifier(module_name, "module name")
    if program.robot.dof != 6:
        raise OutputError(f"{program.robot.name}: a RAPID robtarget needs a 6-joint arm, it has {program.robot.dof}")
    module = _Module(program, written)
    comments = [a.text for k in range(len(program.waypoints)) for a in program.actions_at(k) if a.kind == COMMENT]
    lint(program, RAPID, module_name, module.header(module_name) + comments, written_configurations(program))
    module.add_moves()
    module.check_names(module_name)
    return module.text(module_name)


def check_identifier(name: str, what: str) -> str:
    """``name`` if it is a RAPID identifier, else OutputError naming ``what`` and the rule it breaks."""
    if not isinstance(name, str) or not IDENTIFIER.match(name):
        raise OutputError(f"RAPID {what} {name!r}: an identifier is 1 to 32 letters, digits or underscores "
                          "starting with a letter")
    if name.upper() in RESERVED_WORDS[RAPID]:
        raise OutputError(f"RAPID {what} {name!r} is a reserved word (pipeline.outputs.controllers.names)")
    return name


def number(value: float, decimals: int) -> str:
    """``value`` with at most ``decimals`` decimals, without trailing zeros or a negative zero."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def numbers(values, decimals: int) -> str:
    """``[a,b,...]`` of the values, each as ``number`` writes it."""
    return "[" + ",".join(number(float(v), decimals) for v in values) + "]"


def pose_text(X: np.ndarray) -> str:
    """``[[x,y,z],[q1,q2,q3,q4]]`` of a pose (4, 4) [m]: position [mm], unit quaternion, scalar first, q1 >= 0."""
    quaternion, position = pose_to_quaternion_position(X)
    return f"[{numbers(position * 1e3, MM)},{numbers(quaternion, QUATERNION)}]"


def written_pose(X: np.ndarray, X_B_base: np.ndarray | None = None) -> np.ndarray:
    """The pose (4, 4) [m] a controller reads from ``pose_text(X)``: the rounded position and the rounded
    quaternion normalised; with ``X_B_base`` (the controller's base frame in ours), X is in our base frame and
    written in its."""
    if X_B_base is not None:
        return X_B_base @ written_pose(np.linalg.inv(X_B_base) @ X)
    quaternion, position = pose_to_quaternion_position(X)
    quaternion = np.round(quaternion, QUATERNION)
    return quaternion_position_to_pose(quaternion / np.linalg.norm(quaternion), np.round(position * 1e3, MM) / 1e3)


def written_configuration(robot, X: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The confdata (4,) written with the robtarget of pose X (4, 4) [m] reached with joint values q (6,)
    [rad]: ``selection.written_configuration`` of the pose as the module rounds it (``written_pose``), within
    WRITTEN_JOINTS_RAD of q (an axis on a quadrant boundary, a multiple of 90 deg, may be written on the side
    its rounded robtarget selects)."""
    return selection.written_configuration(robot, written_pose(X, controller_frames(robot, ABB)[0]), q, ABB,
                                           WRITTEN_JOINTS_RAD,
                                             f"the robtarget, rounded to {MM} decimals of mm and {QUATERNION} of "
                                             "the quaternion,")


def written_configurations(program: Program) -> list[np.ndarray | None]:
    """The confdata (4,) written for each waypoint: None for the start and joint waypoints (jointtargets)."""
    return [None] + [None if program.waypoints[m.end].method is None else
                     written_configuration(program.robot, m.X_BT, m.target) for m in program.moves]


def zone_name(program: Program, move: Move) -> tuple[str, str | None]:
    """(the zonedata name, its value or None for a predefined one) at the end of ``move``."""
    if program.exact_stop_at(move):
        return "fine", None
    return zone_data(move.zone)


def zone_data(zone_m: float, stop: bool = False) -> tuple[str, str | None]:
    """(the zonedata name, its value or None for a predefined one) of a zone of ``zone_m`` [m]: ``fine`` at a
    ``stop``, ``z0`` for no zone (or RAPID's z0 itself, PASS_THROUGH_ZONE_M) where the motion passes through."""
    if stop:
        return "fine", None
    if zone_m <= PASS_THROUGH_ZONE_M + 1e-12:
        return "z0", None
    mm = zone_m * 1e3
    name = "zone_" + number(mm, MM).replace(".", "_")
    fields = [number(mm, MM), *[number(mm * ZONE_MM_RATIO, MM)] * 2, number(mm * ZONE_DEG_PER_MM, MM),
              number(mm * ZONE_MM_RATIO, MM), number(mm * ZONE_DEG_PER_MM, MM)]
    return name, f"[FALSE,{','.join(fields)}]"


def action_instruction(action: Action) -> str:
    """The RAPID instruction (or ``! comment``) of one action (module docstring, "Actions"); OutputError when its
    signal's name is not a RAPID identifier."""
    if action.kind == COMMENT:
        return f"! {action.text}"
    if action.kind == WAIT:
        return f"WaitTime \\InPos, {number(action.time_s, 3)};"
    signal = check_identifier(action.signal, "signal name")
    if action.kind == SET:
        return f"SetDO {signal}, {int(action.value)};"
    if action.kind == PULSE:
        return f"PulseDO \\PLength:={number(action.time_s, 3)}, {signal};"
    if action.kind == WAIT_INPUT:
        timeout = "" if action.timeout_s is None else f" \\MaxTime:={number(action.timeout_s, 3)}"
        return f"WaitDI {signal}, {int(action.value)}{timeout};"
    raise OutputError(f"RAPID has no instruction for an action of kind {action.kind!r}")


def path_acceleration(program: Program) -> float | None:
    """The TCP acceleration and deceleration limit [m/s^2] written as ``PathAccLim`` (RAPID Instructions manual,
    PathAccLim: \\AccMax, \\DecelMax in m/s^2, at least 0.1): the job's ``tcp_accel_max`` x the speed scale squared
    (the certified timing's), None without one or without a tool move (RAPID's limit acts on the TCP only)."""
    if program.tcp_accel_max is None or not any(m.is_tool_move for m in program.moves):
        return None
    return max(float(program.tcp_accel_max) * program.speed_scale**2, 0.1)


def joint_move_time(program: Program, q_from: np.ndarray, q_to: np.ndarray, fraction: float) -> float:
    """The time [s] the leading axis needs from q_from to q_to (6,) [rad] at ``fraction`` x the speed scale x
    its speed limit, rounded up to TIME_STEP_S (0: no motion)."""
    speeds = fraction * program.speed_scale * program.limits.qd_max
    seconds = float(np.max(np.abs(np.asarray(q_to) - np.asarray(q_from)) / speeds))
    return math.ceil(seconds / TIME_STEP_S - 1e-9) * TIME_STEP_S


def via_target(program: Program, move: Move) -> tuple[np.ndarray, np.ndarray]:
    """(pose (4, 4) [m], joint values (6,) [rad]) of a circular move's via point: the via position, with the
    orientation and joint values where the move's track passes it."""
    tool_path = move.track.along.tool_path
    index = next(i for i, segment in enumerate(tool_path.segments) if segment.index == move.end)
    centre, radius, e1, e2, _ = tool_path.segments[index].arc
    offset = move.via - centre
    angle = math.atan2(float(offset @ e2), float(offset @ e1)) % (2.0 * math.pi)
    sigma = tool_path.starts[index] + radius * angle
    q = move.track.along.path(np.array([sigma / tool_path.length]))[0]
    X = np.eye(4)
    X[:3, :3] = tool_path.rotation([sigma]).as_matrix()[0]
    X[:3, 3] = move.via
    return X, q


def loaddata_text(load: Payload, X_FA: np.ndarray) -> str:
    """``[mass,[x,y,z],[q1,q2,q3,q4],ix,iy,iz]`` (RAPID loaddata: [kg], cog [mm], aom, principal moments [kg m^2]) of
    ``load`` (in the flange frame F) stated in frame A, X_FA (4, 4) [m] A's pose in F (module docstring)."""
    in_a = expressed_in(load, np.linalg.inv(X_FA))
    moments, R = principal_axes(in_a)
    aom = np.eye(4)
    aom[:3, :3] = R
    quaternion, _ = pose_to_quaternion_position(aom)
    return (f"[{number(in_a.mass, KG)},{numbers(in_a.com * 1e3, MM)},{numbers(quaternion, QUATERNION)},"
            f"{','.join(number(float(m), INERTIA) for m in moments)}]")


def load_text(program: Program) -> str:
    """The tooldata's tload: the job's payload in tool0 (``loaddata_text``), else the 1 kg PLACEHOLDER_LOAD at the
    flange (module docstring)."""
    if program.payload is None:
        return PLACEHOLDER_LOAD
    return loaddata_text(program.payload, controller_frames(program.robot, ABB)[1])


def held_load(program: Program, held: tuple[str, ...]) -> tuple[str, str | None]:
    """(loaddata name, its value or None for load0) that ``GripLoad`` connects while the parts ``held`` are held: the
    part's name (several: their names joined with ``_``) and their load in the tool frame (module docstring)."""
    if not held:
        return NO_LOAD, None
    name = check_identifier("_".join(held), "part name (a loaddata)")
    return name, loaddata_text(combined([program.parts[part] for part in held], name), program.tool.X_FT)


def entry_routine(module_name: str) -> str:
    """The global entry routine of a module (module docstring, "Scope")."""
    return (ENTRY_PREFIX + module_name)[:32]


class _Module:
    """The declarations and instructions of one module, gathered move by move."""

    def __init__(self, program: Program, written: WrittenProgram | None = None):
        self.program = program
        self.written = written
        self.declarations: dict[str, tuple[str, str]] = {}          # name -> (data type, value)
        self.instructions: list[str] = []
        X_WB = None if program.cell is None else program.cell.X_WB
        self.wobj = "" if X_WB is None or np.allclose(X_WB, np.eye(4), atol=1e-12) else f"\\WObj:={WOBJ}"
        self.X_B_base = controller_frames(program.robot, ABB)[0]
        tframe = tool_on_flange(program.robot, ABB, program.tool.X_FT)          # on the controller's tool0
        self.declare(TOOL, "tooldata", f"[TRUE,{pose_text(tframe)},{load_text(program)}]")
        if self.wobj:                                       # uframe: the controller's base frame in the cell
            uframe = pose_text(X_WB @ self.X_B_base)
            self.declare(WOBJ, "wobjdata", f"[FALSE,TRUE,\"\",{uframe},[[0,0,0],[1,0,0,0]]]")

    def declare(self, name: str, datatype: str, value: str | None) -> None:
        """Declare ``name`` once (a repeat of the same data type keeps the first); OutputError when it is already
        declared as another type (a part named like a target)."""
        if value is not None:
            known = self.declarations.setdefault(check_identifier(name, "data name"), (datatype, value))
            if known[0] != datatype:
                raise OutputError(f"RAPID data name {name!r} is both a {known[0]} and a {datatype} of the module: "
                                  "rename the part in the job")

    def jointtarget(self, name: str, q: np.ndarray) -> str:
        angles = axis_angles(self.program.robot, q, ABB)
        self.declare(name, "jointtarget", f"[{numbers(angles, DEG)},{EXTERNAL_AXES}]")
        return name

    def robtarget(self, name: str, X: np.ndarray, q: np.ndarray) -> str:
        robot = self.program.robot
        conf = format_configuration(ABB, written_configuration(robot, X, q))
        pose = pose_text(np.linalg.inv(self.X_B_base) @ X)                   # in the controller's base frame
        self.declare(name, "robtarget", f"[{pose[1:-1]},{conf},{EXTERNAL_AXES}]")
        return name

    def speed(self, move: Move) -> str:
        mm_s = self.program.tool_speed(move) * 1e3
        name = "speed_" + number(mm_s, SPEED).replace(".", "_")
        fields = ",".join([number(mm_s, SPEED), *(number(v, SPEED) for v in SPEED_REST)])
        self.declare(name, "speeddata", f"[{fields}]")
        return name

    def timed(self, q_from: np.ndarray, q_to: np.ndarray, fraction: float) -> str:
        seconds = joint_move_time(self.program, q_from, q_to, fraction)
        return f"vmax\\T:={number(seconds, 4)}" if seconds > 0.0 else "vmax"

    def zone(self, move: Move) -> str:
        if self.written is not None:
            return self.zone_of(self.written.of(move.end)[-1].zone_m)
        name, value = zone_name(self.program, move)
        self.declare(name, "zonedata", value)
        return name

    def zone_of(self, zone_m: float) -> str:
        """The zonedata of a written move's zone [m] (0: ``fine``, the certified motion stops there)."""
        name, value = zone_data(zone_m, stop=zone_m <= 0.0)
        self.declare(name, "zonedata", value)
        return name

    def inner_targets(self, move: Move) -> list[tuple[np.ndarray, str]]:
        """(joint values, zonedata) of the joint targets a joint move passes before its end: with the certified motion
        (``written``) the ones written for it (a planned move's, or a curved joint move's, on the certified path),
        else a planned move's vertices."""
        if self.written is not None:
            return [(w.target, self.zone_of(w.zone_m)) for w in self.written.of(move.end)[:-1]]
        if move.planned is None:
            return []
        return [(vertex, "fine") for vertex in move.planned.waypoints[1:-1]]

    def add_moves(self) -> None:
        program = self.program
        start = self.jointtarget("j0", program.targets[0])
        self.instructions += ["ConfJ\\On;", "ConfL\\On;", f"MoveAbsJ {start}, {APPROACH_SPEED}, fine, {TOOL};"]
        accel = path_acceleration(program)
        if accel is not None:
            # after the approach: PathAccLim acts on the TCP of the moves that follow
            limit = number(accel, 3)
            self.instructions.append(f"PathAccLim TRUE\\AccMax:={limit}, TRUE\\DecelMax:={limit};")
        self.add_actions(0)
        for move in program.moves:
            self.add_move(move)
            self.add_actions(move.end)

    def add_actions(self, k: int) -> None:
        """Waypoint ``k``'s actions, after the last move written into it (module docstring, "Actions"); a grip or
        release as ``GripLoad`` of the parts held after it (module docstring, "Parts")."""
        for i, action in enumerate(self.program.actions_at(k)):
            if action.kind not in (GRIP, RELEASE):
                self.instructions.append(action_instruction(action))
                continue
            name, value = held_load(self.program, held_after(self.program.actions, k, i))
            self.declare(name, "loaddata", value)
            self.instructions.append(f"GripLoad {name};")

    def check_names(self, module_name: str) -> None:
        """OutputError naming a signal whose name is also a name the module declares or uses (its data, the predefined
        data it writes, the module or its entry routine): RAPID would take that name for the data, not the signal; and
        a parts' loaddata named as predefined data, the module or its routine."""
        used = {name.lower() for name in PREDEFINED_NAMES} | {module_name.lower(), entry_routine(module_name).lower()}
        taken = used | {name.lower() for name in self.declarations}
        for k in range(len(self.program.waypoints)):
            for action in self.program.actions_at(k):
                if action.signal is not None and action.signal.lower() in taken:
                    raise OutputError(f"RAPID signal name {action.signal!r} (waypoint {k}) is also a name the module "
                                      "declares or uses for data: rename the signal in the job")
        for name, (datatype, _) in self.declarations.items():
            if datatype == "loaddata" and name.lower() in used:
                raise OutputError(f"RAPID loaddata {name!r} of the parts held is also a name the module uses "
                                  "(predefined data, the module or its routine): rename the part in the job")

    def add_move(self, move: Move) -> None:
        program, k = self.program, move.end
        q_from = program.targets[k - 1]
        tail = f"{self.zone(move)}, {TOOL}{self.wobj};"
        if move.kind == JOINT:
            for i, (vertex, zone) in enumerate(self.inner_targets(move), start=1):
                name = self.jointtarget(f"j{k}_{i}", vertex)
                self.instructions.append(f"MoveAbsJ {name}, {self.timed(q_from, vertex, move.speed)}, {zone}, "
                                         f"{TOOL};")
                q_from = vertex
            speed = self.timed(q_from, move.target, move.speed)
            if program.waypoints[k].method is None:
                self.instructions.append(f"MoveAbsJ {self.jointtarget(f'j{k}', move.target)}, {speed}, {tail}")
            else:
                self.instructions.append(f"MoveJ {self.robtarget(f'p{k}', move.X_BT, move.target)}, {speed}, {tail}")
        elif move.kind == LINEAR:
            self.instructions.append(f"MoveL {self.robtarget(f'p{k}', move.X_BT, move.target)}, {self.speed(move)}, "
                                     f"{tail}")
        elif move.kind == CIRCULAR:
            via = self.robtarget(f"c{k}", *via_target(program, move))
            self.instructions.append(f"MoveC {via}, {self.robtarget(f'p{k}', move.X_BT, move.target)}, "
                                     f"{self.speed(move)}, {tail}")
        else:
            raise OutputError(f"move to waypoint {k}: RAPID has no move of kind {move.kind!r}")

    def header(self, module_name: str) -> list[str]:
        program = self.program
        accel = "none" if program.tcp_accel_max is None else f"{program.tcp_accel_max * 1e3:g} mm/s^2"
        return [
            (f"{module_name}: the compiled program {program.name!r} (robot {program.robot.name}, "
             f"{len(program.moves)} moves), written by {WRITTEN_BY} (pipeline.outputs.controllers.rapid)."),
            "Units: mm, deg; quaternions [q1 (scalar), q2, q3, q4]. Rounding: 0.001 mm, 1e-6, 0.0001 deg.",
            "The controller plans its own velocity profile: this is not the certified profile.",
            "- tool moves run at their TCP speed (speeddata v_tcp); joint moves take \\T, the time the",
            "  leading axis needs at the move's fraction of its speed limit without accelerating,",
            "  and the controller adds its own acceleration",
            *([f"- no acceleration limit is written (the job's TCP limit: {accel}); RAPID sets",
               "  acceleration only as a percentage of the controller's own (AccSet)"]
              if path_acceleration(program) is None else
              [f"- the job's TCP acceleration limit ({accel} x the speed scale squared) as PathAccLim [m/s^2]"]),
            "- zones are the controller's corner paths, not the program's blends; fine stops exactly;",
            ("  z0 where the program passes through a waypoint without a zone; fine at both ends of a planned move"
             if self.written is None else "  z0 where the program passes through a waypoint without a zone; "
             "fine only where the certified motion stops; a planned move's joint targets lie on the certified path"),
            f"- joint moves are axis-interpolated, not the job's path shape ({program.path or 'default'})",
            "confdata [cf1,cf4,cf6,cfx] from each target's joint values; ConfJ/ConfL \\On keep them.",
            frames_words(program.robot, ABB, "the base frame", "tool0", "confdata and jointtargets") + ".",
            job_mark(program.job_name or program.name),
            settings_mark(program),
            *([signals_mark(program)] if signals_mark(program) else []),
            (f"{TOOL}: tframe is the job's tool; its load (1 kg at the flange) is a PLACEHOLDER: set the real one."
             if program.payload is None else f"{TOOL}: tframe is the job's tool, tload its payload (cog in tool0, "
             "aom the principal axes of its inertia, ix, iy, iz its principal moments)."),
            *([("GripLoad connects the load of the parts held (loaddata named by the parts: cog and aom in the tool "
                "frame, principal moments), GripLoad load0 disconnects it"
                + (" (the parts' loads are written though the tool's is the PLACEHOLDER)." if program.payload is None
                   else "."))] if program.parts else []),
            (f"Data are LOCAL to this module; run {entry_routine(module_name)} (PP to Routine, or call it from the "
             "task's main)."),
            (f"{WOBJ}: the robot's base in the cell; the controller's base frame must be set the same."
             if self.wobj else "Targets in the robot's base frame (wobj0)."),
            f"MoveAbsJ j0 at {APPROACH_SPEED} is an approach to the start, not part of the program.",
            *([] if self.written is None else self.written.header_lines()),
        ]

    def text(self, module_name: str) -> str:
        lines = [f"MODULE {module_name}"]
        for line in self.header(module_name):
            lines += [f"  ! {part}"
                      for part in textwrap.wrap(line, COMMENT_WIDTH, subsequent_indent="  ", break_on_hyphens=False)]
        for name, (datatype, value) in sorted(self.declarations.items(), key=lambda item: DATA_ORDER[item[1][0]]):
            lines.append(f"  {STORAGE[datatype]} {datatype} {name} := {value};")
        lines += [f"  PROC {entry_routine(module_name)}()"] + [f"    {instruction}" for instruction in self.instructions]
        lines += ["  ENDPROC", "ENDMODULE"]
        return "\n".join(lines) + "\n"
