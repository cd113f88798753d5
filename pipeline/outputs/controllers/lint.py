"""Checks a controller program must pass before it is written, which no open validator makes: every
writer calls ``lint(program, language, ...)`` once, before writing anything, and a broken rule is a
``ControllerLintError`` naming the move (its waypoint index), the field and the value.

The rules, each with one table row per language (``LIMITS``, every limit with its source):

* names and comments within the language's limits: the program (module, job) name's length and
  characters, not a reserved word (``names``), and every comment line the writer passes;
* points per file: at most the positions one program file may hold, where the language has such a limit;
* zones: a move's zone [m] no larger than half of either neighbouring move's length (the controller would
  silently shrink it: KUKA's approximation distance is at most half of the move, KSS expert programming,
  "Approximate positioning"), so the written corner is the one the certified profile rounds;
* speeds within the robot's limits in the vendor's units: a joint move's speed as the percentage the
  language writes (0 < written value <= 100 %, after the language's rounding), a tool move's TCP speed in
  the language's unit within the language's range and within the robot's TCP speed limit;
* configuration consistent with the joint values: the configuration a writer writes for each target
  equals ``pipeline.model.vendors.configurations`` of its joint values (a target written as joint values,
  which carries none, is passed as None), or, for an axis within round-off of a field's boundary, the
  value on its other side (``configuration.mismatched_field``).

``ControllerLintError`` lives in ``pipeline.errors`` (an OutputError: the program cannot be written).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ...errors import ControllerLintError
from ...model.vendors.configuration import FIELDS, configurations, mismatched_field
from ...program.compile import ZONE_SLACK_M
from ...program.tool_path import move_length
from .names import FANUC_LS, JBI, KRL, LANGUAGES, NAME_MAX, PREFIX, RAPID, URSCRIPT, is_reserved


@dataclass(frozen=True)
class Speed:
    """How a language writes a speed: ``unit``, ``per_si`` (written value per fraction of qd_max for joint
    moves, per m/s for tool moves), ``step`` (the written resolution: the value rounds to a multiple of it),
    ``low``/``high`` the range the language accepts (None: no bound of the language's own), ``source``."""

    unit: str
    per_si: float
    step: float
    low: float
    high: float | None
    source: str


@dataclass(frozen=True)
class LanguageLimits:
    """One language's limits: ``vendor`` (whose configuration data it writes; None: none), ``name_max``
    [characters] and ``name_pattern`` of a program name, ``comment_max`` [characters per comment line;
    None: any], ``points_max`` [targets per file; None: no published limit], ``joint_speed`` and
    ``tool_speed``, and ``sources`` of the name, comment and point limits."""

    vendor: str | None
    name_max: int | None
    name_pattern: str
    comment_max: int | None
    points_max: int | None
    joint_speed: Speed
    tool_speed: Speed
    sources: str


_PERCENT = "% of the axes' speed limits"
LIMITS = {
    RAPID: LanguageLimits(
        "abb", NAME_MAX[RAPID], r"[A-Za-z][A-Za-z0-9_]*", None, None,
        Speed(_PERCENT, 100.0, 1e-3, 0.0, 100.0, "RAPID has no joint percentage: its writer turns the fraction into "
              "speeddata; checked as a fraction of the robot's joint speed limits"),
        Speed("mm/s", 1000.0, 1e-3, 0.0, None, "RAPID reference manual, speeddata: v_tcp [mm/s], no bound of the "
              "language (the robot's own TCP speed bounds it)"),
        "RAPID kernel reference: identifiers are at most 32 characters, a letter first, then letters, digits, _"),
    FANUC_LS: LanguageLimits(
        "fanuc", NAME_MAX[FANUC_LS], r"[A-Z][A-Z0-9_]*", 32, 9999,
        Speed(_PERCENT, 100.0, 1.0, 1.0, 100.0, "FANUC TP: J moves at an integer 1-100 %"),
        Speed("mm/sec", 1000.0, 1.0, 1.0, 2000.0, "FANUC TP: L/C moves at an integer 1-2000 mm/sec (the "
              "controller's default range; unverified against a manual here)"),
        "FANUC teach pendant programs: names of 8 characters, an upper-case letter first, load on every controller "
        "generation (R-30iA and later take up to 36, unverified here); comment lines (!) up to 32 characters; "
        "positions P[1]..P[9999] (unverified here)"),
    JBI: LanguageLimits(
        "yaskawa", NAME_MAX[JBI], r"[A-Z][A-Z0-9_]*", 32, 100000,
        Speed(_PERCENT, 100.0, 0.01, 0.01, 100.0, "INFORM MOVJ VJ=0.01 to 100.00 (%)"),
        Speed("mm/s", 1000.0, 0.1, 0.1, 1500.0, "INFORM MOVL/MOVC V=0.1 to 1500.0 mm/s (NX100 INFORM; "
              "unverified here)"),
        "NX100 operator's manual 4.1 (job data format): //NAME up to 8 characters, comments up to 32; teaching "
        "positions C00000..C99999 (5 digits in the job file; no smaller per-job limit found)"),
    KRL: LanguageLimits(
        "kuka", NAME_MAX[KRL], r"[A-Za-z_][A-Za-z0-9_]*", None, None,
        Speed(_PERCENT, 100.0, 1.0, 1.0, 100.0, "KSS expert programming, $VEL_AXIS[i]: INT, 1-100 % of the axis' "
              "maximum speed"),
        Speed("m/s", 1.0, 1e-3, 0.0, None, "KSS expert programming, $VEL.CP [m/s], bounded by the robot's "
              "machine data $VEL_MA.CP (not known here; the robot's TCP speed limit is checked)"),
        "KSS expert programming, 'Names': at most 24 characters, a letter or _ first, then letters, digits, _; "
        "comments (;) of any length; no published limit of the points in a .dat"),
    URSCRIPT: LanguageLimits(
        None, NAME_MAX[URSCRIPT], r"[A-Za-z_][A-Za-z0-9_]*", None, None,
        Speed(_PERCENT, 100.0, 1e-9, 0.0, 100.0, "URScript movej v [rad/s]: checked as a fraction of the joint "
              "speed limits"),
        Speed("m/s", 1.0, 1e-9, 0.0, None, "URScript movel/movec v [m/s], no bound of the language"),
        "URScript (UR script manual): Python-like names of any length, comments (#) of any length, no point limit"),
}


def language_limits(language: str) -> LanguageLimits:
    """The row of ``LIMITS`` of ``language``, or ControllerLintError naming the languages known."""
    if language not in LIMITS:
        raise ControllerLintError(str(language), None, "language", language,
                                  f"unknown controller language; the languages: {', '.join(LANGUAGES)}")
    return LIMITS[language]


def lint(program, language: str, name: str | None = None, comments=(), configs=None) -> None:
    """Every rule of the module docstring for ``program`` (a pipeline.program Program) written in
    ``language`` as program ``name`` (None: program.name), with the writer's ``comments`` (lines,
    without the comment mark) and ``configs`` (K, fields) the configuration it writes for each of the K
    waypoints (None: the language writes none). Raises ControllerLintError; returns None when all pass."""
    limits = language_limits(language)
    check_name(language, program.name if name is None else name)
    for line in comments:
        check_comment(language, line)
    check_points(language, len(program.targets))
    check_zones(language, program)
    check_speeds(language, program)
    if configs is not None:
        check_configurations(language, program, configs, limits.vendor)


def check_name(language: str, name: str) -> None:
    """The program name's length and characters (LIMITS[language].name_max, name_pattern)."""
    limits = language_limits(language)
    if limits.name_max is not None and len(name) > limits.name_max:
        raise ControllerLintError(language, None, "name", name, f"{len(name)} characters, {language} allows at most "
                                                                f"{limits.name_max} ({limits.sources})")
    if not re.fullmatch(limits.name_pattern, name):
        raise ControllerLintError(language, None, "name", name, f"not a {language} name ({limits.name_pattern}; "
                                                                f"{limits.sources})")
    if is_reserved(language, name):
        raise ControllerLintError(language, None, "name", name, f"a reserved word of {language} or a name its writer "
                                                                f"declares (pipeline.outputs.controllers.names); "
                                                                f"e.g. {PREFIX}{name}")


def check_comment(language: str, line: str) -> None:
    """One comment line within LIMITS[language].comment_max characters, on one line."""
    limits = language_limits(language)
    if "\n" in line or "\r" in line:
        raise ControllerLintError(language, None, "comment", line, "a comment line holds no line break")
    if limits.comment_max is not None and len(line) > limits.comment_max:
        raise ControllerLintError(language, None, "comment", line, f"{len(line)} characters, {language} allows at "
                                                                   f"most {limits.comment_max} ({limits.sources})")


def check_points(language: str, count: int) -> None:
    """At most LIMITS[language].points_max targets in one file."""
    limit = language_limits(language).points_max
    if limit is not None and count > limit:
        raise ControllerLintError(language, None, "points", count, f"{language} holds at most {limit} points per "
                                                                   f"file ({language_limits(language).sources})")


def move_lengths(program) -> np.ndarray:
    """The TCP's length [m] of each move (``pipeline.program.tool_path.move_length``: for a joint move the
    distance the controller measures its approximation against)."""
    starts = [program.robot.fk(program.waypoints[0].q)[:3, 3]] + [m.X_BT[:3, 3] for m in program.moves[:-1]]
    return np.array([move_length(p0, m.X_BT[:3, 3], m.via) for p0, m in zip(starts, program.moves)])


def check_zones(language: str, program) -> None:
    """Each move's zone [m] at most half of its own length and of the next move's."""
    lengths = move_lengths(program)
    for k, move in enumerate(program.moves):
        if move.zone <= 0.0:
            continue
        neighbours = lengths[k: k + 2]
        shortest = float(neighbours.min())
        if move.zone > 0.5 * shortest + ZONE_SLACK_M:
            raise ControllerLintError(language, move.end, "zone", move.zone,
                                      f"zone {move.zone * 1e3:.3f} mm is more than half of a neighbouring move "
                                      f"({shortest * 1e3:.3f} mm long); the controller would shrink it to "
                                      f"{0.5 * shortest * 1e3:.3f} mm and round another corner than the profile")


def written_speed(language: str, program, move) -> tuple[float, Speed]:
    """The value a language writes for ``move``'s speed, rounded to its step, and how it writes it (joint moves:
    percent of the joint speed limits x the speed scale; tool moves: ``program.tool_speed`` in the language's
    TCP speed unit)."""
    limits = language_limits(language)
    speed = limits.tool_speed if move.is_tool_move else limits.joint_speed
    si = program.tool_speed(move) if move.is_tool_move else move.speed * program.speed_scale
    value = si * speed.per_si
    return round(value / speed.step) * speed.step, speed


def check_speeds(language: str, program) -> None:
    """Each move's written speed within the language's range (a tool move's is already capped by the job's
    safety TCP speed limit: ``Program.tool_speed``)."""
    for move in program.moves:
        value, speed = written_speed(language, program, move)
        if value < speed.low or value <= 0.0 or (speed.high is not None and value > speed.high):
            high = "" if speed.high is None else f" to {speed.high:g}"
            raise ControllerLintError(language, move.end, "speed", move.speed,
                                      f"written as {value:g} {speed.unit}, outside {speed.low:g}{high} "
                                      f"{speed.unit} ({speed.source})")


def check_configurations(language: str, program, configs, vendor: str) -> None:
    """The configuration fields ``configs`` (K rows of fields, a row None where waypoint k is written without
    one, as joint values) written for the K waypoints equal the vendor's configuration of their joint values
    (``pipeline.model.vendors.configurations``)."""
    expected = configurations(program.robot, program.targets, vendor)
    rows = list(configs)
    written_rows = [np.asarray(row) for row in rows if row is not None]
    if len(rows) != len(expected) or any(row.shape != expected.shape[1:] for row in written_rows):
        shape = np.asarray(configs).shape if not any(row is None for row in rows) else (len(rows), "...")
        raise ControllerLintError(language, None, "configuration", shape,
                                  f"{len(expected)} waypoints need {expected.shape} {vendor} configuration fields")
    for k, (written, wanted) in enumerate(zip(rows, expected)):
        if written is None:
            continue
        f = mismatched_field(program.robot, program.targets[k], vendor, written)
        if f is not None:
            field = FIELDS[vendor][f]
            raise ControllerLintError(language, k, field, int(written[f]), f"the {vendor} configuration of the "
                                                                           f"joint values there is {field} = "
                                                                           f"{int(wanted[f])}")
