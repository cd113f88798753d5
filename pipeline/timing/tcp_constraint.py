"""The TCP's speed and acceleration limits as a toppra constraint along a joint path.

Along the path the TCP moves with v = p'(s) sd and a = p'(s) sdd + p''(s) sd^2 (``TcpMotion.along``).
The speed limit is a bound on sd^2 at each grid point, (v_max / |p'|)^2. The acceleration vector lies
in the plane of p' and p'', so |a| <= a_max is the disc of that plane, which the constraint replaces
by the regular ACCEL_DIRECTIONS-gon inscribed in it (linear in sdd and sd^2, as toppra needs; at most
1 - cos(pi / 64) = 0.12 % slower than the disc).
"""

from __future__ import annotations

import numpy as np
import toppra.constraint

from ..path import JointPath
from ..robot_spec import Limits
from ..tcp import TcpMotion

ACCEL_DIRECTIONS = 64
#: The bound on sd^2 where the TCP stands still (a turn in place): no bound, but a finite number.
UNBOUNDED = 1e12


class TcpConstraint(toppra.constraint.LinearConstraint):
    """TCP speed (and acceleration, when limited) along ``path`` (real units), for toppra in time units
    of 1 / ``unit`` [1/s] (see ``toppra_backend.time_unit``)."""

    def __init__(self, tcp: TcpMotion, path: JointPath, limits: Limits, unit: float, dof: int):
        super().__init__()
        self.tcp, self.path, self.limits, self.unit, self.dof = tcp, path, limits, unit, dof

    def compute_constraint_params(self, path, gridpoints):
        p1, p2 = self.tcp.along(self.path, np.asarray(gridpoints, dtype=float))
        speed = np.linalg.norm(p1, axis=1)
        with np.errstate(divide="ignore"):
            x_max = np.minimum((self.limits.tcp_speed_max / (self.unit * speed)) ** 2, UNBOUNDED)
        xbound = np.column_stack([np.zeros_like(x_max), x_max])
        if self.limits.tcp_accel_max is None:
            return None, None, None, None, None, None, xbound
        tangent = np.where(speed[:, None] > 0.0, p1 / np.maximum(speed, 1e-300)[:, None], [1.0, 0.0, 0.0])
        normal = p2 - np.sum(p2 * tangent, axis=1, keepdims=True) * tangent
        fallback = np.cross(tangent, [0.0, 0.0, 1.0])
        fallback = np.where(np.linalg.norm(fallback, axis=1, keepdims=True) > 0.1, fallback,
                            np.cross(tangent, [0.0, 1.0, 0.0]))
        normal = np.where(np.linalg.norm(normal, axis=1, keepdims=True) > 1e-9 * np.maximum(speed, 1.0)[:, None],
                          normal, fallback)
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        angles = 2.0 * np.pi * np.arange(ACCEL_DIRECTIONS) / ACCEL_DIRECTIONS
        F = np.cos(angles)[None, :, None] * tangent[:, None, :] + np.sin(angles)[None, :, None] * normal[:, None, :]
        bound = self.limits.tcp_accel_max * np.cos(np.pi / ACCEL_DIRECTIONS) / self.unit**2
        g = np.full((len(gridpoints), ACCEL_DIRECTIONS), bound)
        return p1, p2, np.zeros_like(p1), F, g, None, xbound
