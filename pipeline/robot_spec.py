"""Robot files (YAML) -> validated, SI-unit `RobotSpec` values.

The format is documented in ``models/README.md``. Millimetres and degrees exist only in files:
this module converts them once, and everything after it is metres, radians and seconds.
"""

from __future__ import annotations

import importlib.resources
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import (
    InvalidValueError,
    MissingFieldError,
    RobotFileError,
    RobotNotFoundError,
    UnknownFieldError,
)

#: The preset robot files, installed with the package (the checkout's models/ folder).
PRESETS = importlib.resources.files("pipeline.models")

LENGTH_UNITS = {"mm": 1e-3, "m": 1.0}
ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
CONVENTIONS = ("standard", "modified")
JOINT_TYPES = ("revolute", "prismatic")

_TOP_REQUIRED = ("name", "convention", "length_unit", "angle_unit", "joints")
_TOP_OPTIONAL = ("tool", "base", "provenance", "description", "assumptions", "notes")
_JOINT_REQUIRED = ("a", "alpha", "d", "q_min", "q_max", "qd_max")
_JOINT_OPTIONAL = ("theta_offset", "sign", "type", "name", "qdd_max", "qddd_max", "tau_max", "inertia", "note")
_FRAME_KEYS = ("xyz", "rpy")
_INERTIA_REQUIRED = ("mass",)
_INERTIA_OPTIONAL = ("com", "I")


@dataclass(frozen=True, eq=False)
class LinkInertia:
    """Mass properties of one link, expressed in its DH link frame.

    ``mass`` [kg], ``p_LoLcm`` centre of mass [m], ``I_Lcm`` [kg m^2] 3x3 about the centre of mass.
    """

    mass: float
    p_LoLcm: np.ndarray
    I_Lcm: np.ndarray


@dataclass(frozen=True, eq=False)
class DhJoint:
    """One DH row in SI units.

    Standard (distal) DH: ``A = Rz(theta) Tz(d) Tx(a) Rx(alpha)``.
    Modified (Craig) DH: ``A = Rx(alpha) Tx(a) Rz(theta) Tz(d)``, where ``a``, ``alpha`` are the
    ``a_{i-1}``, ``alpha_{i-1}`` of the row.
    Revolute: ``theta = sign * q + theta_offset``; prismatic: ``d = sign * q + d``.
    ``a``, ``d`` [m]; ``alpha``, ``theta_offset`` [rad]; limits in q units (rad or m, per second).
    """

    name: str
    kind: str
    a: float
    alpha: float
    d: float
    theta_offset: float
    sign: float
    q_min: float
    q_max: float
    qd_max: float
    qdd_max: float | None
    qddd_max: float | None
    inertia: LinkInertia | None
    tau_max: float | None = None

    @property
    def is_revolute(self) -> bool:
        return self.kind == "revolute"


@dataclass(frozen=True, eq=False)
class Limits:
    """Joint limits as SI arrays of length dof; ``qdd_max``, ``qddd_max``, ``tau_max`` [N m or N] are
    None when not given."""

    q_min: np.ndarray
    q_max: np.ndarray
    qd_max: np.ndarray
    qdd_max: np.ndarray | None
    qddd_max: np.ndarray | None
    tau_max: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class RobotSpec:
    """A validated robot description in SI units.

    ``X_BaseD0``: pose of DH frame 0 in the robot base frame; ``X_DnE``: pose of the end frame in
    the last DH frame (the tool). Both 4x4 [m].
    """

    name: str
    convention: str
    joints: tuple[DhJoint, ...]
    X_BaseD0: np.ndarray
    X_DnE: np.ndarray
    source: str
    length_unit: str
    angle_unit: str
    provenance: Any = None

    @property
    def dof(self) -> int:
        return len(self.joints)

    @cached_property
    def limits(self) -> Limits:
        """Joint limits as SI arrays (computed once)."""

        def column(field: str) -> np.ndarray | None:
            values = [getattr(j, field) for j in self.joints]
            return None if any(v is None for v in values) else np.array(values, dtype=float)

        return Limits(
            q_min=column("q_min"),
            q_max=column("q_max"),
            qd_max=column("qd_max"),
            qdd_max=column("qdd_max"),
            qddd_max=column("qddd_max"),
            tau_max=column("tau_max"),
        )

    def dh_table(self) -> str:
        """The DH table in the file's units, with headers matching the convention."""
        lu, au = self.length_unit, self.angle_unit
        ls, as_ = 1.0 / LENGTH_UNITS[lu], 1.0 / ANGLE_UNITS[au]
        if self.convention == "standard":
            head = ("joint", "type", f"a[{lu}]", f"alpha[{au}]", f"d[{lu}]", f"theta_off[{au}]")
        else:
            head = ("joint", "type", f"a_i-1[{lu}]", f"alpha_i-1[{au}]", f"d[{lu}]", f"theta_off[{au}]")
        head += ("sign", "q_min", "q_max", "qd_max")
        rows = []
        for j in self.joints:
            qs = as_ if j.is_revolute else ls
            rows.append(
                (j.name, j.kind[:3], f"{j.a * ls:g}", f"{j.alpha * as_:g}", f"{j.d * ls:g}",
                 f"{j.theta_offset * as_:g}", f"{j.sign:+g}", f"{j.q_min * qs:g}",
                 f"{j.q_max * qs:g}", f"{j.qd_max * qs:g}")
            )
        widths = [max(len(str(r[c])) for r in (head, *rows)) for c in range(len(head))]
        lines = ["  ".join(str(v).rjust(w) for v, w in zip(r, widths)) for r in (head, *rows)]
        title = f"{self.name}: {self.convention} DH, {self.dof} joints (limits in {au} or {lu})"
        return "\n".join([title, *lines])

    def __str__(self) -> str:
        return self.dh_table()


def rpy_to_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll): roll, pitch, yaw about fixed X, Y, Z [rad]."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


class _Reader:
    """Validates one robot document, raising errors that name the source, joint and field."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, cls, field, problem, joint=None, value=None):
        raise cls(self.source, field, problem, joint=joint, value=value)

    def check_keys(self, mapping, required, optional, prefix="", joint=None):
        if not isinstance(mapping, dict):
            where = prefix.rstrip(".") or "document"
            self.fail(InvalidValueError, where, "must be a mapping of keys to values", joint, mapping)
        for key in mapping:
            if key not in required and key not in optional:
                allowed = ", ".join((*required, *optional))
                self.fail(UnknownFieldError, f"{prefix}{key}", f"unknown key; allowed: {allowed}", joint)
        for key in required:
            if key not in mapping:
                self.fail(MissingFieldError, f"{prefix}{key}", "required key is missing", joint)

    def number(self, mapping, key, joint=None, prefix="", default=None):
        field = f"{prefix}{key}"
        value = mapping.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(InvalidValueError, field, "must be a number", joint, value)
        if not math.isfinite(value):
            self.fail(InvalidValueError, field, "must be finite", joint, value)
        return float(value)

    def positive(self, mapping, key, joint=None):
        value = self.number(mapping, key, joint)
        if value <= 0.0:
            self.fail(InvalidValueError, key, "must be > 0", joint, value)
        return value

    def choice(self, mapping, key, allowed, joint=None, default=None):
        value = mapping.get(key, default)
        if value not in allowed:
            self.fail(InvalidValueError, key, f"must be one of {', '.join(allowed)}", joint, value)
        return value

    def vector3(self, mapping, key, prefix, joint=None):
        value = mapping.get(key, [0.0, 0.0, 0.0])
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            self.fail(InvalidValueError, f"{prefix}{key}", "must be a list of 3 numbers", joint, value)
        return np.array([self.number({key: v}, key, joint, prefix) for v in value])

    def frame(self, doc, key, length_scale, angle_scale) -> np.ndarray:
        X = np.eye(4)
        if key not in doc or doc[key] is None:
            return X
        self.check_keys(doc[key], (), _FRAME_KEYS, prefix=f"{key}.")
        X[:3, 3] = self.vector3(doc[key], "xyz", f"{key}.") * length_scale
        X[:3, :3] = rpy_to_rotation(*(self.vector3(doc[key], "rpy", f"{key}.") * angle_scale))
        return X

    def inertia(self, raw, joint, length_scale) -> LinkInertia:
        self.check_keys(raw, _INERTIA_REQUIRED, _INERTIA_OPTIONAL, prefix="inertia.", joint=joint)
        mass = self.number(raw, "mass", joint, "inertia.")
        if mass <= 0.0:
            self.fail(InvalidValueError, "inertia.mass", "must be > 0 [kg]", joint, mass)
        com = self.vector3(raw, "com", "inertia.", joint) * length_scale
        moments = raw.get("I", [0.0] * 6)
        if not isinstance(moments, (list, tuple)) or len(moments) != 6:
            self.fail(InvalidValueError, "inertia.I", "must be [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2]",
                      joint, moments)
        ixx, iyy, izz, ixy, ixz, iyz = (self.number({"I": v}, "I", joint, "inertia.") for v in moments)
        I_Lcm = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        principal = np.linalg.eigvalsh(I_Lcm)
        if principal[0] < 0.0 or principal[0] + principal[1] < principal[2] * (1.0 - 1e-12):
            self.fail(InvalidValueError, "inertia.I",
                      "is not a physical inertia (principal moments must be >= 0 and obey the triangle inequality)",
                      joint, moments)
        return LinkInertia(mass=mass, p_LoLcm=com, I_Lcm=I_Lcm)

    def joint(self, raw, index, length_scale, angle_scale) -> DhJoint:
        self.check_keys(raw, _JOINT_REQUIRED, _JOINT_OPTIONAL, joint=index)
        kind = self.choice(raw, "type", JOINT_TYPES, index, default="revolute")
        sign = self.number(raw, "sign", index, default=1)
        if sign not in (1.0, -1.0):
            self.fail(InvalidValueError, "sign", "must be 1 or -1", index, raw.get("sign"))
        q_scale = angle_scale if kind == "revolute" else length_scale
        q_min = self.number(raw, "q_min", index) * q_scale
        q_max = self.number(raw, "q_max", index) * q_scale
        if q_min >= q_max:
            self.fail(InvalidValueError, "q_min", f"must be < q_max ({raw['q_max']!r})", index, raw["q_min"])
        optional = {}
        for key in ("qdd_max", "qddd_max"):
            optional[key] = self.positive(raw, key, index) * q_scale if key in raw else None
        tau_max = self.positive(raw, "tau_max", index) if "tau_max" in raw else None
        if tau_max is not None and "inertia" not in raw:
            self.fail(MissingFieldError, "inertia", "tau_max needs the link's inertia (torques come from its dynamics)",
                      index)
        name = raw.get("name", f"joint{index + 1}")
        if not isinstance(name, str) or not name:
            self.fail(InvalidValueError, "name", "must be a non-empty string", index, name)
        return DhJoint(
            name=name,
            kind=kind,
            a=self.number(raw, "a", index) * length_scale,
            alpha=self.number(raw, "alpha", index) * angle_scale,
            d=self.number(raw, "d", index) * length_scale,
            theta_offset=self.number(raw, "theta_offset", index, default=0) * angle_scale,
            sign=sign,
            q_min=q_min,
            q_max=q_max,
            qd_max=self.positive(raw, "qd_max", index) * q_scale,
            qdd_max=optional["qdd_max"],
            qddd_max=optional["qddd_max"],
            inertia=self.inertia(raw["inertia"], index, length_scale) if "inertia" in raw else None,
            tau_max=tau_max,
        )

    def spec(self, doc) -> RobotSpec:
        self.check_keys(doc, _TOP_REQUIRED, _TOP_OPTIONAL)
        name = doc["name"]
        if not isinstance(name, str) or not name:
            self.fail(InvalidValueError, "name", "must be a non-empty string", value=name)
        convention = self.choice(doc, "convention", CONVENTIONS)
        length_unit = self.choice(doc, "length_unit", tuple(LENGTH_UNITS))
        angle_unit = self.choice(doc, "angle_unit", tuple(ANGLE_UNITS))
        ls, as_ = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit]
        raw_joints = doc["joints"]
        if not isinstance(raw_joints, list) or not raw_joints:
            self.fail(InvalidValueError, "joints", "must be a non-empty list of joint rows", value=raw_joints)
        joints = tuple(self.joint(raw, i, ls, as_) for i, raw in enumerate(raw_joints))
        names = [j.name for j in joints]
        for i, n in enumerate(names):
            if names.index(n) != i:
                self.fail(InvalidValueError, "name", "joint names must be unique", i, n)
        for field in ("qdd_max", "qddd_max", "tau_max"):
            given = [getattr(j, field) is not None for j in joints]
            if any(given) and not all(given):
                self.fail(MissingFieldError, field, "given for some joints, so required for all",
                          given.index(False))
        return RobotSpec(
            name=name,
            convention=convention,
            joints=joints,
            X_BaseD0=self.frame(doc, "base", ls, as_),
            X_DnE=self.frame(doc, "tool", ls, as_),
            source=self.source,
            length_unit=length_unit,
            angle_unit=angle_unit,
            provenance=doc.get("provenance"),
        )


def parse_robot_spec(doc: Any, source: str = "<dict>") -> RobotSpec:
    """Validate a robot document (the parsed YAML mapping) into a RobotSpec."""
    return _Reader(source).spec(doc)


def resolve_robot_path(name_or_path: str | Path) -> Path:
    """A preset name (``gp7``) or a path to a robot file -> the file's path."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") and candidate.is_file():
        return candidate
    if str(name_or_path) in preset_names():
        return Path(str(PRESETS / f"{name_or_path}.yaml"))
    raise RobotNotFoundError(
        f"{name_or_path!r} is neither a robot file nor a preset; presets: {', '.join(preset_names())}"
    )


def preset_names() -> list[str]:
    """Names of the preset robot files (``models/*.yaml``, installed as ``pipeline.models``)."""
    return sorted(entry.name[: -len(".yaml")] for entry in PRESETS.iterdir() if entry.name.endswith(".yaml"))


def load_robot_spec(name_or_path: str | Path) -> RobotSpec:
    """Read and validate a robot file (a preset name or a path)."""
    path = resolve_robot_path(name_or_path)
    try:
        doc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise RobotFileError(str(path), "document", f"is not valid YAML: {exc}") from exc
    return parse_robot_spec(doc, source=str(path))
