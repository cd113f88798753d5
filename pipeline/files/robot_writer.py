"""RobotSpec -> a robot file (the documented YAML format of ``models/README.md``), in mm and deg by default.

The inverse of ``robot_spec``: reading the written file gives back the same kinematics to 1e-13 m and
1e-14 rad (values are rounded to those resolutions, so 486.49999999999994 mm is written as 486.5). A
continuous joint (no position limits) is written as ``continuous: true`` without ``q_min`` and ``q_max``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from .atomic import WRITTEN_BY, write_text_atomic
from .poses import rotation_to_rpy
from .robot_spec import ControllerSection, DhJoint, LinkInertia, RobotSpec
from .units import ANGLE_UNITS, LENGTH_UNITS

#: Resolution of the written values: lengths [m], angles [rad].
LENGTH_RESOLUTION_M = 1e-13
ANGLE_RESOLUTION_RAD = 1e-14


class _Units:
    """SI -> file units, rounded to the resolutions above."""

    def __init__(self, length_unit: str, angle_unit: str):
        self.ls, self.as_ = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit]
        self.length_digits = round(-math.log10(LENGTH_RESOLUTION_M / self.ls))
        self.angle_digits = round(-math.log10(ANGLE_RESOLUTION_RAD / self.as_))

    def length(self, value: float) -> float:
        return round(float(value) / self.ls, self.length_digits) + 0.0     # + 0.0: no "-0.0"

    def angle(self, value: float) -> float:
        return round(float(value) / self.as_, self.angle_digits) + 0.0

    def q(self, value: float, revolute: bool) -> float:
        return self.angle(value) if revolute else self.length(value)

    def pose(self, X: np.ndarray) -> dict:
        return {"xyz": [self.length(v) for v in X[:3, 3]], "rpy": [self.angle(v) for v in rotation_to_rpy(X[:3, :3])]}


#: Significant digits of masses and moments of inertia (smaller products of inertia are rounding noise).
MASS_DIGITS = 15


def _significant(value: float, scale: float) -> float:
    """``value`` rounded to MASS_DIGITS significant digits of ``scale`` (unrounded when ``scale`` is not
    finite: the robot-file reader refuses such a value with its field)."""
    if not math.isfinite(scale):
        return float(value)
    return round(float(value), MASS_DIGITS - math.ceil(math.log10(scale))) + 0.0 if scale > 0.0 else 0.0


def _inertia(inertia: LinkInertia, units: _Units) -> dict:
    I = inertia.I_Lcm
    largest = float(np.abs(I).max())
    return {"mass": _significant(inertia.mass, inertia.mass), "com": [units.length(v) for v in inertia.p_LoLcm],
            "I": [_significant(v, largest) for v in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])]}


def _joint(joint: DhJoint, units: _Units) -> dict:
    revolute = joint.is_revolute
    row = {"name": joint.name}
    if not revolute:
        row["type"] = "prismatic"
    row.update(a=units.length(joint.a), alpha=units.angle(joint.alpha), d=units.length(joint.d),
               theta_offset=units.angle(joint.theta_offset), sign=int(joint.sign))
    if joint.is_continuous:
        row["continuous"] = True
    else:
        row.update(q_min=units.q(joint.q_min, revolute), q_max=units.q(joint.q_max, revolute))
    for key in ("qd_max", "qdd_max", "qddd_max"):
        if getattr(joint, key) is not None:
            row[key] = units.q(getattr(joint, key), revolute)
    if joint.tau_max is not None:
        row["tau_max"] = float(joint.tau_max)
    if joint.radius is not None:
        row["radius"] = units.length(joint.radius)
    if joint.inertia is not None:
        row["inertia"] = _inertia(joint.inertia, units)
    return row


def robot_document(spec: RobotSpec, length_unit: str = "mm", angle_unit: str = "deg", description: str | None = None,
                   assumptions: list[str] | None = None) -> dict:
    """The robot file of ``spec`` as a mapping (what ``yaml.safe_load`` of the file gives)."""
    units = _Units(length_unit, angle_unit)
    document = {"name": spec.name}
    if description:
        document["description"] = description
    document.update(convention=spec.convention, length_unit=length_unit, angle_unit=angle_unit)
    if spec.provenance is not None:
        document["provenance"] = spec.provenance
    if assumptions:
        document["assumptions"] = list(assumptions)
    for key, X in (("base", spec.X_BaseD0), ("tool", spec.X_DnE)):
        pose = units.pose(X)
        if any(pose["xyz"] + pose["rpy"]):
            document[key] = pose
    if spec.controller is not None:
        document["controller"] = controller_document(spec.controller, units)
    if spec.payload_limits is not None:
        document["payload_limits"] = payload_limits_document(spec)
    document["joints"] = [_joint(joint, units) for joint in spec.joints]
    return document


def payload_limits_document(spec: RobotSpec) -> dict:
    """The ``payload_limits`` section of a robot file (kg, N m, kg m^2 whatever the file's units)."""
    limits = spec.payload_limits
    out = {"source": limits.source}
    if limits.rated_kg is not None:
        out["rated"] = limits.rated_kg
    if limits.wrist:
        out["wrist"] = {spec.joints[i].name: {key: value for key, value in (("moment", moment), ("inertia", inertia))
                                              if value is not None}
                        for i, (moment, inertia) in limits.wrist.items()}
    return out


def controller_document(section: ControllerSection, units: _Units) -> dict:
    """The ``controller`` section of a robot file (defaults left out)."""
    out = {"maker": section.maker}
    axes = {}
    if any(v != 1 for v in section.direction):
        axes["direction"] = list(section.direction)
    if any(section.offset):
        axes["offset"] = [units.angle(v) for v in section.offset]
    if axes:
        out["axes"] = axes
    if section.coupling is not None:
        out["coupling"] = section.coupling
    for key, X in (("base", section.X_B_base), ("flange", section.X_E_flange)):
        pose = units.pose(X)
        if any(pose["xyz"] + pose["rpy"]):
            out[key] = pose
    if any(section.elbow_up):
        out["elbow_up"] = [units.angle(v) for v in section.elbow_up]
    return out


def robot_file_text(document: dict) -> str:
    """A robot file's text: a comment naming its writer, then one flow-style line per joint row, like the
    presets."""
    head = {key: value for key, value in document.items() if key not in ("base", "tool", "controller", "joints")}
    frames = {key: document[key] for key in ("base", "tool", "controller") if key in document}
    text = yaml.safe_dump(head, sort_keys=False, width=110, allow_unicode=True)
    if frames:
        text += yaml.safe_dump(frames, sort_keys=False, default_flow_style=None)
    rows = [yaml.safe_dump([row], sort_keys=False, default_flow_style=None, width=10_000) for row in document["joints"]]
    return f"# A robot file written by {WRITTEN_BY} (its format: models/README.md)\n{text}joints:\n{''.join(rows)}"


def write_robot_file(document: dict, path: str | Path, replace: bool = False) -> Path:
    """Write a robot file atomically (OutputError when it cannot; a file the package did not write is replaced
    only with ``replace``)."""
    return write_text_atomic(path, robot_file_text(document), replace)
