"""The tool kept level on planned moves: its z axis within a largest angle of the cell's vertical (up or
down), as a carried part or an open container needs (job key ``plan_tilt_max``).

``TiltLimit`` measures the tilt at configurations (the planner keeps it, with a margin, at every state
and along every edge it accepts, ``pipeline.cell.planning``); ``certify_tilt`` proves it on a timed profile:
at every sample of the planned moves' time spans, and between two samples through a bound on how far
the tool's axis can turn (for revolute joints the end frame turns by at most the sum of the joints'
turns, ``|q(t) - q_k|_1``, which between samples is bounded by the sampled speeds and the acceleration
limits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class TiltLimit:
    """The tool's z axis within ``max_rad`` of the vertical: ``R_WB`` (3, 3) the robot base's orientation
    in the cell (the vertical is the cell's z axis); the tool's z axis is the robot end frame's (a job's
    tool makes the TCP the end frame)."""

    R_WB: np.ndarray
    max_rad: float

    def angles(self, robot, Q: np.ndarray) -> np.ndarray:
        """The tilt [rad] at each configuration of Q (k, dof): the angle between the tool's z axis and the
        nearer of up and down."""
        z_W = np.einsum("ij,kj->ki", self.R_WB, robot.fk_batch(np.atleast_2d(Q))[:, :3, 2])
        return np.arccos(np.clip(np.abs(z_W[:, 2]), 0.0, 1.0))

    def keeps(self, robot, Q: np.ndarray) -> bool:
        """Every configuration of Q (k, dof) within the limit."""
        return bool(np.all(self.angles(robot, Q) <= self.max_rad))


@dataclass(frozen=True)
class TiltReport:
    """The tilt certificate: ``passed``, the largest tilt bound [rad] (samples and between them), where
    (``at_s``, job time) and the limit [rad]; ``spans``: the (start, end) times [s] judged."""

    passed: bool
    worst_rad: float
    at_s: float
    max_rad: float
    spans: tuple[tuple[float, float], ...]

    def to_dict(self) -> dict:
        return {"passed": self.passed, "worst_deg": float(np.degrees(self.worst_rad)), "at_s": self.at_s,
                "max_deg": float(np.degrees(self.max_rad)),
                "spans_s": [list(span) for span in self.spans]}

    def __str__(self) -> str:
        verdict = "kept" if self.passed else "EXCEEDED"
        return (f"tool tilt {verdict}: at most {np.degrees(self.worst_rad):.2f} deg from the vertical (limit "
                f"{np.degrees(self.max_rad):g} deg, worst at {self.at_s:.3f} s, {len(self.spans)} planned move(s))")


def certify_tilt(robot, limit: TiltLimit, profile, spans: list[tuple[float, float]]) -> TiltReport:
    """The tilt of ``profile`` within ``limit`` on the time ``spans`` [s] (each planned move's): at each
    sample, and between samples k and k + 1 the larger of their tilts plus the largest turn of the
    tool's axis on the way, bounded by ``0.5 * dt * sum_j max(|qd_j|) + dt^2 / 8 * sum_j qdd_max_j`` [rad]
    (revolute joints; the sampled acceleration where the limits give none)."""
    t, q, qd = profile.t, profile.q, profile.qd
    inside = np.zeros(len(t), dtype=bool)
    for start, end in spans:
        inside |= (t >= start) & (t <= end)
    if not inside.any():
        return TiltReport(True, 0.0, 0.0, limit.max_rad, tuple(spans))
    tilt = limit.angles(robot, q)
    dt = np.diff(t)
    qdd_max = profile.limits.qdd_max if profile.limits.qdd_max is not None else np.abs(profile.qdd).max(axis=0)
    speed = np.maximum(np.abs(qd[:-1]), np.abs(qd[1:])).sum(axis=1)
    between = np.maximum(tilt[:-1], tilt[1:]) + 0.5 * dt * speed + dt**2 / 8.0 * float(np.sum(qdd_max))
    judged = np.concatenate([np.where(inside, tilt, -np.inf), np.where(inside[:-1] & inside[1:], between, -np.inf)])
    k = int(np.argmax(judged))
    worst = float(judged[k])
    at = float(t[k] if k < len(t) else t[k - len(t)])
    return TiltReport(bool(worst <= limit.max_rad), worst, at, limit.max_rad, tuple(spans))
