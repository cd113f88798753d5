"""The one reader behind every file the package reads (robot files, job files, and the formats to come).

Two layers:

- ``load_document(path, file_kind)``: bytes -> plain Python data (dicts, lists, str, int, float, bool,
  None) plus the line of every field. YAML is read strictly: UTF-8 only, numbers as in YAML 1.2 (``1e-7``
  is a number, ``170:30`` is text, ``yes`` is text), no duplicate keys, string keys only, no custom tags,
  bounded size, nesting and alias expansion (so a small "billion laughs" file fails at once).
- ``Reader``: typed access to that data (mappings with allowed keys, numbers in a range, choices,
  vectors, unit names, poses), failing with one error type per file kind that names the file, the line,
  the field path (``joints[2].alpha``), a short excerpt of the value and what was allowed.

Units (``pipeline.files.units``) are converted by the readers once: everything after a reader is SI.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import FileFormatError, InvalidValueError, MissingFieldError, UnknownFieldError, file_error
from .poses import quaternion_position_to_pose, rpy_position_to_pose
from .special import special_kind

#: Largest file read [bytes]: the YAML parser takes ~4 s per MiB here; robot and job files are kB.
MAX_FILE_BYTES = 512 * 1024
#: Deepest nesting of mappings and lists, and most values after aliases are expanded.
MAX_DEPTH = 32
MAX_VALUES = 200_000
#: Longest number written in a file [characters] (a 5000-digit integer is a mistake, not a length).
MAX_NUMBER_CHARS = 40
#: A quaternion this close to unit length is normalised; further away it is an error [1].
QUATERNION_NORM_TOLERANCE = 1e-3

Path_ = tuple  # a field path: keys (str) and list indices (int), e.g. ("joints", 2, "alpha")

# YAML 1.2 core schema for plain (unquoted) scalars.
_NULL = re.compile(r"^(?:~|null|Null|NULL|)$")
_TRUE = re.compile(r"^(?:true|True|TRUE)$")
_FALSE = re.compile(r"^(?:false|False|FALSE)$")
_INT = re.compile(r"^[-+]?[0-9]+$")
_FLOAT = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")
_INF = re.compile(r"^[-+]?\.(?:inf|Inf|INF)$")
_NAN = re.compile(r"^\.(?:nan|NaN|NAN)$")
_UNSAFE_NAME = re.compile(r"[/\\\x00-\x1f\x7f]")
_PLAIN = "tag:dh-pipeline:plain"
_STR, _SEQ, _MAP = "tag:yaml.org,2002:str", "tag:yaml.org,2002:seq", "tag:yaml.org,2002:map"


def field_name(path: Path_) -> str:
    """("joints", 2, "alpha") -> "joints[2].alpha"; () -> "document"."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "document"


@dataclass(frozen=True, eq=False)
class Document:
    """Plain data read from a file (or given as a mapping), with the 1-based line of each field path
    and the file's bytes (``content``, empty for a mapping given in code)."""

    data: Any
    source: str
    lines: Mapping[Path_, int] = field(default_factory=dict)
    content: bytes = b""

    def line(self, path: Path_) -> int | None:
        """The line of ``path``, or of its nearest ancestor the file shows (None for a mapping given in code)."""
        for end in range(len(path), -1, -1):
            if path[:end] in self.lines:
                return self.lines[path[:end]]
        return None


class _Loader(yaml.SafeLoader):
    """PyYAML's safe composer with plain scalars left unresolved (we resolve them as YAML 1.2)."""

    def resolve(self, kind, value, implicit):
        if kind is yaml.ScalarNode and implicit[0]:
            return _PLAIN
        return super().resolve(kind, value, implicit)


class _Converter:
    """YAML nodes -> plain data and lines, with duplicate keys, tags, depth and size checked."""

    def __init__(self, fail):
        self.fail = fail
        self.lines: dict[Path_, int] = {}
        self.count = 0

    def value(self, node, path: Path_) -> Any:
        self.count += 1
        self.lines.setdefault(path, node.start_mark.line + 1)
        if self.count > MAX_VALUES:
            self.fail(path, f"the file expands to more than {MAX_VALUES} values (aliases of aliases?)")
        if len(path) > MAX_DEPTH:
            self.fail(path, f"is nested more than {MAX_DEPTH} levels deep")
        if isinstance(node, yaml.MappingNode):
            return self.mapping(node, path)
        if isinstance(node, yaml.SequenceNode):
            if node.tag != _SEQ:
                self.fail(path, f"the tag {node.tag!r} is not supported")
            return [self.value(item, (*path, k)) for k, item in enumerate(node.value)]
        return self.scalar(node, path)

    def mapping(self, node, path: Path_) -> dict:
        if node.tag != _MAP:
            self.fail(path, f"the tag {node.tag!r} is not supported")
        out: dict[str, Any] = {}
        for key_node, value_node in node.value:
            key = self.scalar(key_node, path) if isinstance(key_node, yaml.ScalarNode) else None
            if not isinstance(key, str):
                self.fail(path, f"keys must be text (line {key_node.start_mark.line + 1})")
            if key in out:
                self.fail((*path, key), f"is given twice (lines {self.lines[(*path, key)]} and "
                                        f"{key_node.start_mark.line + 1})")
            self.lines[(*path, key)] = key_node.start_mark.line + 1
            out[key] = self.value(value_node, (*path, key))
        return out

    def scalar(self, node, path: Path_) -> Any:
        text = node.value
        if node.tag == _STR:
            return text
        if node.tag != _PLAIN:
            self.fail(path, f"the tag {node.tag!r} is not supported (write plain values)")
        if _NULL.match(text):
            return None
        if _TRUE.match(text) or _FALSE.match(text):
            return bool(_TRUE.match(text))
        if _INT.match(text) or _FLOAT.match(text):
            if len(text) > MAX_NUMBER_CHARS:
                self.fail(path, f"is a number of more than {MAX_NUMBER_CHARS} characters")
            return int(text) if _INT.match(text) else float(text)
        if _INF.match(text):
            return -math.inf if text.startswith("-") else math.inf
        if _NAN.match(text):
            return math.nan
        return text


def read_file_bytes(path: Path, fail, max_bytes: int = MAX_FILE_BYTES) -> bytes:
    """The file's bytes: it must exist, be a regular file (a FIFO or device may never end; checked before it
    is opened, which would block on a FIFO) and be at most ``max_bytes`` (no more is read, so the readers'
    time is bounded too). ``fail((), problem)`` raises the caller's error."""
    kind = special_kind(path)
    if kind is not None:
        fail((), f"cannot read the file: it is {kind}, not a regular file")
    try:
        with open(path, "rb") as handle:
            raw = handle.read(max_bytes + 1)
    except OSError as exc:
        fail((), f"cannot read the file: {exc.strerror or exc}")
    if len(raw) > max_bytes:
        fail((), f"the file is larger than {max_bytes // 1024} KiB; is it the right file?")
    return raw


def decode_text(raw: bytes, fail) -> str:
    """UTF-8 text (a byte-order mark is allowed)."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        fail((), f"is not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); is it the right file?")


def _raise(file_kind: type[FileFormatError], source: str, path: Path_, problem: str, line: int | None = None):
    """Raise the document-level error of a file (unreadable, not YAML, too big or too deep)."""
    raise file_error(InvalidValueError, file_kind)(source, field_name(path), problem, line=line)


def parse_document(text: str, source: str, file_kind: type[FileFormatError]) -> Document:
    """YAML text -> Document; every problem is ``file_kind`` naming ``source`` and the line."""

    def fail(path, problem, line=None):
        _raise(file_kind, source, path, problem, line if line is not None else converter.lines.get(path))

    converter = _Converter(fail)
    try:
        node = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        fail((), f"is not valid YAML: {exc.problem or exc.context}", line=mark.line + 1 if mark else None)
    except yaml.YAMLError as exc:
        fail((), f"is not valid YAML: {exc}")
    except RecursionError:
        fail((), f"is not valid here: nested more than {MAX_DEPTH} levels deep")
    data = None if node is None else converter.value(node, ())
    return Document(data, source, converter.lines)


def load_document(path: str | Path, file_kind: type[FileFormatError]) -> Document:
    """Read a YAML file into a Document (``content``: the bytes read); any problem is a ``file_kind``
    error naming the file."""
    source = str(path)
    fail = functools.partial(_raise, file_kind, source)
    raw = read_file_bytes(Path(path), fail)
    return dataclasses.replace(parse_document(decode_text(raw, fail), source, file_kind), content=raw)


class Reader:
    """Typed access to a Document's fields; every failure names the file, line and field path.

    ``file_kind``: the error family of the file (RobotFileError, JobFileError, ...). Methods take the
    field's path and return SI values where a unit applies.
    """

    def __init__(self, document: Document, file_kind: type[FileFormatError]):
        self.document = document
        self.file_kind = file_kind

    @property
    def source(self) -> str:
        return self.document.source

    def fail(self, path: Path_, problem: str, value: Any = None, kind: type[FileFormatError] = InvalidValueError):
        """Raise the file's error of ``kind`` for the field at ``path``."""
        joint = path[1] if len(path) > 1 and path[0] == "joints" and isinstance(path[1], int) else None
        raise file_error(kind, self.file_kind)(self.source, field_name(path), problem, joint=joint, value=value,
                                               line=self.document.line(path))

    def get(self, path: Path_, default: Any = None) -> Any:
        """The value at ``path`` (``default`` where a key on the way is absent)."""
        value = self.document.data
        for part in path:
            if isinstance(part, int) and isinstance(value, (list, tuple)) and -len(value) <= part < len(value):
                value = value[part]
            elif isinstance(part, str) and isinstance(value, dict) and part in value:
                value = value[part]
            else:
                return default
        return value

    def mapping(self, path: Path_, required: tuple[str, ...], optional: tuple[str, ...]) -> dict:
        """The mapping at ``path`` with only the allowed keys and every required one."""
        value = self.get(path)
        if not isinstance(value, dict):
            self.fail(path, "must be a mapping of keys to values", value)
        allowed = (*required, *optional)
        for key in value:
            if key not in allowed:
                self.fail((*path, key), f"unknown key; allowed: {', '.join(allowed)}", kind=UnknownFieldError)
        for key in required:
            if key not in value:
                self.fail((*path, key), "required key is missing", kind=MissingFieldError)
        return value

    def flag(self, path: Path_, default: bool = False) -> bool:
        """A boolean: ``true`` or ``false`` (``default`` when absent)."""
        value = self.get(path, default)
        if not isinstance(value, bool):
            self.fail(path, "must be true or false", value)
        return value

    def has(self, path: Path_) -> bool:
        """Whether the key at the end of ``path`` is present (and not null)."""
        return self.get(path) is not None

    def number(self, path: Path_, default: float | None = None, low: float | None = None,
               high: float | None = None, low_open: bool = False, unit: str = "") -> float:
        """A finite number (``default`` when absent), optionally within [low, high] (``(low`` when
        ``low_open``), in the file's units: the caller converts."""
        value = self.get(path, default)
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            self.fail(path, "must be a number", value)
        value = float(value)
        if not math.isfinite(value):
            self.fail(path, "must be finite", value)
        below = low is not None and (value <= low if low_open else value < low)
        if below or (high is not None and value > high):
            self.fail(path, f"must be in {_interval(low, high, low_open)}{' ' + unit if unit else ''}", value)
        return value

    def positive(self, path: Path_, unit: str = "") -> float:
        """A finite number > 0."""
        return self.number(path, low=0.0, low_open=True, unit=unit)

    def choice(self, path: Path_, allowed, default: str | None = None) -> str:
        """One of ``allowed`` (text)."""
        value = self.get(path, default)
        if not isinstance(value, str) or value not in allowed:
            self.fail(path, f"must be one of {', '.join(allowed)}", value)
        return value

    def text(self, path: Path_, default: str | None = None, max_chars: int = 200) -> str:
        """A non-empty string of at most ``max_chars`` characters."""
        value = self.get(path, default)
        if not isinstance(value, str) or not value.strip():
            self.fail(path, "must be a non-empty text", value)
        if len(value) > max_chars:
            self.fail(path, f"must be at most {max_chars} characters long", value)
        return value

    def name(self, path: Path_, default: str | None = None) -> str:
        """A name that is also safe in a file name: at most 64 characters, no slashes or control
        characters, not ``.`` or ``..``."""
        value = self.text(path, default, max_chars=64)
        if _UNSAFE_NAME.search(value) or value.strip(".") == "":
            self.fail(path, "must not contain slashes or control characters (it names output files)", value)
        return value

    def sequence(self, path: Path_, min_items: int = 0, what: str = "values") -> list:
        """The list at ``path`` with at least ``min_items`` items."""
        value = self.get(path)
        if not isinstance(value, (list, tuple)) or len(value) < min_items:
            self.fail(path, f"must be a list of at least {min_items} {what}" if min_items else
                      f"must be a list of {what}", value if not isinstance(value, (list, tuple)) else None)
        return list(value)

    def vector(self, path: Path_, size: int, what: str, default=None) -> np.ndarray:
        """A list of exactly ``size`` finite numbers (file units); ``default`` when absent."""
        if default is not None and not self.has(path):
            return np.array(default, dtype=float)
        value = self.get(path)
        if not isinstance(value, (list, tuple)):
            self.fail(path, f"must be a list of {size} numbers ({what})", value)
        if len(value) != size:
            self.fail(path, f"must have {size} values ({what}), got {len(value)}")
        return np.array([self.number((*path, i)) for i in range(size)])

    def unit(self, path: Path_, units: Mapping[str, float], needed_by: str | None) -> float | None:
        """The SI factor of the unit named at ``path``; None when absent and not needed (``needed_by``
        says why it is needed, for the message)."""
        if not self.has(path):
            if needed_by:
                self.fail(path, f"required because {needed_by}; one of {', '.join(units)}", kind=MissingFieldError)
            return None
        return units[self.choice(path, tuple(units))]

    def pose(self, path: Path_, length_scale: float, angle_scale: float | None, complete: bool = True,
             max_length_m: float = math.inf, extra: tuple[str, ...] = ()) -> np.ndarray:
        """``{xyz, rpy}`` or ``{xyz, quaternion: [w, x, y, z]}`` -> X (4, 4) [m]. ``complete``: xyz and one
        rotation are required; otherwise each part is optional (zero, identity). ``max_length_m``
        bounds |xyz| [m]: farther is a unit mistake. ``angle_scale`` None: the file gave no angle unit.
        ``extra``: more keys the mapping may have (the caller reads them)."""
        value = self.mapping(path, ("xyz",) if complete else (), (*(("rpy", "quaternion") if complete
                                                                    else ("xyz", "rpy", "quaternion")), *extra))
        if ("rpy" in value and "quaternion" in value) or (complete and "rpy" not in value
                                                           and "quaternion" not in value):
            self.fail(path, "give exactly one of rpy or quaternion")
        p = self.vector((*path, "xyz"), 3, "x, y, z", default=[0.0, 0.0, 0.0]) * length_scale
        if np.abs(p).max() > max_length_m:
            self.fail((*path, "xyz"), f"has a coordinate of {np.abs(p).max():.4g} m, farther than "
                      f"{max_length_m:g} m: is the length unit right?", self.get((*path, "xyz")))
        if "quaternion" in value:
            quat = self.vector((*path, "quaternion"), 4, "w, x, y, z")
            norm = float(np.linalg.norm(quat))
            if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
                self.fail((*path, "quaternion"), f"must be unit length within {QUATERNION_NORM_TOLERANCE:g}, "
                          f"|q| = {norm:.6g}")
            return quaternion_position_to_pose(quat / norm, p)
        rpy = self.vector((*path, "rpy"), 3, "roll, pitch, yaw", default=[0.0, 0.0, 0.0])
        if angle_scale is None:
            self.fail((*path, "rpy"), "needs angle_unit (deg or rad) at the top of the file", kind=MissingFieldError)
        return rpy_position_to_pose(rpy * angle_scale, p)


def _interval(low: float | None, high: float | None, low_open: bool) -> str:
    if high is None:
        return f"{'>' if low_open else '>='} {low:g}"
    if low is None:
        return f"<= {high:g}"
    return f"{'(' if low_open else '['}{low:g}, {high:g}]"


def document_from_data(data: Any, source: str = "<dict>") -> Document:
    """A Document for data given in code (no lines)."""
    return Document(data, source)
