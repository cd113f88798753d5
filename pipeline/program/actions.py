"""Process actions of a program: what the controller does at a waypoint besides moving.

A waypoint's actions run in order once the robot reaches it (waypoint 0's before the first move):

* ``set``: a digital output switched on or off (``{set: gripper_close, value: on}``);
* ``pulse``: a digital output on for ``time`` [s], the program going on meanwhile (``{pulse: blow_off, time: 0.2}``);
* ``wait``: the motion stands still for ``time`` [s] (``{wait: 0.5}``);
* ``wait_input``: the program waits until a digital input has a value (``{wait_input: part_present, value: on,
  timeout: 2.0}``); how long is not known before the robot runs: it is timed as 0 s, at most ``timeout`` [s] (after
  which the controller stops the program with an error; None: it waits for ever);
* ``comment``: a line of text in the program (``{comment: close the gripper}``);
* ``grip``: from here on the robot carries the part (``{grip: box}``, a part of the job's ``parts`` table:
  ``pipeline.program.payload``); ``release``: it no longer does (``{release: box}``). The controller's load data
  changes there (RAPID ``GripLoad``, KRL ``$LOAD``, FANUC ``PAYLOAD[n]``, URScript ``set_target_payload``).

A wait of either kind, a grip and a release stop the motion at their waypoint (the profile rests there for the
wait's time; the load changes at rest). Signals are
named in the job (``signals: {gripper_close: {output: 1}, part_present: {input: 3}}``): each name maps to a digital
output or input and its number on the controller (None where the program names it without a number: a RAPID
module's signals are names configured on the controller, and a numbered language cannot write them).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

SET, PULSE, WAIT, WAIT_INPUT, COMMENT = "set", "pulse", "wait", "wait_input", "comment"
GRIP, RELEASE = "grip", "release"
ACTION_KINDS = (SET, PULSE, WAIT, WAIT_INPUT, COMMENT, GRIP, RELEASE)
OUTPUT, INPUT = "output", "input"
#: A signal's name: a letter, then letters, digits or underscores (a RAPID, KRL and URScript identifier).
SIGNAL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}\Z")
#: Largest signal number a job may give (the controllers' I/O ranges are far below).
MAX_SIGNAL_NUMBER = 9999
#: Longest wait, pulse or timeout a job may give [s] (a guard against milliseconds written as seconds).
MAX_ACTION_TIME_S = 3600.0
#: Longest comment [characters] (the pendants show about this much on a line).
MAX_COMMENT_CHARS = 120


@dataclass(frozen=True)
class Signal:
    """A named digital I/O signal: ``direction`` output or input, ``number`` on the controller (None: not known)."""

    name: str
    direction: str
    number: int | None = None

    def to_document(self) -> dict:
        return {self.direction: self.number}


@dataclass(frozen=True)
class Action:
    """One action (module docstring): ``kind``; ``signal`` (set, pulse, wait_input: the signal's name); ``value``
    (set, wait_input: on is True); ``time_s`` (pulse: its length, wait: its time) [s]; ``timeout_s`` (wait_input,
    None: none) [s]; ``text`` (comment); ``part`` (grip, release: the part's name in the job's ``parts``)."""

    kind: str
    signal: str | None = None
    value: bool | None = None
    time_s: float | None = None
    timeout_s: float | None = None
    text: str | None = None
    part: str | None = None

    @property
    def stops_motion(self) -> bool:
        """Whether the motion stops at its waypoint for it (a wait, or a change of the load)."""
        return self.kind in (WAIT, WAIT_INPUT, GRIP, RELEASE)

    @property
    def rest_s(self) -> float:
        """How long the motion stands still for it as timed [s] (a wait for an input: 0, not known before the robot
        runs)."""
        return self.time_s if self.kind == WAIT else 0.0

    def to_document(self) -> dict:
        """The action as a job file writes it."""
        if self.kind == SET:
            return {SET: self.signal, "value": _on_off(self.value)}
        if self.kind == PULSE:
            return {PULSE: self.signal, "time": self.time_s}
        if self.kind == WAIT:
            return {WAIT: self.time_s}
        if self.kind == WAIT_INPUT:
            timeout = {} if self.timeout_s is None else {"timeout": self.timeout_s}
            return {WAIT_INPUT: self.signal, "value": _on_off(self.value), **timeout}
        if self.kind in (GRIP, RELEASE):
            return {self.kind: self.part}
        return {COMMENT: self.text}

    def __str__(self) -> str:
        if self.kind == SET:
            return f"set {self.signal} {_on_off(self.value)}"
        if self.kind == PULSE:
            return f"pulse {self.signal} {self.time_s:g} s"
        if self.kind == WAIT:
            return f"wait {self.time_s:g} s"
        if self.kind == WAIT_INPUT:
            timeout = "" if self.timeout_s is None else f" (timeout {self.timeout_s:g} s)"
            return f"wait for {self.signal} {_on_off(self.value)}{timeout}"
        if self.kind in (GRIP, RELEASE):
            return f"{self.kind} {self.part}"
        return f"comment {self.text!r}"


def rest_s(actions: tuple[Action, ...]) -> float:
    """How long the motion stands still for a waypoint's ``actions`` as timed [s]."""
    return float(sum(a.rest_s for a in actions))


def stops_motion(actions: tuple[Action, ...]) -> bool:
    """Whether a waypoint's ``actions`` stop the motion there."""
    return any(a.stops_motion for a in actions)


def held_after(actions_per_waypoint, k: int, i: int | None = None) -> tuple[str, ...]:
    """The parts held once waypoint ``k``'s actions have run (``i``: its actions up to and including action i), in
    the order gripped, from no part at waypoint 0's start."""
    held: list[str] = []
    done = [*actions_per_waypoint[:k], tuple(actions_per_waypoint[k])[: None if i is None else i + 1]] \
        if k < len(actions_per_waypoint) else actions_per_waypoint
    for actions in done:
        for action in actions:
            if action.kind == GRIP:
                held.append(action.part)
            elif action.kind == RELEASE and action.part in held:
                held.remove(action.part)
    return tuple(held)


def actions_document(actions: tuple[Action, ...]) -> list[dict]:
    """A waypoint's actions as a job file's ``do:`` list."""
    return [a.to_document() for a in actions]


def signals_document(signals: dict[str, Signal]) -> dict:
    """A program's signals as a job file's ``signals:`` mapping."""
    return {name: signal.to_document() for name, signal in signals.items()}


def _on_off(value: bool) -> str:
    return "on" if value else "off"
