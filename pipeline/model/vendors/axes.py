"""Controller axis angles from our model's joint values: per vendor and preset, the zero offset and
direction of each axis, and FANUC's J2/J3 coupling.

Every preset's joint variable is the manufacturer's axis angle as the ROS-Industrial description of
the arm defines it (models/SOURCES.md, "Conventions every preset follows"): q = 0 is the controller's
zero pose and the positive direction is the controller's. So the maps are the identity (offset 0 deg,
direction +1), except that a FANUC controller shows J3 relative to the horizontal, J3 = q3 - q2
(``pipeline.model.vendors.pendant``). A robot of another maker than the vendor (or of none, such as ``arm6``) gets the
identity map, and ``AxisMap.source`` says so: no published map exists for it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import VendorConfigurationError
from .pendant import fanuc_serial_to_pendant

#: The controllers whose configuration data this package computes.
ABB, FANUC, YASKAWA, KUKA = "abb", "fanuc", "yaskawa", "kuka"
VENDORS = (ABB, FANUC, YASKAWA, KUKA)


@dataclass(frozen=True)
class AxisMap:
    """Axis angle [deg] = ``direction`` * q [rad -> deg] + ``offset`` [deg] per joint (6,), then for a
    FANUC pendant J3 = q3 - q2 when ``fanuc_j3`` is set; ``source`` says where the map comes from."""

    direction: tuple[int, ...]
    offset: tuple[float, ...]
    fanuc_j3: bool
    source: str


_IDENTITY, _ZERO = (1,) * 6, (0.0,) * 6

#: (preset name, vendor) -> its map, with the facts it rests on.
PRESET_MAPS = {
    ("irb1600", ABB): AxisMap(_IDENTITY, _ZERO, False,
                              "irb1600 on an ABB IRC5: identity; q is the ABB axis angle (ROS-Industrial "
                              "abb_irb1600 description, models/SOURCES.md)"),
    ("lrmate200id", FANUC): AxisMap(_IDENTITY, _ZERO, True,
                                    "lrmate200id on a FANUC R-30iB: identity except the pendant's J3 = q3 - q2 "
                                    "(ROS-Industrial fanuc_lrmate200id description, models/SOURCES.md, "
                                    "pipeline.model.vendors.pendant)"),
    ("gp7", YASKAWA): AxisMap(_IDENTITY, _ZERO, False,
                              "gp7 on a Yaskawa controller: identity; q is the S, L, U, R, B, T axis angle "
                              "(ROS-Industrial motoman_gp7 description, models/SOURCES.md)"),
}


def check_vendor(vendor) -> str:
    """The vendor name, or VendorConfigurationError naming the ones known."""
    if vendor not in VENDORS:
        raise VendorConfigurationError(f"unknown controller vendor {vendor!r}; the vendors: {', '.join(VENDORS)}")
    return vendor


def axis_map(robot, vendor: str) -> AxisMap:
    """The map of ``robot`` (a 6-joint Robot) to ``vendor``'s axis angles: the preset's own, else the
    identity, whose ``source`` says that no published map exists for this robot on that controller."""
    check_vendor(vendor)
    if robot.dof != 6:
        raise VendorConfigurationError(f"{robot.name}: controller axis angles need 6 joints, it has {robot.dof}")
    known = PRESET_MAPS.get((robot.name, vendor))
    if known is not None:
        return known
    return AxisMap(_IDENTITY, _ZERO, False, f"{robot.name} on a {vendor} controller: no published map, the identity "
                                            "(q taken as the controller's axis angles)")


def axis_angles(robot, Q, vendor: str) -> np.ndarray:
    """The controller's axis angles [deg] (N, 6) of configurations Q (N, 6) [rad]; one (6,) gives (6,)."""
    mapping = axis_map(robot, vendor)
    single = np.ndim(Q) == 1
    Q = robot.as_batch(np.atleast_2d(Q)) * np.array(mapping.direction)
    if mapping.fanuc_j3:
        Q = fanuc_serial_to_pendant(Q, "rad")
    angles = np.degrees(Q) + np.array(mapping.offset)
    return angles[0] if single else angles
