"""``write_jbi(program, name) -> str``: a program as a Yaskawa INFORM job (``.jbi``).

The file follows the job data format of Yaskawa's data transmission manuals (NX100 "Data Transmission
Function" HW0481924, section 4.1 "Job Data Format"; DX100 156191-1CD, section 4.1): ``/JOB``, ``//NAME``
(up to 8 characters), ``//POS`` with ``///NPOS`` (robot teaching positions, then base axis, station,
position variables: 0), ``///TOOL``, ``///POSTYPE ROBOT`` (Cartesian data in the robot frame), ``///RECTAN``,
``///RCONF`` (the manipulator type of the Cartesian data that follow it: Flip, Upper/Lower arm, Front/Rear,
R, T, S >= 180, then the DX100's 18 unused fields as 0), ``Cxxxxx=X,Y,Z,Rx,Ry,Rz``, then ``//INST`` with
``///DATE``, ``///COMM`` (up to 32 characters), ``///ATTR SC,RW`` (save complete, read/write) and
``///GROUP1 RB1``, and the instructions between ``NOP`` and ``END``. What this writer emits, and why:

* Name: 1 to 8 characters, an upper-case letter then upper-case letters, digits or ``_`` (the NX100 limit;
  newer controllers take longer names, a short one loads on all). Comments (``'text``): up to 32 characters.
* Moves: a joint move to the first waypoint (where the robot starts is not known), then ``MOVJ C.. VJ=``
  (% of the joints' maximum speed, 0.01 to 100.00: the move's fraction of the speed limits x the job's
  ``speed_scale``; a planned move's planner vertices each get a MOVJ without PL, an exact stop, as do both
  ends of a planned move), ``MOVL C.. V=`` (TCP speed in mm/s, to 0.1 mm/s), ``MOVC`` x 3 for a circular move: INFORM
  defines an arc by three MOVC points, and the controller reaches the first on a straight line from the point before
  (Yaskawa's operator's manuals, "circular interpolation": P0 -> P1 linear, P1 -> P2 -> P3 the arc): a linear move
  into an arc is written as the arc's first MOVC point, with its speed and PL; after a joint move or another arc,
  the arc's start (where the previous move ends) is written again as the first MOVC point, then the via and the end
  point; an arc ending where the next arc starts gets ``FPT``.
* Zones: ``PL=n`` (positioning level, 0 to 8). A level is a distance the controller's parameters
  S1CxG033..S1CxG040 set for PL1..PL8, not a fixed size; ``PL_MM`` is our assumption for them (12.5 mm,
  doubling per level), to be set on the controller or replaced by the controller's values through
  ``pl_mm``. A zone z > 0 gets the largest level whose distance is <= z (so the controller never rounds more
  than the certified zone), PL=0 when z is below PL1's distance; a move without a zone gets no PL (the
  controller stops at its point, as PL=0). A joint move or an arc followed by an arc gets no PL (``written_zone``): the
  arc's first MOVC repeats that point, a zero-length segment, into which the controller cannot round.
  With the certified motion (``written``: ``controller_motion.certified_moves``): a planned move's targets are the
  certified path's joint targets, no PL only where the certified motion stops (or into an arc after a joint move or
  an arc, as above), and a
  zone gets the level closest to it, PL1 at least (``closest_pl_level``: PL=0 would position on the point where the
  certified motion flows); the distances are ``PL_MM`` (an assumption, stated in the header), ``pl_differences``
  lists the difference per move (header, and what ``program`` prints), ``pl_zones`` the levels' distances, with
  which ``runner.language_zones_certificate`` certifies the program as Yaskawa writes it.
* Job: ``NOP`` first and ``END`` last (a job without them is refused on loading: "ERROR 3200: NOP or END
  instruction not found", ros-industrial/motoman issue 142); a comment line records the job (``job=NAME``,
  ``pipeline.files.atomic.job_mark``) and the name is never an INFORM word (``names``).
* Load: INFORM jobs hold no load data. The tool file on the controller does (W [kg], Xg, Yg, Zg [mm] the centre of
  gravity in the flange frame, Ix, Iy, Iz [kg m^2] about it in the flange axes; NX100/DX200/YRC1000 manuals, "ARM
  control"), and no INFORM instruction we can cite changes it while a job runs: this writer does not change the load
  the controller uses. It numbers the loads the program carries (``settings_mark.load_schedules``: load 1 the tool's
  load alone, then each new set of parts held, in the order the grip and release actions first carry it), states
  each one's tool file data in the header (``tool_file_texts``) with the loads mark (``settings_mark.loads_mark``)
  that ``read_jbi`` reads back, and at each grip and release writes two comment lines in its place among the
  waypoint's actions: ``'dh.grip=box`` (``dh.release=``: the part) and ``'ARM control: load 2 from here``: the
  controller's ARM control must be given that load (e.g. a tool file holding its data), or the robot runs with the
  wrong one. Ix, Iy, Iz are the diagonal of the load's inertia in the flange axes: its principal moments when that
  inertia is diagonal, else the diagonal alone, said in the comment (the tool file holds no products of inertia). A
  job without any load (no payload, no part) gets a PLACEHOLDER comment.
* Points: every point in Cartesian data (``POSTYPE ROBOT``): the TCP in the robot frame, X, Y, Z in mm to
  0.001 mm, Rx, Ry, Rz in deg to 0.01 deg, the rotations "in the order Rz, Ry, Rx" of the frame (DX100
  manual, section 4.3: R = Rz Ry Rx, rotations about the fixed x, y, z axes), with ``///RCONF`` from
  ``pipeline.model.vendors.configuration``. Pulse data (``POSTYPE PULSE``) would need each axis's pulses per
  degree, which the robot files do not give: joint waypoints are written as Cartesian data too. Each point
  is solved again as written, with its RCONF, and must land on the program's joint values within the
  rounding (``fanuc_ls.written_point_configuration``): an axis R, T or S at exactly +-180 deg, where the ">= 180"
  bit is decided by the last digit, gets the bit of the side its rounded pose lies on.
* Frames: the robot frame is the robot file's yaskawa controller section's base frame (the GP7's 330 mm above
  its mounting face; ``fanuc_ls.controller_frame``); robots without one are written in our base frame. ``///TOOL 1``
  must hold the job's tool on the controller's flange frame, the section's flange (stated in the comments).
* Actions (``pipeline.program.actions``): a waypoint's actions right after its last written move (waypoint 0's after
  the joint move into it), one INFORM instruction each: ``DOUT OT#(n) ON``/``OFF`` (set an output), ``PULSE OT#(n)
  T=0.10`` (an output on for T seconds while the job goes on), ``TIMER T=0.25`` (the job waits), ``WAIT IN#(n)=ON``
  (waits for the input; with a timeout ``WAIT IN#(n)=ON T=2.00``, after which the controller goes on to the next
  line whether or not the input came, so the writer follows it with ``PAUSE IF IN#(n)=OFF``: the job stops there
  when the input did not come, the only pattern ``read_jbi`` reads as a timeout), ``'text`` (a comment, wrapped to 32
  characters: a longer one reads back as several). Times are 0.01 s steps, 0.01 to 655.35 s (INFORM's T=). A
  waypoint with a wait is an exact stop (no PL): the controller runs the next instruction once the robot is in
  position there, so a TIMER or WAIT starts with the robot at rest at the point. INFORM numbers its I/O: a signal
  without a number is refused, and the job's names ride in one header comment per signal
  (``settings_mark.signals_mark``'s ``dh.signal.NAME=out1``; a name too long for a 32-character comment is left
  out: it reads back as ``do1`` / ``di3``). A linear move into an arc whose end has actions is written as a MOVL
  (the actions run there), the arc's first MOVC repeating its point, as after a joint move.
  Sources: ros-industrial/motoman ``motoman_driver/Inform/*/INIT_ROS.JBI`` (BSD; ``DOUT OT#(890) OFF``, ``TIMER
  T=0.05``, ``WAIT OT#(890)=ON``); AGSweeney/Motoman_EnIP_ToolChanger ``MH180_Progs/SAMPLE_TC.JBI`` (MIT; ``DOUT
  OT#(186) OFF``, ``TIMER T=0.50``, ``WAIT IN#(204)=ON``, ``PULSE OT#(212)``); a public powder-coating job
  generator (index id 53774280828) writing ``WAIT IN#(6)=ON T=5.00`` then ``JUMP *END IF IN#(6)=OFF`` (the job goes
  on after T= and checks the input again); ``PAUSE IF IN#(12)=ON`` in a public INFORM instruction reference (index id
  930884944); the FS100 INFORM manual section 1.1.2 (I/O instructions DOUT, WAIT; control instructions TIMER).
"""

from __future__ import annotations

import datetime as _dt
import re
from dataclasses import replace

import numpy as np

from ...errors import ConfigurationError
from ...files.atomic import job_mark
from ...model.vendors.axes import YASKAWA
from ...model.vendors.configuration import configurations
from ...program.actions import COMMENT, GRIP, PULSE, RELEASE, SET, WAIT, WAIT_INPUT, Action
from ...program.model import CIRCULAR, JOINT, LINEAR, Move, Program
from .fanuc_ls import (MM, Motion, check_name, check_six_joints, comment_lines, controller_frame, flange_diagonal,
                       header_intro, load_texts, placeholder_text, program_points, rounded, tool_text,
                       written_point_configuration, xyz_rpy)
from .lint import JBI, lint
from .settings_mark import LoadSchedules, check_signal_numbers, load_schedules, settings_mark, signals_mark

#: Our assumed PL1..PL8 distances [mm] (module docstring): the controller's S1CxG033..S1CxG040 decide.
PL_MM = (12.5, 25.0, 50.0, 100.0, 200.0, 400.0, 800.0, 1600.0)
NAME_PATTERN = re.compile(r"^[A-Z][A-Z0-9_]{0,7}$")
#: ///RCONF fields after l, m, n, o, p, q on DX100 and later controllers (r1..r18, unused).
UNUSED_RCONF = 18
#: INFORM's T= of TIMER, PULSE and WAIT: 0.01 s steps up to 655.35 s.
TIME_STEP_S, TIME_MAX_S = 0.01, 655.35
#: Characters of a comment line (NX100 4.1: comments up to 32 characters).
COMMENT_MAX = 32
#: The second comment line at a grip or release (module docstring, "Load"): the load carried from there on.
LOAD_CHANGE = "ARM control: load {n} from here"


def pl_level(zone: float, pl_mm=PL_MM) -> int:
    """PL level 0..8 of a zone [m]: the largest level whose distance [mm] is <= the zone."""
    return int(np.searchsorted(np.asarray(pl_mm, dtype=float), zone * MM + 1e-9, side="right"))


def closest_pl_level(zone: float, pl_mm=PL_MM) -> int:
    """PL level 1..8 of a zone [m] > 0 of the certified motion: the level whose distance [mm] is closest to the
    zone (PL=0 would stop the robot where the certified motion flows; ties go to the smaller level)."""
    return 1 + int(np.argmin(np.abs(np.asarray(pl_mm, dtype=float) - zone * MM)))


#: The header's statement of how a written zone becomes PL (with the certified motion).
WRITTEN_PL_RULE = ("Certified motion: planned moves as joint targets on the certified path; no PL only where it "
                   "stops. PL=n is the level closest to the zone, not equal to it: PL1..PL8 = {levels} mm is an "
                   "ASSUMPTION (the controller parameters S1CxG033-040 decide); the difference per move below.")


def pl_zones(program: Program, written, pl_mm=PL_MM) -> list[float]:
    """Per written move, the zone [m] of the PL level written for it (the assumed ``pl_mm``; 0 without PL)."""
    return [pl_mm[closest_pl_level(m.zone, pl_mm) - 1] / MM if m.zone > 0.0 else 0.0
            for m in job_points(program, written)[1:]]


def pl_differences(program: Program, written, pl_mm=PL_MM) -> list[str]:
    """Per written move, the PL written for its zone and the difference of that level's assumed distance to the
    certified zone (a zone dropped into an arc after a joint move: an exact stop, the arc's first MOVC repeats the
    point)."""
    lines, zones = [], [w.zone_m for w in written.moves]
    for k, motion in enumerate(job_points(program, written)[1:]):
        certified = zones[k]
        if certified <= 0.0:
            continue
        if motion.zone <= 0.0:
            lines.append(f"written move {k + 1} (to waypoint {motion.move.end}): zone {certified * MM:.1f} mm -> no PL "
                         f"(an exact stop: the next arc's first MOVC repeats this point after a joint move)")
            continue
        n = closest_pl_level(motion.zone, pl_mm)
        lines.append(f"written move {k + 1} (to waypoint {motion.move.end}): zone {certified * MM:.1f} mm -> PL={n} "
                     f"~ {pl_mm[n - 1]:g} mm ({pl_mm[n - 1] - certified * MM:+.1f} mm)")
    return lines


def write_jbi(program: Program, name: str, created: _dt.datetime | None = None, pl_mm=PL_MM, written=None) -> str:
    """The program as a Yaskawa INFORM job (module docstring); ``name`` its //NAME, ``created`` its
    ///DATE (None: now, UTC), ``pl_mm`` the controller's PL1..PL8 distances [mm]. ConfigurationError for
    a bad name, a non-6R robot, a speed the controller cannot take or pl_mm not 8 increasing distances;
    ``lint`` runs first on the name, the comment lines and the RCONF of every waypoint (all are Cartesian:
    ControllerLintError). ``written`` (``controller_motion.certified_moves``): the certified motion, its targets and
    zones (PL the closest level, ``pl_differences``), its certificate in the header."""
    check_name(name, NAME_PATTERN, "Yaskawa job")
    check_six_joints(program)
    check_signal_numbers(program, "INFORM", "OT#(n), IN#(n)")
    if len(pl_mm) != 8 or np.any(np.diff(pl_mm) <= 0) or min(pl_mm) <= 0:
        raise ConfigurationError(f"pl_mm must be 8 increasing distances [mm] for PL1..PL8, got {pl_mm}")
    X_B_base, frame = controller_frame(program.robot, YASKAWA)
    schedules = load_schedules(program)
    header = [job_mark(program.job_name or program.name), *comment_lines(settings_mark(program)),
              *signal_mark_lines(program),
              *comment_lines(_header_text(program, frame)),
              *(line for text in tool_file_texts(program, schedules) for line in comment_lines(text))]
    if written is not None:
        levels = "/".join(f"{v:g}" for v in pl_mm)
        header += [line for text in [WRITTEN_PL_RULE.format(levels=levels), *written.header_lines(),
                                     *pl_differences(program, written, pl_mm)] for line in comment_lines(text)]
    motions = job_points(program, written)
    level = pl_level if written is None else closest_pl_level
    zones = [f"zone {m.zone * MM:.1f}mm PL{level(m.zone, pl_mm)}" for m in motions if m.zone > 0.0]
    changes = [load_comment(a) for k in range(len(program.waypoints)) for a in program.actions_at(k)
               if a.kind in (GRIP, RELEASE)]
    lint(program, JBI, name, header + zones + changes, configurations(program.robot, program.targets, YASKAWA))
    positions, instructions, index = [], [], 0
    for k, motion in enumerate(motions):
        labels = []
        for point in motion.points:
            labels.append(f"C{index:05d}")
            positions.extend(_position(program, labels[-1], point.q, point.X_BT, X_B_base, positions))
            index += 1
        following = motions[k + 1].move if k + 1 < len(motions) else None
        instructions.extend(_instructions(program, motion, labels, following, pl_mm, level))
        if following is None or following is not motion.move:            # the waypoint's last written move
            instructions.extend(action_lines(program, 0 if motion.move is None else motion.move.end, schedules))
    comments = [f"'{line}" for line in header]
    when = created or _dt.datetime.now(_dt.timezone.utc)
    return "\n".join(["/JOB", f"//NAME {name}", "//POS", f"///NPOS {index},0,0,0,0,0", "///TOOL 1",
                      "///POSTYPE ROBOT", "///RECTAN", *positions, "//INST", f"///DATE {when:%Y/%m/%d %H:%M}",
                      f"///COMM {comment_lines(program.name)[0] if program.name else name}", "///ATTR SC,RW",
                      "///GROUP1 RB1", "NOP", *comments, *instructions, "END", ""])


def written_zone(program: Program, move: Move) -> float:
    """The zone [m] written at the end of ``move`` (module docstring): 0 where the program stops and before an arc
    after a joint move or an arc (whose first MOVC repeats this point), else the move's zone."""
    following = program.moves[move.end] if move.end < len(program.moves) else None
    stop = program.exact_stop_at(move) or (following is not None and following.kind == CIRCULAR
                                           and not _merges_into_arc(program, move))
    return 0.0 if stop else move.zone


def _merges_into_arc(program: Program, move: Move | None) -> bool:
    """Whether ``move`` (followed by an arc) is written as the arc's first MOVC point: a linear move without actions
    at its end (module docstring)."""
    return move is not None and move.kind == LINEAR and not program.actions_at(move.end)


def _into_arc(motions: list[Motion], k: int) -> bool:
    """Whether motion k + 1 begins a circular move (another move than motion k's)."""
    following = motions[k + 1].move if k + 1 < len(motions) else None
    return following is not None and following.kind == CIRCULAR and following is not motions[k].move


def _line_into_arc(program: Program, motions: list[Motion], k: int) -> bool:
    """Whether motion k is a linear move into an arc written as the arc's first MOVC point, which the controller
    reaches on a straight line (module docstring: not when actions run at its end)."""
    return _into_arc(motions, k) and _merges_into_arc(program, motions[k].move)


def job_points(program: Program, written=None) -> list[Motion]:
    """``fanuc_ls.program_points`` for Yaskawa: a linear move into an arc is the arc's first MOVC point (with its
    zone); an arc after a joint move or an arc repeats its start (the previous motion's end) as its first MOVC
    point, and no zone leads into it (``written_zone``): the points in the order C00000, C00001, ... are written.
    ``written``: the certified motion's targets and zones (``program_points``)."""
    motions = program_points(program, YASKAWA, written)
    if written is None:
        motions = [replace(m, zone=written_zone(program, m.move)) if m.zone > 0.0 else m for m in motions]
    else:
        motions = [replace(m, zone=0.0) if _into_arc(motions, k) and not _line_into_arc(program, motions, k) else m
                   for k, m in enumerate(motions)]
    return [replace(m, points=[motions[k - 1].points[-1], *m.points])
            if m.move is not None and m.move.kind == CIRCULAR and not _line_into_arc(program, motions, k - 1) else m
            for k, m in enumerate(motions)]


def _header_text(program: Program, frame: str) -> str:
    return (f"{header_intro(program, 'at PL points')} TOOL 1 = "
            f"{tool_text(program, YASKAWA)} (x y z rx ry rz, mm deg). {frame}. All points are Cartesian data: the robot "
            "file gives no pulses per degree for pulse data.")


def _position(program: Program, label: str, q, X_BT, X_B_base: np.ndarray, written: list[str]) -> list[str]:
    """The lines of one Cartesian point: ///RCONF when it differs from the last one written, then Cxxxxx=."""
    p, angles = xyz_rpy(X_BT, X_B_base)
    p, angles = rounded(p, 3), rounded(angles, 2)
    config = written_point_configuration(program.robot, YASKAWA, label, q, p, angles, X_B_base, (0.001, 0.01))
    rconf = "///RCONF " + ",".join(str(int(v)) for v in [*config, *([0] * UNUSED_RCONF)])
    last = next((line for line in reversed(written) if line.startswith("///RCONF")), None)
    values = [f"{v:.3f}" for v in p] + [f"{v:.2f}" for v in angles]
    return ([] if rconf == last else [rconf]) + [f"{label}={','.join(values)}"]


def _speed(program: Program, move: Move | None) -> str:
    """VJ= for a joint move (% to 0.01, 0.01..100), V= for a tool move (mm/s to 0.1); ConfigurationError for a
    TCP speed that rounds to 0 (the robot's own maximum is for the lint to check)."""
    if move is None or move.kind == JOINT:
        fraction = program.speed_scale if move is None else move.speed * program.speed_scale
        return f"VJ={min(100.0, max(0.01, round(fraction * 100.0, 2))):.2f}"
    mm_s = round(program.tool_speed(move) * MM, 1)
    if mm_s < 0.1:
        raise ConfigurationError(f"move {move.end}: TCP speed {program.tool_speed(move) * MM:.4g} mm/s rounds "
                                 "to 0 in V= (0.1 mm/s steps)")
    return f"V={mm_s:.1f}"


def _instructions(program: Program, motion: Motion, labels: list[str], following: Move | None,
                  pl_mm, level=pl_level) -> list[str]:
    """The INFORM lines of one motion: a zone comment and MOVJ / MOVL / MOVC x 3 with speed and PL."""
    move = motion.move
    speed = _speed(program, move)
    tail = ""
    if motion.zone > 0.0:
        tail = f" PL={level(motion.zone, pl_mm)}"
    if move is None or move.kind == JOINT:
        lines = [f"MOVJ {labels[0]} {speed}{tail}"]
    elif move.kind == CIRCULAR:
        fpt = " FPT" if following is not None and following.kind == CIRCULAR else ""
        lines = [f"MOVC {label} {speed}" for label in labels[:-1]] + [f"MOVC {labels[-1]} {speed}{tail}{fpt}"]
    else:
        into_arc = following is not None and following.kind == CIRCULAR and following is not move
        lines = [f"{'MOVC' if into_arc and _merges_into_arc(program, move) else 'MOVL'} {labels[0]} {speed}{tail}"]
    if tail:
        lines.insert(0, f"'zone {motion.zone * MM:.1f}mm PL{level(motion.zone, pl_mm)}")
    return lines


def signal_mark_lines(program: Program) -> list[str]:
    """The signals mark (``settings_mark.signals_mark``), one comment line per signal; an entry longer than a
    comment line is left out (module docstring)."""
    return [entry for entry in signals_mark(program).split() if len(entry) <= COMMENT_MAX]


#: The header's first sentence on the loads (module docstring, "Load").
LOADS_INTRO = ("Loads: no INFORM instruction changes the tool file load, so give ARM control (tool file W kg, Xg Yg "
               "Zg mm in the flange frame, Ix Iy Iz kg m2 about the centre in the flange axes) the load each grip and "
               "release names.")


def tool_file_texts(program: Program, schedules: LoadSchedules | None) -> list[str]:
    """The header's loads (module docstring, "Load"): per load its tool file data to give ARM control, then the
    loads mark; a PLACEHOLDER for a load the job does not give."""
    if schedules is None:
        return [placeholder_text("tool file 1 (W, Xg, Yg, Zg, Ix, Iy, Iz)")]
    return load_texts(program, schedules, LOADS_INTRO, "load", lambda n: f"load {n}", _tool_file_data, COMMENT_MAX)


def _tool_file_data(load) -> str:
    """A load as tool file data (module docstring, "Load"): W [kg], Xg, Yg, Zg [mm], Ix, Iy, Iz [kg m^2]."""
    diagonal, products = flange_diagonal(load)
    centre = " ".join(f"{v:.3f}" for v in rounded(load.com * MM, 3))
    inertia = " ".join(f"{v:.6f}" for v in rounded(diagonal, 6))
    kept = "" if not products else " (the diagonal in the flange axes: products of inertia not held)"
    return f"W {load.mass:g} kg, Xg Yg Zg {centre} mm, Ix Iy Iz {inertia} kg m2{kept}."


def action_lines(program: Program, k: int, schedules: LoadSchedules | None = None) -> list[str]:
    """The INFORM lines of waypoint ``k``'s actions (module docstring); a grip or release names the load it leaves
    the robot carrying (``schedules``)."""
    return [line for i, action in enumerate(program.actions_at(k))
            for line in _action_lines(program, action, k, schedules and schedules.selected.get((k, i)))]


def load_comment(action: Action) -> str:
    """The first comment line of a grip or release (module docstring, "Load"): ``dh.grip=box``."""
    return f"dh.{action.kind}={action.part}"


def _action_lines(program: Program, action: Action, k: int, load: int | None) -> list[str]:
    if action.kind in (GRIP, RELEASE):
        return [f"'{load_comment(action)}", f"'{LOAD_CHANGE.format(n=load)}"]
    if action.kind == COMMENT:
        return [f"'{line}" for line in comment_lines(action.text)]
    if action.kind == WAIT:
        return [f"TIMER T={_seconds(action.time_s, k, action)}"]
    number = program.signals[action.signal].number
    if action.kind == SET:
        return [f"DOUT OT#({number}) {_on_off(action.value)}"]
    if action.kind == PULSE:
        return [f"PULSE OT#({number}) T={_seconds(action.time_s, k, action)}"]
    assert action.kind == WAIT_INPUT, action.kind
    wait = f"WAIT IN#({number})={_on_off(action.value)}"
    if action.timeout_s is None:
        return [wait]
    return [f"{wait} T={_seconds(action.timeout_s, k, action)}", f"PAUSE IF IN#({number})={_on_off(not action.value)}"]


def _on_off(value: bool) -> str:
    return "ON" if value else "OFF"


def _seconds(t: float, k: int, action: Action) -> str:
    """A time [s] as INFORM's T= (0.01 s steps); ConfigurationError when it rounds to 0 or exceeds 655.35 s."""
    value = round(t / TIME_STEP_S) * TIME_STEP_S
    if not TIME_STEP_S <= value <= TIME_MAX_S:
        raise ConfigurationError(f"waypoint {k}: {action}: {t:g} s is not an INFORM time T= ({TIME_STEP_S:g} to "
                                 f"{TIME_MAX_S:g} s in {TIME_STEP_S:g} s steps)")
    return f"{value:.2f}"
