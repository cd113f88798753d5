"""Inverse velocity kinematics (seed 003): joint rates from an end-frame twist, through the damped
pseudo-inverse of the geometric Jacobian, with a flag near singularities."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...files.arrays import MAX_MAGNITUDE, float_array

#: Below this smallest singular value [m/rad or 1] the Jacobian counts as near singular and damping
#: grows smoothly from 0 (Maciejewski-Klein damped least squares).
NEAR_SINGULAR = 1e-2
MAX_DAMPING = 1e-2


@dataclass(frozen=True, eq=False)
class JointVelocityResult:
    """``qd`` [rad/s or m/s]; ``near_singular`` when sigma_min < threshold (damping was applied);
    ``residual`` = |J qd - twist| (0 away from singularities for a full-rank square J)."""

    qd: np.ndarray
    near_singular: bool
    smallest_singular_value: float
    damping: float
    residual: float


def joint_velocities(robot, q, twist, threshold: float = NEAR_SINGULAR, max_damping: float = MAX_DAMPING) -> JointVelocityResult:
    """qd for an end-frame twist [vx vy vz wx wy wz] (base frame, at the end-frame origin) [m/s, rad/s]."""
    twist = float_array(twist, "twist [v; w]", (6,), MAX_MAGNITUDE)
    J = robot.jacobian(q)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    sigma_min = float(s[-1])
    near = sigma_min < threshold
    damping = max_damping * (1.0 - (sigma_min / threshold) ** 2) if near else 0.0
    gains = s / (s**2 + damping**2)
    qd = Vt.T @ (gains * (U.T @ twist))
    return JointVelocityResult(qd, near, sigma_min, damping, float(np.linalg.norm(J @ qd - twist)))
