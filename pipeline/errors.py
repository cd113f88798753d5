"""One error hierarchy for the whole pipeline.

Every message names where the problem is (file, field, joint) and what was allowed, so a user
can fix the input without reading code.
"""

from __future__ import annotations


class PipelineError(Exception):
    """Base class of every error this package raises on purpose."""


class RobotFileError(PipelineError):
    """A robot file (or robot dict) is not valid.

    Attributes: ``source`` (file path or ``<dict>``), ``field`` (dotted key), ``joint`` (0-based
    index or None), ``value`` (the offending value, or None).
    """

    def __init__(self, source: str, field: str, problem: str, joint: int | None = None, value=None):
        self.source = source
        self.field = field
        self.joint = joint
        self.value = value
        where = f"joints[{joint}].{field}" if joint is not None else field
        shown = f" (got {value!r})" if value is not None else ""
        super().__init__(f"{source}: {where}: {problem}{shown}")


class UnknownFieldError(RobotFileError):
    """A key the robot file format does not define (often a typo)."""


class MissingFieldError(RobotFileError):
    """A required key is absent."""


class InvalidValueError(RobotFileError):
    """A key has a value of the wrong type, out of range, or inconsistent with another key."""


class RobotNotFoundError(PipelineError):
    """Neither a preset name nor an existing file path."""


class ConfigurationError(PipelineError):
    """A joint vector or batch has the wrong shape or non-finite values."""


class TimingError(PipelineError):
    """A path could not be timed within the limits (names the waypoint or segment where it can)."""


class JobFileError(PipelineError):
    """A job file is not valid: names the file, the field and, for waypoints, the waypoint index."""
