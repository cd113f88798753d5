"""URDF XML -> a `UrdfModel`: links (with their mass properties) and joints, in SI units as URDF is.

Only what kinematics and dynamics need is read: joint type, parent, child, origin, axis, limits and
mimic; link inertials. Visuals, collisions, transmissions and plugins are skipped, so meshes need not
exist. Errors are UrdfFileError naming the file and the element (``joint[elbow].limit.velocity``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UrdfFileError
from ..poses import rpy_position_to_pose

#: Largest URDF read [bytes]: robot descriptions are tens of kB; this leaves room for comments.
MAX_URDF_BYTES = 16 * 1024 * 1024
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
XACRO_NAMESPACE = "{http://ros.org/wiki/xacro}"
#: An axis shorter than this is not a direction [1].
MIN_AXIS_NORM = 1e-9


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
                default: tuple[float, ...] | None = None) -> np.ndarray:
        """``count`` finite numbers from a whitespace-separated attribute (``default`` when absent)."""
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
        return np.array(values)

    def number(self, element: ET.Element | None, attribute: str, field: str) -> float | None:
        """One finite number, or None when the element or the attribute is absent."""
        if element is None or element.get(attribute) is None:
            return None
        return float(self.numbers(element, attribute, 1, field)[0])

    def origin(self, element: ET.Element, field: str) -> np.ndarray:
        """The ``<origin xyz rpy>`` child of ``element`` as X (4, 4) [m] (identity when absent)."""
        origin = element.find("origin")
        xyz = self.numbers(origin, "xyz", 3, f"{field}.origin", default=(0.0, 0.0, 0.0))
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
        mass = self.number(element.find("mass"), "value", f"{field}.mass")
        if mass is None or mass < 0.0:
            self.fail(f"{field}.mass.value", "must be a number >= 0", mass)
        inertia = element.find("inertia")
        moments = {key: self.number(inertia, key, f"{field}.inertia") or 0.0
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
        norm = float(np.linalg.norm(axis))
        if kind in ("revolute", "continuous", "prismatic") and norm < MIN_AXIS_NORM:
            self.fail(f"{field}.axis.xyz", "must not be zero", element.find("axis").get("xyz"))
        limit = element.find("limit")
        lower, upper, velocity, effort = (self.number(limit, key, f"{field}.limit")
                                          for key in ("lower", "upper", "velocity", "effort"))
        if kind in ("revolute", "prismatic") and limit is None:
            self.fail(f"{field}.limit", f"is required for a {kind} joint")
        mimic = element.find("mimic")
        return UrdfJoint(
            name=name, kind=kind, parent=links["parent"], child=links["child"],
            X_PJ=self.origin(element, field), axis=axis / norm if norm >= MIN_AXIS_NORM else axis,
            lower=lower, upper=upper, velocity=velocity, effort=effort if effort else None,
            mimic=None if mimic is None else (mimic.get("joint") or "?"),
        )


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
    links: dict[str, UrdfInertial | None] = {}
    for k, element in enumerate(root.findall("link")):
        name = reader.name(element, f"link[{k}]")
        if name in links:
            reader.fail(f"link[{name}]", "link names must be unique")
        links[name] = reader.inertial(element, f"link[{name}]")
    joints = tuple(reader.joint(element, k) for k, element in enumerate(root.findall("joint")))
    names = [j.name for j in joints]
    for joint in joints:
        if names.count(joint.name) > 1:
            reader.fail(f"joint[{joint.name}]", "joint names must be unique")
        for role in ("parent", "child"):
            if getattr(joint, role) not in links:
                reader.fail(f"joint[{joint.name}].{role}.link", "names no <link> of this file", getattr(joint, role))
    return UrdfModel(name=root.get("name") or "robot", source=source, links=links, joints=joints)


def read_urdf(path: str | Path) -> UrdfModel:
    """Read and parse a URDF file (UrdfFileError naming the file when it cannot)."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_URDF_BYTES:
            raise UrdfFileError(str(path), "document", f"is larger than {MAX_URDF_BYTES // 2**20} MiB")
        raw = path.read_bytes()
    except OSError as exc:
        raise UrdfFileError(str(path), "document", f"cannot be read: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UrdfFileError(str(path), "document", f"is not UTF-8 text: {exc}") from exc
    return parse_urdf(text, str(path))
