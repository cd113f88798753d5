"""The TCP's speed and acceleration limits along a joint path, as a toppra constraint and as copp rows.

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


def speed_bound(p1: np.ndarray, limits: Limits, unit: float) -> np.ndarray:
    """The bound on sd^2 (n,) at stations whose dp/ds is ``p1`` (n, 3), time in units of 1 / ``unit``
    [1/s]: (v_max / |p'|)^2, UNBOUNDED where the TCP stands still or its speed is not limited."""
    if limits.tcp_speed_max is None:
        return np.full(len(p1), UNBOUNDED)
    with np.errstate(divide="ignore"):
        return np.minimum((limits.tcp_speed_max / (unit * np.linalg.norm(p1, axis=1))) ** 2, UNBOUNDED)


def accel_rows(p1: np.ndarray, p2: np.ndarray, limits: Limits, unit: float) -> tuple[np.ndarray, float]:
    """The ACCEL_DIRECTIONS unit directions F (n, ACCEL_DIRECTIONS, 3) in the plane of p' and p'' (n, 3)
    and the bound g, time in units of 1 / ``unit`` [1/s]: F (p' sdd + p'' sd^2) <= g keeps the TCP's
    acceleration within the inscribed polygon of the |a| <= a_max disc."""
    speed = np.linalg.norm(p1, axis=1)
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
    return F, limits.tcp_accel_max * np.cos(np.pi / ACCEL_DIRECTIONS) / unit**2


class TcpConstraint(toppra.constraint.LinearConstraint):
    """TCP speed (and acceleration, when limited) along ``path`` (real units), for toppra in time units
    of 1 / ``unit`` [1/s] (see ``toppra_backend.time_unit``)."""

    def __init__(self, tcp: TcpMotion, path: JointPath, limits: Limits, unit: float, dof: int):
        super().__init__()
        self.tcp, self.path, self.limits, self.unit, self.dof = tcp, path, limits, unit, dof

    def compute_constraint_params(self, path, gridpoints):
        p1, p2 = self.tcp.along(self.path, np.asarray(gridpoints, dtype=float))
        x_max = speed_bound(p1, self.limits, self.unit)
        xbound = np.column_stack([np.zeros_like(x_max), x_max])
        if self.limits.tcp_accel_max is None:
            return None, None, None, None, None, None, xbound
        F, bound = accel_rows(p1, p2, self.limits, self.unit)
        g = np.full((len(gridpoints), ACCEL_DIRECTIONS), bound)
        return p1, p2, np.zeros_like(p1), F, g, None, xbound


def add_copp_rows(constraints, tcp: TcpMotion, path: JointPath, limits: Limits, unit: float, s: np.ndarray) -> None:
    """The same TCP speed and acceleration rows for copp on stations ``s`` (n,), time in units of
    1 / ``unit`` [1/s]: a first-order bound on a = sd^2 and second-order rows in (a, b = sdd)."""
    p1, p2 = tcp.along(path, s)
    constraints.add_constraint_1st(speed_bound(p1, limits, unit)[:, None], 0)
    if limits.tcp_accel_max is not None:
        F, bound = accel_rows(p1, p2, limits, unit)
        constraints.add_constraint_2nd(np.einsum("nkj,nj->nk", F, p2), np.einsum("nkj,nj->nk", F, p1),
                                       np.full((len(s), ACCEL_DIRECTIONS), bound), 0)
