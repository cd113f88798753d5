"""``write_urscript(program, name, profile=None, period=0.002) -> str``: a compiled Program as a URScript
program (``.script``) for a Universal Robots controller, and optionally the certified profile's replay.

What it writes, and the URScript facts it follows (Universal Robots, "The URScript Programming Language",
Script Manual e-Series SW 5.x: the language chapter for ``def``/``end``, ``if``/``else``, ``#`` comments,
lists and poses; "Module motion" for the functions):

* Units: m, rad, s; a pose is ``p[x, y, z, rx, ry, rz]`` (position [m] and rotation vector [rad]) of the TCP in
  the robot's base frame, rounded to 1e-6; joint values [rad] rounded to 1e-6. ``set_tcp`` sets the job's
  tool (X_FT). URScript has no configuration data: a joint target is the joint vector itself.
* ``movej(q, a, v, r)`` for every joint move (to its solved joint values, whether the job gave joints or a
  pose: the branch is then the program's), with v = the move's fraction x the speed scale x the smallest
  joint speed limit [rad/s] (URScript's v is the leading axis's speed) and a = the speed scale^2 x the smallest
  joint acceleration limit [rad/s^2] (the manual's default 1.4 rad/s^2 when the robot has none); a planned
  joint move passes its planner vertices with ``r=0`` (movej is straight in joint space, the segments the
  planner checked).
* ``movel(pose, a, v, r)`` and ``movec(pose_via, pose_to, a, v, r, mode=0)`` for tool moves, v the move's TCP
  speed x the speed scale (capped by the job's safety TCP limit x the scale) [m/s], a the job's TCP
  acceleration limit x the scale^2 (the manual's default 1.2 m/s^2 when the job has none) [m/s^2]; mode 0
  interpolates the orientation from the start to the target pose, as the program's slerp does; the via
  pose's rotation is not used by movec (the manual) and is written as the target's.
* ``r``: the move's zone [m]; 0 at the program's stops, at both ends of a planned joint move, and where the
  program passes through a waypoint without a zone (the controller stops there). With the certified motion
  (``written``: ``controller_motion.certified_moves``): a planned move's targets are the certified path's joint
  targets and r is each written zone exactly [m] (a blend radius is a distance: nothing to approximate); r = 0
  only where the certified motion stops.
* With a certified profile: ``certified_replay()`` moves to the profile's first sample with ``movej`` (the
  manual's default a, v: an approach), then calls ``servoj(q, t=period, lookahead_time, gain)`` once per
  controller period with the profile resampled at k x period (cubic Hermite on the profile's q and qd
  samples; the last call at the profile's end), then ``stopj``. ``native_moves()`` holds the moves above, and
  ``use_certified_replay`` chooses which one runs. servoj: t is how long the call controls the robot [s]
  (0.002 s on e-Series, 0.008 s on CB3: ``period``), lookahead_time [s] in [0.03, 0.2] smooths the target
  over that horizon and delays it, gain in [100, 2000] is the proportional gain of the tracking (the manual's
  defaults: 0.1 s and 300). A replay holds at most MAX_REPLAY_LINES servoj lines: a longer one is refused, saying
  how long the profile is and which period would fit.
* The file defines the program ``def name(): ... end`` and then calls it (``name()`` on the last line): sent to
  the secondary interface (port 30002) as a script, the trailing call is what runs it; loaded as a program, the
  controller runs the file's top-level statements, and the call runs the program once (a file that only
  defines one function is run by the controller as a program, but whether a Script node does so is unconfirmed:
  the explicit call does not depend on it).
* The payload (``pipeline.program.payload``): ``set_target_payload(m, cog, inertia)`` (UR Script Manual SW 10.6,
  set_target_payload, PolyScope 5.10 and later: m [kg], cog [x, y, z] [m] from the tool mount, inertia [Ixx, Iyy,
  Izz, Ixy, Ixz, Iyz] [kg m^2] with origin in the centre of mass and the flange's axes; transition_time left at its
  0: the change applies at once, as the deprecated set_payload's; "called when the robot picks up or puts down a
  workpiece") of the TOTAL the flange
  carries (``Program.load_after``, to PAYLOAD_DECIMALS decimals): the tool's load before the first move, and at each
  ``grip``/``release`` action in its place among its waypoint's actions the tool's load and the parts then held
  (a grip and a release stop the motion: the payload changes at rest). A job without a payload and without parts
  gets a PLACEHOLDER comment (the controller keeps its installation's payload); with parts but no tool's load the
  parts' loads alone are written and the header says the tool's load is unknown. The header says that
  set_target_payload needs PolyScope 5.10 or later: for an older controller replace each
  ``set_target_payload(m, cog, inertia)`` by ``set_payload(m, cog)`` (the older function, deprecated by it: mass and
  centre of mass, no inertia); ``read_urscript`` reads both.
* Actions (``pipeline.program.actions``), right after the last written move into their waypoint (waypoint 0's after
  the approach movej; the Script Manual's "Module interfaces" for the functions): a set is
  ``set_standard_digital_out(n, True|False)`` for the job's outputs 0-7, ``set_configurable_digital_out(n - 8, b)``
  for 8-15 and ``set_tool_digital_out(n - 16, b)`` for 16-17 (the pin numbering of UR's ROS interface, ur_msgs
  SetIO.srv: PIN_CONF_OUT0 = 8, PIN_TOOL_DOUT0 = 16; inputs alike with ``get_*_digital_in``); a signal without a
  number, or past 17, is refused naming it. URScript has no pulse instruction: a pulse runs a thread
  (``thread dh_pulse_N(): set on, sleep(t), set off end``, defined once per output and time before the moves) with
  ``run dh_pulse_N()``, without waiting for it. A wait is ``sleep(t)``: it follows a move with r = 0 (a wait is a
  stop of the program), and what follows a move with r = 0 runs once the robot has stopped there (UR's CB3 user
  manual, 3.4.5, 14.6 "Command: Fixed Waypoint": after a stop point, "it is executed when the robot arm has
  stopped at the waypoint"; with a blend it would run on entering the blend). A wait for an input is PolyScope's
  Wait node as issue 37 quotes it, ``while (not(get_standard_digital_in(n) == True)): sync() end`` (no PolyScope
  export with a Wait node was found to check it against); with a timeout the fixed pattern ``wait_input_lines``
  (sleep TIMEOUT_TICK a turn, count the time in ``dh_waited`` [s], past the timeout ``popup(text, title, False,
  True, False)``, an error popup in the positional form PolyScope's URCap code writes (warning, error, blocking:
  pharmbio/robotlab programs/dan_delid.script @ 536ca11f), and ``halt``: the program stops with an error). A
  comment is ``# text``. The header names the numbered signals (``settings_mark.signals_mark``) and the parts the
  program grips (``settings_mark.gripped_mark``: it sets only the total load). In the servoj
  replay the actions follow the sample where the replay arrives at their waypoint (``arrival``), each after the
  waits before it in the list (the certified profile rests at the waypoint for them: no ``sleep``).
* The header records the job (``job=NAME``, ``pipeline.files.atomic.job_mark``); the name is never a keyword
  nor a name the program defines (``names``).
* Arms: ``check_arm`` refuses what URScript cannot move (the one place an arm's maker is checked): an arm
  that is not 6-joint, or whose robot file has no controller section of maker ``ur`` (Universal Robots).
"""

from __future__ import annotations

import math
import re
import textwrap

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.spatial.transform import Rotation

from ...errors import OutputError
from ...files.atomic import WRITTEN_BY, job_mark
from ...model.vendors.controller import controller_of
from ...program.actions import COMMENT, GRIP, OUTPUT, PULSE, RELEASE, SET, WAIT, WAIT_INPUT, Action, Signal
from ...program.model import CIRCULAR, JOINT, LINEAR, Move, Program
from ...program.payload import Payload
from ...timing.profile import Profile
from .lint import LIMITS, URSCRIPT, lint
from .names import RESERVED_WORDS
from .settings_mark import gripped_mark, settings_mark, signals_mark

IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
#: The Script Manual's defaults: movej a [rad/s^2], v [rad/s]; movel a [m/s^2].
MOVEJ_DEFAULT_A, MOVEJ_DEFAULT_V, MOVEL_DEFAULT_A = 1.4, 1.05, 1.2
#: servoj: the manual's default lookahead_time [s] and gain, and the ranges it allows.
LOOKAHEAD_S, GAIN = 0.1, 300.0
LOOKAHEAD_RANGE, GAIN_RANGE = (0.03, 0.2), (100.0, 2000.0)
#: servoj's t [s]: from the e-Series controller period (0.002 s; CB3: 0.008 s) to four CB3 periods; a longer t
#: leaves the certified profile to the controller's own interpolation between far targets.
PERIOD_RANGE = (0.002, 0.032)
#: Most servoj lines of a replay (2 minutes at 0.002 s, some 7 MB of script: read-program reads it back).
MAX_REPLAY_LINES = 60_000
#: Decimals written for lengths [m], angles [rad], speeds and accelerations.
DECIMALS = 6
#: Decimals written for a payload's mass [kg], centre of mass [m] and inertia [kg m^2] (1e-9 kg m^2: the parts read
#: back as differences of two totals keep 1e-6 kg m^2).
PAYLOAD_DECIMALS = 9
#: The header's statement of the payload.
PAYLOAD_NOTE = ("Payload: set_target_payload(m, cog, inertia) [kg, m, kg m^2] of all the flange carries (the tool's "
                "load and the parts held), before the first move and at each grip and release; set_target_payload "
                "needs PolyScope 5.10 or later (UR Script Manual): on an older controller replace each by "
                "set_payload(m, cog).")
#: A profile must start at the program's first target within this [rad or m].
START_TOLERANCE = 1e-6
COMMENT_WIDTH = 96


def write_urscript(program: Program, name: str, profile: Profile | None = None, period: float = 0.002,
                   lookahead_time: float = LOOKAHEAD_S, gain: float = GAIN, written=None) -> str:
    """The URScript program text of ``program`` (module docstring), its ``def`` named ``name``; with
    ``profile`` (the program's certified Profile) also its servoj replay every ``period`` [s] with
    ``lookahead_time`` [s] and ``gain``. OutputError names what cannot be written; ``lint`` runs first on
    the name and the header comments (ControllerLintError; URScript writes no configuration data). ``written``
    (``controller_motion.certified_moves``): the native moves are the certified motion (a planned move as joint
    targets on the certified path, blend radii r = the written zones exactly, r = 0 only where it stops) and the
    header carries its certificate."""
    check_name(name)
    _check_replay_options(period, lookahead_time, gain)
    check_arm(program.robot)
    header = _header(program, name, profile, period, lookahead_time, gain)
    if written is not None:
        header += [part for line in [WRITTEN_BLEND_RULE, *written.header_lines()]
                   for part in textwrap.wrap(line, COMMENT_WIDTH, subsequent_indent="  ", break_on_hyphens=False)]
    lint(program, URSCRIPT, name, header)
    pulses = pulse_threads(program)
    moves = _native_moves(program, written, pulses)
    lines = [f"def {name}():"]
    lines += [f"  # {line}" for line in header]
    lines.append(f"  set_tcp({pose(program.tool.X_FT)})")
    lines.append(f"  {payload_line(program)}")
    lines += [f"  {line}" for line in thread_lines(pulses)]
    if profile is None:
        lines += [f"  {move}" for move in moves]
    else:
        replay = _replay(program, profile, period, lookahead_time, gain, pulses)
        lines += ["  use_certified_replay = True", "  def native_moves():"] + [f"    {m}" for m in moves]
        lines += ["  end", "  def certified_replay():"] + [f"    {m}" for m in replay]
        lines += ["  end", "  if use_certified_replay:", "    certified_replay()", "  else:", "    native_moves()",
                  "  end"]
    return "\n".join(lines + ["end", f"{name}()", ""])


def check_arm(robot) -> None:
    """OutputError unless URScript can move ``robot`` (a Robot): a 6-joint arm whose robot file's controller
    section names the maker ``ur`` (a Universal Robots controller runs URScript, no other does)."""
    if robot.dof != 6:
        raise OutputError(f"{robot.name}: URScript moves a 6-joint arm, this one has {robot.dof}")
    maker = getattr(controller_of(robot), "maker", None)
    if maker != "ur":
        has = "no controller section" if maker is None else f"a controller section of maker {maker}"
        own = [language for language, limits in LIMITS.items() if limits.vendor and maker in (None, limits.vendor)]
        raise OutputError(f"{robot.name}: URScript runs only on a Universal Robots controller, and the robot file "
                          f"{robot.spec.source} has {has}: for a UR arm add 'controller: {{maker: ur}}' to the robot "
                          "file (models/README.md, \"The controller section\"); else write the program in its "
                          f"maker's language (--lang {'/'.join(own)})")


def payload_line(program: Program) -> str:
    """The tool's load before the first move (``payload_call``); a comment without one (module docstring)."""
    if program.payload is not None:
        return payload_call(program.payload)
    if program.parts:
        return ("# the job gives no tool's load (unknown): the installation's payload is used until the first grip; "
                "the payloads at the grips and releases are the parts' alone")
    return ("# PLACEHOLDER: the job gives no payload: the installation's payload is used; "
            "set_target_payload(m, cog, inertia)")


def payload_call(load: Payload | None) -> str:
    """``set_target_payload(m, [cx, cy, cz], [Ixx, Iyy, Izz, Ixy, Ixz, Iyz])`` [kg, m, kg m^2] of ``load`` (None:
    nothing, mass 0)."""
    if load is None:
        load = Payload(0.0, np.zeros(3))
    values = [number(v, PAYLOAD_DECIMALS) for v in (load.mass, *load.com, *load.inertia_six)]
    return f"set_target_payload({values[0]}, [{', '.join(values[1:4])}], [{', '.join(values[4:])}])"


def payload_notes(program: Program) -> list[str]:
    """The header's lines on the payload (none when nothing is written)."""
    return [PAYLOAD_NOTE] if program.payload is not None or program.parts else []


def check_name(name: str) -> str:
    """``name`` if it can name the program's ``def``, else OutputError naming the rule."""
    if not isinstance(name, str) or not IDENTIFIER.match(name) or name in RESERVED_WORDS[URSCRIPT]:
        raise OutputError(f"URScript program name {name!r}: a name is letters, digits and underscores starting "
                          "with a letter, and not a keyword or a name the program defines")
    return name


def check_servo_period(period) -> float:
    """The servoj period [s], or OutputError: a number in PERIOD_RANGE."""
    if not (isinstance(period, (int, float)) and not isinstance(period, bool) and math.isfinite(period)
            and PERIOD_RANGE[0] <= period <= PERIOD_RANGE[1]):
        raise OutputError(f"servoj period must be a time in [{PERIOD_RANGE[0]:g}, {PERIOD_RANGE[1]:g}] s (the "
                          f"controller period: 0.002 e-Series, 0.008 CB3), got {period!r}")
    return float(period)


def _check_replay_options(period: float, lookahead_time: float, gain: float) -> None:
    check_servo_period(period)
    if not LOOKAHEAD_RANGE[0] <= lookahead_time <= LOOKAHEAD_RANGE[1]:
        raise OutputError(f"servoj lookahead_time must be in {list(LOOKAHEAD_RANGE)} s, got {lookahead_time!r}")
    if not GAIN_RANGE[0] <= gain <= GAIN_RANGE[1]:
        raise OutputError(f"servoj gain must be in {list(GAIN_RANGE)}, got {gain!r}")


def number(value: float, decimals: int = DECIMALS) -> str:
    """``value`` with at most ``decimals`` decimals, without trailing zeros or a negative zero (always a float)."""
    text = f"{value:.{decimals}f}".rstrip("0")
    text = text + "0" if text.endswith(".") else text
    return "0.0" if text == "-0.0" else text


def joints(q) -> str:
    """``[q1, ..., q6]`` [rad]."""
    return "[" + ", ".join(number(float(v)) for v in q) + "]"


def pose(X: np.ndarray) -> str:
    """``p[x, y, z, rx, ry, rz]`` of a pose (4, 4) [m]: position [m], rotation vector [rad]."""
    rotation = Rotation.from_matrix(X[:3, :3]).as_rotvec()
    return "p[" + ", ".join(number(float(v)) for v in (*X[:3, 3], *rotation)) + "]"


def joint_speed(program: Program, fraction: float) -> tuple[float, float]:
    """(a [rad/s^2], v [rad/s]) of a joint move at ``fraction`` of the joint speed limits (module docstring)."""
    limits, scale = program.limits, program.speed_scale
    accel = MOVEJ_DEFAULT_A if limits.qdd_max is None else float(np.min(limits.qdd_max)) * scale**2
    return accel, fraction * scale * float(np.min(limits.qd_max))


def tool_speed(program: Program, move: Move) -> tuple[float, float]:
    """(a [m/s^2], v [m/s]) of a tool move (module docstring)."""
    scale = program.speed_scale
    accel = MOVEL_DEFAULT_A if program.tcp_accel_max is None else program.tcp_accel_max * scale**2
    return accel, program.tool_speed(move)


def blend(program: Program, move: Move) -> float:
    """The blend radius r [m] at the end of ``move``: its zone; 0 at a stop and at both ends of a planned joint
    move (a controller's blend there is not a path the planner or the clearance certificate checked)."""
    return 0.0 if program.exact_stop_at(move) else move.zone


#: The header's statement of the blend radii with the certified motion.
WRITTEN_BLEND_RULE = ("Certified motion (native_moves): planned moves as joint targets on the certified path; blend "
                      "radii r are the written zones exactly [m] (no closest value needed); r = 0 only where the "
                      "certified motion stops.")


def _native_moves(program: Program, written=None, pulses: dict | None = None) -> list[str]:
    a, v = MOVEJ_DEFAULT_A, MOVEJ_DEFAULT_V
    lines = [f"movej({joints(program.targets[0])}, a={number(a)}, v={number(v)}, r=0.0)"]
    lines += action_lines(program, 0, pulses or {})
    for move in program.moves:
        if written is None:
            r = number(blend(program, move))
            vertices = [(q, 0.0) for q in ([] if move.planned is None else move.planned.waypoints[1:-1])]
        else:
            ws = written.of(move.end)
            r = number(ws[-1].zone_m)
            vertices = [(w.target, w.zone_m) for w in ws[:-1]]
        if move.kind == JOINT:
            a, v = joint_speed(program, move.speed)
            speeds = f"a={number(a)}, v={number(v)}"
            lines += [f"movej({joints(q)}, {speeds}, r={number(zone)})" for q, zone in vertices]
            lines.append(f"movej({joints(move.target)}, {speeds}, r={r})")
        elif move.kind == LINEAR:
            a, v = tool_speed(program, move)
            lines.append(f"movel({pose(move.X_BT)}, a={number(a)}, v={number(v)}, r={r})")
        elif move.kind == CIRCULAR:
            a, v = tool_speed(program, move)
            X_via = move.X_BT.copy()
            X_via[:3, 3] = move.via
            lines.append(f"movec({pose(X_via)}, {pose(move.X_BT)}, a={number(a)}, v={number(v)}, r={r}, mode=0)")
        else:
            raise OutputError(f"move to waypoint {move.end}: URScript has no move of kind {move.kind!r}")
        lines += action_lines(program, move.end, pulses or {})
    return lines


#: A job's signal number -> the controller's digital I/O: (first number, count, URScript function's word, the
#: reader's name prefix). Standard outputs/inputs 0-7, configurable 8-15 (function index n - 8), tool 16-17 (n - 16):
#: the pin numbering of UR's ROS interface (ur_msgs SetIO.srv: PIN_CONF_OUT0 = 8, PIN_TOOL_DOUT0 = 16).
IO_BANKS = ((0, 8, "standard", ""), (8, 8, "configurable", "conf_"), (16, 2, "tool", "tool_"))
#: A wait for an input with a timeout polls every TIMEOUT_TICK [s] (sleep) and counts the time waited.
TIMEOUT_TICK = 0.01
#: The variable counting a timed wait [s], the prefix of the pulse threads.
WAITED, PULSE_THREAD = "dh_waited", "dh_pulse_"
#: The header's statement of how the actions are written.
ACTIONS_NOTE = ("Actions after the last move into their waypoint: set_*_digital_out(n, b); a pulse runs thread "
                "dh_pulse_N (set on, sleep, set off) without waiting; sleep(t) after a move with r=0 (the "
                "robot stopped there); a wait for an input polls it (while ... sync()); with a timeout it "
                f"sleeps {TIMEOUT_TICK:g} s a turn, counts {WAITED} [s] and stops the program (popup, halt) "
                "past it; the servoj replay runs them at the sample nearest the waypoint (its rests are the "
                "waits).")


def io_function(signal, kind: str) -> str:
    """``set_<bank>_digital_out`` (kind "out") or ``get_<bank>_digital_in`` (kind "in") and the index of a numbered
    ``signal`` (module IO_BANKS); OutputError for a signal without a number or one past the tool bank."""
    if signal.number is None:
        raise OutputError(f"signal {signal.name}: URScript numbers its digital I/O: give the signal its number "
                          f"({signal.direction}: N in the job's signals)")
    for first, count, bank, _ in IO_BANKS:
        if first <= signal.number < first + count:
            name = f"set_{bank}_digital_out" if kind == "out" else f"get_{bank}_digital_in"
            return f"{name}({signal.number - first}"
    raise OutputError(f"signal {signal.name}: {signal.direction} {signal.number} is not a UR digital "
                      f"{signal.direction}: 0-7 standard, 8-15 configurable (8 + n), 16-17 tool (16 + n)")


def boolean(value: bool) -> str:
    return "True" if value else "False"


def pulse_threads(program: Program) -> dict[tuple[int, float], str]:
    """(output number, pulse time [s]) -> the name of the thread that pulses it, one per pair, in program order."""
    pulses: dict[tuple[int, float], str] = {}
    for actions in program.actions:
        for action in actions:
            if action.kind == PULSE:
                signal = program.signals[action.signal]
                io_function(signal, "out")
                pulses.setdefault((signal.number, action.time_s), f"{PULSE_THREAD}{len(pulses) + 1}")
    return pulses


def thread_lines(pulses: dict[tuple[int, float], str]) -> list[str]:
    """The pulse threads' definitions: set the output on, sleep the pulse time, set it off."""
    lines = []
    for (output, time_s), name in pulses.items():
        call = io_function(Signal(f"do{output}", OUTPUT, output), "out")
        lines += [f"thread {name}():", f"  {call}, True)", f"  sleep({number(time_s)})", f"  {call}, False)", "end"]
    return lines


def action_lines(program: Program, k: int, pulses: dict) -> list[str]:
    """The lines of waypoint ``k``'s actions (module docstring)."""
    return [line for i in range(len(program.actions_at(k))) for line in _action(program, k, i, pulses)]


def _action(program: Program, k: int, i: int, pulses: dict) -> list[str]:
    """The lines of action ``i`` of waypoint ``k``."""
    action = program.actions_at(k)[i]
    if action.kind in (GRIP, RELEASE):
        return [payload_call(program.load_after(k, i))]
    if action.kind == COMMENT:
        return [f"# {action.text}"]
    if action.kind == WAIT:
        return [f"sleep({number(action.time_s)})"]
    signal = program.signals[action.signal]
    if action.kind == SET:
        return [f"{io_function(signal, 'out')}, {boolean(action.value)})"]
    if action.kind == PULSE:
        return [f"run {pulses[(signal.number, action.time_s)]}()"]
    if action.kind == WAIT_INPUT:
        return wait_input_lines(signal, action)
    raise OutputError(f"URScript writes no action of kind {action.kind!r}")


def wait_input_lines(signal, action: Action) -> list[str]:
    """PolyScope's Wait node for an input (``while (not(get_..._digital_in(n) == True)): sync() end``), with a
    timeout the fixed pattern that counts the time waited and stops the program past it."""
    test = f"while (not({io_function(signal, 'in')}) == {boolean(action.value)})):"
    if action.timeout_s is None:
        return [test, "  sync()", "end"]
    message = (f"dh-pipeline: input {signal.name} ({signal.direction} {signal.number}) not "
               f"{'on' if action.value else 'off'} after {action.timeout_s:g} s")
    return [f"{WAITED} = 0.0", test, f"  if ({WAITED} >= {number(action.timeout_s)}):",
            f"    popup(\"{message}\", \"Timeout\", False, True, False)", "    halt", "  end",
            f"  sleep({number(TIMEOUT_TICK)})", f"  {WAITED} = {WAITED} + {number(TIMEOUT_TICK)}", "end"]


def replay_actions(program: Program, samples: np.ndarray, period: float, pulses: dict) -> dict[int, list[str]]:
    """servoj line index -> the action lines after it (-1: before the first): waypoint k's actions after the
    sample where the replay arrives at its target (``arrival``), each after the waits before it in the list
    [s] (the profile rests there for them); waypoint 0's before the first servoj."""
    at: dict[int, list[str]] = {}
    start = 0
    for k in range(len(program.targets)):
        actions = program.actions_at(k)
        index = -1 if k == 0 else arrival(samples, program.targets[k], start)
        start = max(start, index)
        waited = 0.0
        for i, action in enumerate(actions):
            if action.kind == WAIT:
                waited += action.time_s
                continue
            line = min(len(samples) - 1, index + round(waited / period)) if index >= 0 else -1
            at.setdefault(line, []).extend(_action(program, k, i, pulses))
    return at


def arrival(samples: np.ndarray, target: np.ndarray, start: int) -> int:
    """The first sample from ``start`` on at the least joint distance to ``target`` before the distance grows
    again (the replay's arrival there; a rest at the target is one flat minimum: its first sample)."""
    distance = np.abs(samples[start:] - target).max(axis=1)
    i = 0
    while i + 1 < len(distance) and distance[i + 1] <= distance[i]:
        i += 1
    return start + int(np.argmax(distance[:i + 1] <= distance[i] + 1e-9))


def resample(profile: Profile, period: float) -> np.ndarray:
    """The profile's joint values (n, dof) at t = period, 2 period, ... and its end [s] (the last one the
    profile's end): cubic Hermite interpolation on its samples' q and qd."""
    t = profile.t - profile.t[0]
    count = max(1, math.ceil(t[-1] / period - 1e-9))
    if count > MAX_REPLAY_LINES:
        fits = math.ceil(t[-1] / MAX_REPLAY_LINES * 1e3) / 1e3
        hint = (f"--servo-period {fits:g} would fit" if fits <= PERIOD_RANGE[1] else
                f"no servoj period up to {PERIOD_RANGE[1]:g} s fits it (that would need {fits:g} s)")
        raise OutputError(f"the servoj replay of this {t[-1]:.1f} s profile every {period:g} s would be {count:,} "
                          f"lines, more than {MAX_REPLAY_LINES:,} ({MAX_REPLAY_LINES * period:g} s at this period): "
                          f"{hint}; or split the job, or write it without the replay")
    times = np.minimum(np.arange(1, count + 1) * period, t[-1])
    return CubicHermiteSpline(t, profile.q, profile.qd)(times)


def _replay(program: Program, profile: Profile, period: float, lookahead_time: float, gain: float,
            pulses: dict) -> list[str]:
    if profile.q.shape[1] != 6 or np.abs(profile.q[0] - program.targets[0]).max() > START_TOLERANCE:
        raise OutputError(f"the profile does not start at the program's first target "
                          f"{joints(program.targets[0])} rad: not this program's profile")
    options = f"t={number(period)}, lookahead_time={number(lookahead_time)}, gain={number(gain)}"
    lines = [f"movej({joints(profile.q[0])}, a={number(MOVEJ_DEFAULT_A)}, v={number(MOVEJ_DEFAULT_V)}, r=0.0)"]
    samples = resample(profile, period)
    at = replay_actions(program, samples, period, pulses)
    lines += at.get(-1, [])
    for i, q in enumerate(samples):
        lines.append(f"servoj({joints(q)}, {options})")
        lines += at.get(i, [])
    stop = MOVEJ_DEFAULT_A if program.limits.qdd_max is None else float(np.min(program.limits.qdd_max))
    return lines + [f"stopj({number(stop)})"]


def _header(program: Program, name: str, profile: Profile | None, period: float, lookahead_time: float,
            gain: float) -> list[str]:
    accel = "none" if program.tcp_accel_max is None else f"{program.tcp_accel_max:g} m/s^2"
    lines = [
        (f"{name}: the compiled program {program.name!r} (robot {program.robot.name}, {len(program.moves)} moves), "
         f"written by {WRITTEN_BY} (pipeline.outputs.controllers.urscript)."),
        job_mark(program.job_name or program.name),
        settings_mark(program),
        *([signals_mark(program)] if signals_mark(program) else []),
        *([gripped_mark(program)] if gripped_mark(program) else []),
        "Units: m, rad, s; poses p[x, y, z, rx, ry, rz] (rotation vector) of the TCP in the base frame.",
        ("Native moves: the controller plans its own velocity profiles (trapezoidal in a and v, no jerk limit), "
         "not the certified profile:"),
        ("- movej goes to the program's joint values, straight in joint space (not the job's path shape "
         f"{program.path or 'default'}); v is the move's fraction of the smallest joint speed limit"),
        ("- movel/movec keep the TCP's line or arc at speed v; the controller picks the joint solution itself "
         f"(URScript has no configuration data); a is the job's TCP acceleration limit ({accel}) or the "
         "manual's default"),
        ("- blend radii r are the program's zones, blended the controller's way; r = 0 stops, also where the "
         "certified profile passes through a waypoint without a zone, and at both ends of a planned move"),
        "The first movej goes to the start with the manual's default a and v: an approach.",
        *([ACTIONS_NOTE] if any(program.actions) else []),
        *payload_notes(program),
    ]
    if profile is not None:
        lines += [
            (f"certified_replay: the certified profile itself ({profile.duration:.3f} s, {profile.method}), "
             f"sampled every {period:g} s for servoj (cubic Hermite on its samples every {program.dt:g} s), "
             f"lookahead_time {lookahead_time:g} s (smooths and delays the target by up to that), gain {gain:g}; "
             "the controller's speed scaling (speed slider, safety limits) stretches it in time."),
            "use_certified_replay chooses certified_replay() (True) or native_moves() (False).",
        ]
    return [part for line in lines
            for part in textwrap.wrap(line, COMMENT_WIDTH, subsequent_indent="  ", break_on_hyphens=False)]
