"""A DH robot -> URDF text: ``base_link``, one link per DH frame (``link_1`` .. ``link_n``), ``tool0``.

URDF puts each joint's axis through its child link's origin, so the links carry the modified (Craig)
DH frames of the chain, which lie on their own joint's axis: link_i is frame i of the modified table
(for a standard table, the same chain rewritten by ``standard_to_modified``; its frame i is then the
standard frame i moved back along the common normal). The joints keep the robot file's names, zero
and positive direction (axis ``0 0 sign``), position and velocity limits, and ``tau_max`` as effort
(0, as ROS-Industrial packages write it, where the file gives none); a continuous joint is
``type="continuous"``, its ``<limit>`` without lower and upper. Visual and collision shapes are
the cylinders and spheres of the stick figure (``pipeline.model.chain.geometry``); inertias are written where the
robot file has them. Acceleration and jerk limits have no place in URDF: a comment lists them.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..files.atomic import write_text_atomic
from ..files.poses import rotation_to_rpy
from ..files.robot_spec import DhJoint, RobotSpec
from ..model.chain.dh_convert import standard_to_modified
from ..model.chain.geometry import compute_link_polylines, visual_radius
from ..model.chain.kinematics import DhKinematics
from .chain import ROS_BASE_LINK, ROS_TIP_LINK

#: Segments shorter than this get no cylinder [m].
MIN_SEGMENT_M = 1e-6
LINK_COLOURS = (("orange", "0.93 0.55 0.13 1"), ("light_grey", "0.75 0.75 0.78 1"))
BASE_COLOUR = ("dark_grey", "0.35 0.35 0.38 1")


def _number(value) -> str:
    return repr(float(value) + 0.0)


def _numbers(values) -> str:
    return " ".join(_number(v) for v in values)


def _origin(parent: ET.Element, X: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_numbers(X[:3, 3]), rpy=_numbers(rotation_to_rpy(X[:3, :3])))


def _segment_pose(p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Pose of a cylinder (centred, along its z) spanning p -> r."""
    z = (r - p) / np.linalg.norm(r - p)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    X = np.eye(4)
    X[:3, 0], X[:3, 1], X[:3, 2], X[:3, 3] = x, np.cross(z, x), z, (p + r) / 2.0
    return X


def _shapes(link: ET.Element, points: np.ndarray, radius: float, material: str) -> None:
    """Visual and collision cylinders along the polyline ``points`` (k, 3) (link frame), spheres at its
    inner corners."""
    shapes = []
    for p, r in zip(points[:-1], points[1:]):
        length = float(np.linalg.norm(r - p))
        if length >= MIN_SEGMENT_M:
            shapes.append((_segment_pose(p, r), "cylinder", {"radius": _number(radius), "length": _number(length)}))
    for p in points[1:-1]:
        X = np.eye(4)
        X[:3, 3] = p
        shapes.append((X, "sphere", {"radius": _number(radius)}))
    for tag in ("visual", "collision"):
        for X, kind, size in shapes:
            element = ET.SubElement(link, tag)
            _origin(element, X)
            ET.SubElement(ET.SubElement(element, "geometry"), kind, **size)
            if tag == "visual":
                ET.SubElement(element, "material", name=material)


def _inertial(link: ET.Element, inertia, X_LD: np.ndarray) -> None:
    """``<inertial>`` of a link whose DH frame D sits at X_LD in the link frame."""
    element = ET.SubElement(link, "inertial")
    X_LI = X_LD.copy()
    X_LI[:3, 3] = X_LD[:3, :3] @ inertia.p_LoLcm + X_LD[:3, 3]
    _origin(element, X_LI)
    ET.SubElement(element, "mass", value=_number(inertia.mass))
    I = inertia.I_Lcm
    ET.SubElement(element, "inertia", ixx=_number(I[0, 0]), ixy=_number(I[0, 1]), ixz=_number(I[0, 2]),
                  iyy=_number(I[1, 1]), iyz=_number(I[1, 2]), izz=_number(I[2, 2]))


def urdf_text(spec: RobotSpec) -> str:
    """The URDF of a robot (see the module docstring); lengths in m, angles in rad."""
    craig = standard_to_modified(spec) if spec.convention == "standard" else spec
    q0 = np.zeros(spec.dof)
    X_BL = DhKinematics(craig).fk_all(q0)          # link frames 0..n, then the end frame
    X_BD = DhKinematics(spec).fk_all(q0)           # the robot file's own DH frames
    kinematics = DhKinematics(spec)
    polylines = compute_link_polylines(kinematics, q0)
    radius = visual_radius(kinematics)
    root = ET.Element("robot", name=spec.name)
    for name, rgba in (*LINK_COLOURS, BASE_COLOUR):
        ET.SubElement(ET.SubElement(root, "material", name=name), "color", rgba=rgba)
    names = [ROS_BASE_LINK] + [f"link_{i}" for i in range(1, spec.dof + 1)]
    frames = [np.eye(4)] + [X_BL[i] for i in range(1, spec.dof + 1)]
    for i, (name, X) in enumerate(zip(names, frames)):
        link = ET.SubElement(root, "link", name=name)
        X_inv = np.linalg.inv(X)
        local = polylines[i] @ X_inv[:3, :3].T + X_inv[:3, 3]
        _shapes(link, local, radius, BASE_COLOUR[0] if i == 0 else LINK_COLOURS[(i - 1) % 2][0])
        if i > 0 and spec.joints[i - 1].inertia is not None:
            _inertial(link, spec.joints[i - 1].inertia, X_inv @ X_BD[i])
    ET.SubElement(root, "link", name=ROS_TIP_LINK)
    for i, joint in enumerate(spec.joints, start=1):
        kind = "continuous" if joint.is_continuous else joint.kind
        element = ET.SubElement(root, "joint", name=joint.name, type=kind)
        ET.SubElement(element, "parent", link=names[i - 1])
        ET.SubElement(element, "child", link=names[i])
        _origin(element, np.linalg.inv(frames[i - 1]) @ frames[i])
        ET.SubElement(element, "axis", xyz=_numbers([0.0, 0.0, joint.sign]))
        ET.SubElement(element, "limit", attrib=_limit(joint))
    tool = ET.SubElement(root, "joint", name=f"{spec.joints[-1].name}-{ROS_TIP_LINK}", type="fixed")
    ET.SubElement(tool, "parent", link=names[-1])
    ET.SubElement(tool, "child", link=ROS_TIP_LINK)
    _origin(tool, np.linalg.inv(frames[-1]) @ X_BL[-1])
    ET.indent(root, space="  ")
    return f'<?xml version="1.0"?>\n{_comment(spec)}\n{ET.tostring(root, encoding="unicode")}\n'


def _limit(joint: DhJoint) -> dict[str, str]:
    """The attributes of a joint's ``<limit>``: lower and upper (none for a continuous joint), effort and
    velocity [SI]."""
    bounds = {} if joint.is_continuous else {"lower": _number(joint.q_min), "upper": _number(joint.q_max)}
    return {**bounds, "effort": _number(joint.tau_max or 0.0), "velocity": _number(joint.qd_max)}


def _comment(spec: RobotSpec) -> str:
    lines = [f"Written by dh-pipeline from {spec.source} ({spec.convention} DH, {spec.dof} joints).",
             "Lengths in m, angles in rad. base_link: the robot base frame; link_i: modified-DH frame i (on joint",
             "i's axis, z along it); tool0: the robot file's end frame (flange, or its tool)."]
    for key, unit in (("qdd_max", "s^-2"), ("qddd_max", "s^-3")):
        values = [getattr(j, key) for j in spec.joints]
        if all(v is not None for v in values):
            lines.append(f"{key} (rad or m {unit}, not expressible in URDF): " + _numbers(values))
    text = "\n     ".join(lines).replace("--", "- -")
    return f"<!-- {text} -->"


def write_urdf(robot, path: str | Path, replace: bool = False) -> Path:
    """Write the URDF of a Robot (or RobotSpec) to ``path`` atomically (OutputError when it cannot; a file the
    package did not write is replaced only with ``replace``)."""
    spec = robot.spec if hasattr(robot, "spec") else robot
    return write_text_atomic(path, urdf_text(spec), replace)
