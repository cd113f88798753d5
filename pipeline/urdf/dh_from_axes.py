"""Joint axes at q = 0 -> a standard DH table (the common-normal construction), base and tool frames.

Standard (distal) DH, frames as in Spong, Hutchinson and Vidyasagar, *Robot Modeling and Control*,
section 3.2: frame i-1 has its z on the axis of joint i; x_i lies on the common normal of the axes of
joints i and i+1, pointing from the first to the second (so ``a_i >= 0``); the origin of frame i is
where that normal meets the axis of joint i+1. The choices the construction leaves open are made the
conventional way:

- parallel axes: the normal through the origin of frame i-1, so ``d_i = 0``; the same axis twice:
  ``x_i = x_{i-1}``, ``a_i = d_i = 0``;
- intersecting axes: ``x_i = +-(z_{i-1} x z_i)``, the sign that keeps ``|theta_offset_i| <= 90 deg``
  (``z_{i-1} x z_i`` itself on a tie), the origin at the intersection;
- frame 0: origin where joint 1's axis passes closest to the base origin, x the base x (or y) made
  perpendicular to z_0 (frame 0 is the base frame whenever joint 1 is the base's z axis);
- frame n: z along the last axis, turned to the tip's z when that is closer (``alpha_n`` 0 or 180
  deg); origin where the tip's origin projects on the last axis, moved onto the tip origin along the
  normal when the tip is off the axis (``a_n``); x then the tip's x made perpendicular to z_n;
- every z along the joint's positive direction, so every sign is +1 and q is the URDF's own q.

Whatever DH cannot express goes into the base transform (base frame -> frame 0) and the tool
transform (frame n -> tip). Axes within PARALLEL_SIN of parallel are parallel; axes whose common
normal would sit farther than FAR_FOOT_M from the previous frame are treated as parallel too (a
"snap", reported with the angle it ignores: the exact table would need absurd offsets).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.chain.kinematics import dh_standard

#: |z_a x z_b| below this: the two axes are parallel [1].
PARALLEL_SIN = 1e-9
#: A common normal whose feet lie farther than this from the previous frame's origin is not used:
#: the axes are treated as parallel and the angle between them reported [m].
FAR_FOOT_M = 10.0
#: A tip (or axis) offset below this is no offset: the direction would be noise [m].
MIN_OFFSET_M = 1e-9


@dataclass(frozen=True)
class DhRow:
    """One standard DH row in SI units: ``a`` [m], ``alpha`` [rad], ``d`` [m], ``theta_offset`` [rad]
    (the joint value at q = 0: theta for a revolute joint, d for a prismatic one)."""

    a: float
    alpha: float
    d: float
    theta_offset: float


@dataclass(frozen=True, eq=False)
class DhGeometry:
    """``rows`` of the table, ``X_BD0`` (4, 4) frame 0 in the base frame, ``X_DnT`` (4, 4) the tip in
    frame n, and ``snapped``: (joint index i, angle [rad]) for each pair of axes i, i+1 (0-based)
    treated as parallel although they are not exactly."""

    rows: tuple[DhRow, ...]
    X_BD0: np.ndarray
    X_DnT: np.ndarray
    snapped: tuple[tuple[int, float], ...]


def _frame(origin: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    X = np.eye(4)
    X[:3, 0], X[:3, 1], X[:3, 2], X[:3, 3] = x, np.cross(z, x), z, origin
    return X


def _perpendicular(v: np.ndarray, z: np.ndarray) -> np.ndarray | None:
    """The unit part of ``v`` perpendicular to unit ``z``, or None when ``v`` is (nearly) along z."""
    w = v - (v @ z) * z
    norm = float(np.linalg.norm(w))
    return w / norm if norm > 1e-6 else None


def _angle(u: np.ndarray, v: np.ndarray, about: np.ndarray) -> float:
    """The angle [rad] from u to v about the unit axis ``about`` (u, v perpendicular to it)."""
    return math.atan2(float(np.cross(u, v) @ about), float(u @ v))


def _first_frame(point: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Frame 0: on joint 1's axis closest to the base origin, x from the base x (or y)."""
    origin = point - (point @ z) * z
    x = _perpendicular(np.array([1.0, 0.0, 0.0]), z)
    return _frame(origin, x if x is not None else _perpendicular(np.array([0.0, 1.0, 0.0]), z), z)


def _to_next_axis(F: np.ndarray, point: np.ndarray, z_next: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                                 float | None]:
    """(foot on the current axis, x and origin of the next frame, snapped angle or None) for the next
    axis, through ``point`` along ``z_next``."""
    o, x, z = F[:3, 3], F[:3, 0], F[:3, 2]
    normal = np.cross(z, z_next)
    sin = float(np.linalg.norm(normal))
    if sin >= PARALLEL_SIN:
        w = o - point
        b, dz, dn = float(z @ z_next), float(z @ w), float(z_next @ w)
        s = (b * dn - dz) / sin**2                     # foot on the current axis: o + s z
        t = (dn - b * dz) / sin**2                     # foot on the next axis: point + t z_next
        foot, foot_next = o + s * z, point + t * z_next
        if abs(s) <= FAR_FOOT_M and np.linalg.norm(foot_next - o) <= FAR_FOOT_M:
            x_next = normal / sin
            a = float((foot_next - foot) @ x_next)
            if (a < 0.0) if abs(a) > MIN_OFFSET_M else (x @ x_next < -1e-12):
                x_next = -x_next
            return foot, x_next, foot_next, None
    foot_next = point + ((o - point) @ z_next) * z_next
    x_next = _perpendicular(foot_next - o, z) if np.linalg.norm(foot_next - o) > MIN_OFFSET_M else None
    if x_next is None:
        x_next = x                                      # the same axis: frame i-1's x
    origin_next = o + float((foot_next - o) @ x_next) * x_next
    return o, x_next, origin_next, (math.asin(min(sin, 1.0)) if sin >= PARALLEL_SIN else None)


def _row(F: np.ndarray, foot: np.ndarray, x_next: np.ndarray, origin_next: np.ndarray, z_next: np.ndarray) -> DhRow:
    """The DH row from frame F to the frame at ``origin_next`` with axes x_next, z_next."""
    o, x, z = F[:3, 3], F[:3, 0], F[:3, 2]
    return DhRow(a=float((origin_next - foot) @ x_next), alpha=_angle(z, z_next, x_next),
                 d=float((foot - o) @ z), theta_offset=_angle(x, x_next, z))


def dh_from_axes(points: np.ndarray, axes: np.ndarray, X_BT: np.ndarray) -> DhGeometry:
    """Standard DH rows for the joint axes through ``points`` (n, 3) along unit ``axes`` (n, 3), both
    in the base frame at q = 0 [m], and the tip pose ``X_BT`` (4, 4) at q = 0."""
    F = _first_frame(points[0], axes[0])
    X_BD0, rows, snapped = F, [], []
    for i in range(len(axes)):
        if i + 1 < len(axes):
            foot, x_next, origin_next, snap = _to_next_axis(F, points[i + 1], axes[i + 1])
            z_next = axes[i + 1]
            if snap is not None:
                snapped.append((i, snap))
        else:
            foot, x_next, z_next, origin_next = _to_tip(F, X_BT)
        row = _row(F, foot, x_next, origin_next, z_next)
        rows.append(row)
        F = F @ dh_standard(row.theta_offset, row.d, row.a, row.alpha)
    return DhGeometry(tuple(rows), X_BD0, np.linalg.inv(F) @ X_BT, tuple(snapped))


def _to_tip(F: np.ndarray, X_BT: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(foot, x_n, z_n, origin of frame n) for the last row, towards the tip frame."""
    o, z = F[:3, 3], F[:3, 2]
    p_tip = X_BT[:3, 3]
    foot = o + ((p_tip - o) @ z) * z
    z_n = z if z @ X_BT[:3, 2] >= 0.0 else -z
    offset = p_tip - foot
    if np.linalg.norm(offset) > MIN_OFFSET_M:
        x_n = offset / np.linalg.norm(offset)
        return foot, x_n, z_n, p_tip
    x_n = _perpendicular(X_BT[:3, 0], z)
    if x_n is None:
        x_n = _perpendicular(X_BT[:3, 1], z)
    return foot, x_n, z_n, foot
