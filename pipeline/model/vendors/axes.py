"""Controller axis angles from our model's joint values: per vendor, the zero offset and direction of each
axis, and FANUC's J2/J3 coupling.

The map is the robot file's ``controller`` section (``controller.controller_of``) when its maker is the
vendor asked: the presets carry theirs (models/SOURCES.md, "Conventions every preset follows": q is the
manufacturer's axis angle as ROS-Industrial defines it, so the maps are the identity except a FANUC
pendant's J3 = q3 - q2, ``pipeline.model.vendors.pendant``). A robot of another maker than the vendor (or of
none, such as ``arm6``) gets the identity map, and ``AxisMap.source`` says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import VendorConfigurationError
from .controller import controller_for
from .pendant import fanuc_pendant_to_serial, fanuc_serial_to_pendant

#: The controllers whose configuration data this package computes.
ABB, FANUC, YASKAWA, KUKA = "abb", "fanuc", "yaskawa", "kuka"
VENDORS = (ABB, FANUC, YASKAWA, KUKA)


@dataclass(frozen=True)
class AxisMap:
    """Axis angle [deg] = ``direction`` * q [rad -> deg], for a FANUC pendant (``fanuc_j3``) then J3 = q3 -
    q2, plus ``offset`` [deg] per joint (6,); ``source`` says where the map comes from."""

    direction: tuple[int, ...]
    offset: tuple[float, ...]
    fanuc_j3: bool
    source: str


_IDENTITY, _ZERO = (1,) * 6, (0.0,) * 6


def check_vendor(vendor) -> str:
    """The vendor name, or VendorConfigurationError naming the ones known."""
    if vendor not in VENDORS:
        raise VendorConfigurationError(f"unknown controller vendor {vendor!r}; the vendors: {', '.join(VENDORS)}")
    return vendor


def axis_map(robot, vendor: str) -> AxisMap:
    """The map of ``robot`` (a 6-joint Robot) to ``vendor``'s axis angles: its robot file's controller
    section when that names ``vendor``, else the identity, whose ``source`` says why."""
    check_vendor(vendor)
    if robot.dof != 6:
        raise VendorConfigurationError(f"{robot.name}: controller axis angles need 6 joints, it has {robot.dof}")
    controller = controller_for(robot, vendor)
    if controller is not None:
        return AxisMap(controller.direction, controller.offset, controller.coupling == "fanuc_j2_j3",
                       f"{robot.name} on a {vendor} controller: {controller.source}")
    return AxisMap(_IDENTITY, _ZERO, False, f"{robot.name} on a {vendor} controller: no {vendor} controller section in "
                                            "its robot file, the identity (q taken as the controller's axis angles)")


def joint_values(robot, angles_deg, vendor: str) -> np.ndarray:
    """``axis_angles`` inverted: our q [rad] (..., 6) of the controller's axis angles (..., 6) [deg] (offset,
    then FANUC's pendant J3 back to the serial q3 = J3 + J2, then direction)."""
    mapping = axis_map(robot, vendor)
    q = np.radians(np.asarray(angles_deg, dtype=float) - np.array(mapping.offset))
    if mapping.fanuc_j3:
        q = fanuc_pendant_to_serial(q, "rad")
    return q * np.array(mapping.direction)


def axis_angles(robot, Q, vendor: str) -> np.ndarray:
    """The controller's axis angles [deg] (N, 6) of configurations Q (N, 6) [rad]; one (6,) gives (6,)."""
    mapping = axis_map(robot, vendor)
    single = np.ndim(Q) == 1
    Q = robot.as_batch(np.atleast_2d(Q)) * np.array(mapping.direction)
    if mapping.fanuc_j3:
        Q = fanuc_serial_to_pendant(Q, "rad")
    angles = np.degrees(Q) + np.array(mapping.offset)
    return angles[0] if single else angles
