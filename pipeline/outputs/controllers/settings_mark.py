"""The job's timing settings in a written program's header, and read back from it.

A controller program has no words for how dh-pipeline timed the motion it certified: the timing method (toppra,
topp3 jerk-limited, ruckig), the joint path's shape through joint targets, the speed scale (the job's ``speed_scale``
s scales joint speeds, accelerations and jerks by s, s^2, s^3; the writers write every speed already multiplied by
s), and, for FANUC and Yaskawa, the TCP acceleration limit and the safety TCP speed limit. Every writer states them
in one header comment (``settings_mark``), e.g. ``dh.timing=topp3 dh.path=monotone dh.speed_scale=0.7
dh.tcp_accel_max=2.5`` (SI units: m/s^2, m/s), and ``read-program`` takes them back (``with_written_settings``)
so that the job read back is timed as the one written: the program's speeds divided by the scale (a joint move's
percentage capped at 100), its TCP acceleration (RAPID ``PathAccLim``, KRL ``$ACC.CP``) by the scale squared. A
controller ignores the comment; a program without it (a pendant's) reads as before: toppra at scale 1.

Each key is one word, so the mark survives the writers' wrapping of comments into short lines.

The job's signal names ride in the same way where the language numbers its I/O (``signals_mark``:
``dh.signal.gripper_close=out1 dh.signal.part_present=in3``): a reader names a numbered signal ``do<N>`` / ``di<N>``
(or as the program itself names it), and ``with_signal_names`` gives it back the job's name.
"""

from __future__ import annotations

import math
import re

from ...errors import ConfigurationError
from ...program.actions import INPUT, OUTPUT, PULSE, SET, WAIT_INPUT
from ...program.model import Program

#: The action keys whose value is a signal's name.
SIGNAL_KINDS = (SET, PULSE, WAIT_INPUT)

#: Prefix of every key of the mark.
PREFIX = "dh."
#: The keys, in the order written.
KEYS = ("timing", "path", "speed_scale", "tcp_accel_max", "tcp_speed_limit")
_VALUE = re.compile(r"\bdh\.(timing|path|speed_scale|tcp_accel_max|tcp_speed_limit)=([A-Za-z0-9_.+-]+)")
_NAMES = {"timing": ("toppra", "topp3", "ruckig"), "path": ("linear", "monotone", "spline")}


def settings_mark(program: Program) -> str:
    """The header comment naming ``program``'s timing settings (module docstring)."""
    values = {"timing": program.timing, "path": program.path, "speed_scale": program.speed_scale,
              "tcp_accel_max": program.tcp_accel_max,
              "tcp_speed_limit": program.limits.tcp_speed_max}          # the job's safety limit (compile)
    return " ".join(f"{PREFIX}{key}={_text(values[key])}" for key in KEYS if values[key] is not None)


def signals_mark(program: Program) -> str:
    """The header comment naming ``program``'s numbered signals (module docstring; empty without any)."""
    return " ".join(f"{PREFIX}signal.{s.name}={'out' if s.direction == OUTPUT else 'in'}{s.number}"
                    for s in program.signals.values() if s.number is not None)


def check_signal_numbers(program: Program, language: str, addressing: str) -> None:
    """ConfigurationError naming the first signal ``program``'s actions use without a number, for a ``language`` that
    addresses its I/O by number (``addressing``, e.g. ``DO[n], DI[n]``)."""
    for k in range(len(program.waypoints)):
        for action in program.actions_at(k):
            signal = program.signals.get(action.signal) if action.signal is not None else None
            if action.signal is not None and (signal is None or signal.number is None):
                direction = OUTPUT if signal is None else signal.direction
                raise ConfigurationError(f"waypoint {k}: {action}: signal {action.signal!r} has no number; {language} "
                                         f"addresses I/O by number ({addressing}): give it one in the job's signals: "
                                         f"{{{action.signal}: {{{direction}: N}}}}")


#: One signal of the mark: (name, out or in, number).
SIGNAL_MARK = re.compile(r"\bdh\.signal\.([A-Za-z][A-Za-z0-9_]{0,31})=(out|in)([0-9]{1,4})\b")


def with_signal_names(document: dict, text: str) -> dict:
    """``document`` (a reader's job document) with its numbered signals renamed as ``text``'s mark names them
    (``signals_mark``), in its ``signals`` table and its waypoints' actions. A new dict; ``document`` as it is when
    the text has no mark."""
    table = document.get("signals") or {}
    by_number = {(direction, number): name for name, entry in table.items() for direction, number in entry.items()}
    renamed = {}
    for name, direction, number in SIGNAL_MARK.findall(text):
        old = by_number.get((OUTPUT if direction == "out" else INPUT, int(number)))
        if old is not None and name not in renamed.values() and (name == old or name not in table):
            renamed[old] = name
    if not renamed:
        return document
    signals = {renamed.get(name, name): entry for name, entry in table.items()}
    waypoints = [_renamed_actions(w, renamed) for w in document["waypoints"]]
    return {**document, "signals": signals, "waypoints": waypoints}


def _renamed_actions(waypoint, renamed: dict):
    if not isinstance(waypoint, dict) or "do" not in waypoint:
        return waypoint
    actions = [{key: renamed.get(value, value) if key in SIGNAL_KINDS else value for key, value in action.items()}
               for action in waypoint["do"]]
    return {**waypoint, "do": actions}


def _text(value) -> str:
    return value if isinstance(value, str) else f"{float(value):.9g}"


def marked_settings(text: str) -> dict:
    """The settings a program's text names (``settings_mark``; the first of each key), checked: a method or path
    dh-pipeline does not know, or a number that is not finite and positive (a speed scale above 1), is left out."""
    found = {}
    for key, value in _VALUE.findall(text):
        if key in found:
            continue
        if key in _NAMES:
            if value in _NAMES[key]:
                found[key] = value
            continue
        try:
            number = float(value)
        except ValueError:
            continue
        if math.isfinite(number) and number > 0.0 and (key != "speed_scale" or number <= 1.0):
            found[key] = number
    return found


def with_written_settings(document: dict, text: str) -> dict:
    """``document`` (a reader's job document: SI lengths, joint speeds in %) with the settings ``text`` marks:
    ``timing``, ``path``, ``speed_scale`` (the waypoints' speeds divided by it, a joint move's at most 100 % and none
    for ruckig, the TCP acceleration read from the program by its square), ``tcp_accel_max`` and ``tcp_speed_limit``
    where the program gave none. A new dict; ``document`` as it is when the text has no mark."""
    settings = marked_settings(text)
    if not settings:
        return document
    out = dict(document)
    for key in ("timing", "path"):
        if key in settings:
            out[key] = settings[key]
    scale = settings.get("speed_scale", 1.0)
    if scale != 1.0 or out.get("timing") == "ruckig":
        out["speed_scale"] = scale
        out["waypoints"] = [_unscaled(w, scale, out.get("timing") == "ruckig") for w in document["waypoints"]]
    if scale != 1.0:
        if "tcp_accel_max" in out:
            out["tcp_accel_max"] = out["tcp_accel_max"] / scale**2
    for key in ("tcp_accel_max", "tcp_speed_limit"):
        if key in settings and key not in out:
            out[key] = settings[key]
    return out


def _unscaled(waypoint, scale: float, ruckig: bool):
    """A waypoint's speed divided by ``scale`` (a joint move's at most 100 %); a joint move's dropped for ruckig,
    which times joint waypoints at the scaled limits and takes no speed per move (the speeds written were the
    scale's)."""
    if not isinstance(waypoint, dict) or "speed" not in waypoint:
        return waypoint
    if waypoint.get("move", "joint") != "joint":
        return {**waypoint, "speed": waypoint["speed"] / scale}
    if ruckig:
        return {key: value for key, value in waypoint.items() if key != "speed"}
    return {**waypoint, "speed": min(100.0, waypoint["speed"] / scale)}
