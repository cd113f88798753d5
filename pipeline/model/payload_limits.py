"""A load against the maker's payload diagram (a robot file's ``payload_limits``): the rated payload, and the
allowable static moment and inertia about each wrist axis the file names.

The makers define them alike (Yaskawa "Allowable Moment and Inertia" of the R-, B- and T-axis with the moment arms
L_B from the B-axis rotation centre and L_T from the T axis; FANUC's J4/J5/J6 allowable load moment and inertia;
ABB's J5 = m ((Z + a)^2 + L^2) + max(J0x, J0y) and J6 = m L^2 + J0z): for a load of mass m [kg], centre of mass p and
inertia I about it (all in the flange frame),

* about the last joint's axis (the T axis, J6, axis 6): the moment m g r and the inertia u^T I u + m r^2, with r the
  distance from p to the axis (u its direction);
* about the other wrist joints' axes (R, B; J4, J5; axes 4, 5): the moment m g |p - c| and the inertia
  lambda_max(I + m (|d|^2 E - d d^T)) with d = p - c, where c is the wrist centre (the point of the last axis nearest
  the one before it, the B-axis rotation centre). Both axes pass through c, and a wrist angle can turn either so
  that it is perpendicular to d: these are the largest the load puts on them in any wrist configuration, which is
  how the diagrams are drawn (the load's centre of gravity anywhere on the arm's circle).

g is the standard gravity (the makers' kgf·m). A wrist whose named axis does not pass through c (not a spherical
wrist) has no such worst case: ``wrist_loads`` refuses it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigurationError
from ..files.robot_spec import STANDARD_GRAVITY, RobotSpec
from .chain.kinematics import DhKinematics

#: A mass this many times the rated payload reads as grams written as kilograms.
GRAMS_HINT = 100.0
#: How far a named wrist axis may pass from the wrist centre and still count as through it [m].
WRIST_CENTRE_TOLERANCE_M = 1e-4


@dataclass(frozen=True)
class WristLoad:
    """What a load puts on one wrist joint's axis: ``joint`` (its name), ``arm_m`` [m], ``moment_n_m`` [N m] and
    ``inertia_kg_m2`` [kg m^2] (module docstring), and the joint's allowable ``moment_limit`` and ``inertia_limit``
    (None: not given)."""

    joint: str
    arm_m: float
    moment_n_m: float
    inertia_kg_m2: float
    moment_limit: float | None
    inertia_limit: float | None


def wrist_loads(spec: RobotSpec, load) -> list[WristLoad]:
    """Per wrist joint the file's ``payload_limits`` names, what ``load`` (mass [kg], com (3,) [m], inertia (3, 3)
    [kg m^2] in the flange frame) puts on its axis (module docstring). ConfigurationError for a named axis other
    than the last that misses the wrist centre."""
    limits = spec.payload_limits
    if limits is None or not limits.wrist:
        return []
    axes = _flange_axes(spec)
    last_point, last_direction = axes[-1]
    centre = _wrist_centre(*axes[-2], last_point, last_direction)
    p, m, I = np.asarray(load.com, dtype=float), float(load.mass), np.asarray(load.inertia, dtype=float)
    out = []
    for index, (moment_limit, inertia_limit) in sorted(limits.wrist.items()):
        name = spec.joints[index].name
        if index == spec.dof - 1:
            r_vector = (p - last_point) - ((p - last_point) @ last_direction) * last_direction
            arm = float(np.linalg.norm(r_vector))
            inertia = float(last_direction @ I @ last_direction) + m * arm ** 2
        else:
            point, direction = axes[index]
            offset = (centre - point) - ((centre - point) @ direction) * direction
            if np.linalg.norm(offset) > WRIST_CENTRE_TOLERANCE_M:
                raise ConfigurationError(
                    f"{spec.source}: payload_limits.wrist.{name}: the axis of joint {name} passes "
                    f"{np.linalg.norm(offset) * 1e3:.1f} mm from the wrist centre: the allowable moment and inertia "
                    "are checked for spherical wrists only")
            d = p - centre
            arm = float(np.linalg.norm(d))
            inertia = float(np.linalg.eigvalsh(I + m * (float(d @ d) * np.eye(3) - np.outer(d, d)))[-1])
        out.append(WristLoad(name, arm, m * STANDARD_GRAVITY * arm, inertia, moment_limit, inertia_limit))
    return out


def payload_problems(spec: RobotSpec, load) -> list[str]:
    """Why ``load`` (``wrist_loads``) is beyond the robot's payload diagram: one sentence per limit exceeded, naming
    the axis, the value and the limit ([] within every limit, or without a payload diagram)."""
    limits = spec.payload_limits
    if limits is None:
        return []
    problems = []
    if limits.rated_kg is not None and load.mass > limits.rated_kg:
        grams = " (is the mass in grams? it is in kg)" if load.mass > GRAMS_HINT * limits.rated_kg else ""
        problems.append(f"{load.mass:.3g} kg exceeds the {spec.name}'s rated payload {limits.rated_kg:g} kg{grams}")
    for w in wrist_loads(spec, load):
        if w.moment_limit is not None and w.moment_n_m > w.moment_limit:
            problems.append(f"the moment about axis {w.joint} is {w.moment_n_m:.3g} N m (centre of mass "
                            f"{w.arm_m * 1e3:.0f} mm from it), above the allowable {w.moment_limit:g} N m")
        if w.inertia_limit is not None and w.inertia_kg_m2 > w.inertia_limit:
            problems.append(f"the inertia about axis {w.joint} is {w.inertia_kg_m2:.3g} kg m^2, above the allowable "
                            f"{w.inertia_limit:g} kg m^2")
    return problems


def _flange_axes(spec: RobotSpec) -> list[tuple[np.ndarray, np.ndarray]]:
    """(point [m], unit direction) of each joint's axis in the flange frame, at the middle of the joint ranges (the
    last two axes' relation, all this module uses, is the same in every configuration)."""
    kinematics = DhKinematics(spec)
    frames, X_BE = kinematics.joint_frames(spec.limits.q_middle)
    X_EB = np.linalg.inv(X_BE)
    return [((X_EB @ frame)[:3, 3], (X_EB @ frame)[:3, 2]) for frame in frames]


def _wrist_centre(p1: np.ndarray, u1: np.ndarray, p2: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """The point of line (p2, u2) nearest line (p1, u1) (p2 itself when they are parallel)."""
    w = p2 - p1
    b = float(u1 @ u2)
    denominator = 1.0 - b * b
    if denominator < 1e-12:
        return p2
    t = (b * float(u1 @ w) - float(u2 @ w)) / denominator
    return p2 + t * u2
