"""The TCP's speed and acceleration limits along a joint path, and joint speed limits that change along it
(a schedule's), as constraints of the TOPP-RA passes (in toppra's canonical form, ``compute_constraint_params``;
``reachability.canonical_rows``) and as copp rows.

Along the path the TCP moves with v = p'(s) sd and a = p'(s) sdd + p''(s) sd^2 (``TcpMotion.along``).
The speed limit is a bound on sd^2 at each grid point, (v_max / |p'|)^2. The acceleration vector lies
in the plane of p' and p'', so |a| <= a_max is the disc of that plane, which the constraint replaces
by the regular ACCEL_DIRECTIONS-gon inscribed in it (linear in sdd and sd^2, as toppra needs; at most
1 - cos(pi / 64) = 0.12 % slower than the disc). The limits may differ from grid point to grid point
(``PathLimits.at``: a schedule on top of the limits); a grid point where the TCP is not limited gets no
binding row.
"""

from __future__ import annotations

import numpy as np

from .joint_path import JointPath
from .tcp import PathLimits, TcpMotion

ACCEL_DIRECTIONS = 64
#: The bound on sd^2 where the TCP stands still (a turn in place) or is not limited: no bound, but a finite number.
UNBOUNDED = 1e12


def speed_bound(p1: np.ndarray, speed_max: np.ndarray, unit: float) -> np.ndarray:
    """The bound on sd^2 (n,) at stations whose dp/ds is ``p1`` (n, 3) and TCP speed limit ``speed_max`` (n,)
    [m/s] (inf: none), time in units of 1 / ``unit`` [1/s]: (v_max / |p'|)^2, UNBOUNDED where the TCP stands
    still or its speed is not limited."""
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = (speed_max / (unit * np.linalg.norm(p1, axis=1))) ** 2
    return np.where(np.isnan(bound), UNBOUNDED, np.minimum(bound, UNBOUNDED))


def accel_rows(p1: np.ndarray, p2: np.ndarray, accel_max: np.ndarray, unit: float) -> tuple[np.ndarray, np.ndarray]:
    """The ACCEL_DIRECTIONS unit directions F (n, ACCEL_DIRECTIONS, 3) in the plane of p' and p'' (n, 3)
    and the bounds g (n, ACCEL_DIRECTIONS), for TCP acceleration limits ``accel_max`` (n,) [m/s^2], time in
    units of 1 / ``unit`` [1/s]: F (p' sdd + p'' sd^2) <= g keeps the TCP's acceleration within the inscribed
    polygon of the |a| <= a_max disc; where ``accel_max`` is inf, F is 0 and g 1 (no binding row)."""
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
    limited = np.isfinite(accel_max)
    F[~limited] = 0.0
    bound = np.where(limited, accel_max, unit**2) * np.cos(np.pi / ACCEL_DIRECTIONS) / unit**2
    return F, np.repeat(bound[:, None], ACCEL_DIRECTIONS, axis=1)


class TcpConstraint:
    """TCP speed (and acceleration, where limited) along ``path`` (real units) within ``limits`` (a
    PathLimits: the TCP's limits at each grid point), for the solver in time units of 1 / ``unit`` [1/s] (see
    ``toppra_backend.time_unit``).

    The acceleration is limited at each grid point s_i and at the end of its interval, s_{i+1}, which
    the constant path acceleration u_i of the interval reaches with x = sd^2 = x_i + 2 (s_{i+1} - s_i) u_i:
    rows (p'(s_{i+1}) + 2 ds p''(s_{i+1})) u_i + p''(s_{i+1}) x_i, linear in (u_i, x_i) as the solver needs,
    with the interval's own limit and the path's derivatives on the interval's side (d2q/ds2 may jump at
    s_{i+1}). Where p' changes fast against p'' (a turn in place: p' = 0 and p'' not)
    the rows at s_i alone leave u_i free, and the grid solution swings between bang-bang path
    accelerations that exceed the limit inside every interval, however fine the grid."""

    def __init__(self, tcp: TcpMotion, path: JointPath, limits: PathLimits, unit: float, dof: int):
        self.tcp, self.path, self.limits, self.unit, self.dof = tcp, path, limits, unit, dof

    def compute_constraint_params(self, path, gridpoints):
        s = np.asarray(gridpoints, dtype=float)
        _, speed_max, accel_max = self.limits.at(s)
        p1, p2 = self.tcp.along(self.path, s)
        x_max = speed_bound(p1, speed_max, self.unit)
        xbound = np.column_stack([np.zeros_like(x_max), x_max])
        if not np.isfinite(accel_max).any():
            return None, None, None, None, None, None, xbound
        end = np.append(s[1:], s[-1])
        end_p1, end_p2 = np.vstack([p1[1:], p1[-1:]]), np.vstack([p2[1:], p2[-1:]])
        jumps = np.flatnonzero(np.isin(end, self.path.breakpoints[1:-1]))      # the interval's side of s_{i+1}
        if jumps.size:
            end_p1[jumps], end_p2[jumps] = self.tcp.along(self.path, np.nextafter(end[jumps], -np.inf))
        end_p1 = end_p1 + 2.0 * (end - s)[:, None] * end_p2
        own = self.limits.at((s + end) / 2.0)[2]                  # the interval's own limit (not a bound's)
        F, g = accel_rows(p1, p2, accel_max, self.unit)
        end_F, end_g = accel_rows(end_p1, end_p2, own, self.unit)
        zeros = np.zeros_like(F)
        F = np.concatenate([np.concatenate([F, zeros], axis=2), np.concatenate([zeros, end_F], axis=2)], axis=1)
        a, b = np.hstack([p1, end_p1]), np.hstack([p2, end_p2])
        return a, b, np.zeros_like(a), F, np.hstack([g, end_g]), None, xbound


class VaryingSpeedConstraint:
    """Joint speed limits ``qd_max`` (dof,) (in the solver's units, the path speed cap last) x the joint speed
    factor of ``limits`` (a PathLimits) at each grid point; the cap is not scaled: a bound on sd^2."""

    def __init__(self, qd_max: np.ndarray, limits: PathLimits):
        self.qd_max, self.limits, self.dof = qd_max, limits, len(qd_max)

    def compute_constraint_params(self, path, gridpoints):
        gridpoints = np.asarray(gridpoints, dtype=float)
        xbound = np.column_stack([np.zeros(len(gridpoints)),
                                  varying_speed_bound(path(gridpoints, 1), self.qd_max, self.limits.at(gridpoints)[0])])
        return None, None, None, None, None, None, xbound


def varying_speed_bound(d1: np.ndarray, qd_max: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """The bound on sd^2 (n,) at stations whose dq/ds is ``d1`` (n, dof) (the solver's coordinates, the path
    speed cap last, whose limit is not scaled), for joint speed limits ``qd_max`` (dof,) x ``factor`` (n,)."""
    scaled = qd_max[None, :] * np.concatenate([np.repeat(factor[:, None], len(qd_max) - 1, axis=1),
                                               np.ones((len(factor), 1))], axis=1)
    with np.errstate(divide="ignore"):
        return np.minimum(np.min((scaled / np.abs(d1)) ** 2, axis=1), UNBOUNDED)


def add_copp_rows(constraints, tcp: TcpMotion | None, path: JointPath, limits: PathLimits, unit: float,
                  s: np.ndarray) -> None:
    """The TCP's speed and acceleration rows (when ``tcp`` is given and ``limits`` limit the TCP) for copp on
    stations ``s`` (n,), time in units of 1 / ``unit`` [1/s]: a first-order bound on a = sd^2 and second-order
    rows in (a, b = sdd)."""
    if tcp is None or not limits.limits_tcp:
        return
    _, speed_max, accel_max = limits.at(s)
    p1, p2 = tcp.along(path, s)
    constraints.add_constraint_1st(speed_bound(p1, speed_max, unit)[:, None], 0)
    if np.isfinite(accel_max).any():
        F, g = accel_rows(p1, p2, accel_max, unit)
        constraints.add_constraint_2nd(np.einsum("nkj,nj->nk", F, p2), np.einsum("nkj,nj->nk", F, p1), g, 0)
