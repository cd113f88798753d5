"""Job files (YAML) -> validated, SI-unit ``Job`` values.

The format is documented in ``trajectories/README.md``. Degrees and millimetres exist only in the
file: waypoints, poses and the start configuration are converted here once. Reading is two steps: the
job's own fields (the schema reader, no robot needed), then its waypoints against the robot it names
(lengths, limits, and pose targets within the arm's reach, which catches unit mistakes). Values that fit
only another unit are refused with a hint: TCP speeds (limits and tool moves' own), accelerations and
tool offsets under mm that are m/s, m/s^2 or metres, rpy values that are radians under deg or degrees
under rad. Every error is a ``JobFileError`` naming the file, the line, the field and, for waypoints,
the waypoint index; a robot file without the limits the timing needs is that file's own
``RobotFileError``. ``Job.error`` gives errors found after reading (IK, collisions) the line of their
field.
"""

from __future__ import annotations

import hashlib
import importlib.resources
import json
import logging
import math
import os
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ..cell.cell_file import Cell, cell_names, load_cell, resolve_cell_path
from ..errors import ConfigurationError, JobFileError, MissingFieldError, RobotNotFoundError
from ..files.arrays import inertia_matrix
from ..files.branch_names import parse_configuration
from ..files.choices import (DEFAULT_DT, DEFAULT_PATH_SHAPE, DEFAULT_PLANNER, FULL_POSE, IK_METHODS, MOVES, PATH_SHAPES,
                             PLAN_MODES, PLAN_TIME_BUDGET_S, PLANNERS, SINGULARITY_POLICIES, TARGET_KINDS, TIMING_ALIASES,
                             TIMING_LIMITS, TIMING_METHODS)
from ..files.robot_spec import missing_limit_error, preset_names, resolve_robot_path
from ..files.schema import Document, Reader, document_from_data, field_name, load_document
from ..files.units import ANGLE_UNITS, LENGTH_UNITS
from ..model.payload_limits import payload_problems
from ..model.robot import Robot, load_robot, robot_with_tool
from .actions import (ACTION_KINDS, COMMENT, GRIP, INPUT, MAX_ACTION_TIME_S, MAX_COMMENT_CHARS, MAX_SIGNAL_NUMBER,
                      OUTPUT, PULSE, RELEASE, SET, SIGNAL_NAME, WAIT, WAIT_INPUT, Action, Signal, held_after,
                      stops_motion)
from .payload import MAX_GYRATION_M, MAX_PAYLOAD_KG, Payload, combined, physical_inertia_problem

OUTPUTS = ("csv", "npz", "json", "png", "html", "arm_png", "ros2_yaml", "json_trajectory", "tcp_png", "rapid", "ls",
           "jbi", "krl", "urscript")
#: Written when a job lists no outputs (the 3-D views, html and arm_png, the controller formats,
#: ros2_yaml and json_trajectory, and the programs in a controller's own language, rapid (ABB RAPID
#: .mod), ls (FANUC LS), jbi (Yaskawa INFORM), krl (KUKA KRL .src + .dat) and urscript (URScript), only
#: when asked for; the TCP figure, tcp_png, by default when the job has tool moves or TCP limits, and only
#: then).
DEFAULT_OUTPUTS = ("csv", "npz", "json", "png")
#: Allowed sample times [s].
DT_RANGE = (1e-4, 0.1)
#: A pose target closer to the base origin than this fraction of the closest end-frame position among
#: REACH_SAMPLES random configurations is refused as a unit mistake (metres written under mm).
INNER_REACH_FRACTION = 0.5
REACH_SAMPLES = 4096

_REQUIRED = ("waypoints",)
_OPTIONAL = ("robot", "description", "angle_unit", "length_unit", "start", "ik", "timing", "path", "speed_scale",
             "dt", "outputs", "allow_branch_change", "tool", "tcp_speed_max", "tcp_accel_max", "singularity", "cell",
             "plan", "planner", "plan_time_budget", "plan_tilt_max", "tcp_speed_limit", "payload", "parts", "signals")
#: The keys of a pose waypoint besides its pose: what IK must match, the configuration it must have (ours,
#: a controller's, or both), and how the TCP gets there (move, via point, zone, speed).
_POSE_EXTRA = ("target", "config", "controller_config", "move", "via", "zone", "speed", "do")
#: How each vendor's configuration is written under a pose waypoint's ``controller_config`` (the syntax
#: of ``pipeline.model.vendors.configuration.parse_configuration``), for messages.
CONTROLLER_CONFIG_EXAMPLES = {"abb": "{abb: [0, -1, 1, 2]}", "fanuc": "{fanuc: 'N U T, 0, 0, 0'}",
                              "yaskawa": "{yaskawa: [1, 0, 0, 0, 0, 0]}", "kuka": "{kuka: \"S 'B010', T 'B100011'\"}"}
#: The keys of a joint waypoint written as a mapping (a plain list is its joint values alone).
_JOINT_REQUIRED = ("joints",)
_JOINT_OPTIONAL = ("speed", "zone", "do")
#: Largest TCP speed [m/s] and acceleration [m/s^2] a job may ask for: beyond any arm (unit mistakes).
MAX_TCP_SPEED = 20.0
MAX_TCP_ACCEL = 1000.0
#: Under ``length_unit: mm``, a TCP speed below 1 mm/s, an acceleration below 10 mm/s^2 and a tool
#: offset below 1 mm (but not 0) are m/s, m/s^2 and metres written under mm: refused with a hint (a value
#: that small is stated unambiguously under ``length_unit: m``).
MIN_TCP_SPEED_MM = 1.0
MIN_TCP_ACCEL_MM = 10.0
MIN_TOOL_OFFSET_MM = 1.0
#: Under ``angle_unit: deg``, rpy values are radians written under deg when every rpy value of the
#: waypoints (or of the tool, judged apart) is within a turn (2 pi) and one of them is a fraction within
#: RADIAN_LIKE_TOLERANCE of a nonzero multiple of pi/4 (3.14, 1.5708, 0.785, ...); [180, 0, 90],
#: [0, 0, 0] and whole angles are degrees.
RADIAN_LIKE_TOLERANCE = 0.01
#: The TCP quantities a job may give -> (largest [SI], smallest under mm [mm/s^k], SI unit): the bounds above.
_TCP_BOUNDS = {"speed": (MAX_TCP_SPEED, MIN_TCP_SPEED_MM, "m/s"),
               "acceleration": (MAX_TCP_ACCEL, MIN_TCP_ACCEL_MM, "m/s^2")}
#: A joint move's ``speed`` is a percentage of the joint speed limits, at most this.
MAX_JOINT_SPEED_PERCENT = 100.0

#: The demo jobs, installed with the package (the checkout's trajectories/jobs/).
DEMO_JOBS = importlib.resources.files("pipeline.demo_jobs")
_log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class JointWaypoint:
    """A waypoint given in joint space: ``q`` (dof,) [rad or m], reached by a joint move at ``speed`` (a
    fraction in (0, 1] of the joint speed limits; None: 1) and passed with ``zone`` [m] (as a
    PoseWaypoint's)."""

    q: np.ndarray
    zone: float = 0.0
    speed: float | None = None
    move: str = "joint"
    actions: tuple[Action, ...] = ()
    is_tool_move = False


@dataclass(frozen=True, eq=False)
class PoseWaypoint:
    """A waypoint given as an end-frame pose: ``X_BE`` (4, 4), base frame [m]; ``target``: what IK must
    match (pose, position+axis, position); ``config``: the configuration it must have (parts of
    shoulder/elbow/wrist; None: the rule of ``pipeline.model.ik.branches`` picks); ``controller_config``: a
    controller's configuration data, (vendor, its integer fields as ``pipeline.model.vendors.configuration``
    orders them), naming one IK branch and 2 pi representative (None: none); ``move``: how the TCP gets
    there (joint, linear, circular through ``via`` (3,) [m]); ``zone`` [m]: the waypoint is passed
    without stopping, the TCP leaving the programmed path at most this far before it and rejoining it at
    most this far after (0: an exact stop, except between two joint moves, which a joint path passes
    through); ``speed``: the move's own speed, a TCP speed [m/s] for a tool move, a fraction in (0, 1]
    of the joint speed limits for a joint move (None: the job's ``tcp_speed_max``, or 1); ``actions``: what the
    controller does once there (``pipeline.program.actions``; a JointWaypoint's too)."""

    X_BE: np.ndarray
    target: str = FULL_POSE
    config: dict | None = None
    move: str = "joint"
    via: np.ndarray | None = None
    zone: float = 0.0
    speed: float | None = None
    controller_config: tuple[str, tuple[int, ...]] | None = None
    actions: tuple[Action, ...] = ()

    @property
    def is_tool_move(self) -> bool:
        return self.move != "joint"


@dataclass(frozen=True, eq=False)
class Job:
    """A validated job in SI units.

    ``name``: the file's stem; ``source``: the job file (or ``<dict>``); ``waypoints``: JointWaypoint or
    PoseWaypoint values in order; ``start`` (dof,) [rad or m] or None: the IK seed of the first pose
    waypoint; ``ik``, ``timing``: method names; ``path``: the path shape (None with ``ruckig``, which
    times waypoint to waypoint); ``speed_scale`` in (0, 1]; ``dt`` [s];
    ``outputs``: which of csv, npz, json, png, html, arm_png, ros2_yaml, json_trajectory, tcp_png, rapid, ls,
    jbi, krl, urscript to write (the last five: the program in ABB RAPID, FANUC LS, Yaskawa INFORM, KUKA KRL,
    URScript);
    ``inputs_sha256``: hash of the job file bytes followed by the robot file bytes;
    ``allow_branch_change``: a change of IK branch between consecutive pose waypoints is reported
    instead of refused. ``tool``: X_ET (4, 4) [m], the TCP in the robot's end frame, or None (then
    ``robot`` is the robot as its file gives it; with a tool, ``robot``'s end frame is the TCP and every
    pose is a TCP pose); ``tcp_speed_max`` [m/s]: the default speed of tool moves, ``tcp_accel_max``
    [m/s^2]: the TCP's acceleration limit on tool moves, or None (neither limits joint moves);
    ``payload``: the tool's load (``pipeline.program.payload.Payload``: mass, centre of mass and inertia in the flange
    frame, source) or None: not given (controller programs then carry a marked placeholder); ``parts``: the parts the
    waypoints' ``grip`` and ``release`` actions name (name -> Payload); ``signals``: the named digital signals the
    waypoints' actions use (name ->
    ``pipeline.program.actions.Signal``);
    ``tcp_speed_limit`` [m/s] or None: a TCP speed limit that holds everywhere (a safety-rated reduced
    speed), certified on the whole profile; ``singularity``:
    what a tool move does near a singularity (stop, slow_down). ``cell``: the Cell the job runs in (None:
    none; then nothing is checked for collision); ``plan``: direct or collision_free (joint moves
    replaced by planned ones where the direct path comes too close); ``planner`` (an OMPL planner name)
    and ``plan_time_budget`` [s] per planned move; ``plan_tilt_max`` [rad] or None: the largest angle
    between the tool's z axis and the cell's vertical on planned moves (``pipeline.cell.tilt``). ``document``:
    the file as read, so that errors found after reading (IK, collisions, timing) name the line of their
    field (``error``). A pose waypoint's ``controller_config`` is written as ``{vendor: configuration}``,
    the text a controller's program writes or its integer fields (``pipeline.model.vendors.configuration``):
    ``{abb: [0, -1, 1, 2]}`` (confdata cf1, cf4, cf6, cfx), ``{fanuc: 'N U T, 0, 0, 0'}`` (CONFIG),
    ``{yaskawa: [1, 0, 0, 0, 0, 0]}`` (RCONF l, m, n, o, p, q), ``{kuka: "S 'B010', T 'B100011'"}``
    (Status, Turn).
    """

    name: str
    source: str
    robot: Robot
    waypoints: tuple[JointWaypoint | PoseWaypoint, ...]
    start: np.ndarray | None
    ik: str
    timing: str
    path: str | None
    speed_scale: float
    dt: float
    outputs: tuple[str, ...]
    inputs_sha256: str
    description: str = ""
    allow_branch_change: bool = False
    tool: np.ndarray | None = None
    tcp_speed_max: float | None = None
    tcp_accel_max: float | None = None
    singularity: str = "stop"
    cell: Cell | None = None
    plan: str = "direct"
    planner: str = DEFAULT_PLANNER
    plan_time_budget: float = PLAN_TIME_BUDGET_S
    plan_tilt_max: float | None = None
    document: Document | None = None
    tcp_speed_limit: float | None = None
    payload: Payload | None = None
    signals: dict = field(default_factory=dict)
    parts: dict = field(default_factory=dict)

    def location(self, path: tuple) -> str:
        """``file:line: field`` of the field at ``path`` (``file: field`` where the line is unknown)."""
        return f"{self.source if self.document is None else _where(self.document, path)}: {field_name(path)}"

    def error(self, path: tuple, problem: str, value: Any = None) -> JobFileError:
        """The JobFileError of a problem found after reading, naming this file, the field at ``path``
        (e.g. ``("waypoints", 3)``) and its line."""
        line = None if self.document is None else self.document.line(path)
        return JobFileError(self.source, field_name(path), problem, value=value, line=line)

    @property
    def has_poses(self) -> bool:
        return any(isinstance(w, PoseWaypoint) for w in self.waypoints)

    @property
    def has_tool_moves(self) -> bool:
        return any(isinstance(w, PoseWaypoint) and w.is_tool_move for w in self.waypoints)

    def __str__(self) -> str:
        kinds = "pose" if self.has_poses else "joint"
        return (f"Job {self.name!r} ({self.source}): {self.robot.name}, {len(self.waypoints)} {kinds} waypoints, "
                f"ik {self.ik}, timing {self.timing}, path {self.path or '-'}, speed scale {self.speed_scale:g}, "
                f"dt {self.dt:g} s")


class _JobReader(Reader):
    """Validates one job document: its own fields first, then its waypoints against the robot."""

    def __init__(self, document: Document, base_dir: Path):
        super().__init__(document, JobFileError)
        self.base_dir = base_dir
        self.cell: Cell | None = None

    def robot_reference(self) -> str | Path:
        """The ``robot`` field: a preset name, or a robot file path (relative to the job file); without
        one, the cell's robot."""
        self.mapping((), _REQUIRED, _OPTIONAL)
        if not self.has(("robot",)):
            if self.cell is None:
                self.fail(("robot",), "required key is missing (or name a cell, whose robot the job then uses)",
                          kind=MissingFieldError)
            return self.cell.robot
        value = self.text(("robot",), max_chars=4096)
        candidate = Path(value)
        if candidate.suffix not in (".yaml", ".yml"):
            return value
        return candidate if candidate.is_absolute() else self.base_dir / candidate

    def load_cell(self) -> Cell | None:
        """The cell the job names: a cell file (relative to the job file) or a demo cell's name (its own
        errors name the cell file)."""
        self.mapping((), _REQUIRED, _OPTIONAL)
        if not self.has(("cell",)):
            return None
        value = Path(self.text(("cell",), max_chars=4096))
        path = Path(os.path.normpath(value if value.is_absolute() else self.base_dir / value))
        if not path.is_file() and str(value) in cell_names():
            path = resolve_cell_path(str(value))
        if not path.is_file():
            self.fail(("cell",), f"no cell file at {path}, nor a demo cell of that name; demo cells: "
                      f"{', '.join(cell_names())}", str(value))
        return load_cell(path)

    def load_robot(self) -> Robot:
        """The robot the job names (a robot file's own errors name that file); with a cell, the job may
        name only the cell's robot."""
        self.cell = self.load_cell()
        reference = self.robot_reference()
        if self.cell is not None and _robot_file(reference) != _robot_file(self.cell.robot):
            self.fail(("robot",), f"the cell {self.cell.name} holds {self.cell.robot}; a job in it moves that robot "
                      "(leave robot out)", self.get(("robot",)))
        try:
            return load_robot(reference)
        except RobotNotFoundError:
            self.fail(("robot",), f"unknown robot: neither a robot file nor a preset ({', '.join(preset_names())})",
                      self.get(("robot",)))

    def units(self, robot: Robot) -> tuple[float | None, float | None]:
        """(angle, length) SI factors; each required when the waypoints use it."""
        raw = self.sequence(("waypoints",), min_items=2, what="waypoints (joint lists or mappings, pose mappings)")
        poses = [w for w in raw if _is_pose(w)]
        joints_given = len(poses) < len(raw) or self.has(("start",))
        revolute = np.array([j.is_revolute for j in robot.spec.joints])
        angle_reason = ("joint values are given" if joints_given and revolute.any()
                        else "pose waypoints use rpy" if any("rpy" in w for w in poses)
                        else "plan_tilt_max is given" if self.has(("plan_tilt_max",)) else None)
        length_reason = ("pose waypoints are given" if poses
                         else "prismatic joint values are given" if joints_given and not revolute.all()
                         else "a joint waypoint gives a zone" if any(isinstance(w, dict) and "zone" in w for w in raw)
                         else None)
        return (self.unit(("angle_unit",), ANGLE_UNITS, angle_reason),
                self.unit(("length_unit",), LENGTH_UNITS, length_reason))

    def joint_values(self, path, robot: Robot, scales: np.ndarray) -> np.ndarray:
        """Joint values in file units -> SI, checked for length, finiteness and the limits."""
        q = self.vector(path, robot.dof, f"one per joint of {robot.name}") * scales
        limits = robot.limits
        for j in np.flatnonzero((q < limits.q_min) | (q > limits.q_max)):
            value = self.get((*path, int(j)))
            low, high = limits.q_min[j] / scales[j], limits.q_max[j] / scales[j]
            side, excess = ("below", low - value) if q[j] < limits.q_min[j] else ("above", value - high)
            hint = ""
            if self.get(("angle_unit",)) == "rad" and robot.spec.joints[j].is_revolute and \
                    limits.q_min[j] <= math.radians(value) <= limits.q_max[j] and excess > 0.01 * (high - low):
                hint = "; are these degrees? (angle_unit: rad)"
            self.fail((*path, int(j)), f"joint {robot.joint_names[j]} = {value!r} is outside its limits "
                      f"[{low:.6g}, {high:.6g}] (file units): {excess:.3g} {side}{hint}")
        return q

    def pose_waypoint(self, path, robot: Robot, length_scale: float, angle_scale: float | None,
                      reach: tuple[float, float]) -> PoseWaypoint:
        """A pose waypoint: its pose (within the arm's reach), target kind and configuration."""
        X = self.pose_target(path, robot, length_scale, angle_scale, reach)
        target = self.choice((*path, "target"), TARGET_KINDS, FULL_POSE)
        config = None
        if self.has((*path, "config")):
            from ..model.ik.branches import configuration_family     # the IK kernels only where a waypoint names a branch

            try:
                config = parse_configuration(self.get((*path, "config")), *configuration_family(robot))
            except ConfigurationError as exc:
                self.fail((*path, "config"), str(exc), self.get((*path, "config")))
        move = self.choice((*path, "move"), MOVES, "joint")
        via = None
        if move == "circular":
            if not self.has((*path, "via")):
                self.fail((*path, "via"), "required: a circular move passes through a via point, via: {xyz: [...]}",
                          kind=MissingFieldError)
            self.mapping((*path, "via"), ("xyz",), ())
            via = self.vector((*path, "via", "xyz"), 3, "x, y, z") * length_scale
        elif self.has((*path, "via")):
            self.fail((*path, "via"), f"is the via point of a circular move; this move is {move}")
        if move != "joint" and target != FULL_POSE:
            self.fail((*path, "target"), f"a {move} move follows the full TCP pose: target must be {FULL_POSE}", target)
        speed = self.joint_speed(path, pose=True) if move == "joint" else \
            self.tcp_value((*path, "speed"), length_scale, "speed")
        return PoseWaypoint(X, target, config, move, via, self.zone(path, length_scale), speed,
                            self.controller_config(path, robot, target))

    def controller_config(self, path, robot: Robot, target: str) -> tuple[str, tuple[int, ...]] | None:
        """A pose waypoint's ``controller_config``, one vendor and its configuration data (e.g.
        ``{abb: [0, -1, 1, 2]}``, CONTROLLER_CONFIG_EXAMPLES) -> (vendor, its integer fields); None when
        absent. Refused: another shape, an unknown vendor, malformed fields, a target other than the full
        pose, and a robot whose closed form is not a spherical wrist's (the vendors' fields describe
        only those arms; the UR family has none)."""
        field = (*path, "controller_config")
        if not self.has(field):
            return None
        from ..model.vendors.axes import VENDORS                 # the IK kernels only where a waypoint names a branch
        from ..model.vendors.configuration import parse_configuration as parse_vendor_configuration

        value = self.get(field)
        examples = ", ".join(CONTROLLER_CONFIG_EXAMPLES.values())
        if not isinstance(value, dict) or len(value) != 1:
            self.fail(field, f"is one controller vendor and its configuration data, e.g. {examples}", value)
        (vendor, fields), = value.items()
        if vendor not in VENDORS:
            self.fail(field, f"names the vendor {vendor!r}; the vendors: {', '.join(VENDORS)} (e.g. {examples})",
                      value)
        try:
            parsed = parse_vendor_configuration(vendor, fields)
        except ConfigurationError as exc:
            self.fail((*field, vendor), f"{exc} (e.g. {CONTROLLER_CONFIG_EXAMPLES[vendor]})", fields)
        if target != FULL_POSE:
            self.fail((*field, vendor), f"names a solution of the full pose: target must be {FULL_POSE}, not "
                      f"{target}", fields)
        self.check_vendor_family(field, robot, vendor, fields)
        return vendor, parsed

    def check_vendor_family(self, field, robot: Robot, vendor: str, fields) -> None:
        """The robot's closed form is a spherical wrist's, the only family with vendor configuration data."""
        from ..files.branch_names import FAMILY_TITLES, SPHERICAL_WRIST
        from ..model.ik.analytic import analytic_solver_for

        solver = analytic_solver_for(robot)
        if solver.applicable and solver.family == SPHERICAL_WRIST:
            return
        family = FAMILY_TITLES[solver.family] if solver.applicable else f"no closed-form family ({solver.reason})"
        self.fail((*field, vendor), f"{robot.name} has {family}: {vendor} configuration data has fields only for 6R "
                  "arms with a spherical wrist; name its branch with config: instead", fields)

    def joint_waypoint(self, path, robot: Robot, scales: np.ndarray, length_scale: float | None) -> JointWaypoint:
        """A joint waypoint: its joint values (a list), or ``{joints, speed, zone}`` (``speed`` a
        percentage of the joint speed limits, ``zone`` in length_unit)."""
        if not isinstance(self.get(path), dict):
            return JointWaypoint(self.joint_values(path, robot, scales))
        self.mapping(path, _JOINT_REQUIRED, _JOINT_OPTIONAL)
        q = self.joint_values((*path, "joints"), robot, scales)
        return JointWaypoint(q, self.zone(path, length_scale), self.joint_speed(path, pose=False))

    def zone(self, path, length_scale: float | None) -> float:
        """A waypoint's ``zone`` in length_unit -> [m] (0 when absent: an exact stop)."""
        if not self.has((*path, "zone")):
            return 0.0
        return self.number((*path, "zone"), low=0.0, unit=self.get(("length_unit",))) * length_scale

    def joint_speed(self, path, pose: bool) -> float | None:
        """A joint move's ``speed``, a percentage of the joint speed limits in (0, 100] -> a fraction
        (None when absent). ``pose``: the waypoint is a pose, whose tool moves take a TCP speed instead
        (the hint for a value above 100)."""
        speed_path = (*path, "speed")
        if not self.has(speed_path):
            return None
        percent = self.positive(speed_path, unit="%")
        if percent > MAX_JOINT_SPEED_PERCENT:
            unit = self.get(("length_unit",))
            hint = (f"; {percent:g} looks like a TCP speed in {unit}/s: give the move `move: linear` or write a "
                    "percentage") if pose else ", in (0, 100]"
            self.fail(speed_path, f"joint moves take a percentage of the joint speed limits{hint}", percent)
        return percent / 100.0

    def pose_target(self, path, robot: Robot, length_scale: float, angle_scale: float | None,
                    reach: tuple[float, float]) -> np.ndarray:
        """A pose waypoint's pose -> X_BE (4, 4) [m], its position within the arm's reach."""
        X = self.pose(path, length_scale, angle_scale, extra=_POSE_EXTRA)
        distance = math.hypot(*X[:3, 3])
        inner, outer = reach
        unit = self.get(("length_unit",))
        if distance > outer:
            self.fail((*path, "xyz"), f"is {distance:.4g} m from the base origin, beyond the reach of {robot.name} "
                      f"({outer:.4g} m): is length_unit: {unit} right?", self.get((*path, "xyz")))
        if distance < inner:
            self.fail((*path, "xyz"), f"is {distance * 1e3:.4g} mm from the base origin, closer than the end "
                      f"frame of {robot.name} comes ({inner * 1e3:.4g} mm): is length_unit: {unit} right?",
                      self.get((*path, "xyz")))
        return X

    def waypoints(self, robot: Robot, signals: dict[str, Signal], parts: dict[str, Payload]
                  ) -> tuple[tuple[JointWaypoint | PoseWaypoint, ...], np.ndarray | None]:
        """(waypoints, start) in SI units, their actions using the job's ``signals`` and ``parts``."""
        angle_scale, length_scale = self.units(robot)
        revolute = np.array([j.is_revolute for j in robot.spec.joints])
        scales = np.where(revolute, angle_scale or 1.0, length_scale or 1.0)
        raw = self.get(("waypoints",))
        reach = _reach_interval(robot) if any(_is_pose(w) for w in raw) else (0.0, math.inf)
        waypoints = tuple(
            self.pose_waypoint(("waypoints", k), robot, length_scale, angle_scale, reach)
            if _is_pose(w) else self.joint_waypoint(("waypoints", k), robot, scales, length_scale)
            for k, w in enumerate(raw))
        waypoints = tuple(replace(w, actions=self.actions(("waypoints", k), signals, parts))
                          if isinstance(raw[k], dict) else w for k, w in enumerate(waypoints))
        self.check_moves(waypoints)
        self.check_grips(waypoints)
        start = self.joint_values(("start",), robot, scales) if self.has(("start",)) else None
        return waypoints, start

    def check_moves(self, waypoints) -> None:
        """The first waypoint is where the motion starts (no move to it, so no tool move and no speed);
        a zone joins the move to its waypoint and the next one, of any kinds, so neither the first
        waypoint nor the last (where the motion ends at rest) has one."""
        if waypoints[0].is_tool_move:
            self.fail(("waypoints", 0, "move"), "the first waypoint is where the motion starts: it has no move "
                      "to it", waypoints[0].move)
        if waypoints[0].speed is not None:
            self.fail(("waypoints", 0, "speed"), "the first waypoint is where the motion starts: it has no move "
                      "to it to give a speed", self.get(("waypoints", 0, "speed")))
        ends = {0: "the motion starts at rest on the first waypoint: there is no move into it to blend",
                len(waypoints) - 1: "the motion ends at rest on the last waypoint: there is no next move to blend "
                                    "into (a zone joins the move to its waypoint and the next one)"}
        for k, reason in ends.items():
            if waypoints[k].zone > 0.0:
                self.fail(("waypoints", k, "zone"), reason, self.get(("waypoints", k, "zone")))
        for k, waypoint in enumerate(waypoints):
            if waypoint.zone > 0.0 and stops_motion(waypoint.actions):
                self.fail(("waypoints", k, "zone"), "the waypoint's actions wait or change the load there, so the "
                          "motion stops: remove the zone (or move the action to a waypoint without one)",
                          self.get(("waypoints", k, "zone")))

    def check_loads(self, spec, payload: Payload | None, parts: dict[str, Payload], waypoints) -> None:
        """Every load the program carries (the tool's, and with each set of parts it holds) within the robot file's
        payload diagram (``pipeline.model.payload_limits``); the error names the part gripped last (or the payload),
        the axis, the value and the limit."""
        carried = {(): payload} if payload is not None else {}
        for k in range(len(waypoints)):
            held = held_after([w.actions for w in waypoints], k)
            if held and held not in carried:
                carried[held] = combined([payload] + [parts[name] for name in held])
        for held, load in carried.items():
            problems = payload_problems(spec, load)
            if problems:
                what = " + ".join(["tool"] * (payload is not None) + list(held))
                self.fail(("parts", held[-1]) if held else ("payload",),
                          f"{what} ({load.mass:.3g} kg) is beyond the {spec.name}'s payload diagram: "
                          f"{'; '.join(problems)} (payload_limits of {Path(spec.source).name})")

    def check_grips(self, waypoints) -> None:
        """A part is gripped only when not held and released only when held (the program starts holding none)."""
        held: set[str] = set()
        for k, waypoint in enumerate(waypoints):
            for i, action in enumerate(waypoint.actions):
                path = ("waypoints", k, "do", i, action.kind)
                if action.kind == GRIP and action.part in held:
                    self.fail(path, "the robot already holds this part here (gripped earlier, not released)",
                              action.part)
                if action.kind == RELEASE and action.part not in held:
                    self.fail(path, "the robot does not hold this part here (no grip of it before; the program starts "
                              "holding nothing)", action.part)
                if action.kind == GRIP:
                    held.add(action.part)
                elif action.kind == RELEASE:
                    held.discard(action.part)

    def signals(self) -> dict[str, Signal]:
        """``signals: {name: {output: N} or {input: N}}`` (N the controller's number, or null where not known)."""
        if not self.has(("signals",)):
            return {}
        table = self.get(("signals",))
        if not isinstance(table, dict):
            self.fail(("signals",), "must map signal names to {output: N} or {input: N}", table)
        out = {}
        for name in table:
            path = ("signals", name)
            if not SIGNAL_NAME.match(name):
                self.fail(path, "a signal's name is a letter, then letters, digits or underscores (at most 32)", name)
            entry = self.get(path, {})
            if not isinstance(entry, dict) or len(entry) != 1 or next(iter(entry)) not in (OUTPUT, INPUT):
                self.fail(path, "must be {output: N} or {input: N} (N the controller's signal number, or null)", entry)
            direction, number = next(iter(entry.items()))
            if number is not None:
                if isinstance(number, bool) or not isinstance(number, int) or not 0 <= number <= MAX_SIGNAL_NUMBER:
                    self.fail((*path, direction), f"must be a whole number in [0, {MAX_SIGNAL_NUMBER}] or null", number)
            out[name] = Signal(name, direction, number)
        return out

    def actions(self, path, signals: dict[str, Signal], parts: dict[str, Payload]) -> tuple[Action, ...]:
        """A waypoint's ``do:`` list (``pipeline.program.actions``) -> its Actions."""
        path = (*path, "do")
        if not self.has(path):
            return ()
        return tuple(self.action((*path, i), signals, parts) for i in range(len(self.sequence(path, 1, "actions"))))

    def action(self, path, signals: dict[str, Signal], parts: dict[str, Payload]) -> Action:
        entry = self.get(path)
        kinds = [key for key in (entry if isinstance(entry, dict) else ()) if key in ACTION_KINDS]
        if len(kinds) != 1:
            self.fail(path, "must be one action: {set: NAME, value: on}, {pulse: NAME, time: s}, {wait: s}, "
                      "{wait_input: NAME, value: on, timeout: s}, {comment: TEXT}, {grip: PART} or {release: PART}",
                      entry)
        kind = kinds[0]
        extra = {SET: ((SET, "value"), ()), PULSE: ((PULSE, "time"), ()), WAIT: ((WAIT,), ()),
                 WAIT_INPUT: ((WAIT_INPUT, "value"), ("timeout",)), COMMENT: ((COMMENT,), ()),
                 GRIP: ((GRIP,), ()), RELEASE: ((RELEASE,), ())}[kind]
        self.mapping(path, *extra)
        if kind in (GRIP, RELEASE):
            name = self.get((*path, kind))
            if not isinstance(name, str) or name not in parts:
                listed = ", ".join(parts) or "none"
                self.fail((*path, kind), f"names no part of the job's parts: table ({listed}); add it, e.g. parts: "
                          f"{{{name}: {{mass: 3.0, com: [0, 0, 120]}}}}", name)
            return Action(kind, part=name)
        if kind == COMMENT:
            text = self.text((*path, COMMENT), max_chars=MAX_COMMENT_CHARS)
            if any(c in text for c in "\r\n\"'") or not text.isprintable():
                self.fail((*path, COMMENT), "a comment is one line of printable text without quotes", text)
            return Action(COMMENT, text=text)
        if kind == WAIT:
            return Action(WAIT, time_s=self.seconds((*path, WAIT)))
        signal = self.signal((*path, kind), signals, INPUT if kind == WAIT_INPUT else OUTPUT)
        if kind == PULSE:
            return Action(PULSE, signal, True, time_s=self.seconds((*path, "time")))
        timeout = self.seconds((*path, "timeout")) if self.has((*path, "timeout")) else None
        return Action(kind, signal, self.on_off((*path, "value")), timeout_s=timeout)

    def seconds(self, path) -> float:
        """A time in (0, MAX_ACTION_TIME_S] [s], with a hint when it reads as milliseconds."""
        value = self.get(path)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and value > MAX_ACTION_TIME_S:
            self.fail(path, f"is in seconds, at most {MAX_ACTION_TIME_S:g}: are these milliseconds?", value)
        return self.number(path, low=0.0, high=MAX_ACTION_TIME_S, low_open=True, unit="s")

    def signal(self, path, signals: dict[str, Signal], direction: str) -> str:
        """The name at ``path``, a signal of the job's table with ``direction``."""
        name = self.get(path)
        known = signals.get(name) if isinstance(name, str) else None
        if known is None:
            listed = ", ".join(signals) or "none"
            self.fail(path, f"names no signal of the job's signals: table ({listed}); add it, e.g. signals: "
                      f"{{{name}: {{{direction}: 1}}}}", name)
        if known.direction != direction:
            self.fail(path, f"is a digital {known.direction}; this action needs a digital {direction}", name)
        return name

    def on_off(self, path) -> bool:
        """on/off (or true/false, 1/0) -> a bool."""
        value = self.get(path)
        words = {"on": True, "off": False, "true": True, "false": False, "high": True, "low": False}
        if isinstance(value, bool):
            return value
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        if isinstance(value, str) and value.lower() in words:
            return words[value.lower()]
        self.fail(path, "must be on or off", value)

    def tool(self, robot: Robot, length_scale: float | None, angle_scale: float | None) -> np.ndarray | None:
        """The job's ``tool`` -> X_ET (4, 4) [m] (None when absent)."""
        if not self.has(("tool",)):
            return None
        if length_scale is None:
            self.fail(("length_unit",), "required because a tool is given", kind=MissingFieldError)
        X_ET = self.pose(("tool",), length_scale, angle_scale, complete=False, max_length_m=robot.spec.reach_bound)
        offset_mm = float(np.linalg.norm(X_ET[:3, 3])) * 1e3
        if self.get(("length_unit",)) == "mm" and 0.0 < offset_mm < MIN_TOOL_OFFSET_MM:
            xyz = self.get(("tool", "xyz"))
            self.fail(("tool", "xyz"), f"puts the TCP {offset_mm:.3g} mm from the end frame (the flange) under "
                      f"length_unit: mm, shorter than any tool ({MIN_TOOL_OFFSET_MM:g} mm): is this in metres? Then "
                      f"write {_listed(np.array(xyz) * 1e3)}. (An offset this small is stated unambiguously with "
                      f"length_unit: m: {_listed(np.array(xyz) * 1e-3)}; none at all is [0, 0, 0].)", xyz)
        return X_ET

    def tcp_value(self, path, length_scale: float | None, quantity: str) -> float | None:
        """A TCP ``quantity`` (speed or acceleration, _TCP_BOUNDS) at ``path`` in length_unit/s^k -> SI
        (None when absent): ``tcp_speed_max``, ``tcp_accel_max``, ``tcp_speed_limit`` or a tool move's
        ``speed``. At most the largest [SI] and, under mm, at least the smallest [mm/s^k] (below: SI
        written under mm)."""
        if not self.has(path):
            return None
        high, low_mm, unit = _TCP_BOUNDS[quantity]
        if length_scale is None:
            self.fail(("length_unit",), f"required because {field_name(path)} is given "
                      f"({unit.replace('m', 'length_unit', 1)})", kind=MissingFieldError)
        written = self.positive(path)
        if self.get(("length_unit",)) == "mm" and written < low_mm:
            self.fail(path, f"is this {unit}? Under length_unit: mm, {written:g} is {written:g} m{unit}, below any "
                      f"TCP {quantity} ({low_mm:g} m{unit}): for {written:g} {unit} write {written * 1e3:g}. (A value "
                      f"this low is stated unambiguously with length_unit: m: {written * 1e-3:g}.)", written)
        value = written * length_scale
        if value > high:
            self.fail(path, f"is {value:.4g} {unit}, above any arm ({high:g} {unit}): is length_unit right?", written)
        return value

    def check_rpy_unit(self) -> None:
        """rpy values that fit only the other angle unit: under rad, more than a turn (degrees); under
        deg, radians by the rule of RADIAN_LIKE_TOLERANCE, the tool and the waypoints judged apart."""
        waypoints = [("waypoints", k, "rpy") for k in range(len(self.get(("waypoints",))))]
        for paths in ([("tool", "rpy")], waypoints):
            given = [(path, np.array(self.get(path), dtype=float)) for path in paths if self.has(path)]
            if self.get(("angle_unit",)) == "rad":
                self.check_turns(given)
            elif all(np.abs(rpy).max() <= 2.0 * math.pi + RADIAN_LIKE_TOLERANCE for _, rpy in given):
                self.check_radian_like(given)

    def check_turns(self, given: list) -> None:
        """Under angle_unit: rad, no rpy angle beyond a full turn (degrees written under rad)."""
        for path, rpy in given:
            if np.abs(rpy).max() > 2.0 * math.pi + 1e-9:
                self.fail(path, "has an angle of more than a full turn: are these degrees? (angle_unit: rad)",
                          self.get(path))

    def check_radian_like(self, given: list) -> None:
        """Under angle_unit: deg, no rpy value a fraction within RADIAN_LIKE_TOLERANCE of a nonzero
        multiple of pi/4 (the caller checked that every value is within a turn)."""
        for path, rpy in given:
            quarter_turns = np.round(rpy / (math.pi / 4.0))
            like = (quarter_turns != 0) & (np.abs(rpy - quarter_turns * math.pi / 4.0) <= RADIAN_LIKE_TOLERANCE) \
                & (rpy != np.round(rpy))
            if like.any():
                i = int(np.argmax(like))
                self.fail(path, f"are these radians? Under angle_unit: deg they turn by a few degrees at most, and "
                          f"{rpy[i]:g} is {_pi_fraction(int(quarter_turns[i]))} in radians: for radians write "
                          f"{_listed(np.degrees(rpy))}. (Angles this small in degrees are stated unambiguously with "
                          f"angle_unit: rad: {_listed(np.radians(rpy))}.)", self.get(path))

    def check_timing_limits(self, robot: Robot, timing: str) -> None:
        """The robot file gives the limits ``timing`` needs (TIMING_LIMITS): a RobotFileError naming the
        robot file, the joint and its line otherwise."""
        for key in TIMING_LIMITS[timing]:
            if getattr(robot.limits, key) is None:
                raise missing_limit_error(robot.spec, key, f"timing {timing} (the job {self.source})")

    def outputs(self, has_tcp: bool) -> tuple[str, ...]:
        """The outputs to write; ``has_tcp``: the job has tool moves or TCP limits (a TCP figure)."""
        path = ("outputs",)
        if not self.has(path):
            return DEFAULT_OUTPUTS + (("tcp_png",) if has_tcp else ())
        value = self.sequence(path, min_items=1, what=f"outputs ({', '.join(OUTPUTS)})")
        for i, item in enumerate(value):
            self.choice((*path, i), OUTPUTS)
            if value.index(item) != i:
                self.fail((*path, i), "listed twice", item)
            if item == "tcp_png" and not has_tcp:
                self.fail((*path, i), "the TCP figure needs tool moves or TCP limits (tcp_speed_max, tcp_accel_max, "
                          "tcp_speed_limit) in the job", item)
        return tuple(value)

    def tcp_limits(self, waypoints, length_scale: float | None) -> dict:
        """``tcp_speed_max`` [m/s] (the default speed of tool moves: required when one gives no ``speed``),
        ``tcp_accel_max`` [m/s^2] (the TCP's acceleration on tool moves) and ``tcp_speed_limit`` [m/s] (a
        TCP speed limit everywhere), each None when absent. The first two without tool moves limit
        nothing: a warning says so, naming the file and line."""
        limits = {"tcp_speed_max": self.tcp_value(("tcp_speed_max",), length_scale, "speed"),
                  "tcp_accel_max": self.tcp_value(("tcp_accel_max",), length_scale, "acceleration"),
                  "tcp_speed_limit": self.tcp_value(("tcp_speed_limit",), length_scale, "speed")}
        unset = next((k for k, w in enumerate(waypoints) if w.is_tool_move and w.speed is None), None)
        if unset is not None and limits["tcp_speed_max"] is None:
            self.fail(("tcp_speed_max",), f"required because waypoint {unset} is a {waypoints[unset].move} move and "
                      "gives no speed of its own (the TCP's default speed along tool moves, length_unit/s; or give "
                      "every linear and circular waypoint its `speed`)", kind=MissingFieldError)
        if not any(w.is_tool_move for w in waypoints):
            for key in ("tcp_speed_max", "tcp_accel_max"):
                if limits[key] is not None:
                    _log.warning("%s: %s: no longer limits anything in a job without tool moves (linear or circular): "
                                 "it applies to tool moves only, and joint moves run at their joint speed limits; for "
                                 "a TCP speed limit everywhere use tcp_speed_limit", _where(self.document, (key,)), key)
        return limits

    def check_ruckig(self, waypoints, tcp_speed_limit: float | None) -> None:
        """ruckig times waypoint to waypoint, at rest at each, off the path: no tool moves, TCP limits,
        zones or per-move speeds."""
        if tcp_speed_limit is not None or any(w.is_tool_move for w in waypoints):
            self.fail(("timing",), "ruckig times waypoint to waypoint and leaves the path: tool moves and TCP limits "
                      "need toppra or topp3", "ruckig")
        for k, w in enumerate(waypoints):
            for key, given in (("zone", w.zone > 0.0), ("speed", w.speed is not None)):
                if given:
                    self.fail(("waypoints", k, key), "timing ruckig times waypoint to waypoint, at rest at each: zones "
                              "and per-move speeds need toppra or topp3", self.get(("waypoints", k, key)))

    def job(self, robot: Robot, name: str, inputs_sha256: str) -> Job:
        angle_scale, length_scale = self.units(robot)
        tool = self.tool(robot, length_scale, angle_scale)
        flange_spec = robot.spec
        if tool is not None:
            robot = robot_with_tool(robot, tool)
        signals = self.signals()
        parts = self.parts(length_scale)
        payload = self.load(("payload",), length_scale, "tool")
        waypoints, start = self.waypoints(robot, signals, parts)
        self.check_loads(flange_spec, payload, parts, waypoints)
        timing = self.choice(("timing",), TIMING_METHODS + tuple(TIMING_ALIASES), "toppra")
        timing = TIMING_ALIASES.get(timing, timing)
        self.check_rpy_unit()
        self.check_timing_limits(robot, timing)
        tcp = self.tcp_limits(waypoints, length_scale)
        if timing == "ruckig":
            self.check_ruckig(waypoints, tcp["tcp_speed_limit"])
        if timing == "ruckig" and self.has(("path",)):
            self.fail(("path",), "has no effect with timing ruckig, which times waypoint to waypoint; remove it")
        path = None if timing == "ruckig" else self.choice(("path",), PATH_SHAPES, DEFAULT_PATH_SHAPE)
        if timing == "topp3" and path == "linear":
            self.fail(("path",), "timing topp3 (jerk-limited path following) needs a path whose d2q/ds2 is continuous: "
                      "monotone or spline, not linear (its corners jump in acceleration)", path)
        return Job(
            name=name,
            source=self.source,
            robot=robot,
            waypoints=waypoints,
            start=start,
            ik=self.choice(("ik",), IK_METHODS, "auto"),
            timing=timing,
            path=path,
            speed_scale=self.number(("speed_scale",), 1.0, low=0.0, high=1.0, low_open=True),
            dt=self.number(("dt",), DEFAULT_DT, *DT_RANGE, unit="s"),
            outputs=self.outputs(any(w.is_tool_move for w in waypoints) or any(v is not None for v in tcp.values())),
            inputs_sha256=inputs_sha256,
            description=self.text(("description",), max_chars=10_000) if self.has(("description",)) else "",
            allow_branch_change=self.flag(("allow_branch_change",)),
            tool=tool,
            **tcp,
            singularity=self.choice(("singularity",), SINGULARITY_POLICIES, "stop"),
            cell=self.cell,
            document=self.document,
            payload=payload,
            signals=signals,
            parts=parts,
            **self.planning(angle_scale),
        )

    def parts(self, length_scale: float | None) -> dict[str, Payload]:
        """``parts: {name: {mass, com, inertia, source}}``: what the ``grip`` actions pick up (``load``)."""
        if not self.has(("parts",)):
            return {}
        table = self.get(("parts",))
        if not isinstance(table, dict) or not table:
            self.fail(("parts",), "must map part names to {mass: kg, com: [x, y, z], inertia: [...], source: text}",
                      table)
        for name in table:
            if not isinstance(name, str) or not SIGNAL_NAME.match(name):
                self.fail(("parts", name), "a part's name is a letter, then letters, digits or underscores (at most "
                          "32)", name)
        return {name: self.load(("parts", name), length_scale, name) for name in table}

    def load(self, path, length_scale: float | None, name: str) -> Payload | None:
        """A load at ``path`` (``pipeline.program.payload``): ``{mass: kg, com: [x, y, z], inertia: [Ixx, Iyy, Izz,
        Ixy, Ixz, Iyz], source: text}``; com (length_unit) the centre of mass in the flange frame (the flange's origin
        when absent), inertia [kg m^2 whatever length_unit] about it in the flange's axes (absent: a point mass),
        source where the numbers come from. None when absent."""
        if not self.has(path):
            return None
        self.mapping(path, ("mass",), ("com", "inertia", "source"))
        mass = self.number((*path, "mass"), low=0.0, high=MAX_PAYLOAD_KG, low_open=True, unit="kg")
        com = np.zeros(3)
        if self.has((*path, "com")):
            if length_scale is None:
                self.fail(("length_unit",), f"required because {field_name(path)} gives com (length_unit: m or mm)",
                          kind=MissingFieldError)
            com = self.vector((*path, "com"), 3, "x, y, z of the centre of mass in the flange frame") * length_scale
        inertia = np.zeros((3, 3))
        if self.has((*path, "inertia")):
            six = self.vector((*path, "inertia"), 6, "Ixx, Iyy, Izz, Ixy, Ixz, Iyz [kg m^2] about the centre of mass")
            if np.max(np.abs(six)) > mass * MAX_GYRATION_M ** 2:
                self.fail((*path, "inertia"), f"is in kg m^2: more than {mass:g} kg x ({MAX_GYRATION_M:g} m)^2 about "
                          "the centre of mass is no load a robot carries: are these kg mm^2 (divide by 1e6)?",
                          self.get((*path, "inertia")))
            inertia = inertia_matrix(six)
            problem = physical_inertia_problem(inertia)
            if problem is not None:
                self.fail((*path, "inertia"), f"is no body's inertia: {problem}", self.get((*path, "inertia")))
        source = self.text((*path, "source"), max_chars=500) if self.has((*path, "source")) else ""
        return Payload(mass, com, inertia, source, name)

    def planning(self, angle_scale: float | None) -> dict:
        """``plan``, ``planner``, ``plan_time_budget`` and ``plan_tilt_max`` (in the file's angle unit, at
        most a quarter turn); planning needs a cell."""
        plan = self.choice(("plan",), PLAN_MODES, "direct")
        keys = ("planner", "plan_time_budget", "plan_tilt_max")
        for key in ("plan",) + keys:
            if self.has((key,)) and self.cell is None:
                self.fail((key,), "needs a cell to plan in (cell: path/to/cell.yaml)", self.get((key,)))
        if plan == "direct":
            for key in keys:
                if self.has((key,)):
                    self.fail((key,), "has no effect with plan: direct (plan: collision_free plans)", self.get((key,)))
        tilt = None
        if self.has(("plan_tilt_max",)):
            degrees = self.get(("angle_unit",)) == "deg"
            tilt = angle_scale * self.number(("plan_tilt_max",), low=0.0, high=90.0 if degrees else np.pi / 2.0,
                                             low_open=True, unit="deg" if degrees else "rad (are these degrees?)")
        return {"plan": plan, "planner": self.choice(("planner",), PLANNERS, DEFAULT_PLANNER),
                "plan_time_budget": self.number(("plan_time_budget",), PLAN_TIME_BUDGET_S, low=0.0, high=600.0,
                                                low_open=True, unit="s"),
                "plan_tilt_max": tilt}


def _is_pose(raw_waypoint) -> bool:
    """Whether a waypoint as written is a pose (a mapping without ``joints``), not joint values."""
    return isinstance(raw_waypoint, dict) and "joints" not in raw_waypoint


def _where(document: Document, path: tuple) -> str:
    """``file:line`` of the field at ``path`` in ``document`` (``file`` where the line is unknown)."""
    line = document.line(path)
    return f"{document.source}{'' if line is None else f':{line}'}"


def _listed(values) -> str:
    """Numbers as a file would give them: [0, 0, 100], 6 significant digits."""
    return f"[{', '.join(f'{v:.6g}' for v in values)}]"


def _pi_fraction(quarter_turns: int) -> str:
    """3 -> "3 pi/4", 4 -> "pi", -2 -> "-pi/2"."""
    fraction = Fraction(quarter_turns, 4)
    number = "" if abs(fraction.numerator) == 1 else f"{abs(fraction.numerator)} "
    return f"{'-' if fraction < 0 else ''}{number}pi{'' if fraction.denominator == 1 else f'/{fraction.denominator}'}"


def _robot_file(reference: str | Path) -> Path | None:
    """The robot file a preset name or path stands for, resolved (None when there is none)."""
    try:
        return resolve_robot_path(reference).resolve()
    except RobotNotFoundError:
        return None


def _reach_interval(robot: Robot) -> tuple[float, float]:
    """(inner, outer) distances of the end frame from the base origin [m] that a pose target may have:
    outer is the spec's reach bound; inner INNER_REACH_FRACTION of the closest of REACH_SAMPLES seeded
    random configurations."""
    Q = robot.random_configurations(np.random.default_rng(0), REACH_SAMPLES)
    closest = float(np.linalg.norm(robot.fk_batch(Q)[:, :3, 3], axis=1).min())
    return INNER_REACH_FRACTION * closest, robot.spec.reach_bound * (1.0 + 1e-9)


def _sha256(job_bytes: bytes, robot: Robot, cell: Cell | None) -> str:
    """Hash of the job file's bytes followed by the robot file's bytes (a preset's or a path's) and the
    cell file's bytes (if any)."""
    cell_bytes = b"" if cell is None or cell.source == "<dict>" else Path(cell.source).read_bytes()
    return hashlib.sha256(job_bytes + Path(robot.spec.source).read_bytes() + cell_bytes).hexdigest()


def parse_job(doc: Any, source: str = "<dict>", name: str = "job", base_dir: str | Path = ".",
              job_bytes: bytes | None = None) -> Job:
    """Validate a job document (the parsed YAML mapping) into a Job.

    ``base_dir``: where relative robot file paths start; ``job_bytes``: the file's bytes for the input
    hash (default: the document as canonical JSON).
    """
    if job_bytes is None:
        job_bytes = json.dumps(doc, sort_keys=True, default=str).encode()
    return _read_job(document_from_data(doc, source), Path(base_dir), name, job_bytes)


def load_job(path: str | Path) -> Job:
    """Read and validate a job file (or the demo job of that name: ``resolve_job_path``); relative robot and
    cell paths in it are relative to the file."""
    path = resolve_job_path(path)
    document = load_document(path, JobFileError)
    return _read_job(document, path.parent, path.stem, document.content)


def resolve_job_path(name_or_path: str | Path) -> Path:
    """A demo job's name (``gp7_pick_place``, ``demo_job_names``) or a path to a job file -> the file's path (a
    path is returned as given: the reader words its errors)."""
    if not Path(name_or_path).exists() and str(name_or_path) in demo_job_names():
        return Path(str(DEMO_JOBS / f"{name_or_path}.yaml"))
    return Path(name_or_path)


def demo_job_names() -> list[str]:
    """Names of the demo jobs (``trajectories/jobs/*.yaml``, installed as ``pipeline.demo_jobs``)."""
    return sorted(entry.name[: -len(".yaml")] for entry in DEMO_JOBS.iterdir() if entry.name.endswith(".yaml"))


def _read_job(document: Document, base_dir: Path, name: str, job_bytes: bytes) -> Job:
    reader = _JobReader(document, base_dir)
    robot = reader.load_robot()
    return reader.job(robot, name, _sha256(job_bytes, robot, reader.cell))
