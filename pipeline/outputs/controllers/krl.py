"""KUKA KRL: a program as the ``.src`` (its motions) and ``.dat`` (its targets) a KUKA KR C4 controller
(KUKA System Software 8.x) runs, ``write_krl(program, name) -> (src, dat)``.

What it writes, and the facts it follows (KUKA System Software, Expert Programming / Operating and
Programming Instructions for System Integrators; the chapter and section named at each):

* ``DEF name( )`` ... ``END`` in the .src and ``DEFDAT name`` ... ``ENDDAT`` in the .dat ("Structure
  of a KRL program", "Data lists"); names at most 24 characters ("Names"), checked by ``lint``.
* No call of BAS: the .src sets what BAS(#INITMOV) would, and says what it assumes: ``$BASE =
  $ROBROOT`` (targets in the controller's base frame) and ``$TOOL`` the job's tool on its flange frame
  $FLANGE, both from the robot file's kuka controller section (``model.vendors.controller``; without one:
  our base frame and our end frame without the tool, as the header says),
  ``$IPO_MODE = #BASE``, ``$ORI_TYPE = #VAR`` (the orientation turns from start to end, as in our tool
  moves), ``$CIRC_TYPE = #BASE``, ``$ADVANCE = 3`` (approximation needs an advance run), accelerations
  ``$ACC_AXIS[i] = 100`` % and ``$ACC.CP`` the job's tcp_accel_max [m/s^2] (else the machine data's
  ``$ACC_MA.CP``), orientation speeds and accelerations the machine data's ("System variables").
* Speeds from each move's speed times the job's speed_scale: a PTP's ``$VEL_AXIS[1..6]`` [INT %] of the
  axes' maximum speeds, a LIN's or CIRC's ``$VEL.CP`` [m/s] ("Motion programming: PTP, LIN, CIRC";
  "$VEL_AXIS", "$VEL").
* Moves: ``PTP`` to an E6AXIS (a waypoint given as joint values) or E6POS (a pose waypoint), ``LIN`` to an
  E6POS, a PTP's pose target as an E6AXIS when its written E6POS with S and T would not name its joint
  values alone (Turn is a sign per axis: an axis of more than +-180 deg, such as the IRB 1600's axis 6 of
  +-400 deg, has two 2 pi variants of one sign; an axis at 0 can cross the sign by the rounding),
  ``CIRC aux, end`` with the via point as a FRAME (KRL ignores the auxiliary point's orientation
  and Status/Turn; we write the end's orientation). The first motion is a PTP to the start (the BCO run)
  at 10 % of the axes' speeds.
* Zones: a move with a zone gets ``$APO.CDIS`` = the zone [mm] ("Approximate positioning": approximation
  starts at the earliest when the TCP is closer than $APO.CDIS to the end point) and ``C_DIS`` on LIN and CIRC.
  On PTP the approximation keyword depends on the controller generation (``GENERATIONS``, ``generation=``):
  ``krc2`` (the default: KR C2 / KSS 5.x, and what a plain KRL parser accepts: the grammars-v4 ``kuka/krl.g4``
  ANTLR grammar, BSD, takes only ``C_PTP`` after PTP, optionally followed by C_DIS/C_ORI/C_VEL for a PTP-CP
  transition) writes ``PTP XPk C_PTP`` (``C_PTP C_DIS`` when a LIN or CIRC follows) with ``$APO.CPTP`` =
  ceil(100 x zone / half the shorter neighbouring TCP move), 1..100 %: C_PTP is a percentage of the machine
  data's $APO_DIS_PTP axis angle, not a distance, so this percentage is an assumption stated in the header
  (KSS caps approximation at half a move); ``kss8`` (KR C4, KSS 8.x inline forms, robot-forum thread 14422)
  writes ``PTP XPk C_DIS``. A zone of 0 is an exact stop (no approximation parameter), as are both ends of a
  planned joint move and its planner vertices (``PTP XPk_i`` to E6AXIS targets: PTP is straight in joint
  space, the segments the planner checked). With the certified motion (``written``: ``controller_motion.
  certified_moves``, what ``program`` writes) the XPk_i are joint targets sampled from the certified path, each
  approximated (C_PTP with $APO.CDIS and $APO.CPTP as above; C_DIS under kss8), the move's ends keep the job's
  zones, exact stops stand only where the certified motion stops, and the header carries the written program's
  certificate and cycle time as written.
* Load ("$LOAD": the load data of the current tool, KRL's one load on the flange: the TOTAL of the tool and what it
  carries; KUKA System Variables, "$LOAD"): ``$LOAD = {M m,CM {X,Y,Z,A,B,C},J {X,Y,Z}}`` as one assignment of the
  whole structure, M [kg] to 0.001 kg, CM the centre of mass [mm] in the flange frame $FLANGE to 0.001 mm with A,
  B, C [deg] (to 0.0001 deg, R = Rz(A) Ry(B) Rx(C)) the orientation of the principal axes of the inertia at it, J
  the principal moments [kg m^2] to 1e-6 (``payload.principal_axes``: A, B, C 0 for a diagonal inertia). After the
  initialisation the job's ``payload``; at each ``grip``/``release``, in its place among the waypoint's actions,
  the total after it (``Program.load_after``: the tool's load and the parts held, ``payload.combined``). Without a
  payload a PLACEHOLDER comment says that the controller keeps its own $LOAD and to set it; parts without a
  payload are still written, each $LOAD then the parts' alone (no part held: M 0), with a PLACEHOLDER comment on
  its line saying that the tool's load is missing from it.
* Actions (``pipeline.program.actions``), each waypoint's right after its last written motion (waypoint 0's after
  the PTP to the start), with the signals' numbers on the controller (a signal without a number is an OutputError
  naming it; the job's names ride in the header's signals mark, ``settings_mark.signals_mark``, the parts' in its
  gripped mark, ``settings_mark.gripped_mark``, and each output
  statement ends in a comment naming its signal): ``set`` -> ``$OUT[n] = TRUE`` / ``FALSE`` ("Switching functions",
  "OUT"); ``pulse`` -> ``PULSE($OUT[n], TRUE, t)`` (the output on for t [s] while the program goes on: "PULSE");
  ``wait`` -> ``WAIT SEC t`` (it stops the advance run, so the time runs once the robot rests at the exact-stop point
  the job makes there: "WAIT SEC", "Advance run"); ``wait_input`` -> ``WAIT FOR $IN[n]`` / ``WAIT FOR NOT $IN[n]``
  ("WAIT FOR"), and with a timeout, as KRL's WAIT FOR has none, this fixed pattern (``TIMER``: KRL timer 1, [ms];
  "$TIMER", "$TIMER_STOP"; the pattern industrialmonitordirect.com's "KUKA KRL WAIT FOR Timeout" page shows):
  ``$TIMER[1] = 0``, ``$TIMER_STOP[1] = FALSE``, ``WAIT FOR $IN[n] OR ($TIMER[1] > ms)``, ``$TIMER_STOP[1] = TRUE``,
  ``IF NOT $IN[n] THEN`` / ``HALT`` / ``ENDIF`` (the program stops when the input has not come); ``comment`` -> a
  ``; text`` line. Times are written to 0.001 s, a timeout in whole ms. An output statement or PULSE stops the
  advance run (KSS: "statements that trigger an advance run stop"; the pendant's OUT and PULSE inline forms write
  CONTINUE before it only with their CONT option), so at an approximated waypoint (a zone, no wait: the job refuses
  a wait there) its outputs are ``TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[n] = ...`` / ``DO PULSE(...)`` before
  the motion ("Path-related switching actions (TRIGGER)": DISTANCE=1 switches at the end point, in the middle of
  its approximation contour), its comments after it. Manual: KUKA System Software 8.3, Operating and Programming Instructions
  for System Integrators (studylib.net/doc/26132835), "Programming for user group Expert / KRL syntax".
* Names: the program name is never a KRL keyword nor an XP/XA point name (``names``: ``DEF END( )`` is not
  KRL); the header records the job (``job=NAME``, ``pipeline.files.atomic.job_mark``).
* E6POS ``{X, Y, Z, A, B, C, S, T, E1..E6}``: the TCP in the base frame, X, Y, Z [mm] rounded to 0.001
  mm, A, B, C [deg] rounded to 0.0001 deg in KUKA's convention R = Rz(A) Ry(B) Rx(C) (A about Z, then B
  about the new Y, then C about the newest X: "Orientation angles A, B, C"); S and T the KUKA Status and
  Turn of the target's joint values (``pipeline.model.vendors.configuration``; an axis at 0 gets the sign
  its written E6POS selects: ``written_status_turn``), written in decimal as the
  pendant writes them; E1..E6 = 0 (no external axes). E6AXIS ``{A1..A6, E1..E6}`` [deg] rounded to 0.0001
  deg: the controller's axis angles (``pipeline.model.vendors.axes``). KRL REAL is a 32-bit float (about 7
  significant digits), which holds these roundings for coordinates up to 9999.999 mm and angles up to
  999.9999 deg.
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import ConfigurationNotFoundError, OutputError
from ...files.atomic import WRITTEN_BY, job_mark
from ...files.poses import rotation_to_rpy, rpy_to_rotation
from ...model.vendors.axes import KUKA, axis_angles, axis_map
from ...model.vendors.configuration import configurations
from ...model.vendors.controller import controller_frames, frames_words, tool_on_flange
from ...model.vendors.selection import select_solution, written_configuration
from ...program.actions import COMMENT, GRIP, PULSE, RELEASE, SET, WAIT, WAIT_INPUT
from ...program.payload import Payload, expressed_in, principal_axes
from .controller_motion import WrittenProgram
from .lint import KRL, lint, move_lengths, written_speed
from .settings_mark import gripped_mark, settings_mark, signals_mark

#: Controller generations (module docstring): the approximation keyword of a PTP with a zone.
KRC2, KSS8 = "krc2", "kss8"
GENERATIONS = (KRC2, KSS8)
#: Axis speed [% of the axes' maximum] of the first motion (the BCO run to the start).
BCO_PERCENT = 10
#: Decimal places written: positions [mm], angles [deg], masses [kg], inertias [kg m^2].
MM_DECIMALS, DEG_DECIMALS, KG_DECIMALS, INERTIA_DECIMALS = 3, 4, 3, 6
#: A PTP target re-solved from its written E6POS with its S and T must land this close to its joints [rad]
#: (0.002 deg: the written rounding moves the joints by a few 1e-4 deg away from singular poses).
SELECTED_TOL = np.radians(0.002)
_NO_EXTERNAL = ",".join(f"E{i} 0.0" for i in range(1, 7))
#: The KRL timer ($TIMER[n], [ms]) a wait for an input with a timeout uses (module docstring).
TIMER = 1


def kuka_abc(R: np.ndarray) -> tuple[float, float, float]:
    """KUKA's A, B, C [deg] of a rotation (3, 3): R = Rz(A) Ry(B) Rx(C), our yaw, pitch, roll
    (``pipeline.files.poses``; at B = +-90 deg, where only A -+ C is defined, A = 0)."""
    roll, pitch, yaw = np.degrees(rotation_to_rpy(R))
    return float(yaw), float(pitch), float(roll)


def abc_rotation(a: float, b: float, c: float) -> np.ndarray:
    """The rotation matrix (3, 3) Rz(A) Ry(B) Rx(C) of KUKA's A, B, C [deg]."""
    return rpy_to_rotation(*np.radians([c, b, a]))


def written_pose(X: np.ndarray, X_B_base: np.ndarray | None = None) -> np.ndarray:
    """The pose (4, 4) [m] the controller reads back from X (4, 4) [m] as ``frame_text`` writes it (rounded);
    with ``X_B_base`` (the controller's base frame in ours), X is in our base frame and written in its."""
    if X_B_base is not None:
        return X_B_base @ written_pose(np.linalg.inv(X_B_base) @ X)
    a, b, c = (round(v, DEG_DECIMALS) for v in kuka_abc(X[:3, :3]))
    out = np.eye(4)
    out[:3, :3] = abc_rotation(a, b, c)
    out[:3, 3] = np.round(X[:3, 3] * 1000.0, MM_DECIMALS) / 1000.0
    return out


def names_its_joints(robot, X: np.ndarray, status_turn, q: np.ndarray) -> bool:
    """Whether the written pose X (4, 4) [m] with its Status and Turn selects the joint values q (6,) [rad]
    and no other in-limit solution (within SELECTED_TOL): Turn is a sign per axis, so on an axis of more
    than +-180 deg two 2 pi variants can share it, and rounding can move an axis near 0 across the sign."""
    try:
        found = select_solution(robot, written_pose(X, controller_frames(robot, KUKA)[0]),
                                tuple(int(v) for v in status_turn), KUKA)
    except ConfigurationNotFoundError:
        return False
    return bool(np.abs(found - q).max() <= SELECTED_TOL)


def _num(value: float, decimals: int) -> str:
    """A REAL as KRL writes it, at ``decimals`` places, without a negative zero."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def frame_text(X: np.ndarray) -> str:
    """``X 1.000,Y 2.000,Z 3.000,A 0.0000,B 0.0000,C 180.0000`` of a pose X (4, 4) [m]."""
    xyz = [_num(v * 1000.0, MM_DECIMALS) for v in X[:3, 3]]
    abc = [_num(v, DEG_DECIMALS) for v in kuka_abc(X[:3, :3])]
    return ",".join(f"{k} {v}" for k, v in zip("XYZABC", xyz + abc))


def e6pos(name: str, X: np.ndarray, status: int, turn: int) -> str:
    """The .dat declaration of an E6POS ``name`` at pose X (4, 4) [m] with Status and Turn."""
    return f"DECL E6POS {name}={{{frame_text(X)},S {int(status)},T {int(turn)},{_NO_EXTERNAL}}}"


def e6axis(name: str, angles_deg) -> str:
    """The .dat declaration of an E6AXIS ``name`` at the axis angles (6,) [deg]."""
    axes = ",".join(f"A{i} {_num(v, DEG_DECIMALS)}" for i, v in enumerate(angles_deg, start=1))
    return f"DECL E6AXIS {name}={{{axes},{_NO_EXTERNAL}}}"


def frame(name: str, X: np.ndarray) -> str:
    """The .dat declaration of a FRAME ``name`` (a CIRC auxiliary point) at pose X (4, 4) [m]."""
    return f"DECL FRAME {name}={{{frame_text(X)}}}"


def header(program, name: str, generation: str = KRC2) -> list[str]:
    """The comment lines at the top of the .src: what the controller does differently from the certified
    profile, and what the program assumes."""
    mapping = axis_map(program.robot, KUKA)
    ptp = ("PTP zones: C_PTP with $APO.CPTP = the zone's share of half the shorter neighbouring move (a percentage "
           "of $APO_DIS_PTP, not a distance: check on the controller); C_DIS after it for a PTP-CP transition"
           if generation == KRC2 else "PTP zones: C_DIS (KSS 8 inline form)")
    return [
        f"{name}: {len(program.moves)} moves of job {program.name} on {program.robot.name}, written by "
        f"{WRITTEN_BY} (pipeline.outputs.controllers.krl)",
        f"{job_mark(program.job_name or program.name)} generation={generation}",
        settings_mark(program),
        *([signals_mark(program)] if signals_mark(program) else []),
        *([gripped_mark(program)] if gripped_mark(program) else []),
        ptp,
        "What the controller does differently from the certified profile:",
        "- it plans its own velocity profile for every PTP, LIN and CIRC (its machine data's accelerations and "
        "jerk): the timing differs",
        "- a PTP moves all axes synchronously straight in axis space from its start; our joint path may be a "
        "spline through the waypoints",
        "- C_DIS corners are the controller's own approximation contour within $APO.CDIS of the point, not our "
        "blend",
        "- LIN and CIRC keep the start's configuration and ignore a target's S and T; only PTP uses them",
        "- PTP targets whose E6POS with S and T would name more than one joint solution are written as E6AXIS",
        "- $ACC_AXIS is 100 % of the machine data; our joint acceleration limits are not written",
        "- a waypoint's outputs switch at its exact stop, or by TRIGGER WHEN DISTANCE=1 in the middle of its "
        "approximation contour",
        *(["$LOAD at each grip and release: the total carried (the tool's load and the parts held), as KRL holds one "
           "load on the flange"] if program.parts else []),
        "Assumed (no BAS call): no external axes; "
        + frames_words(program.robot, KUKA, "$ROBROOT", "$FLANGE", "S/T"),
        f"Axis angles: {mapping.source}",
    ]


def load_assignment(program, load: Payload | None) -> str:
    """``$LOAD = {M ..,CM {X,Y,Z,A,B,C},J {X,Y,Z}}`` of ``load`` (in the flange frame F; None: no load, M 0) in the
    controller's flange frame $FLANGE (module docstring); without a job payload the line ends in the PLACEHOLDER
    comment."""
    if load is None:
        load = Payload(0.0, np.zeros(3))
    in_flange = expressed_in(load, np.linalg.inv(controller_frames(program.robot, KUKA)[1]))
    moments, R = principal_axes(in_flange)
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = R, in_flange.com
    inertia = ",".join(f"{k} {_num(float(v), INERTIA_DECIMALS)}" for k, v in zip("XYZ", moments))
    text = f"$LOAD = {{M {_num(in_flange.mass, KG_DECIMALS)},CM {{{frame_text(X)}}},J {{{inertia}}}}}"
    if program.payload is None:
        text += " ; PLACEHOLDER: the tool's load is unknown (no payload in the job): this is the parts' load alone"
    return text


def load_lines(program) -> list[str]:
    """The job's payload as ``$LOAD`` (``load_assignment``), or the PLACEHOLDER comment (module docstring)."""
    if program.payload is None:
        return ["; PLACEHOLDER: the job gives no payload: $LOAD is the controller's own; set the tool's mass, "
                "centre of mass and inertia (payload: {mass, com, inertia} in the job)"]
    return [load_assignment(program, program.payload)]


def _init(program) -> list[str]:
    """The BAS-free initialisation of the .src (module docstring)."""
    tool = frame_text(tool_on_flange(program.robot, KUKA, program.tool.X_FT))
    acc_cp = f"{program.tcp_accel_max:.3f}" if program.tcp_accel_max is not None else "$ACC_MA.CP"
    lines = ["$ADVANCE = 3", "$BASE = $ROBROOT", f"$TOOL = {{{tool}}}", "$IPO_MODE = #BASE",
             "$ORI_TYPE = #VAR", "$CIRC_TYPE = #BASE", f"$ACC.CP = {acc_cp}", "$ACC.ORI1 = $ACC_MA.ORI1",
             "$ACC.ORI2 = $ACC_MA.ORI2", "$VEL.ORI1 = $VEL_MA.ORI1", "$VEL.ORI2 = $VEL_MA.ORI2"]
    lines += [f"$ACC_AXIS[{i}] = 100" for i in range(1, 7)]
    lines += [f"$VEL_AXIS[{i}] = {BCO_PERCENT}" for i in range(1, 7)]
    return lines + load_lines(program)


def _speed_lines(program, move, current: dict) -> list[str]:
    """The speed assignments before ``move`` that differ from ``current`` (updated in place)."""
    value, _ = written_speed(KRL, program, move)
    if move.is_tool_move:
        text = f"{value:.3f}"
        if current.get("cp") == text:
            return []
        current["cp"] = text
        return [f"$VEL.CP = {text}"]
    percent = int(round(value))
    if current.get("axis") == percent:
        return []
    current["axis"] = percent
    return [f"$VEL_AXIS[{i}] = {percent}" for i in range(1, 7)]


def cptp_percent(program, move) -> int:
    """$APO.CPTP [%] of a PTP's zone under ``KRC2``: ceil(100 x zone / half the shorter of the move and the next
    one, TCP chords), 1..100 (module docstring)."""
    lengths = move_lengths(program)[move.end - 1: move.end + 1]
    reach = 0.5 * float(lengths.min())
    return 100 if reach <= 0.0 else int(min(100, max(1, math.ceil(100.0 * move.zone / reach - 1e-9))))


def _motion(program, move, point: str, aux: str | None, zone_m: float, generation: str) -> list[str]:
    """The approximation settings and the motion line of ``move`` to ``point`` (via ``aux`` if circular)
    with a zone of ``zone_m`` [m] (0: an exact stop) for the controller ``generation``."""
    zone, approx = [], ""
    if zone_m > 0.0:
        zone, approx = [f"$APO.CDIS = {zone_m * 1000.0:.3f}"], " C_DIS"
        if not move.is_tool_move and generation == KRC2:
            following = program.moves[move.end] if move.end < len(program.moves) else None
            zone.append(f"$APO.CPTP = {cptp_percent(program, move)}")
            approx = " C_PTP C_DIS" if following is not None and following.is_tool_move else " C_PTP"
    if aux is not None:
        return zone + [f"CIRC {aux}, {point}{approx}"]
    return zone + [f"{'LIN' if move.is_tool_move else 'PTP'} {point}{approx}"]


def written_status_turn(program) -> np.ndarray:
    """Status and Turn (K, 2) written with each waypoint: of its joint values, except an axis at 0 to within
    round-off (Turn is its sign), which gets the sign the written E6POS selects (``selection.
    written_configuration``), so that the file names the joint values its reader will find."""
    robot, poses = program.robot, [program.robot.fk(program.waypoints[0].q)] + [m.X_BT for m in program.moves]
    own = configurations(robot, program.targets, KUKA)
    return np.array([own[k] if program.waypoints[k].method is None else
                     written_configuration(robot, written_pose(X, controller_frames(robot, KUKA)[0]), q, KUKA,
                                           SELECTED_TOL, "the E6POS")
                     for k, (X, q) in enumerate(zip(poses, program.targets))])


def _as_axes(program, k: int, X: np.ndarray, status_turn) -> bool:
    """Whether waypoint k is written as an E6AXIS: given as joint values, or a PTP target (the start or a
    joint move's end) whose written E6POS with its S and T does not name its joint values alone. LIN and
    CIRC targets stay E6POS: the controller ignores their S and T and follows the path from where it is."""
    if program.waypoints[k].method is None:
        return True
    ptp = k == 0 or not program.moves[k - 1].is_tool_move
    return ptp and not names_its_joints(program.robot, X, status_turn, program.targets[k])


def _declarations(program, status_turn: np.ndarray, angles: np.ndarray,
                  written: WrittenProgram | None = None) -> list[str]:
    """The .dat declarations: waypoint k as XPk (E6AXIS or E6POS: ``_as_axes``), the via point of a
    circular move to waypoint k as XAk and vertex i of a planned move to waypoint k as XPk_i (E6AXIS)."""
    poses = [program.robot.fk(program.waypoints[0].q)] + [m.X_BT for m in program.moves]
    X_base_B = np.linalg.inv(controller_frames(program.robot, KUKA)[0])       # written in $ROBROOT
    lines = []
    for k, X in enumerate(poses):
        if _as_axes(program, k, X, status_turn[k]):
            lines.append(e6axis(f"XP{k}", angles[k]))
        else:
            lines.append(e6pos(f"XP{k}", X_base_B @ X, *status_turn[k]))
    for move in program.moves:
        if move.via is not None:
            X = move.X_BT.copy()
            X[:3, 3] = move.via
            lines.append(frame(f"XA{move.end}", X_base_B @ X))
        lines += [e6axis(name, axis_angles(program.robot, q, KUKA)) for name, q, _ in _vertices(move, written)]
    return lines


def _vertices(move, written: WrittenProgram | None = None) -> list[tuple[str, np.ndarray, float]]:
    """(name, joint values (6,) [rad], zone [m]) of each joint target of a joint move between its ends: the
    written certified motion's targets on the certified path (``written``: a planned move's, or a curved joint
    move's), else a planned move's vertices, exact stops."""
    if written is not None:
        return [(f"XP{move.end}_{i}", w.target, w.zone_m) for i, w in enumerate(written.of(move.end)[:-1], start=1)]
    if move.planned is None:
        return []
    return [(f"XP{move.end}_{i}", q, 0.0) for i, q in enumerate(move.planned.waypoints[1:-1], start=1)]


def _ptp_lines(program, point: str, q_from: np.ndarray, q_to: np.ndarray, q_next: np.ndarray, zone_m: float,
               generation: str) -> list[str]:
    """A PTP to a planned move's inner joint target ``point`` (joint values ``q_to``, between ``q_from`` and
    ``q_next``) with a zone of ``zone_m`` [m]: $APO.CDIS and C_PTP ($APO.CPTP the zone's share of half the shorter
    TCP chord beside it, as ``cptp_percent``) under ``KRC2``, C_DIS under ``KSS8``; no zone: an exact stop."""
    if zone_m <= 0.0:
        return [f"PTP {point}"]
    if generation != KRC2:
        return [f"$APO.CDIS = {zone_m * 1000.0:.3f}", f"PTP {point} C_DIS"]
    tcp = program.robot.fk_batch(np.array([q_from, q_to, q_next]))[:, :3, 3]
    reach = 0.5 * float(np.linalg.norm(np.diff(tcp, axis=0), axis=1).min())
    percent = 100 if reach <= 0.0 else int(min(100, max(1, math.ceil(100.0 * zone_m / reach - 1e-9))))
    return [f"$APO.CDIS = {zone_m * 1000.0:.3f}", f"$APO.CPTP = {percent}", f"PTP {point} C_PTP"]


def _io(program, name: str, direction: str) -> str:
    """``$OUT[n]`` / ``$IN[n]`` of the job's signal ``name``; OutputError when it has no number."""
    number = program.signals[name].number
    if number is None:
        raise OutputError(f"signal {name!r} has no number: KRL addresses digital I/O by number ($OUT[n], $IN[n]); "
                          f"give it one in the job's signals: {{{name}: {{{direction}: N}}}}")
    return f"${'OUT' if direction == 'output' else 'IN'}[{number}]"


def _seconds(value: float) -> str:
    """A time [s] as written (to 0.001 s)."""
    return f"{value:.3f}"


def _wait_input_lines(program, action) -> list[str]:
    """A wait for an input (module docstring): WAIT FOR, with a timeout the $TIMER pattern ending in HALT."""
    signal = _io(program, action.signal, "input")
    wanted = signal if action.value else f"NOT {signal}"
    if action.timeout_s is None:
        return [f"WAIT FOR {wanted}"]
    ms = round(action.timeout_s * 1000.0)
    missing = f"NOT {signal}" if action.value else signal
    halt = f"HALT ; {action.signal}: no {'on' if action.value else 'off'} within {action.timeout_s:g} s"
    return [f"$TIMER[{TIMER}] = 0", f"$TIMER_STOP[{TIMER}] = FALSE",
            f"WAIT FOR {wanted} OR ($TIMER[{TIMER}] > {ms})", f"$TIMER_STOP[{TIMER}] = TRUE",
            f"IF {missing} THEN", halt, "ENDIF"]


def _output_statement(program, action) -> str:
    """``$OUT[n] = TRUE`` / ``FALSE`` of a set, ``PULSE($OUT[n], TRUE, t)`` of a pulse."""
    output = _io(program, action.signal, "output")
    if action.kind == SET:
        return f"{output} = {'TRUE' if action.value else 'FALSE'}"
    return f"PULSE({output}, TRUE, {_seconds(action.time_s)})"


def action_lines(program, k: int, zoned: bool = False) -> tuple[list[str], list[str]]:
    """The KRL lines of waypoint k's actions (module docstring): (before its motion, after it); a grip or release as
    the ``$LOAD`` of the total after it. ``zoned``: the
    motion to k is approximated, so its outputs switch on the path (TRIGGER WHEN DISTANCE=1: at the middle of the
    approximation contour), written before the motion; its comments follow the motion (a job refuses waits there)."""
    before, after = [], []
    for i, action in enumerate(program.actions_at(k)):
        if action.kind in (SET, PULSE):
            statement = f"{_output_statement(program, action)} ; {action.signal}"
            if zoned:
                before.append(f"TRIGGER WHEN DISTANCE=1 DELAY=0 DO {statement}")
            else:
                after.append(statement)
        elif action.kind == WAIT:
            after.append(f"WAIT SEC {_seconds(action.time_s)}")
        elif action.kind == WAIT_INPUT:
            after += _wait_input_lines(program, action)
        elif action.kind == COMMENT:
            after.append(f"; {action.text}")
        elif action.kind in (GRIP, RELEASE):
            after.append(load_assignment(program, program.load_after(k, i)))
    return before, after


def _written_zone(program, move, written: WrittenProgram | None) -> float:
    """The zone [m] written at the end of ``move`` (0: an exact stop): the certified motion's (``written``), else the
    job's unless the program stops there."""
    if written is not None:
        return written.of(move.end)[-1].zone_m
    return 0.0 if program.exact_stop_at(move) else move.zone


def write_krl(program, name: str, generation: str = KRC2, written: WrittenProgram | None = None) -> tuple[str, str]:
    """The program's .src and .dat texts (module docstring) as program ``name`` for the controller
    ``generation`` (``GENERATIONS``). ``lint`` runs first: a ControllerLintError names what KRL cannot hold (a
    name over 24 characters or reserved, a zone over half a move, a speed out of range, a configuration that
    does not match its joint values). A planned joint move (a cell's collision-free detour) is a PTP to each
    planner vertex (E6AXIS), exact stops at the vertices and at both ends of the move: PTP is straight in joint
    space, the segments the planner checked. ``written`` (``controller_motion.certified_moves``): the certified
    motion instead, a planned move as PTPs to joint targets on the certified path, zones wherever it does not stop,
    its certificate in the header."""
    if generation not in GENERATIONS:
        raise OutputError(f"KRL controller generation {generation!r}: one of {', '.join(GENERATIONS)}")
    status_turn = written_status_turn(program)
    comments = header(program, name, generation) + ([] if written is None else written.header_lines())
    zones = [0.0] + [_written_zone(program, move, written) for move in program.moves]
    actions = [action_lines(program, k, zones[k] > 0.0) for k in range(len(program.targets))]
    lint(program, KRL, name, comments + [line[2:] for _, after in actions for line in after if line.startswith("; ")],
         status_turn)
    angles = axis_angles(program.robot, program.targets, KUKA)
    body, speeds = ["PTP XP0", *actions[0][1]], {"axis": BCO_PERCENT}
    for move in program.moves:
        body += _speed_lines(program, move, speeds)
        vertices = _vertices(move, written)
        q_from = program.targets[move.end - 1]
        for i, (point, q, zone) in enumerate(vertices):
            q_next = vertices[i + 1][1] if i + 1 < len(vertices) else move.target
            body += _ptp_lines(program, point, q_from, q, q_next, zone, generation)
            q_from = q
        motion = _motion(program, move, f"XP{move.end}", f"XA{move.end}" if move.via is not None else None,
                         zones[move.end], generation)
        before, after = actions[move.end]
        body += motion[:-1] + before + motion[-1:] + after
    src = [f"DEF {name}( )"] + [f"; {line}" for line in comments] + _init(program) + body + ["END"]
    dat = [f"DEFDAT {name}", f"; the targets of {name}.src, written by {WRITTEN_BY}, "
           f"{job_mark(program.job_name or program.name)}",
           *_declarations(program, status_turn, angles, written), "ENDDAT"]
    return "\n".join(src) + "\n", "\n".join(dat) + "\n"
