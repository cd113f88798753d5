"""One error hierarchy for the whole pipeline.

Every message names where the problem is (file, line, field, joint) and what was allowed, so a user
can fix the input without reading code. The CLI turns every ``PipelineError`` into one line and exit
status 2; anything else is an internal error (exit 1).

Input-file errors say two things at once: which file kind (``RobotFileError``, ``JobFileError``) and
what is wrong (``UnknownFieldError``, ``MissingFieldError``, ``InvalidValueError``); the reader raises
a class deriving from both (``file_error``), so either can be caught.
"""

from __future__ import annotations

import functools
import reprlib

#: Messages show an excerpt of an offending value, never all of it (a value may be huge or deep).
_SHOWN = reprlib.Repr()
_SHOWN.maxlevel, _SHOWN.maxlist, _SHOWN.maxtuple, _SHOWN.maxdict = 2, 6, 6, 4
_SHOWN.maxstring, _SHOWN.maxother, _SHOWN.maxlong = 60, 60, 40


def shown(value) -> str:
    """A short ``repr`` of ``value`` (at most ~60 characters per item, 6 items, 2 levels deep)."""
    try:
        return _SHOWN.repr(value)
    except ValueError:                      # an int too long to print
        return f"<{type(value).__name__} too long to show>"


class PipelineError(Exception):
    """Base class of every error this package raises on purpose."""


class FileFormatError(PipelineError):
    """An input file (or the mapping parsed from one) is not valid.

    Attributes: ``source`` (file path or ``<dict>``), ``line`` (1-based, or None where the reader does
    not know it), ``field`` (dotted path such as ``joints[2].alpha``), ``problem`` (what is wrong and
    what is allowed), ``joint`` (0-based index or None), ``value`` (the offending value, or None).
    """

    def __init__(self, source: str, field: str, problem: str, joint: int | None = None, value=None,
                 line: int | None = None):
        self.source = str(source)
        self.field = field
        self.problem = problem
        self.joint = joint
        self.value = value
        self.line = line
        where = f"{self.source}:{line}" if line is not None else self.source
        got = f" (got {shown(value)})" if value is not None else ""
        super().__init__(f"{where}: {field}: {problem}{got}")


class RobotFileError(FileFormatError):
    """A robot file (or robot dict) is not valid."""


class JobFileError(FileFormatError):
    """A job file is not valid, or one of its waypoints cannot be reached."""


class CellFileError(FileFormatError):
    """A cell file is not valid (``field`` names the object by index, e.g. ``objects[2].box``)."""


class CollisionError(PipelineError):
    """A configuration or motion comes closer than the clearance to an obstacle, or links touch: names
    the pair, and the waypoint, move, sample or time where it happens."""


class PlanningError(PipelineError):
    """No collision-free joint path was found within the planner's budget (names the move, the planner
    and its time)."""


class UnknownFieldError(FileFormatError):
    """A key the file format does not define (often a typo)."""


class MissingFieldError(FileFormatError):
    """A required key is absent."""


class InvalidValueError(FileFormatError):
    """A key has a value of the wrong type, out of range, implausible for its unit, or inconsistent
    with another key; also a file that cannot be read or parsed (field ``document``)."""


@functools.cache
def file_error(problem: type[FileFormatError], file_kind: type[FileFormatError]) -> type[FileFormatError]:
    """The error class that is both ``problem`` (e.g. InvalidValueError) and ``file_kind`` (e.g.
    RobotFileError), so callers may catch either."""
    if issubclass(problem, file_kind):
        return problem
    return type(problem.__name__, (problem, file_kind), {"__doc__": problem.__doc__,
                                                        "__module__": __name__})


class RobotNotFoundError(PipelineError):
    """Neither a preset name nor an existing file path."""


class ConfigurationError(PipelineError):
    """An argument of the Python API is not valid: a joint vector, pose or batch of the wrong shape or
    with non-finite values, or an option out of its range."""


class TimingError(PipelineError):
    """A path could not be timed within the limits (names the waypoint or segment where it can)."""


class ProfileSizeError(TimingError):
    """A profile would have more samples than allowed (names its duration, dt and the limit)."""


class OutputError(PipelineError):
    """An output folder or file cannot be written: it is a file, is not writable, or holds files this
    package did not write."""


class ControllerLintError(OutputError):
    """A program breaks a rule of the controller language it is written in: ``language``, ``move`` (the
    waypoint index a move ends at, None for the whole program), ``field`` (e.g. ``zone``, ``speed``,
    ``name``, ``S``) and ``value`` (the offending value)."""

    def __init__(self, language: str, move: int | None, field: str, value, problem: str):
        self.language, self.move, self.field, self.value, self.problem = language, move, field, value, problem
        where = "program" if move is None else f"move to waypoint {move}"
        super().__init__(f"{language}: {where}: {field} = {shown(value)}: {problem}")

    def __reduce__(self):
        return type(self), (self.language, self.move, self.field, self.value, self.problem)


class UrdfFileError(FileFormatError):
    """A URDF file is not valid XML or not a valid URDF (``field`` names the element, e.g.
    ``joint[elbow].limit.velocity``), or its chain cannot become a DH robot (``UrdfChainError``)."""


class UrdfChainError(UrdfFileError):
    """The chain asked for is not a serial chain of revolute and prismatic joints: a branch with
    moving joints on more than one side, a mimic, floating or planar joint, or no path from the base
    link to the tip link. ``field`` names the joint or link."""


class ScaleInputError(ConfigurationError):
    """A bad input of a batch or a reachability map (``pipeline.scale``): ``field`` names the argument or
    option (e.g. ``step``, ``jobs``, ``--workers``), ``value`` what was given."""

    def __init__(self, field: str, problem: str, value=None):
        self.field, self.problem, self.value = field, problem, value
        got = f" (got {shown(value)})" if value is not None else ""
        super().__init__(f"{field}: {problem}{got}")

    def __reduce__(self):                   # pickles (e.g. across Dask) with its own arguments
        return type(self), (self.field, self.problem, self.value)


class ClusterError(PipelineError):
    """The Dask scheduler named cannot be reached (names its address and why)."""


class VendorConfigurationError(ConfigurationError):
    """A controller's configuration data cannot be computed or read: an unknown vendor, a malformed
    configuration (names the vendor, the field and what it allows), or an arm without named branches."""


class ConfigurationNotFoundError(VendorConfigurationError):
    """No in-limit IK solution of a pose has the vendor configuration asked for, or more than one has
    it. ``pose`` (4, 4) [m], ``requested`` the configuration's text, ``available`` the texts of the
    configurations the pose's solutions have."""

    def __init__(self, message: str, pose, requested: str, available: tuple[str, ...]):
        self.pose, self.requested, self.available = pose, requested, available
        super().__init__(message)

    def __reduce__(self):
        return type(self), (self.args[0], self.pose, self.requested, self.available)
