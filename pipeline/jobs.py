"""Job files (YAML) -> validated, SI-unit ``Job`` values.

The format is documented in ``trajectories/README.md``. Degrees and millimetres exist only in the
file: waypoints, poses and the start configuration are converted here once. Every error is a
``JobFileError`` naming the file, the field and, for waypoints, the waypoint index.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import JobFileError, PipelineError, RobotNotFoundError
from .ik import METHODS as IK_METHODS
from .path import SHAPES
from .poses import quaternion_position_to_pose
from .robot import Robot, load_robot
from .robot_spec import ANGLE_UNITS, LENGTH_UNITS, preset_names, rpy_to_rotation
from .timing import DEFAULT_DT, METHODS as TIMING_METHODS

OUTPUTS = ("csv", "npz", "json", "png", "html", "arm_png")
#: Written when a job lists no outputs (the 3-D views, html and arm_png, only when asked for).
DEFAULT_OUTPUTS = ("csv", "npz", "json", "png")
#: Allowed sample times [s].
DT_RANGE = (1e-4, 0.1)
#: A quaternion this close to unit length is normalised; further away it is an error [1].
QUATERNION_NORM_TOLERANCE = 1e-3

_REQUIRED = ("robot", "waypoints")
_OPTIONAL = ("description", "angle_unit", "length_unit", "start", "ik", "timing", "path", "speed_scale",
             "dt", "outputs")


@dataclass(frozen=True, eq=False)
class JointWaypoint:
    """A waypoint given in joint space: ``q`` (dof,) [rad or m]."""

    q: np.ndarray


@dataclass(frozen=True, eq=False)
class PoseWaypoint:
    """A waypoint given as an end-frame pose: ``X_BE`` (4, 4), base frame [m]."""

    X_BE: np.ndarray


@dataclass(frozen=True, eq=False)
class Job:
    """A validated job in SI units.

    ``name``: the file's stem; ``source``: the job file (or ``<dict>``); ``waypoints``: JointWaypoint or
    PoseWaypoint values in order; ``start`` (dof,) [rad or m] or None: the IK seed of the first pose
    waypoint; ``ik``, ``timing``, ``path``: method names; ``speed_scale`` in (0, 1]; ``dt`` [s];
    ``outputs``: which of csv, npz, json, png, html, arm_png to write; ``inputs_sha256``: hash of the
    job file bytes followed by the robot file bytes.
    """

    name: str
    source: str
    robot: Robot
    waypoints: tuple[JointWaypoint | PoseWaypoint, ...]
    start: np.ndarray | None
    ik: str
    timing: str
    path: str
    speed_scale: float
    dt: float
    outputs: tuple[str, ...]
    inputs_sha256: str
    description: str = ""

    @property
    def has_poses(self) -> bool:
        return any(isinstance(w, PoseWaypoint) for w in self.waypoints)

    def __str__(self) -> str:
        kinds = "pose" if self.has_poses else "joint"
        return (f"Job {self.name!r} ({self.source}): {self.robot.name}, {len(self.waypoints)} {kinds} waypoints, "
                f"ik {self.ik}, timing {self.timing}, path {self.path}, speed scale {self.speed_scale:g}, "
                f"dt {self.dt:g} s")


class _Reader:
    """Validates one job document, raising JobFileError naming the source and the field."""

    def __init__(self, source: str, base_dir: Path):
        self.source = source
        self.base_dir = base_dir

    def fail(self, field: str, problem: str, value: Any = None):
        shown = f" (got {value!r})" if value is not None else ""
        raise JobFileError(f"{self.source}: {field}: {problem}{shown}")

    def check_keys(self, mapping, required, optional, field: str):
        if not isinstance(mapping, dict):
            self.fail(field, "must be a mapping of keys to values", mapping)
        prefix = f"{field}." if field != "document" else ""
        for key in mapping:
            if key not in required and key not in optional:
                self.fail(f"{prefix}{key}", f"unknown key; allowed: {', '.join((*required, *optional))}")
        for key in required:
            if key not in mapping:
                self.fail(f"{prefix}{key}", "required key is missing")

    def choice(self, doc, key, allowed, default):
        value = doc.get(key, default)
        if not isinstance(value, str) or value not in allowed:
            self.fail(key, f"must be one of {', '.join(allowed)}", value)
        return value

    def number(self, value, field: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(field, "must be a number", value)
        if not math.isfinite(value):
            self.fail(field, "must be finite", value)
        return float(value)

    def vector(self, value, size: int, field: str, what: str) -> np.ndarray:
        if not isinstance(value, (list, tuple)):
            self.fail(field, f"must be a list of {size} numbers ({what})", value)
        if len(value) != size:
            self.fail(field, f"must have {size} values ({what}), got {len(value)}")
        return np.array([self.number(v, f"{field}[{i}]") for i, v in enumerate(value)])

    def unit(self, doc, key, units, needed_by: str | None):
        if key not in doc:
            if needed_by:
                self.fail(key, f"required because {needed_by}; one of {', '.join(units)}")
            return None
        value = doc[key]
        if not isinstance(value, str) or value not in units:
            self.fail(key, f"must be one of {', '.join(units)}", value)
        return units[value]

    def robot(self, value) -> tuple[Robot, Path]:
        if not isinstance(value, str) or not value:
            self.fail("robot", "must be a preset name or a robot file path", value)
        candidate = Path(value)
        if candidate.suffix in (".yaml", ".yml") and not candidate.is_absolute():
            candidate = self.base_dir / candidate
        try:
            robot = load_robot(candidate if candidate.suffix in (".yaml", ".yml") else value)
        except RobotNotFoundError:
            self.fail("robot", f"unknown robot: neither a robot file nor a preset ({', '.join(preset_names())})",
                      value)
        except PipelineError as exc:
            raise JobFileError(f"{self.source}: robot: {exc}") from exc
        return robot, Path(robot.spec.source)

    def joint_values(self, value, robot: Robot, scales: np.ndarray, field: str) -> np.ndarray:
        """Joint values in file units -> SI, checked for length, finiteness and the limits."""
        q = self.vector(value, robot.dof, field, f"one per joint of {robot.name}") * scales
        limits = robot.limits
        for j in np.flatnonzero((q < limits.q_min) | (q > limits.q_max)):
            self.fail(f"{field}[{j}]", f"joint {robot.joint_names[j]} = {value[j]} is outside its limits "
                      f"[{limits.q_min[j] / scales[j]:.6g}, {limits.q_max[j] / scales[j]:.6g}] (file units)")
        return q

    def pose(self, value, length_scale: float, angle_scale: float, field: str) -> np.ndarray:
        """``{xyz, rpy}`` or ``{xyz, quaternion}`` -> X_BE (4, 4) [m]."""
        self.check_keys(value, ("xyz",), ("rpy", "quaternion"), field)
        if ("rpy" in value) == ("quaternion" in value):
            self.fail(field, "give exactly one of rpy or quaternion")
        p = self.vector(value["xyz"], 3, f"{field}.xyz", "position") * length_scale
        if "rpy" in value:
            rpy = self.vector(value["rpy"], 3, f"{field}.rpy", "roll, pitch, yaw") * angle_scale
            return self._transform(rpy_to_rotation(*rpy), p)
        quat = self.vector(value["quaternion"], 4, f"{field}.quaternion", "w, x, y, z")
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
            self.fail(f"{field}.quaternion", f"must be unit length within {QUATERNION_NORM_TOLERANCE:g}, "
                      f"|q| = {norm:.6g}")
        return quaternion_position_to_pose(quat / norm, p)

    @staticmethod
    def _transform(R: np.ndarray, p: np.ndarray) -> np.ndarray:
        X = np.eye(4)
        X[:3, :3], X[:3, 3] = R, p
        return X

    def bounded(self, doc, key, default, low, high, low_open: bool) -> float:
        value = self.number(doc.get(key, default), key)
        below = value <= low if low_open else value < low
        if below or value > high:
            self.fail(key, f"must be in {'(' if low_open else '['}{low:g}, {high:g}]", value)
        return value

    def outputs(self, value) -> tuple[str, ...]:
        if not isinstance(value, list) or not value:
            self.fail("outputs", f"must be a non-empty list of {', '.join(OUTPUTS)}", value)
        for i, item in enumerate(value):
            if item not in OUTPUTS:
                self.fail(f"outputs[{i}]", f"must be one of {', '.join(OUTPUTS)}", item)
            if value.index(item) != i:
                self.fail(f"outputs[{i}]", "listed twice", item)
        return tuple(value)

    def job(self, doc, name: str, job_bytes: bytes) -> Job:
        self.check_keys(doc, _REQUIRED, _OPTIONAL, "document")
        robot, robot_path = self.robot(doc["robot"])
        raw = doc["waypoints"]
        if not isinstance(raw, list) or len(raw) < 2:
            self.fail("waypoints", "must be a list of at least 2 waypoints (joint lists or pose mappings)",
                      raw if not isinstance(raw, list) else None)
        given_joints = any(not isinstance(w, dict) for w in raw) or "start" in doc
        revolute = np.array([j.is_revolute for j in robot.spec.joints])
        angle_reason = ("joint values are given" if given_joints and revolute.any()
                        else "pose waypoints use rpy" if any(isinstance(w, dict) and "rpy" in w for w in raw)
                        else None)
        length_reason = ("pose waypoints are given" if any(isinstance(w, dict) for w in raw)
                         else "prismatic joint values are given" if given_joints and not revolute.all()
                         else None)
        angle_scale = self.unit(doc, "angle_unit", ANGLE_UNITS, angle_reason)
        length_scale = self.unit(doc, "length_unit", LENGTH_UNITS, length_reason)
        scales = np.where(revolute, angle_scale or 1.0, length_scale or 1.0)
        waypoints = tuple(
            PoseWaypoint(self.pose(w, length_scale, angle_scale, f"waypoints[{k}]")) if isinstance(w, dict)
            else JointWaypoint(self.joint_values(w, robot, scales, f"waypoints[{k}]"))
            for k, w in enumerate(raw))
        start = self.joint_values(doc["start"], robot, scales, "start") if "start" in doc else None
        timing = self.choice(doc, "timing", TIMING_METHODS, "toppra")
        if timing == "ruckig" and "path" in doc:
            self.fail("path", "has no effect with timing ruckig, which times waypoint to waypoint; remove it")
        description = doc.get("description", "")
        if not isinstance(description, str):
            self.fail("description", "must be text", description)
        return Job(
            name=name,
            source=self.source,
            robot=robot,
            waypoints=waypoints,
            start=start,
            ik=self.choice(doc, "ik", IK_METHODS, "auto"),
            timing=timing,
            path=self.choice(doc, "path", SHAPES, "spline"),
            speed_scale=self.bounded(doc, "speed_scale", 1.0, 0.0, 1.0, low_open=True),
            dt=self.bounded(doc, "dt", DEFAULT_DT, *DT_RANGE, low_open=False),
            outputs=self.outputs(doc.get("outputs", list(DEFAULT_OUTPUTS))),
            inputs_sha256=hashlib.sha256(job_bytes + robot_path.read_bytes()).hexdigest(),
            description=description,
        )


def parse_job(doc: Any, source: str = "<dict>", name: str = "job", base_dir: str | Path = ".",
              job_bytes: bytes | None = None) -> Job:
    """Validate a job document (the parsed YAML mapping) into a Job.

    ``base_dir``: where relative robot file paths start; ``job_bytes``: the file's bytes for the input
    hash (default: the document as canonical JSON).
    """
    if job_bytes is None:
        job_bytes = json.dumps(doc, sort_keys=True, default=str).encode()
    return _Reader(source, Path(base_dir)).job(doc, name, job_bytes)


def load_job(path: str | Path) -> Job:
    """Read and validate a job file; relative robot paths in it are relative to the file."""
    path = Path(path)
    try:
        job_bytes = path.read_bytes()
    except OSError as exc:
        raise JobFileError(f"{path}: cannot read the job file: {exc.strerror}") from exc
    try:
        doc = yaml.safe_load(job_bytes)
    except yaml.YAMLError as exc:
        raise JobFileError(f"{path}: document: is not valid YAML: {exc}") from exc
    return parse_job(doc, source=str(path), name=path.stem, base_dir=path.parent, job_bytes=job_bytes)
