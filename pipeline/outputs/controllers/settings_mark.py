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

The loads ride in the same way where the language holds none (FANUC's payload schedules and Yaskawa's tool file are
settings on the controller): ``load_schedules`` numbers the distinct loads a program carries (1: the tool's load
alone, then each new set of parts held in the order the grip and release actions first carry it), and ``loads_mark``
states them, one word per number so that the 32-character comment lines of both languages keep every word whole:
``dh.payload.2=tool+1`` (load 2 is the tool's load and part 1), ``dh.part.1=box`` (part 1's name), ``dh.tool.m=1.2``,
``dh.tool.cz=0.045``, ``dh.part.1.ixx=0.0052`` (mass [kg], centre of mass cx, cy, cz [m] in the flange frame,
inertia ixx, iyy, izz, ixy, ixz, iyz [kg m^2] about it in the flange axes; a 0 is left out) with 9 significant digits,
so ``marked_loads`` reads back the job's numbers to 1e-9 of each. A load the job does not give (no payload) has no
words.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ...errors import ConfigurationError
from ...program.actions import GRIP, INPUT, OUTPUT, PULSE, RELEASE, SET, WAIT_INPUT, held_after
from ...program.model import Program
from ...program.payload import Payload, combined

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


#: The parts a program grips, by the number a reader of a total load gives them (``part1``, ``part2``: KRL, URScript).
GRIPPED_MARK = re.compile(r"\bdh\.gripped\.([0-9]{1,3})=([A-Za-z][A-Za-z0-9_]{0,31})\b")
#: How a reader of a total load names the n-th part gripped (``PART_NAME.format(n)``).
PART_NAME = "part{}"


def gripped_mark(program: Program) -> str:
    """``dh.gripped.1=box dh.gripped.2=lid``: the job's parts in the order the program first grips them, for a
    language that holds only the total load ("" without grips)."""
    names = list(dict.fromkeys(action.part for actions in program.actions for action in actions
                               if action.kind == GRIP))
    return " ".join(f"{PREFIX}gripped.{n}={name}" for n, name in enumerate(names, start=1))


def with_part_names(document: dict, text: str) -> dict:
    """``document`` (a reader's job document) with its parts ``part1``, ``part2``... renamed as ``text``'s gripped
    mark names them (``gripped_mark``), in its ``parts`` table and its grips and releases; as it is unless the mark
    names exactly as many parts, each once, as the document has, all named ``partN`` in order."""
    marked = {int(n): name for n, name in GRIPPED_MARK.findall(text)}
    parts = document.get("parts") or {}
    read = [PART_NAME.format(n) for n in range(1, len(parts) + 1)]
    if not marked or list(parts) != read or sorted(marked) != list(range(1, len(read) + 1)) or \
            len(set(marked.values())) != len(read):
        return document
    renamed = {PART_NAME.format(n): name for n, name in marked.items()}
    waypoints = [_renamed_actions(w, renamed, (GRIP, RELEASE)) for w in document["waypoints"]]
    return {**document, "parts": {renamed[name]: entry for name, entry in parts.items()}, "waypoints": waypoints}


def _renamed_actions(waypoint, renamed: dict, kinds: tuple[str, ...] = SIGNAL_KINDS):
    """A waypoint entry whose actions of ``kinds`` name what ``renamed`` maps by their new names."""
    if not isinstance(waypoint, dict) or "do" not in waypoint:
        return waypoint
    actions = [{key: renamed.get(value, value) if key in kinds else value for key, value in action.items()}
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


@dataclass(frozen=True)
class LoadSchedules:
    """The distinct loads a program carries (module docstring): ``held[n - 1]`` the parts load n carries with the
    tool's load (load 1: none), in the order first gripped; ``selected[(k, i)]`` the load waypoint k's action i (a
    grip or a release) leaves the robot carrying."""

    held: tuple[tuple[str, ...], ...]
    selected: dict

    def load(self, program: Program, n: int) -> Payload | None:
        """Load n as one (``payload.combined``; None: the job gives neither the tool's load nor a part of it)."""
        what = " + ".join(("tool", *self.held[n - 1]))
        return combined([program.payload, *(program.parts[name] for name in self.held[n - 1])], name=what)


def load_schedules(program: Program) -> LoadSchedules | None:
    """The loads ``program`` carries, numbered in order of first use (module docstring); None when the job gives
    no load (no payload, no part)."""
    if program.payload is None and not program.parts:
        return None
    numbers, selected = {frozenset(): 1}, {}
    order = [()]
    for k in range(len(program.waypoints)):
        for i, action in enumerate(program.actions_at(k)):
            if action.kind not in (GRIP, RELEASE):
                continue
            held = held_after(program.actions, k, i)
            key = frozenset(held)
            if key not in numbers:
                numbers[key] = len(order) + 1
                order.append(tuple(held))
            selected[(k, i)] = numbers[key]
    return LoadSchedules(tuple(order), selected)


#: A load's quantities in the mark, and where each is in a Payload (module docstring).
LOAD_KEYS = ("m", "cx", "cy", "cz", "ixx", "iyy", "izz", "ixy", "ixz", "iyz")


def _load_words(key: str, load: Payload) -> list[str]:
    values = [load.mass, *load.com, *load.inertia_six]
    return [f"{PREFIX}{key}.{name}={value:.9g}" for name, value in zip(LOAD_KEYS, values)
            if name == "m" or value != 0.0]


def loads_mark(program: Program, schedules: LoadSchedules, max_chars: int) -> str:
    """The header comment stating the loads and what each numbered load carries (module docstring).
    ConfigurationError when a word is longer than ``max_chars`` (a comment line), naming it."""
    index = {name: i + 1 for i, name in enumerate(program.parts)}
    words = [f"{PREFIX}payload.{n}=" + "+".join(("tool", *(str(index[name]) for name in held)))
             for n, held in enumerate(schedules.held, start=1)]
    if program.payload is not None:
        words += _load_words("tool", program.payload)
    for name, i in index.items():
        words += [f"{PREFIX}part.{i}={name}", *_load_words(f"part.{i}", program.parts[name])]
    for word in words:
        if len(word) > max_chars:
            raise ConfigurationError(f"the loads' mark {word!r} is longer than a comment line ({max_chars} "
                                     "characters): a shorter part name, or fewer parts held at once")
    return " ".join(words)


_SCHEDULE = re.compile(r"\bdh\.payload\.([0-9]{1,3})=tool((?:\+[0-9]{1,3})*)(?![A-Za-z0-9_+])")
_PART = re.compile(r"\bdh\.part\.([0-9]{1,3})=([A-Za-z][A-Za-z0-9_]{0,31})\b")
_LOAD_VALUE = re.compile(r"\bdh\.(tool|part\.[0-9]{1,3})\.(" + "|".join(LOAD_KEYS) + r")=([0-9eE.+-]+)")


@dataclass(frozen=True)
class MarkedLoads:
    """What a program's loads mark states (``marked_loads``): ``payload`` the tool's load and ``parts`` {name: load}
    as job file entries (mass [kg], com [m], inertia [kg m^2]), ``schedules`` {n: the parts load n carries}."""

    payload: dict | None
    parts: dict
    schedules: dict

    def document(self, source: str) -> dict:
        """The job document's ``payload`` and ``parts`` entries, their ``source`` naming ``source``."""
        said = {"source": f"{source}: the writer's loads mark (dh.tool, dh.part)"}
        out = {} if self.payload is None else {"payload": {**self.payload, **said}}
        if self.parts:
            out["parts"] = {name: {**entry, **said} for name, entry in self.parts.items()}
        return out


def marked_loads(text: str) -> MarkedLoads | None:
    """The loads ``text``'s mark states (``loads_mark``), or None without a ``dh.payload`` word. A part the mark
    names without its mass, a number that is not one and a load naming a part without a name are left out."""
    names = {int(i): name for i, name in _PART.findall(text)}
    values: dict = {}
    for key, quantity, value in _LOAD_VALUE.findall(text):
        try:
            number = float(value)
        except ValueError:
            continue
        if math.isfinite(number):
            values.setdefault(key, {}).setdefault(quantity, number)
    loads = {key: _entry(found) for key, found in values.items() if "m" in found}
    parts = {name: loads[f"part.{i}"] for i, name in names.items() if f"part.{i}" in loads}
    schedules = {}
    for n, indices in _SCHEDULE.findall(text):
        held = [names.get(int(i)) for i in indices.split("+")[1:]]
        if None not in held and all(name in parts for name in held):
            schedules.setdefault(int(n), frozenset(held))
    if not schedules:
        return None
    return MarkedLoads(loads.get("tool"), parts, schedules)


def _entry(found: dict) -> dict:
    """A job file's load entry from the mark's quantities (a missing one is 0)."""
    value = {key: found.get(key, 0.0) for key in LOAD_KEYS}
    entry = {"mass": value["m"], "com": [value["cx"], value["cy"], value["cz"]]}
    inertia = [value[key] for key in LOAD_KEYS[4:]]
    return {**entry, "inertia": inertia} if any(inertia) else entry
