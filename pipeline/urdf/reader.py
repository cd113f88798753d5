"""URDF XML -> a `UrdfModel`: links (with their mass properties) and joints, in SI units as URDF is.

Only what kinematics and dynamics need is read: joint type, parent, child, origin, axis, limits and
mimic; link inertials. Visuals, collisions, transmissions and plugins are skipped, so meshes need not
exist. Errors are UrdfFileError naming the file and the element (``joint[elbow].limit.velocity``).

Every count and number is bounded before it multiplies work: the file's size (a regular file of at
most MAX_URDF_BYTES, read no further), its links and joints (MAX_URDF_LINKS), and numbers plausible
for a robot (lengths within MAX_LENGTH_M, masses, inertias, limits; an axis any non-zero finite
vector, normalised without overflow).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UrdfFileError
from ..files.poses import rpy_position_to_pose
from ..files.robot_spec import MAX_LENGTH_M, MAX_MASS_KG, MAX_RATE, MAX_TURNS
from ..files.special import special_kind

#: Largest URDF read [bytes]: robot descriptions are tens of kB; this leaves room for comments.
MAX_URDF_BYTES = 16 * 1024 * 1024
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
XACRO_NAMESPACE = "{http://ros.org/wiki/xacro}"
#: An axis shorter than this is not a direction [1].
MIN_AXIS_NORM = 1e-9
#: Most links (and so joints) of a URDF: robot descriptions have tens, a cell with sensors a few
#: hundred; more is not a robot, and every link costs time in the chain search.
MAX_URDF_LINKS = 10_000
#: Largest joint limit [rad or m]: as many turns as a robot file allows (MAX_TURNS).
MAX_LIMIT = MAX_TURNS * 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class UrdfInertial:
    """A link's mass properties: ``mass`` [kg], ``X_LI`` (4, 4) pose of the inertial frame in the link
    frame [m], ``I`` (3, 3) [kg m^2] about the centre of mass, in the inertial frame's axes."""

    mass: float
    X_LI: np.ndarray
    I: np.ndarray


@dataclass(frozen=True, eq=False)
class UrdfJoint:
    """One ``<joint>``: ``X_PJ`` (4, 4) the joint frame (= child link frame at q = 0) in the parent link
    frame [m]; ``axis`` (3,) unit, in the joint frame; limits in rad or m (per s), ``effort`` [N m or N]
    (None when absent or 0, which ROS packages write for "unknown"); ``mimic`` the joint it copies."""

    name: str
    kind: str
    parent: str
    child: str
    X_PJ: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    velocity: float | None
    effort: float | None
    mimic: str | None

    @property
    def is_movable(self) -> bool:
        return self.kind != "fixed"


@dataclass(frozen=True, eq=False)
class UrdfModel:
    """A parsed URDF: the robot's ``name``, ``links`` (name -> UrdfInertial or None) and ``joints`` in
    file order; ``source`` the file path."""

    name: str
    source: str
    links: dict[str, UrdfInertial | None]
    joints: tuple[UrdfJoint, ...]


class _Reader:
    """Typed access to the XML elements; every failure names the file and the element."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, field: str, problem: str, value=None):
        raise UrdfFileError(self.source, field, problem, value=value)

    def numbers(self, element: ET.Element | None, attribute: str, count: int, field: str,
                default: tuple[float, ...] | None = None, largest: float = math.inf) -> np.ndarray:
        """``count`` finite numbers from a whitespace-separated attribute (``default`` when absent), each
        at most ``largest`` in magnitude."""
        text = None if element is None else element.get(attribute)
        if text is None:
            if default is None:
                self.fail(f"{field}.{attribute}", "is required")
            return np.array(default, dtype=float)
        try:
            values = [float(word) for word in text.split()]
        except ValueError:
            self.fail(f"{field}.{attribute}", f"must be {count} numbers", text)
        if len(values) != count or not all(math.isfinite(v) for v in values):
            self.fail(f"{field}.{attribute}", f"must be {count} finite numbers", text)
        if max(abs(v) for v in values) > largest:
            self.fail(f"{field}.{attribute}", f"is implausible for a robot: magnitudes up to {largest:g} "
                      "in SI units", text)
        return np.array(values)

    def number(self, element: ET.Element | None, attribute: str, field: str,
               largest: float = math.inf) -> float | None:
        """One finite number of magnitude at most ``largest``, or None when the element or the
        attribute is absent."""
        if element is None or element.get(attribute) is None:
            return None
        return float(self.numbers(element, attribute, 1, field, largest=largest)[0])

    def origin(self, element: ET.Element, field: str) -> np.ndarray:
        """The ``<origin xyz rpy>`` child of ``element`` as X (4, 4) [m] (identity when absent)."""
        origin = element.find("origin")
        xyz = self.numbers(origin, "xyz", 3, f"{field}.origin", default=(0.0, 0.0, 0.0), largest=MAX_LENGTH_M)
        rpy = self.numbers(origin, "rpy", 3, f"{field}.origin", default=(0.0, 0.0, 0.0))
        return rpy_position_to_pose(rpy, xyz)

    def name(self, element: ET.Element, field: str) -> str:
        value = element.get("name")
        if not value:
            self.fail(f"{field}.name", "is required")
        return value

    def inertial(self, link: ET.Element, field: str) -> UrdfInertial | None:
        element = link.find("inertial")
        if element is None:
            return None
        field = f"{field}.inertial"
        mass = self.number(element.find("mass"), "value", f"{field}.mass", largest=MAX_MASS_KG)
        if mass is None or mass < 0.0:
            self.fail(f"{field}.mass.value", "must be a number >= 0", mass)
        inertia = element.find("inertia")
        moments = {key: self.number(inertia, key, f"{field}.inertia", largest=MAX_RATE) or 0.0
                   for key in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
        I = np.array([[moments["ixx"], moments["ixy"], moments["ixz"]],
                      [moments["ixy"], moments["iyy"], moments["iyz"]],
                      [moments["ixz"], moments["iyz"], moments["izz"]]])
        return UrdfInertial(mass=mass, X_LI=self.origin(element, field), I=I)

    def joint(self, element: ET.Element, index: int) -> UrdfJoint:
        name = self.name(element, f"joint[{index}]")
        field = f"joint[{name}]"
        kind = element.get("type")
        if kind not in JOINT_TYPES:
            self.fail(f"{field}.type", f"must be one of {', '.join(JOINT_TYPES)}", kind)
        links = {}
        for role in ("parent", "child"):
            tag = element.find(role)
            if tag is None or not tag.get("link"):
                self.fail(f"{field}.{role}.link", "is required")
            links[role] = tag.get("link")
        axis = self.numbers(element.find("axis"), "xyz", 3, f"{field}.axis", default=(1.0, 0.0, 0.0))
        if kind in ("revolute", "continuous", "prismatic") and np.abs(axis).max() < MIN_AXIS_NORM:
            self.fail(f"{field}.axis.xyz", "must not be zero", element.find("axis").get("xyz"))
        limit = element.find("limit")
        lower, upper = (self.number(limit, key, f"{field}.limit", largest=MAX_LIMIT) for key in ("lower", "upper"))
        velocity, effort = (self.number(limit, key, f"{field}.limit", largest=MAX_RATE) for key in ("velocity", "effort"))
        if kind in ("revolute", "prismatic") and limit is None:
            self.fail(f"{field}.limit", f"is required for a {kind} joint")
        mimic = element.find("mimic")
        return UrdfJoint(
            name=name, kind=kind, parent=links["parent"], child=links["child"],
            X_PJ=self.origin(element, field), axis=unit_axis(axis),
            lower=lower, upper=upper, velocity=velocity, effort=effort if effort else None,
            mimic=None if mimic is None else (mimic.get("joint") or "?"),
        )


def unit_axis(axis: np.ndarray) -> np.ndarray:
    """``axis`` (3,) scaled to unit length without overflow (divided by its largest component first,
    so ``1e308 1e308 0`` is fine); a zero axis stays zero."""
    largest = float(np.abs(axis).max())
    if largest == 0.0:
        return axis
    scaled = axis / largest
    return scaled / np.linalg.norm(scaled)


def parse_urdf(text: str, source: str = "<string>") -> UrdfModel:
    """URDF text -> UrdfModel (names unique, every joint's links declared)."""
    reader = _Reader(source)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        reader.fail("document", f"is not well-formed XML: {exc}")
    if root.tag != "robot":
        reader.fail("document", "the root element must be <robot>", root.tag)
    if any(element.tag.startswith(XACRO_NAMESPACE) for element in root.iter()) or "${" in text:
        reader.fail("document", "is a xacro file: expand it first (xacro FILE.urdf.xacro > FILE.urdf)")
    link_elements, joint_elements = root.findall("link"), root.findall("joint")
    for tag, elements in (("link", link_elements), ("joint", joint_elements)):
        if len(elements) > MAX_URDF_LINKS:
            reader.fail("document", f"has {len(elements):,} <{tag}> elements, more than {MAX_URDF_LINKS:,}: "
                        "is it a robot description?")
    links: dict[str, UrdfInertial | None] = {}
    for k, element in enumerate(link_elements):
        name = reader.name(element, f"link[{k}]")
        if name in links:
            reader.fail(f"link[{name}]", "link names must be unique")
        links[name] = reader.inertial(element, f"link[{name}]")
    joints = tuple(reader.joint(element, k) for k, element in enumerate(joint_elements))
    names: set[str] = set()
    for joint in joints:
        if joint.name in names:
            reader.fail(f"joint[{joint.name}]", "joint names must be unique")
        names.add(joint.name)
        for role in ("parent", "child"):
            if getattr(joint, role) not in links:
                reader.fail(f"joint[{joint.name}].{role}.link", "names no <link> of this file", getattr(joint, role))
    return UrdfModel(name=root.get("name") or "robot", source=source, links=links, joints=joints)


def read_urdf(path: str | Path) -> UrdfModel:
    """Read and parse a URDF file (UrdfFileError naming the file when it cannot): a regular file
    (never a FIFO or device, which may never end), of which at most MAX_URDF_BYTES + 1 bytes are read."""
    path = Path(path)
    kind = special_kind(path)
    if kind is not None:
        raise UrdfFileError(str(path), "document", f"is {kind}, not a URDF file")
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_URDF_BYTES + 1)
    except OSError as exc:
        raise UrdfFileError(str(path), "document", f"cannot be read: {exc.strerror or exc}") from exc
    if len(raw) > MAX_URDF_BYTES:
        raise UrdfFileError(str(path), "document", f"is larger than {MAX_URDF_BYTES // 2**20} MiB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UrdfFileError(str(path), "document", f"is not UTF-8 text: {exc}") from exc
    return parse_urdf(text, str(path))
