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

from ..errors import MissingFieldError, RobotFileError, RobotNotFoundError, file_error
from .arrays import inertia_matrix
from .schema import Document, Reader, document_from_data, load_document
from .units import ANGLE_UNITS, LENGTH_UNITS

#: The preset robot files, installed with the package (the checkout's models/ folder).
PRESETS = importlib.resources.files("pipeline.models")

CONVENTIONS = ("standard", "modified")
JOINT_TYPES = ("revolute", "prismatic")

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
    ``radius`` [m]: of the capsules around the link's DH legs (``pipeline.model.chain.geometry``; None: the default).
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
    radius: float | None = None

    @property
    def is_revolute(self) -> bool:
        return self.kind == "revolute"

    @property
    def is_continuous(self) -> bool:
        """A revolute joint that turns without end: no position limits (q_min = -inf, q_max = +inf)."""
        return math.isinf(self.q_min) and math.isinf(self.q_max)


@dataclass(frozen=True, eq=False)
class Limits:
    """Joint limits as SI arrays of length dof; ``qdd_max``, ``qddd_max``, ``tau_max`` [N m or N] are
    None when not given; a continuous joint has ``q_min`` -inf and ``q_max`` +inf. ``tcp_speed_max``
    [m/s] and ``tcp_accel_max`` [m/s^2]: limits of the TCP (the robot's end frame) that a job may add for
    its tool moves (None: not limited)."""

    q_min: np.ndarray
    q_max: np.ndarray
    qd_max: np.ndarray
    qdd_max: np.ndarray | None
    qddd_max: np.ndarray | None
    tau_max: np.ndarray | None = None
    tcp_speed_max: float | None = None
    tcp_accel_max: float | None = None

    @property
    def continuous(self) -> np.ndarray:
        """(dof,) bool: the joints without position limits (continuous joints)."""
        return np.isinf(self.q_min) & np.isinf(self.q_max)

    @property
    def q_middle(self) -> np.ndarray:
        """(dof,) the middle of each joint's range [rad or m]; 0 for a continuous joint, which has none."""
        return self._middle.copy()

    @cached_property
    def _middle(self) -> np.ndarray:
        continuous = self.continuous
        return (np.where(continuous, 0.0, self.q_min) + np.where(continuous, 0.0, self.q_max)) / 2.0


#: The makers whose controller a robot file's ``controller`` section may name.
CONTROLLER_MAKERS = ("abb", "fanuc", "yaskawa", "kuka", "ur")
#: Axis couplings a ``controller`` section may name: a FANUC pendant's J3 = q3 - q2.
COUPLINGS = ("fanuc_j2_j3",)


@dataclass(frozen=True, eq=False)
class ControllerSection:
    """A robot file's ``controller`` section in SI units: the ``maker``; per joint the controller's axis
    angle = ``direction`` (+-1) * q, coupled (``coupling``: None or ``fanuc_j2_j3``, J3 = J3 - J2), plus
    ``offset`` [rad]; ``X_B_base`` the controller's base frame in our base frame and ``X_E_flange`` its
    flange frame in our end frame, (4, 4) [m]; ``elbow_up`` the axis angles [rad] of a pose the maker
    calls elbow up."""

    maker: str
    direction: tuple[int, ...]
    offset: tuple[float, ...]
    coupling: str | None
    X_B_base: np.ndarray
    X_E_flange: np.ndarray
    elbow_up: tuple[float, ...]


#: Gravity for the payload diagram's static moments [m/s^2] (the makers' kgf·m to N·m).
STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True, eq=False)
class PayloadLimits:
    """A robot file's ``payload_limits``: the maker's payload diagram. ``rated_kg`` the rated payload [kg] (None: not
    given); ``wrist``: joint index -> (allowable static moment [N m] or None, allowable inertia [kg m^2] or None) about
    that joint's axis; ``source`` where the numbers come from (pipeline.model.payload_limits checks a load)."""

    rated_kg: float | None
    wrist: dict[int, tuple[float | None, float | None]]
    source: str


@dataclass(frozen=True, eq=False)
class RobotSpec:
    """A validated robot description in SI units.

    ``X_BaseD0``: pose of DH frame 0 in the robot base frame; ``X_DnE``: pose of the end frame in
    the last DH frame (the tool). Both 4x4 [m]. ``controller``: the file's controller section (None: none).
    ``payload_limits``: the maker's payload diagram (None: not given).
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
    controller: ControllerSection | None = None
    payload_limits: PayloadLimits | None = None

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

    @cached_property
    def reach_bound(self) -> float:
        """An upper bound of the end frame's distance from the base origin [m]: every length added up
        (|a| + |d| per row, the longest slide of each prismatic joint, base and tool offsets)."""
        slides = sum(max(abs(j.q_min), abs(j.q_max)) for j in self.joints if not j.is_revolute)
        return float(sum(abs(j.a) + abs(j.d) for j in self.joints) + slides
                     + np.linalg.norm(self.X_BaseD0[:3, 3]) + np.linalg.norm(self.X_DnE[:3, 3]))

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


#: Plausibility bounds that catch unit mistakes before any work (SI units).
MAX_LENGTH_M = 100.0          # any a, d, xyz, com or prismatic limit: farther is mm written under m
MIN_REACH_M = 0.01            # the sum of all lengths: shorter is metres written under mm
MAX_ANGLE_RAD = 2.0 * math.pi  # alpha, theta_offset, rpy: more than a turn is degrees written under rad
MAX_RANGE_RAD = 6.0 * math.pi  # a revolute range wider than three turns is a unit mistake or a continuous
                               # joint (real wrists reach +-450 deg, 2.5 turns; degrees under rad give ~50)
MAX_TURNS = 1000              # a revolute limit stays within this many turns of zero
MAX_SPEED_RAD_S = 100.0       # a revolute qd_max above ~5700 deg/s is a unit mistake
MIN_RATE = 1e-9               # qd_max, qdd_max, qddd_max [unit/s^k]: smaller cannot move
MIN_SPEED_RAD_S = 0.1         # a revolute qd_max below ~5.7 deg/s, or qdd_max below MIN_ACCEL_RAD_S2 (~29 deg/s^2), is
MIN_ACCEL_RAD_S2 = 0.5        #   slower than any robot axis: rad/s written under deg (3.93 rad/s read as 3.93 deg/s)
MAX_RATE = 1e9                # qdd_max, qddd_max, tau_max: beyond any drive
MAX_MASS_KG = 1e6
MAX_RADIUS_M = 2.0            # a link radius [m]: thicker is mm written under m
MIN_SIZE_M = 1e-6             # a link radius, a cell shape's size [m]: thinner is no shape (0 aborts Drake)

_TOP_REQUIRED = ("name", "convention", "length_unit", "angle_unit", "joints")
_TOP_OPTIONAL = ("tool", "base", "controller", "provenance", "description", "assumptions", "notes", "payload_limits")
_CONTROLLER_REQUIRED = ("maker",)
_CONTROLLER_OPTIONAL = ("axes", "coupling", "base", "flange", "elbow_up")
#: Required on every row but a continuous joint's, which must not give them.
POSITION_LIMITS = ("q_min", "q_max")
_JOINT_REQUIRED = ("a", "alpha", "d", "qd_max")
_JOINT_OPTIONAL = (*POSITION_LIMITS, "continuous", "theta_offset", "sign", "type", "name", "qdd_max", "qddd_max",
                   "tau_max", "inertia", "radius", "note")


class _RobotReader(Reader):
    """Validates one robot document into a RobotSpec (SI units), with the plausibility checks."""

    def __init__(self, document: Document):
        super().__init__(document, RobotFileError)
        self.length_unit = self.angle_unit = ""
        self.ls = self.as_ = 1.0

    def length(self, path, default=None) -> float:
        """A length in the file's unit -> [m], within MAX_LENGTH_M."""
        value = self.number(path, default) * self.ls
        if abs(value) > MAX_LENGTH_M:
            self.fail(path, f"is {abs(value):.4g} m, longer than any arm ({MAX_LENGTH_M:g} m): "
                      f"is length_unit: {self.length_unit} right?", self.get(path))
        return value

    def angle(self, path, default=None) -> float:
        """An angle in the file's unit -> [rad], at most a turn."""
        value = self.number(path, default) * self.as_
        if abs(value) > MAX_ANGLE_RAD + 1e-9:
            hint = "are these degrees? (angle_unit: rad)" if self.angle_unit == "rad" else "at most 360 deg"
            self.fail(path, f"is more than a full turn: {hint}", self.get(path))
        return value

    def rate(self, path, q_scale: float, high: float, hint: str) -> float:
        """A limit > 0 in q units per second^k -> SI, in [MIN_RATE, high]."""
        value = self.positive(path) * q_scale
        if value < MIN_RATE:
            self.fail(path, f"is too small to move by (below {MIN_RATE:g} in SI units)", self.get(path))
        if value > high:
            self.fail(path, f"is implausibly large ({value:.4g} in SI units, above {high:g}): {hint}", self.get(path))
        return value

    def plausible_rate(self, path, q_scale: float, low: float, per: str) -> None:
        """A revolute joint's speed or acceleration limit of at least ``low`` [rad/s^k]: below it no robot axis
        moves, and a value in degrees' place that reads right in radians gets that hint."""
        given = self.number(path)
        if not MIN_RATE <= given * q_scale < low:          # too small to move at all: ``rate`` says so
            return
        hint = (f": is it in rad/{per}? Then write {math.degrees(given):.4g} (deg/{per})" if self.angle_unit == "deg"
                and given >= low else "")
        self.fail(path, f"is {given * q_scale:.4g} rad/{per}, slower than any robot axis (at least {low:g} rad/{per})"
                  f"{hint}", self.get(path))

    def joint_range(self, path, kind: str, q_scale: float) -> tuple[float, float]:
        """(q_min, q_max) in SI: (-inf, +inf) for a continuous joint (``continuous_range``); else both
        given, q_min < q_max, and a revolute range within three turns."""
        if self.flag((*path, "continuous")):
            return self.continuous_range(path, kind)
        for key in POSITION_LIMITS:
            if key not in self.get(path):
                self.fail((*path, key), "required key is missing (a joint that turns without end says "
                          "continuous: true instead)", kind=MissingFieldError)
        q_min = self.number((*path, "q_min")) * q_scale
        q_max = self.number((*path, "q_max")) * q_scale
        if q_min >= q_max:
            self.fail((*path, "q_min"), f"must be < q_max ({self.get((*path, 'q_max'))!r})", self.get((*path, "q_min")))
        if kind == "prismatic":
            for key, value in (("q_min", q_min), ("q_max", q_max)):
                if abs(value) > MAX_LENGTH_M:
                    self.fail((*path, key), f"is {abs(value):.4g} m, longer than any axis ({MAX_LENGTH_M:g} m): "
                              f"is length_unit: {self.length_unit} right?", self.get((*path, key)))
            return q_min, q_max
        if max(abs(q_min), abs(q_max)) > MAX_TURNS * 2.0 * math.pi:
            self.fail((*path, "q_max"), f"is more than {MAX_TURNS} turns from zero", self.get((*path, "q_max")))
        if q_max - q_min > MAX_RANGE_RAD + 1e-9:
            hint = ("are these degrees? (angle_unit: rad)" if self.angle_unit == "rad"
                    else "a joint that turns without end says continuous: true instead of q_min and q_max")
            self.fail((*path, "q_max"), f"the range q_min..q_max is wider than three turns (1080 deg): {hint}",
                      self.get((*path, "q_max")))
        return q_min, q_max

    def continuous_range(self, path, kind: str) -> tuple[float, float]:
        """(-inf, +inf) [rad] for a row with ``continuous: true``: revolute, and with neither q_min nor
        q_max (a limit that would be ignored is refused, not dropped)."""
        if kind != "revolute":
            self.fail((*path, "continuous"), "only a revolute joint turns without end (this one is prismatic)", True)
        for key in POSITION_LIMITS:
            if key in self.get(path):
                self.fail((*path, key), "a continuous joint has no position limits: drop q_min and q_max, or drop "
                          "continuous: true to keep the joint within them", self.get((*path, key)))
        return -math.inf, math.inf

    def inertia(self, path) -> LinkInertia:
        self.mapping(path, ("mass",), ("com", "I"))
        mass = self.number((*path, "mass"), low=0.0, low_open=True, high=MAX_MASS_KG, unit="kg")
        com = np.zeros(3)
        if self.has((*path, "com")):
            self.vector((*path, "com"), 3, "x, y, z")
            com = np.array([self.length((*path, "com", i)) for i in range(3)])
        moments = self.vector((*path, "I"), 6, "Ixx, Iyy, Izz, Ixy, Ixz, Iyz [kg m^2]", default=[0.0] * 6)
        if np.abs(moments).max() > MAX_RATE:
            self.fail((*path, "I"), f"is implausibly large (above {MAX_RATE:g} kg m^2)", self.get((*path, "I")))
        I_Lcm = inertia_matrix(moments)
        principal = np.linalg.eigvalsh(I_Lcm)
        if principal[0] < 0.0 or principal[0] + principal[1] < principal[2] * (1.0 - 1e-12):
            self.fail((*path, "I"), "is not a physical inertia (principal moments must be >= 0 and obey the "
                      "triangle inequality)", self.get((*path, "I")))
        return LinkInertia(mass=mass, p_LoLcm=com, I_Lcm=I_Lcm)

    def joint(self, index: int) -> DhJoint:
        path = ("joints", index)
        raw = self.mapping(path, _JOINT_REQUIRED, _JOINT_OPTIONAL)
        kind = self.choice((*path, "type"), JOINT_TYPES, default="revolute")
        sign = self.number((*path, "sign"), default=1)
        if sign not in (1.0, -1.0):
            self.fail((*path, "sign"), "must be 1 or -1", raw.get("sign"))
        q_scale = self.as_ if kind == "revolute" else self.ls
        q_min, q_max = self.joint_range(path, kind, q_scale)
        speed_high = MAX_SPEED_RAD_S if kind == "revolute" else MAX_LENGTH_M
        unit_hint = f"is angle_unit: {self.angle_unit} right?" if kind == "revolute" else \
            f"is length_unit: {self.length_unit} right?"
        optional = {key: self.rate((*path, key), q_scale, MAX_RATE, unit_hint) if key in raw else None
                    for key in ("qdd_max", "qddd_max")}
        if kind == "revolute":
            self.plausible_rate((*path, "qd_max"), q_scale, MIN_SPEED_RAD_S, "s")
            if optional["qdd_max"] is not None:
                self.plausible_rate((*path, "qdd_max"), q_scale, MIN_ACCEL_RAD_S2, "s^2")
        tau_max = self.rate((*path, "tau_max"), 1.0, MAX_RATE, "N m or N") if "tau_max" in raw else None
        if tau_max is not None and "inertia" not in raw:
            self.fail((*path, "inertia"), "tau_max needs the link's inertia (torques come from its dynamics)",
                      kind=MissingFieldError)
        name = self.name((*path, "name"), default=f"joint{index + 1}")
        return DhJoint(
            name=name,
            kind=kind,
            a=self.length((*path, "a")),
            alpha=self.angle((*path, "alpha")),
            d=self.length((*path, "d")),
            theta_offset=self.angle((*path, "theta_offset"), default=0),
            sign=sign,
            q_min=q_min,
            q_max=q_max,
            qd_max=self.rate((*path, "qd_max"), q_scale, speed_high, unit_hint),
            qdd_max=optional["qdd_max"],
            qddd_max=optional["qddd_max"],
            inertia=self.inertia((*path, "inertia")) if "inertia" in raw else None,
            tau_max=tau_max,
            radius=self.radius((*path, "radius")) if "radius" in raw else None,
        )

    def radius(self, path) -> float:
        """A link radius in the file's unit -> [m], in [MIN_SIZE_M, MAX_RADIUS_M]."""
        value = self.positive(path, self.length_unit) * self.ls
        if not value >= MIN_SIZE_M:
            self.fail(path, f"is {value:.4g} m, thinner than any shape ({MIN_SIZE_M:g} m, checked in metres)",
                      self.get(path))
        if value > MAX_RADIUS_M:
            self.fail(path, f"is {value:.4g} m, thicker than any arm link ({MAX_RADIUS_M:g} m): is length_unit: "
                      f"{self.length_unit} right?", self.get(path))
        return value

    def frame(self, key: str) -> np.ndarray:
        """The optional ``base`` or ``tool`` transform -> (4, 4) [m] (identity when absent)."""
        if not self.has((key,)):
            return np.eye(4)
        X = self.pose((key,), self.ls, self.as_, complete=False, max_length_m=MAX_LENGTH_M)
        if self.has((key, "rpy")):
            for i in range(3):
                self.angle((key, "rpy", i))
        return X

    def payload_limits(self, names: list[str]) -> PayloadLimits | None:
        """The optional ``payload_limits: {rated: kg, wrist: {JOINT: {moment: N m, inertia: kg m^2}}, source: text}``
        (the maker's payload diagram: models/README.md, "Payload limits"); the wrist entries name the last three
        joints."""
        path = ("payload_limits",)
        if not self.has(path):
            return None
        self.mapping(path, ("source",), ("rated", "wrist"))
        source = self.text((*path, "source"), max_chars=1000)
        rated = self.number((*path, "rated"), low=0.0, high=MAX_MASS_KG, low_open=True, unit="kg") \
            if self.has((*path, "rated")) else None
        wrist = {}
        if self.has((*path, "wrist")):
            table = self.get((*path, "wrist"))
            if not isinstance(table, dict) or not table:
                self.fail((*path, "wrist"), "must map wrist joint names to {moment: N m, inertia: kg m^2}", table)
            for name in table:
                entry = (*path, "wrist", name)
                if name not in names[-3:]:
                    self.fail(entry, f"names no wrist joint (the last three: {', '.join(map(str, names[-3:]))})", name)
                self.mapping(entry, (), ("moment", "inertia"))
                moment, inertia = (self.number((*entry, key), low=0.0, high=MAX_RATE, low_open=True,
                                               unit=unit) if self.has((*entry, key)) else None
                                   for key, unit in (("moment", "N m"), ("inertia", "kg m^2")))
                if moment is None and inertia is None:
                    self.fail(entry, "gives neither moment [N m] nor inertia [kg m^2]", table[name])
                wrist[names.index(name)] = (moment, inertia)
        return PayloadLimits(rated, wrist, source)

    def controller(self, dof: int) -> ControllerSection | None:
        """The optional ``controller`` section (models/README.md, "The controller section") in SI units."""
        path = ("controller",)
        if not self.has(path):
            return None
        raw = self.mapping(path, _CONTROLLER_REQUIRED, _CONTROLLER_OPTIONAL)
        maker = self.choice((*path, "maker"), CONTROLLER_MAKERS)
        direction, offset = (1,) * dof, (0.0,) * dof
        if self.has((*path, "axes")):
            self.mapping((*path, "axes"), (), ("direction", "offset"))
            signs = self.vector((*path, "axes", "direction"), dof, "+1 or -1 per joint", default=[1.0] * dof)
            for i, sign in enumerate(signs):
                if sign not in (1.0, -1.0):
                    self.fail((*path, "axes", "direction", i), "must be 1 or -1", sign)
            direction = tuple(int(v) for v in signs)
            if self.has((*path, "axes", "offset")):
                self.vector((*path, "axes", "offset"), dof, f"one angle per joint [{self.angle_unit}]")
                offset = tuple(self.angle((*path, "axes", "offset", i)) for i in range(dof))
        coupling = self.choice((*path, "coupling"), COUPLINGS) if "coupling" in raw else None
        if coupling is not None and (maker != "fanuc" or dof < 3):
            self.fail((*path, "coupling"), f"is a FANUC pendant's J2/J3 coupling; this is a {maker} robot with "
                      f"{dof} joints", coupling)
        frames = []
        for key in ("base", "flange"):
            X = np.eye(4)
            if self.has((*path, key)):
                X = self.pose((*path, key), self.ls, self.as_, complete=False, max_length_m=MAX_LENGTH_M)
                if self.has((*path, key, "rpy")):
                    for i in range(3):
                        self.angle((*path, key, "rpy", i))
            frames.append(X)
        elbow_up = (0.0,) * dof
        if self.has((*path, "elbow_up")):
            self.vector((*path, "elbow_up"), dof, f"the controller's axis angles [{self.angle_unit}]")
            elbow_up = tuple(self.number((*path, "elbow_up", i)) * self.as_ for i in range(dof))
        return ControllerSection(maker, direction, offset, coupling, frames[0], frames[1], elbow_up)

    def spec(self) -> RobotSpec:
        self.mapping((), _TOP_REQUIRED, _TOP_OPTIONAL)
        name = self.name(("name",))
        convention = self.choice(("convention",), CONVENTIONS)
        self.length_unit = self.choice(("length_unit",), tuple(LENGTH_UNITS))
        self.angle_unit = self.choice(("angle_unit",), tuple(ANGLE_UNITS))
        self.ls, self.as_ = LENGTH_UNITS[self.length_unit], ANGLE_UNITS[self.angle_unit]
        count = len(self.sequence(("joints",), min_items=1, what="joint rows"))
        joints = tuple(self.joint(i) for i in range(count))
        names = [j.name for j in joints]
        for i, n in enumerate(names):
            if names.index(n) != i:
                self.fail(("joints", i, "name"), "joint names must be unique", n)
        for key in ("qdd_max", "qddd_max", "tau_max", "radius"):
            given = [getattr(j, key) is not None for j in joints]
            if any(given) and not all(given):
                self.fail(("joints", given.index(False), key), "given for some joints, so required for all",
                          kind=MissingFieldError)
        spec = RobotSpec(
            name=name,
            convention=convention,
            joints=joints,
            X_BaseD0=self.frame("base"),
            X_DnE=self.frame("tool"),
            source=self.source,
            length_unit=self.length_unit,
            angle_unit=self.angle_unit,
            provenance=self.get(("provenance",)),
            controller=self.controller(len(joints)),
            payload_limits=self.payload_limits(names),
        )
        if spec.reach_bound < MIN_REACH_M:
            self.fail(("joints",), f"the arm reaches at most {spec.reach_bound * 1e3:.3g} mm from its base: "
                      f"are the lengths in metres under length_unit: {self.length_unit}?")
        return spec


#: What a missing optional limit is and where its value comes from, for the error of a method that needs it.
_LIMIT_HINTS = {
    "qdd_max": "the joints' acceleration limits [unit/s^2]: add qdd_max to every joint row. Datasheets rarely "
               "give it; from the time T a joint takes to reach full speed, qdd_max = qd_max / T (the presets "
               "assume T = 0.3 s); import-urdf --time-to-full-speed T fills it in (models/README.md, 'Acceleration "
               "and jerk limits')",
    "qddd_max": "the joints' jerk limits [unit/s^3]: add qddd_max to every joint row, e.g. qdd_max / 0.1 s as the "
                "presets assume (models/README.md, 'Acceleration and jerk limits')",
}


def missing_limit_error(spec: RobotSpec, key: str, needed_by: str) -> RobotFileError:
    """The error of a robot file without ``key`` (qdd_max or qddd_max), which ``needed_by`` needs: a
    MissingFieldError naming the file, the first joint row without it and that row's line."""
    joint = next(i for i, j in enumerate(spec.joints) if getattr(j, key) is None)
    path = ("joints", joint, key)
    line = None
    if Path(spec.source).is_file():
        try:
            line = load_document(spec.source, RobotFileError).line(path)
        except RobotFileError:
            line = None
    return file_error(MissingFieldError, RobotFileError)(
        spec.source, f"joints[{joint}].{key}", f"required by {needed_by}; the file gives none: {_LIMIT_HINTS[key]}",
        joint=joint, line=line)


def parse_robot_spec(doc: Any, source: str = "<dict>") -> RobotSpec:
    """Validate a robot document (the parsed YAML mapping) into a RobotSpec."""
    return _RobotReader(document_from_data(doc, source)).spec()


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
    return _RobotReader(load_document(resolve_robot_path(name_or_path), RobotFileError)).spec()
