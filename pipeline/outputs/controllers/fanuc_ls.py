"""``write_ls(program, name) -> str``: a program as a FANUC teach pendant program in ASCII (``.ls``).

The file (FANUC R-30iA/R-30iB operator's manuals: "program header information", "motion instructions",
"position data"; the ASCII layout is the one the ASCII Program Loader reads and ROBOGUIDE/``PrintTP``
writes) is ``/PROG name``, ``/ATTR`` (the header), ``/MN`` (numbered lines), ``/POS`` (the points) and
``/END``. What this writer emits, and why:

* Name: 1 to 8 characters, an upper-case letter then letters, digits or ``_``. Controllers from the
  R-30iA on accept longer names (up to 36 characters, not checked against a manual here); 8 is the limit
  every controller generation that reads ``.ls`` accepts, so a program loads anywhere unchanged.
* Moves: the robot first goes to the program's first waypoint with a joint move (where it starts is not
  known), then one line per move: ``J`` (joint), ``L`` (linear), ``C`` (circular: via point, then end point
  on a continuation line). Joint moves run at ``%`` of the joints' maximum speed (the move's fraction of the
  speed limits x the job's ``speed_scale``, 1 to 100), tool moves at ``mm/sec`` (the move's TCP speed x
  ``speed_scale``, whole mm/sec as the pendant takes them).
* Planned joint moves (a cell's collision-free detour): a ``J`` to each planner vertex, given in joints,
  each ``FINE``: joint interpolation is straight in joint space, the segments the planner checked.
* Termination: ``FINE`` where the move's zone is 0 (every stop, and the waypoints a joint path passes through:
  the controller stops there) and at both ends of a planned move, else ``CNTn``. CNT is not a distance: it is how far the controller lets the
  next move start during this one's deceleration (a percentage), so the corner it cuts grows with speed.
  We pick n = ceil(100 zone / reach), 1..100, where reach is the distance over which the controller can round
  at all: for a tool move with a TCP acceleration limit, its deceleration distance v^2 / (2 a) at the
  programmed speed (CNT100 rounds over about that distance, so the corner is not cut by more than the zone
  at the programmed speed); otherwise half the shorter of the two neighbouring TCP moves (the largest zone
  the program may have). The zone in mm and the reach are stated in a comment line before each CNT move.
  Why CNT and not a distance: the corner-region option of the R-30iB writes ``CNT100 CR50`` (CR in mm), but it is
  an option that not every controller generation or configuration has, and a program using it does not load
  where it is missing; CNT loads on every controller, so it is written with the reason in the header.
* With the certified motion (``written``: ``controller_motion.certified_moves``, what ``program`` and ``run``
  write): a planned move's targets are the certified path's joint targets, ``FINE`` stands only where the certified
  motion stops and every other motion gets ``CNTn`` for its written zone, n = ceil(100 zone / reach) with reach
  half the shorter TCP chord of the written segments beside the target (a tool move under a TCP acceleration limit:
  its deceleration distance, as above): the closest CNT at or above the zone, never equal to it (CNT100 stands for
  the whole reach, so a zone larger than the reach gets less); ``cnt_differences`` lists per move the zone, the CNT
  and the difference (header, and what ``program`` prints), ``cnt_zones`` the zones CNT stands for, with which
  ``runner.language_zones_certificate`` certifies the program as FANUC writes it.
* Frames: ``/MN`` starts with ``UFRAME_NUM=0 ;`` and ``UTOOL_NUM=1 ;``, the frames every point names (``UF : 0,
  UT : 1``): a point whose UF/UT differs from the active frame numbers stops the program with an INTP-250-class
  alarm (user frame number mismatch; a third-party knowledge-base page, unverified for the tool frame).
* Load: LS holds no load data: ``PAYLOAD[n]`` selects payload schedule n, whose data are system settings on the
  controller (up to 10 schedules: PAYLOAD [kg], PAYLOAD CENTER X, Y, Z [cm], the centre of gravity's offset from the
  faceplate centre in the faceplate (flange) frame, PAYLOAD INERTIA X, Y, Z [kgf cm s^2, 1 kg m^2 = 100 / 9.80665];
  FANUC setup manual, as Lincoln Electric's copy gives it; secondary). The writer numbers the distinct loads the
  program carries (``settings_mark.load_schedules``: schedule 1 the tool's load alone, then each new set of parts
  held, in the order the grip and release actions first carry it; more than 10 is refused), writes ``PAYLOAD[1]``
  before the first motion and ``PAYLOAD[n]`` for each grip and release in its place among its waypoint's actions,
  and states each schedule's data in the header (``schedule_texts``: to set on the controller) with the loads mark
  (``settings_mark.loads_mark``) that ``read_ls`` reads back. The inertia X, Y, Z written is the diagonal of the
  load's inertia about its centre of gravity in the faceplate axes: its principal moments when that inertia is
  diagonal, else the diagonal alone, said in the comment (the schedule holds no products of inertia). A job
  without any load (no payload, no part) gets a PLACEHOLDER comment and no ``PAYLOAD`` instruction.
* Name and job: the program name is never a word of the format or of the TP instructions (``names``); a comment
  line records the job (``job=NAME``, ``pipeline.files.atomic.job_mark``).
* Points: ``P[i]{ GP1: UF : 0, UT : 1, CONFIG : 'F/N U/D T/B, t1, t4, t6', X Y Z W P R }`` for poses, the
  TCP in user frame 0 (FANUC's world frame) in mm, W P R in deg as FANUC defines them: rotations about the
  fixed x, y, z axes of the frame, R = Rz(R) Ry(P) Rx(W); CONFIG from ``pipeline.model.vendors.configuration``.
  A waypoint the job gives in joints is written in joints, J1..J6 in deg as the pendant shows them
  (J3 = q3 - q2 on FANUC arms, ``pipeline.model.vendors.axes``). Values are rounded to 0.001 mm and 0.001 deg.
* Checked before writing: each Cartesian point, as written (rounded) and with its written CONFIG, is solved
  again (``selection.select_solution``) and must land on the program's joint values within what the rounding
  allows (``rounding_bound``); CONFIG is the one the written pose selects nearest the joint values
  (``written_point_configuration``: an axis on a field's boundary, e.g. at exactly +-180 deg, may be written on
  either side), and a point near a singular set, where the rounding alone could send the controller to
  another branch, is refused.
* Frames: points are in FANUC's world frame, the robot file's fanuc controller section's base frame
  (``controller.controller_frames``; the LR Mate 200iD's is 330 mm above the mounting face, ROS-Industrial
  ``fanuc_lrmate200id_support``: the ``base_link-base`` transform "to Fanuc World Coordinates"; a robot without
  a section is written in our base frame). UT 1 must hold the job's tool on the controller's flange (faceplate)
  frame, the section's flange (stated in the header comment; the identity when the job has none).

* Actions (``pipeline.program.actions``), after the last written move of their waypoint (waypoint 0's after the
  joint move into it), in TP's own instructions (FANUC R-30iA/R-30iB operator's manuals, "I/O instructions", "Wait
  instructions", "Branching instructions"; the Lincoln Electric copy of the FANUC ArcTool manual, ch. 26 "Wait
  instructions", ch-delivery.lincolnelectric.com/api/public/content/67cd62debb004088957ebe41ecebc9c1: WAIT time in
  seconds with a minimum unit of 0.01 s; "Time out, LBL[i]" with $WAITTMOUT "in 100ths of a second"):
  ``DO[n:name]=ON`` / ``=OFF`` (set), ``DO[n:name]=PULSE,t sec`` (pulse, t in 0.1 s steps as the pendant shows it;
  the program goes on), ``WAIT t(sec)`` (wait, 0.01 s steps; it follows a FINE move, since the job stops wherever
  it waits, so the robot is at rest: FINE waits for the move to end before the next instruction),
  ``WAIT DI[n:name]=ON`` (wait for an input) and, with a timeout, ``$WAITTMOUT=k`` (k hundredths of a second) then
  ``WAIT DI[n:name]=ON TIMEOUT,LBL[999]``; the program then ends in ``END``, ``LBL[999:input timeout]``,
  ``UALM[1]`` (user alarm 1: set its message, $UALRM_MSG[1], and a stopping severity on the controller) and
  ``ABORT``, so a timeout stops the program with an alarm (``timeout_lines``); a comment is ``!text`` lines of at
  most 32 characters, each but the last ending in ``+``. Signals are numbered I/O with the job's name as the I/O
  comment in the brackets, and the header carries the signals mark (``settings_mark.signals_mark``); a signal
  without a number is refused (``check_signal_numbers``). An output at a waypoint with a zone (CNT, where the job
  neither waits nor stops) follows the CNT move: the controller runs it as the robot rounds the corner, not at the
  point (unverified how early).

``program_points`` (the motions in the order they are written, with their points' joint values),
``controller_frame``, ``flange_diagonal`` and ``placeholder_text`` are shared with the Yaskawa writer.
"""

from __future__ import annotations

import datetime as _dt
import math
import re
import textwrap
from dataclasses import dataclass

import numpy as np

from ...errors import ConfigurationError, ConfigurationNotFoundError, OutputError
from ...files.atomic import WRITTEN_BY, job_mark
from ...files.poses import rotation_to_rpy, rpy_position_to_pose
from ...model.vendors.axes import FANUC, YASKAWA, axis_angles
from ...model.vendors.configuration import configurations, format_configuration
from ...model.vendors.controller import controller_frames, frames_words, tool_on_flange
from ...model.vendors.selection import select_solution, written_configuration
from ...program.actions import COMMENT, GRIP, PULSE, RELEASE, SET, WAIT, WAIT_INPUT, Action
from ...program.model import CIRCULAR, JOINT, Move, Program
from ...program.payload import Payload
from .lint import FANUC_LS, lint
from .settings_mark import LoadSchedules, check_signal_numbers, load_schedules, loads_mark, settings_mark, signals_mark

#: Comment lines of a pendant program: at most this many characters each.
COMMENT_CHARS = 32
NAME_PATTERN = re.compile(r"^[A-Z][A-Z0-9_]{0,7}$")
FANUC_SPEED_MM_S = (1, 2000)
MM, DEG = 1000.0, 180.0 / math.pi
#: FANUC's payload schedules (module docstring, "Load"); kgf cm s^2 per kg m^2 (1 kgf = 9.80665 N, 1 m^2 = 1e4 cm^2).
MAX_PAYLOAD_SCHEDULES, KGF_CM_S2 = 10, 100.0 / 9.80665
#: A product of inertia below this is none [kg m^2] (below what the comments write of a moment).
PRODUCT_TOLERANCE = 1e-9
#: The user frame and tool frame numbers every point names and /MN selects (module docstring, "Frames").
USER_FRAME, TOOL_FRAME = 0, 1
_SEPARATOR = ",\t"


@dataclass(frozen=True, eq=False)
class Point:
    """A point a program goes to: ``q`` (6,) [rad] its joint values, ``X_BT`` (4, 4) [m] the TCP in our
    base frame, ``in_joints`` (the job gave it as joint values), ``via`` (a circular move's via point)."""

    q: np.ndarray
    X_BT: np.ndarray
    in_joints: bool
    via: bool = False


def check_six_joints(program: Program) -> None:
    """ConfigurationError unless the program's robot has 6 revolute joints (the controllers' arms)."""
    robot = program.robot
    if robot.dof != 6 or not np.all(robot.revolute_mask):
        raise ConfigurationError(f"{robot.name}: a controller program needs a 6-axis arm of revolute joints")


@dataclass(frozen=True, eq=False)
class Motion:
    """One written motion: ``move`` (None: the joint move to the first waypoint; each vertex of a planned
    move is a motion of that move), the ``points`` it goes to (a circular move: via, end) and the ``zone``
    [m] at its end (0: an exact stop, as at the start, at a planned move's vertices and at both its ends)."""

    move: Move | None
    points: list[Point]
    zone: float
    #: With the certified motion (``written``): half the shorter TCP chord of the written segments beside this
    #: motion's end [m] (the reach CNT is made over at a joint target); None: ``zone_reach``.
    reach: float | None = None
    reach_how: str = "half chord"


def program_points(program: Program, vendor: str, written=None) -> list[Motion]:
    """The motions in the order they are written: the joint move to the first waypoint, then per move its
    planner vertices (a planned joint move: joint points, exact stops, the straight joint segments the
    planner checked) and its end, a circular move's via point before its end. A via point takes its
    orientation from the move's nearest IK sample and its joint values from ``select_solution`` with that
    sample's ``vendor`` configuration. With ``written`` (``controller_motion.certified_moves``), a planned
    move's targets are the certified path's joint targets with their zones, and every zone is the written one
    (exact stops only where the certified motion stops)."""
    robot, start = program.robot, program.waypoints[0]
    motions = [Motion(None, [Point(start.q, robot.fk(start.q), start.method is None)], 0.0)]
    reaches = None if written is None else _written_reaches(program, written)
    index = 0
    for move in program.moves:
        if written is None:
            vertices = [(q, 0.0, None) for q in ([] if move.planned is None else move.planned.waypoints[1:-1])]
            end_zone, end_reach, end_how = (0.0 if program.exact_stop_at(move) else move.zone), None, ""
        else:
            ws = written.of(move.end)
            vertices = [(w.target, w.zone_m, reaches[index + i]) for i, w in enumerate(ws[:-1])]
            index += len(ws)
            end_zone = ws[-1].zone_m
            end_reach, end_how = reaches[index - 1], "half chord"
            if move.kind != JOINT and program.tcp_accel_max:
                end_reach, end_how = zone_reach(program, move.end - 1)
        motions += [Motion(move, [Point(q, robot.fk(q), True)], zone, reach) for q, zone, reach in vertices]
        end = Point(move.target, move.X_BT, program.waypoints[move.end].method is None)
        points = [via_point(program, move, vendor), end] if move.kind == CIRCULAR else [end]
        motions.append(Motion(move, points, end_zone, end_reach, end_how or "half chord"))
    return motions


def _written_reaches(program: Program, written) -> list[float]:
    """Per written move, half the shorter TCP chord of the written segments before and after its target [m]."""
    q = np.array([program.targets[0], *(w.target for w in written.moves)])
    tcp = program.robot.fk_batch(q)[:, :3, 3]
    chords = np.linalg.norm(np.diff(tcp, axis=0), axis=1)
    after = np.append(chords[1:], np.inf)
    return [float(min(a, b)) / 2.0 for a, b in zip(chords, after)]


def via_point(program: Program, move: Move, vendor: str) -> Point:
    """The via point of a circular move (see ``program_points``)."""
    robot, samples = program.robot, move.samples
    X = robot.fk_batch(samples)
    nearest = int(np.argmin(np.linalg.norm(X[:, :3, 3] - move.via, axis=1)))
    X_via = X[nearest].copy()
    X_via[:3, 3] = move.via
    config = configurations(robot, samples[nearest], vendor)
    return Point(select_solution(robot, X_via, config, vendor), X_via, False, True)


def controller_frame(robot, vendor: str) -> tuple[np.ndarray, str]:
    """(X_B_base (4, 4) [m]: the controller's robot frame in our base frame, the header's words on the frames):
    the robot file's ``vendor`` controller section (``model.vendors.controller.controller_frames``)."""
    return controller_frames(robot, vendor)[0], frames_words(robot, vendor, "robot frame", "flange", "configuration")


def xyz_rpy(X_BT: np.ndarray, X_B_base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y, z [mm] in the controller's robot frame X_B_base (4, 4) [m], rotations about its fixed x, y, z
    axes [deg] with R = Rz Ry Rx) of a TCP pose X_BT (4, 4) [m] in our base frame."""
    X = np.linalg.inv(X_B_base) @ X_BT
    return X[:3, 3] * MM, rotation_to_rpy(X[:3, :3]) * DEG


def controller_pose(X_B_base: np.ndarray, xyz_mm, angles_deg) -> np.ndarray:
    """``xyz_rpy`` inverted: the pose (4, 4) [m] in our base frame of x, y, z [mm] and rotations [deg] in the
    controller's robot frame X_B_base (4, 4) [m]."""
    return X_B_base @ rpy_position_to_pose(np.radians(angles_deg), np.asarray(xyz_mm, dtype=float) / MM)


def rounding_bound(robot, q, mm_step: float, deg_step: float) -> np.ndarray:
    """How far (6,) [rad] re-solving a pose written to ``mm_step`` [mm] and ``deg_step`` [deg] may land
    from q (6,) [rad]: each written number is off by at most half a step, so the TCP position by at most
    sqrt(3) mm_step / 2 and its rotation (three rotations about fixed axes, each off by deg_step / 2) by
    at most 3 deg_step / 2; to first order joint i moves by |J^-1 row i, v part| |dp| + |J^-1 row i, w
    part| |dtheta| (J the TCP Jacobian at q); twice that, plus 1e-9 rad, covers the second order and the
    closed-form IK's own error."""
    J_inv = np.linalg.inv(robot.jacobian(q))
    dp = math.sqrt(3.0) * mm_step / 2.0 / MM
    dtheta = 3.0 * math.radians(deg_step) / 2.0
    return 2.0 * (np.linalg.norm(J_inv[:, :3], axis=1) * dp + np.linalg.norm(J_inv[:, 3:], axis=1) * dtheta) + 1e-9


def written_point_configuration(robot, vendor: str, label: str, q, xyz_mm, angles_deg, X_B_base: np.ndarray,
                                steps: tuple[float, float]) -> np.ndarray:
    """The configuration fields to write with a Cartesian point whose file holds ``xyz_mm`` [mm] in the
    controller's robot frame X_B_base (4, 4) [m] and ``angles_deg`` [deg] (as rounded to ``steps``: the file's
    mm and deg steps) and whose joint values are q (6,) [rad]: ``selection.written_configuration`` of the pose as
    written (q's own, or for an axis on a field's boundary, such as +-180 deg, the side the rounded pose
    selects). ConfigurationError naming the point unless the pose as written with it selects joint values
    within ``rounding_bound`` of q: a point near a singular set, where the rounding alone can make the
    controller take another branch, is refused rather than written."""
    X = controller_pose(X_B_base, xyz_mm, angles_deg)
    bound = rounding_bound(robot, q, *steps)
    try:
        config = written_configuration(robot, X, q, vendor, float(bound.max()), label)
        landed = select_solution(robot, X, config, vendor)
        why = f"it selects {np.round(np.degrees(landed), 4).tolist()} deg with {format_configuration(vendor, config)}"
    except (ConfigurationNotFoundError, OutputError) as error:
        landed, why = None, str(error)
    if landed is None or np.any(np.abs(landed - q) > bound):
        raise ConfigurationError(f"{label}: joint values {np.round(np.degrees(q), 4).tolist()} deg: the pose as "
                                 f"written does not bring them back within the file's rounding ({why}); "
                                 f"{_hint(robot, vendor, q)}")
    return config


def _hint(robot, vendor: str, q) -> str:
    """What to do about a point the written pose does not bring back: Yaskawa's R, T, S >= 180 bits cannot tell an
    axis at -180 deg from one at +180 deg (a whole turn apart); otherwise the point is near a singular set."""
    angles = axis_angles(robot, q, vendor)
    near = [axis + 1 for axis in (3, 5, 0) if abs(abs(angles[axis]) - 180.0) < 0.01]
    if vendor == YASKAWA and near:
        return (f"axis {near[0]} is at +-180 deg, where RCONF's >= 180 bit is the same for -180 and +180 deg (a whole "
                "turn apart): turn the tool about its axis a little at this waypoint, or write another language")
    return "a near-singular waypoint? move it off the singularity"


def rounded(values, decimals: int) -> np.ndarray:
    """``values`` rounded to ``decimals``, without negative zeros (a file shows 0.000, not -0.000)."""
    return np.round(np.asarray(values, dtype=float), decimals) + 0.0


def comment_lines(text: str) -> list[str]:
    """``text`` in lines of at most COMMENT_CHARS characters, without the characters pendants refuse."""
    return textwrap.wrap(re.sub(r"[;'\"!]", "", text), COMMENT_CHARS, break_on_hyphens=False)


def tool_text(program: Program, vendor: str) -> str:
    """The tool on the ``vendor`` controller's flange as x, y, z [mm] and rotations about the fixed x, y, z axes
    [deg] (R = Rz Ry Rx)."""
    X = tool_on_flange(program.robot, vendor, program.tool.X_FT)
    return "tool " + " ".join(f"{v:.3f}" for v in rounded(np.concatenate(xyz_rpy(X, np.eye(4))), 3))


def check_name(name: str, pattern: re.Pattern, what: str) -> str:
    if not isinstance(name, str) or not pattern.match(name):
        raise ConfigurationError(f"{what} name {name!r}: 1 to 8 characters, an upper-case letter first, then "
                                 "upper-case letters, digits or _")
    return name


def zone_reach(program: Program, k: int) -> tuple[float, str]:
    """(the distance [m] over which the controller rounds at all at move k's end, what it is): move k's
    deceleration distance at its programmed TCP speed when it is a tool move and the TCP acceleration is
    limited, else half the shorter of moves k and k + 1 (TCP chords)."""
    move = program.moves[k]
    if move.kind != JOINT and program.tcp_accel_max:
        v = program.tool_speed(move)
        return v * v / (2.0 * program.tcp_accel_max), "decel"
    before = program.robot.fk(program.targets[k])[:3, 3]
    lengths = [np.linalg.norm(move.X_BT[:3, 3] - before)]
    if k + 1 < len(program.moves):
        lengths.append(np.linalg.norm(program.moves[k + 1].X_BT[:3, 3] - move.X_BT[:3, 3]))
    return min(lengths) / 2.0, "half move"


def cnt_value(zone: float, reach: float) -> int:
    """CNT n, 1..100, for a zone [m] over a reach [m] (module docstring)."""
    if reach <= 0.0:
        return 100
    return int(min(100, max(1, math.ceil(100.0 * zone / reach - 1e-9))))


def write_ls(program: Program, name: str, created: _dt.datetime | None = None, written=None) -> str:
    """The program as a FANUC ``.ls`` file (module docstring); ``name`` its /PROG name, ``created`` the
    header's date (None: now, UTC). ConfigurationError for a bad name, a non-6R robot or a speed the
    controller cannot take; ``lint`` runs first on the name, the comment lines and the CONFIG of every Cartesian
    waypoint (ControllerLintError). ``written`` (``controller_motion.certified_moves``): the certified motion, its
    targets and zones (CNT the closest to each zone, ``cnt_differences``), its certificate in the header."""
    check_name(name, NAME_PATTERN, "FANUC program")
    check_six_joints(program)
    X_B_base, frame = controller_frame(program.robot, FANUC)
    check_signal_numbers(program, "FANUC TP", "DO[n], DI[n]")
    schedules = load_schedules(program)
    comments = [job_mark(program.job_name or program.name), *comment_lines(settings_mark(program)),
                *comment_lines(signals_mark(program)),
                *comment_lines(_header_text(program, frame)),
                *(line for text in schedule_texts(program, schedules) for line in comment_lines(text))]
    if written is not None:
        comments += [line for text in [WRITTEN_CNT_RULE, *written.header_lines(), *cnt_differences(program, written)]
                     for line in comment_lines(text)]
    motions = program_points(program, FANUC, written)
    zones = [line for motion in motions if motion.zone > 0.0 for line in comment_lines(_zone_comment(program, motion))]
    configs = [None if w.method is None else configurations(program.robot, w.q, FANUC) for w in program.waypoints]
    lint(program, FANUC_LS, name, comments + zones, configs)
    lines = [f"UFRAME_NUM={USER_FRAME}", f"UTOOL_NUM={TOOL_FRAME}", *(f"!{line}" for line in comments),
             *([] if schedules is None else ["PAYLOAD[1]"])]
    positions, index = [], 0
    for m, motion in enumerate(motions):
        labels = []
        for point in motion.points:
            index += 1
            labels.append(f"P[{index}]")
            positions.append(_position(program, index, point, X_B_base))
        if motion.zone > 0.0:
            lines.extend(f"!{line}" for line in comment_lines(_zone_comment(program, motion)))
        lines.append(_motion(program, motion, labels))
        if m + 1 == len(motions) or motions[m + 1].move is not motion.move:     # the waypoint's last motion
            k = 0 if motion.move is None else motion.move.end
            lines.extend(line for i, action in enumerate(program.actions_at(k))
                         for line in action_lines(program, action, schedules and schedules.selected.get((k, i))))
    lines.extend(timeout_lines(program))
    return "\n".join([f"/PROG  {name}", *_attributes(program, len(lines), created), "/MN",
                      *(f"{n:4d}:  {line} ;" for n, line in enumerate(lines, start=1)), "/POS", *positions, "/END",
                      ""])


#: The label a timed wait for an input jumps to, the user alarm it raises there (module docstring, "Actions").
TIMEOUT_LABEL, TIMEOUT_ALARM = 999, 1
#: The timeout label's comment, and the lines that end the program there: the fixed pattern the reader recognises.
TIMEOUT_COMMENT = "input timeout"
#: $WAITTMOUT counts hundredths of a second; WAIT t(sec) takes 0.01 s steps; a pulse's width 0.1 s steps [s].
WAITTMOUT_S, WAIT_STEP_S, PULSE_STEP_S = 0.01, 0.01, 0.1


def action_lines(program: Program, action: Action, schedule: int | None = None) -> list[str]:
    """The /MN lines (without number and ``;``) of one action (module docstring, "Actions"); a grip or release:
    ``PAYLOAD[schedule]``, the load it leaves the robot carrying (module docstring, "Load")."""
    if action.kind in (GRIP, RELEASE):
        return [f"PAYLOAD[{schedule}]"]
    if action.kind == COMMENT:
        return [f"!{line}" for line in comment_action_lines(action.text)]
    if action.kind == WAIT:
        return [f"WAIT {_steps(action.time_s, WAIT_STEP_S, 'wait'):6.2f}(sec)"]
    signal = program.signals[action.signal]
    io = f"{'DO' if action.kind in (SET, PULSE) else 'DI'}[{signal.number}:{signal.name}]"
    if action.kind == SET:
        return [f"{io}={'ON' if action.value else 'OFF'}"]
    if action.kind == PULSE:
        return [f"{io}=PULSE,{_steps(action.time_s, PULSE_STEP_S, 'pulse'):.1f}sec"]
    wait = f"WAIT {io}={'ON' if action.value else 'OFF'}"
    if action.timeout_s is None:
        return [wait]
    ticks = round(_steps(action.timeout_s, WAITTMOUT_S, "timeout") / WAITTMOUT_S)
    return [f"$WAITTMOUT={ticks}", f"{wait} TIMEOUT,LBL[{TIMEOUT_LABEL}]"]


def _steps(time_s: float, step: float, what: str) -> float:
    """``time_s`` [s] rounded to the instruction's ``step`` [s]; ConfigurationError where that leaves nothing."""
    value = round(time_s / step) * step
    if value <= 0.0:
        raise ConfigurationError(f"a {what} of {time_s:g} s: FANUC writes it in steps of {step:g} s, so it would be 0")
    return value


#: A comment action's line that the next line continues (the pendant's comment lines hold 32 characters).
CONTINUED = "+"


def comment_action_lines(text: str) -> list[str]:
    """A comment action as ``!`` lines of at most COMMENT_CHARS characters, without the characters pendants
    refuse; every line but the last ends with CONTINUED (the reader joins them with a space)."""
    lines = textwrap.wrap(re.sub(r"[;'\"!]", "", text), COMMENT_CHARS - len(CONTINUED), break_on_hyphens=False)
    return [f"{line}{CONTINUED}" for line in lines[:-1]] + lines[-1:] if lines else [""]


def timeout_lines(program: Program) -> list[str]:
    """The program's end when a wait for an input has a timeout: ``END``, then the label the wait jumps to, the
    user alarm and ``ABORT`` (module docstring, "Actions"); none without such a wait."""
    timed = any(a.kind == WAIT_INPUT and a.timeout_s is not None
                for k in range(len(program.waypoints)) for a in program.actions_at(k))
    if not timed:
        return []
    return ["END", f"LBL[{TIMEOUT_LABEL}:{TIMEOUT_COMMENT}]", f"UALM[{TIMEOUT_ALARM}]", "ABORT"]


#: The header's statement of how a written zone becomes CNT (with the certified motion).
WRITTEN_CNT_RULE = ("Certified motion: planned moves as joint targets on the certified path; FINE only where it "
                    "stops. CNTn = ceil(100 zone / reach), reach half the shorter TCP chord beside the target (a "
                    "tool move under a TCP acceleration limit: its deceleration distance): the closest CNT at or "
                    "above the zone, not equal to it (CNT is a speed-dependent percentage); ~mm is n% of the "
                    "reach, the difference to the certified zone per move below.")


def header_intro(program: Program, rounded_at: str) -> str:
    """The first sentences of an LS or JBI header: the program, its robot and writer, and that the controller plans
    its own speed profile (``rounded_at``: where its path differs from the certified one)."""
    return (f"{program.name} on {program.robot.name}, written by {WRITTEN_BY}. The controller plans its own speed "
            f"profile for each move, not the certified one: timing and the path {rounded_at} differ.")


def _header_text(program: Program, frame: str) -> str:
    return (f"{header_intro(program, 'in zones')} It stops (FINE) at every waypoint without a zone. UT 1 = "
            f"{tool_text(program, FANUC)} (x y z w p r, mm deg). {frame}. Loading .ls needs the "
            "ASCII Program Loader option (or MakeTP offline). CNTn is a speed-dependent percentage, not a distance: "
            "n is made from the zone (its mm stated before each CNT move); the CR option (mm) is not on every "
            "controller.")


def placeholder_text(where: str) -> str:
    """A comment for a job that gives no load (no payload, no part): a PLACEHOLDER to set the real one in ``where``."""
    return f"PLACEHOLDER: the job gives no payload: set the real one in {where}"


#: The header's first sentence on the loads (module docstring, "Load").
SCHEDULES_INTRO = ("Payload schedules to set on the controller: PAYLOAD kg, CENTER X Y Z cm (faceplate frame), "
                   "INERTIA X Y Z kgf cm s2 (about the center, faceplate axes).")


def schedule_texts(program: Program, schedules: LoadSchedules | None) -> list[str]:
    """The header's payload schedules (module docstring, "Load"): per schedule its data to set on the controller,
    then the loads mark; a PLACEHOLDER for a load the job does not give. ConfigurationError beyond 10 schedules."""
    if schedules is None:
        return [placeholder_text("PAYLOAD schedule 1 (UT 1)")]
    if len(schedules.held) > MAX_PAYLOAD_SCHEDULES:
        raise ConfigurationError(f"the program carries {len(schedules.held)} distinct loads (tool and parts held): "
                                 f"FANUC has {MAX_PAYLOAD_SCHEDULES} payload schedules")
    return load_texts(program, schedules, SCHEDULES_INTRO, "schedule", lambda n: f"PAYLOAD[{n}]", _schedule_data,
                      COMMENT_CHARS)


def load_texts(program: Program, schedules: LoadSchedules, intro: str, what: str, heading, data,
               comment_chars: int) -> list[str]:
    """The header's loads: ``intro``, a PLACEHOLDER when the job gives no tool load (``what``: the word for one
    load), per load n ``heading(n)``, the tool and parts it holds and its ``data(load)`` (or "no load known"), then
    the loads mark in comments of ``comment_chars``."""
    texts = [intro]
    if program.payload is None:
        texts.append(f"PLACEHOLDER: the job gives no payload (the tool's load): add it to every {what}.")
    for n in range(1, len(schedules.held) + 1):
        load = schedules.load(program, n)
        texts.append(f"{heading(n)} {' + '.join(('tool', *schedules.held[n - 1]))}: "
                     + ("no load known" if load is None else data(load)))
    return [*texts, loads_mark(program, schedules, comment_chars)]


def _schedule_data(load: Payload) -> str:
    """A schedule's data (module docstring, "Load"): payload [kg], center [cm], inertia [kgf cm s^2]."""
    diagonal, products = flange_diagonal(load)
    center = " ".join(f"{v:.3f}" for v in rounded(load.com * 100.0, 3))
    inertia = " ".join(f"{v:.5f}" for v in rounded(diagonal * KGF_CM_S2, 5))
    kept = "" if not products else " (the diagonal in the faceplate axes: products of inertia not held)"
    return f"payload {load.mass:g} kg, center {center} cm, inertia {inertia} kgf cm s2{kept}."


def flange_diagonal(load: Payload) -> tuple[np.ndarray, bool]:
    """(the load's inertia about its centre of mass in the flange axes, diagonal (3,) [kg m^2], whether it has
    products of inertia, which a controller holding three moments drops)."""
    inertia = np.asarray(load.inertia, dtype=float)
    return np.diag(inertia).copy(), bool(np.any(np.abs(inertia - np.diag(np.diag(inertia))) > PRODUCT_TOLERANCE))


def _reach(program: Program, motion: Motion) -> tuple[float, str]:
    if motion.reach is not None:
        return motion.reach, motion.reach_how
    return zone_reach(program, motion.move.end - 1)


def _zone_comment(program: Program, motion: Motion) -> str:
    reach, how = _reach(program, motion)
    n = cnt_value(motion.zone, reach)
    text = f"zone {motion.zone * MM:.1f}mm CNT{n} {how} {reach * MM:.1f}mm"
    if motion.reach is None:
        return text
    return f"{text} ~{n * reach * MM / 100.0:.1f}mm ({(n * reach / 100.0 - motion.zone) * MM:+.1f})"


def _termination(program: Program, motion: Motion) -> str:
    if motion.zone <= 0.0:
        return "FINE"
    return f"CNT{cnt_value(motion.zone, _reach(program, motion)[0])}"


def cnt_zones(program: Program, written) -> list[float]:
    """Per written move, the zone [m] its CNT stands for in the model (n % of its reach; 0 at FINE): the zones the
    written program is certified with as FANUC writes it (``runner.language_zones_certificate``)."""
    zones = []
    for motion in program_points(program, FANUC, written)[1:]:
        reach = _reach(program, motion)[0] if motion.zone > 0.0 else 0.0
        zones.append(cnt_value(motion.zone, reach) * reach / 100.0 if motion.zone > 0.0 else 0.0)
    return zones


def cnt_differences(program: Program, written) -> list[str]:
    """Per written move with a zone, the CNT written for it and how far the zone CNT stands for (n % of the reach,
    ``cnt_value``: the closest integer percentage at or above the zone, not equal) is from the certified zone."""
    lines = []
    for k, motion in enumerate(m for m in program_points(program, FANUC, written)[1:]):
        if motion.zone > 0.0:
            reach, _ = _reach(program, motion)
            n = cnt_value(motion.zone, reach)
            lines.append(f"written move {k + 1} (to waypoint {motion.move.end}): zone {motion.zone * MM:.1f} mm -> "
                         f"CNT{n} ~ {n * reach * MM / 100.0:.1f} mm ({(n * reach / 100.0 - motion.zone) * MM:+.1f} "
                         f"mm; reach {reach * MM:.1f} mm)")
    return lines


def _speed(program: Program, move: Move | None) -> str:
    """A joint move's % (1..100), a tool move's mm/sec; ConfigurationError where the controller cannot."""
    if move is None or move.kind == JOINT:
        fraction = program.speed_scale if move is None else move.speed * program.speed_scale
        return f"{int(min(100, max(1, round(fraction * 100.0))))}%"
    mm_s = round(program.tool_speed(move) * MM)
    low, high = FANUC_SPEED_MM_S
    if not low <= mm_s <= high:
        raise ConfigurationError(f"move {move.end}: TCP speed {mm_s} mm/sec is outside FANUC's {low}..{high} mm/sec")
    return f"{mm_s}mm/sec"


def _motion(program: Program, motion: Motion, labels: list[str]) -> str:
    """One numbered /MN line: J or L to a point, or C through the via point with the end point on a
    continuation line (":"), then speed and termination."""
    move = motion.move
    tail = f"{_speed(program, move)} {_termination(program, motion)}"
    if move is None or move.kind == JOINT:
        return f"J {labels[0]} {tail}"
    if move.kind == CIRCULAR:
        return f"C {labels[0]}\n       :  {labels[1]} {tail}"
    return f"L {labels[0]} {tail}"


def _position(program: Program, index: int, point: Point, X_B_base: np.ndarray) -> str:
    """One /POS entry: joints as the pendant shows them, or CONFIG and X Y Z W P R."""
    head = f"P[{index}]{{\n   GP1:\n\tUF : {USER_FRAME}, UT : {TOOL_FRAME},"
    if point.in_joints:
        J = rounded(axis_angles(program.robot, point.q, FANUC), 3)
        values = [f"J{i + 1}= {v:10.3f} deg" for i, v in enumerate(J)]
        return f"{head}\n\t{_SEPARATOR.join(values[:3])},\n\t{_SEPARATOR.join(values[3:])}\n}};"
    p, wpr = (rounded(v, 3) for v in xyz_rpy(point.X_BT, X_B_base))
    config = format_configuration(FANUC, written_point_configuration(program.robot, FANUC, f"P[{index}]", point.q, p,
                                                                     wpr, X_B_base, (0.001, 0.001)))
    xyz = _SEPARATOR.join(f"{axis} = {v:10.3f}  mm" for axis, v in zip("XYZ", p))
    angles = _SEPARATOR.join(f"{axis} = {v:10.3f} deg" for axis, v in zip("WPR", wpr))
    return f"{head}\t\tCONFIG : '{config}',\n\t{xyz},\n\t{angles}\n}};"


def _attributes(program: Program, line_count: int, created: _dt.datetime | None) -> list[str]:
    when = created or _dt.datetime.now(_dt.timezone.utc)
    stamp = f"DATE {when:%y-%m-%d}  TIME {when:%H:%M:%S}"
    return ["/ATTR", "OWNER\t\t= MNEDITOR;", 'COMMENT\t\t= "";', "PROG_SIZE\t= 0;", f"CREATE\t\t= {stamp};",
            f"MODIFIED\t= {stamp};", "FILE_NAME\t= ;", "VERSION\t\t= 0;", f"LINE_COUNT\t= {line_count};",
            "MEMORY_SIZE\t= 0;", "PROTECT\t\t= READ_WRITE;",
            "TCD:  STACK_SIZE\t= 0,", "      TASK_PRIORITY\t= 50,", "      TIME_SLICE\t= 0,",
            "      BUSY_LAMP_OFF\t= 0,", "      ABORT_REQUEST\t= 0,", "      PAUSE_REQUEST\t= 0;",
            "DEFAULT_GROUP\t= 1,*,*,*,*;", "CONTROL_CODE\t= 00000000 00000000;"]
