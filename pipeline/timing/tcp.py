"""The TCP's motion from the joints' (the robot's end frame is the TCP): what tool limits are judged on.

``TcpMotion(robot)``: position, velocity ``v = Jv qd`` and acceleration ``a = Jv qdd + dJv/dt qd`` of
the end frame's origin [m, m/s, m/s^2] for joint samples, and ``along(path, s)``: the track's
derivatives dp/ds, d2p/ds2 along a joint path, the coefficients of the TCP limits in path timing
(v = p' sd, a = p' sdd + p'' sd^2). ``dJv/dt qd`` is a central difference of the Jacobian along qd.
``PathLimits``: the limits a timing back end meets along a path (joints, TCP, a schedule), sample by sample.
"""

from __future__ import annotations

import numpy as np

from ..files.robot_spec import Limits
from .joint_path import JointPath
from .profile import TcpSamples, limits_at
from .schedule import LimitSchedule

#: Step of the central differences along the motion, as the largest joint change [rad or m].
JOINT_STEP = 1e-6


class TcpMotion:
    """The TCP kinematics of ``robot`` (a Robot whose end frame is the TCP)."""

    def __init__(self, robot):
        self.robot = robot

    def _jv(self, Q: np.ndarray) -> np.ndarray:
        return self.robot.jacobian_batch(Q)[:, :3, :]

    def bias(self, Q: np.ndarray, QD: np.ndarray) -> np.ndarray:
        """dJv/dt qd (n, 3) at joint positions Q and velocities QD (n, dof): a central difference of Jv along qd."""
        scale = np.maximum(np.abs(QD).max(axis=1, keepdims=True), 1e-300)
        h = JOINT_STEP / scale
        direction = QD * h
        forward, backward = self._jv(Q + direction), self._jv(Q - direction)
        return np.einsum("nij,nj->ni", forward - backward, QD) / (2.0 * h)

    def motion(self, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray):
        """(p, v, a) (n, 3) [m, m/s, m/s^2] of the TCP for joint samples (n, dof)."""
        jv = self._jv(Q)
        return (self.robot.fk_batch(Q)[:, :3, 3], np.einsum("nij,nj->ni", jv, QD),
                np.einsum("nij,nj->ni", jv, QDD) + self.bias(Q, QD))

    def along(self, path: JointPath, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dp/ds, d2p/ds2) (n, 3) of the TCP along a joint path at s (n,) [m per unit s^k]: Jv q' and
        Jv q'' + (dJv/ds) q', with the path's own q' and q'' (at a breakpoint, the piece that starts there)
        and dJv/ds a central difference in joint space along q' (never across a breakpoint of the path)."""
        q, d1 = path(s), path(s, 1)
        jv = self._jv(q)
        return np.einsum("nij,nj->ni", jv, d1), np.einsum("nij,nj->ni", jv, path(s, 2)) + self.bias(q, d1)

    def samples(self, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray) -> TcpSamples:
        """The TCP's position, speed and acceleration at a profile's samples."""
        p, v, a = self.motion(Q, QD, QDD)
        return TcpSamples(p, np.linalg.norm(v, axis=1), np.linalg.norm(a, axis=1))


class PathLimits:
    """The limits a timing back end meets along one path: ``limits`` everywhere, ``schedule`` (a
    LimitSchedule over the path's s, already scaled like the limits; None: none) on top, the TCP's through
    ``tcp`` (a TcpMotion; None: the TCP is not judged)."""

    def __init__(self, limits: Limits, tcp: TcpMotion | None = None, schedule: LimitSchedule | None = None):
        self.limits, self.tcp, self.schedule = limits, tcp, schedule

    def at(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(joint speed factor [1], TCP speed [m/s], TCP acceleration [m/s^2]) (n,) at s (n,); inf: not
        limited (``pipeline.timing.profile.limits_at``)."""
        return limits_at(self.limits, self.schedule, s)

    @property
    def limits_tcp(self) -> bool:
        """Whether the TCP is judged and something limits it somewhere."""
        return self.tcp is not None and (self.limits.tcp_speed_max is not None or self.limits.tcp_accel_max is not None
                                         or (self.schedule is not None and self.schedule.limits_tcp))

    def sample_ratios(self, s: np.ndarray, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray,
                      tcp_rows=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Per sample (n,) at path positions s (n,): the largest speed ratio (each |qd_j| over qd_max_j x the
        joint speed factor, and the TCP's speed over its limit) and acceleration ratio (|qdd_j| / qdd_max_j, the
        TCP's) [1]; the TCP's only on the samples ``tcp_rows`` selects (a slice or index array)."""
        joint_speed, tcp_speed, tcp_accel = self.at(s)
        speed = (np.abs(QD) / self.limits.qd_max).max(axis=1) / joint_speed
        accel = (np.abs(QDD) / self.limits.qdd_max).max(axis=1)
        if self.limits_tcp:
            _, v, a = self.tcp.motion(Q[tcp_rows], QD[tcp_rows], QDD[tcp_rows])
            speed[tcp_rows] = np.maximum(speed[tcp_rows], np.linalg.norm(v, axis=1) / tcp_speed[tcp_rows])
            accel[tcp_rows] = np.maximum(accel[tcp_rows], np.linalg.norm(a, axis=1) / tcp_accel[tcp_rows])
        return speed, accel

    def peaks(self, s: np.ndarray, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray,
              tcp_rows=slice(None)) -> tuple[float, float]:
        """The peak speed and acceleration ratios of ``sample_ratios`` [1] (what a uniform slow-down must bring
        down to 1)."""
        speed, accel = self.sample_ratios(s, Q, QD, QDD, tcp_rows)
        return float(speed.max()), float(accel.max())
