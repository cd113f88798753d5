"""Cell files (YAML) -> validated, SI-unit ``Cell`` values: the robot, where it stands and the fixed
obstacles around it (the format is documented in ``models/README.md``).

A cell names its robot (a preset or a robot file relative to the cell file) without loading it: the
reader checks the file alone, ``Cell.load_robot`` loads the robot. Every error is a ``CellFileError``
naming the file, the line, the field (``objects[2].box``) and the value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import CellFileError, ConfigurationError, InvalidValueError, MissingFieldError, file_error, shown
from ..files.robot_spec import MAX_LENGTH_M, MIN_SIZE_M, PRESETS, preset_names
from ..files.schema import Document, Reader, document_from_data, load_document
from ..files.units import ANGLE_UNITS, LENGTH_UNITS

#: Shape kinds and what their size lists hold (file length units): box full sizes along x, y, z;
#: cylinder and capsule radius and length along their z (a capsule's length without its caps); sphere
#: radius (one number).
SHAPE_SIZES = {"box": ("x", "y", "z"), "cylinder": ("radius", "length"), "sphere": ("radius",),
               "capsule": ("radius", "length")}
#: The largest clearance a cell may ask for [m]: more is a unit mistake.
MAX_CLEARANCE_M = 1.0
#: Most objects, and most tool shapes, in a cell. Drake's collision checker costs time and memory
#: growing with the square of the shapes (measured with gp7 and small boxes: 200 objects 0.6 s and
#: +40 MB, 400 1.7 s and +130 MB, 800 15 s and +440 MB, 5000 runs out of memory); real cells have tens.
MAX_CELL_SHAPES = 300

#: The demo cell files, installed with the package (the checkout's models/cells/ folder).
DEMO_CELLS = PRESETS / "cells"

_TOP_REQUIRED = ("name", "length_unit", "robot")
_TOP_OPTIONAL = ("angle_unit", "robot_base", "clearance", "objects", "tool_shapes", "description", "notes")


@dataclass(frozen=True, eq=False)
class Shape:
    """A box, cylinder, sphere or capsule: ``size`` in SI units as in SHAPE_SIZES [m], each in
    [MIN_SIZE_M, MAX_LENGTH_M] (ConfigurationError otherwise: Drake aborts the process on a size of 0),
    centred at its pose ``X`` (4, 4) [m] (in the cell frame W for obstacles, in the robot's end frame
    for tool shapes)."""

    name: str
    kind: str
    size: tuple[float, ...]
    X: np.ndarray

    def __post_init__(self):
        if self.kind not in SHAPE_SIZES or len(self.size) != len(SHAPE_SIZES[self.kind]) or not all(
                MIN_SIZE_M <= value <= MAX_LENGTH_M for value in self.size):
            raise ConfigurationError(f"shape {self.name!r}: a {self.kind} needs sizes "
                                     f"{', '.join(SHAPE_SIZES.get(self.kind, ()))} in [{MIN_SIZE_M:g}, "
                                     f"{MAX_LENGTH_M:g}] m, got {shown(self.size)}")

    @property
    def bounding_radius(self) -> float:
        """The farthest point of the shape from its centre [m]."""
        if self.kind == "box":
            return float(np.linalg.norm(self.size)) / 2.0
        if self.kind == "sphere":
            return self.size[0]
        radius, length = self.size
        return math.hypot(radius, length / 2.0) if self.kind == "cylinder" else radius + length / 2.0

    def describe(self) -> str:
        sizes = ", ".join(f"{label} {value * 1e3:g}" for label, value in zip(SHAPE_SIZES[self.kind], self.size))
        return f"{self.name}: {self.kind} ({sizes} mm) at {np.round(self.X[:3, 3] * 1e3, 1).tolist()} mm"


@dataclass(frozen=True, eq=False)
class Cell:
    """A validated cell in SI units. ``robot``: a preset name or a robot file path (relative paths are
    already resolved against the cell file); ``X_WB`` (4, 4) [m]: the robot's base frame in the cell
    frame; ``clearance`` [m]: the smallest distance a profile may come to an obstacle; ``objects``:
    fixed obstacles (poses in W); ``tool_shapes``: shapes carried by the robot (poses in its end frame,
    the robot file's, before any job tool)."""

    name: str
    source: str
    robot: str | Path
    X_WB: np.ndarray
    clearance: float
    objects: tuple[Shape, ...]
    tool_shapes: tuple[Shape, ...] = ()
    description: str = ""

    def load_robot(self):
        """The cell's robot (a Robot; its file's own errors name that file)."""
        from ..model.robot import load_robot

        return load_robot(self.robot)

    def __str__(self) -> str:
        lines = [f"cell {self.name} ({self.source}): robot {self.robot}, clearance {self.clearance * 1e3:g} mm, "
                 f"base at {np.round(self.X_WB[:3, 3] * 1e3, 1).tolist()} mm",
                 *(f"  object {shape.describe()}" for shape in self.objects),
                 *(f"  tool shape {shape.describe()}" for shape in self.tool_shapes)]
        return "\n".join(lines)


class _CellReader(Reader):
    def __init__(self, document: Document, base_dir: Path):
        super().__init__(document, CellFileError)
        self.base_dir = base_dir
        self.ls = 1.0
        self.as_: float | None = None

    def robot(self) -> str | Path:
        value = self.text(("robot",), max_chars=4096)
        candidate = Path(value)
        if candidate.suffix in (".yaml", ".yml"):
            path = candidate if candidate.is_absolute() else self.base_dir / candidate
            if not path.is_file():
                self.fail(("robot",), f"no robot file at {path}", value, kind=MissingFieldError)
            return path
        if value not in preset_names():
            self.fail(("robot",), f"unknown robot: neither a robot file (.yaml) nor a preset ({', '.join(preset_names())})",
                      value)
        return value

    def size(self, path) -> float:
        """A shape's size in the file's unit -> [m], checked after the conversion: in [MIN_SIZE_M,
        MAX_LENGTH_M]."""
        value = self.length(path)
        if not value >= MIN_SIZE_M:
            self.fail(path, f"is {value:.4g} m, smaller than any shape ({MIN_SIZE_M:g} m, checked in metres): is "
                      "length_unit right?", self.get(path))
        return value

    def length(self, path, low_open: bool = True) -> float:
        value = self.number(path, low=0.0, low_open=low_open, unit=self.get(("length_unit",))) * self.ls
        if value > MAX_LENGTH_M:
            self.fail(path, f"is {value:.4g} m, larger than any cell ({MAX_LENGTH_M:g} m): is length_unit right?",
                      self.get(path))
        return value

    def angle_scale(self, path) -> float | None:
        """The angle unit's factor for the pose at ``path`` (None, an error, only when it has rpy)."""
        return self.as_ if self.has((*path, "rpy")) else 1.0

    def shape(self, path, default_name: str) -> Shape:
        raw = self.get(path)
        if not isinstance(raw, dict):
            self.fail(path, f"must be a mapping with one of {', '.join(SHAPE_SIZES)} and its pose", raw)
        kinds = [kind for kind in SHAPE_SIZES if kind in raw]
        if len(kinds) != 1:
            self.fail(path, f"must have exactly one of {', '.join(SHAPE_SIZES)} (found {', '.join(kinds) or 'none'})")
        kind = kinds[0]
        labels = SHAPE_SIZES[kind]
        if len(labels) == 1:
            size = (self.size((*path, kind)),)
        else:
            self.vector((*path, kind), len(labels), ", ".join(labels))
            size = tuple(self.size((*path, kind, i)) for i in range(len(labels)))
        X = self.pose(path, self.ls, self.angle_scale(path), complete=False, max_length_m=MAX_LENGTH_M,
                      extra=(kind, "name", "note"))
        return Shape(self.name((*path, "name"), default=default_name), kind, size, X)

    def shapes(self, key: str, default_prefix: str) -> tuple[Shape, ...]:
        if not self.has((key,)):
            return ()
        count = len(self.sequence((key,), what="shapes (box, cylinder, sphere or capsule mappings)"))
        if count > MAX_CELL_SHAPES:
            self.fail((key,), f"has {count:,} shapes, more than {MAX_CELL_SHAPES}: the collision checker's time and "
                      "memory grow with their square; merge small shapes into larger ones")
        return tuple(self.shape((key, i), f"{default_prefix}{i}") for i in range(count))

    def cell(self) -> Cell:
        self.mapping((), _TOP_REQUIRED, _TOP_OPTIONAL)
        self.ls = LENGTH_UNITS[self.choice(("length_unit",), tuple(LENGTH_UNITS))]
        if self.has(("angle_unit",)):
            self.as_ = ANGLE_UNITS[self.choice(("angle_unit",), tuple(ANGLE_UNITS))]
        robot = self.robot()
        X_WB = np.eye(4)
        if self.has(("robot_base",)):
            X_WB = self.pose(("robot_base",), self.ls, self.angle_scale(("robot_base",)), complete=False,
                             max_length_m=MAX_LENGTH_M)
        clearance = self.number(("clearance",), 0.0, low=0.0, unit=self.get(("length_unit",))) * self.ls
        if clearance > MAX_CLEARANCE_M:
            self.fail(("clearance",), f"is {clearance:.4g} m, above {MAX_CLEARANCE_M:g} m: is length_unit right?",
                      self.get(("clearance",)))
        objects = self.shapes("objects", "object")
        tool_shapes = self.shapes("tool_shapes", "tool")
        seen: set[str] = set()
        for key, shapes in (("objects", objects), ("tool_shapes", tool_shapes)):
            for i, name in enumerate(s.name for s in shapes):
                if name in seen:
                    self.fail((key, i, "name"), "names of objects and tool shapes must be unique", name)
                seen.add(name)
                if name.startswith("link") or name in ("robot_base", "tool", "world"):
                    self.fail((key, i, "name"), "robot_base, tool, world and link<k> name the robot's own bodies", name)
        return Cell(name=self.name(("name",)), source=self.source, robot=robot, X_WB=X_WB, clearance=clearance,
                    objects=objects, tool_shapes=tool_shapes,
                    description=self.text(("description",), max_chars=10_000) if self.has(("description",)) else "")


def parse_cell(doc: Any, source: str = "<dict>", base_dir: str | Path = ".") -> Cell:
    """Validate a cell document (the parsed YAML mapping); ``base_dir``: where a relative robot path starts."""
    return _CellReader(document_from_data(doc, source), Path(base_dir)).cell()


def resolve_cell_path(name_or_path: str | Path) -> Path:
    """A demo cell's name (``gp7_wall_cell``) or a path to a cell file -> the file's path."""
    candidate = Path(name_or_path)
    if candidate.is_file():
        return candidate
    if str(name_or_path) in cell_names():
        return Path(str(DEMO_CELLS / f"{name_or_path}.yaml"))
    raise file_error(InvalidValueError, CellFileError)(
        str(name_or_path), "document", f"no such cell file, nor a demo cell of that name; demo cells: "
        f"{', '.join(cell_names())}")


def cell_names() -> list[str]:
    """Names of the demo cell files (``models/cells/*.yaml``, installed as ``pipeline.models``)."""
    return sorted(entry.name[: -len(".yaml")] for entry in DEMO_CELLS.iterdir() if entry.name.endswith(".yaml"))


def load_cell(name_or_path: str | Path) -> Cell:
    """Read and validate a cell file (a demo cell's name or a path); a relative robot path in it is
    relative to the file."""
    path = resolve_cell_path(name_or_path)
    return _CellReader(load_document(path, CellFileError), path.parent).cell()

