"""The TCP's motion from the joints' (the robot's end frame is the TCP): what tool limits are judged on.

``TcpMotion(robot)``: position, velocity ``v = Jv qd`` and acceleration ``a = Jv qdd + dJv/dt qd`` of
the end frame's origin [m, m/s, m/s^2] for joint samples, and ``along(path, s)``: the track's
derivatives dp/ds, d2p/ds2 along a joint path, the coefficients of the TCP limits in path timing
(v = p' sd, a = p' sdd + p'' sd^2). ``dJv/dt qd`` is a central difference of the Jacobian along qd.
"""

from __future__ import annotations

import numpy as np

from .path import JointPath
from .profile import TcpSamples
from .robot_spec import Limits

#: Step of the central differences along the motion, as the largest joint change [rad or m]; and,
#: along a path, in its parameter s.
JOINT_STEP = 1e-6
PATH_STEP = 1e-6


class TcpMotion:
    """The TCP kinematics of ``robot`` (a Robot whose end frame is the TCP)."""

    def __init__(self, robot):
        self.robot = robot

    def _jv(self, Q: np.ndarray) -> np.ndarray:
        return self.robot.jacobian_batch(Q)[:, :3, :]

    def velocity_and_bias(self, Q: np.ndarray, QD: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(v, dJv/dt qd) (n, 3) at joint positions Q and velocities QD (n, dof)."""
        scale = np.maximum(np.abs(QD).max(axis=1, keepdims=True), 1e-300)
        h = JOINT_STEP / scale
        direction = QD * h
        forward, backward = self._jv(Q + direction), self._jv(Q - direction)
        bias = np.einsum("nij,nj->ni", forward - backward, QD) / (2.0 * h)
        return np.einsum("nij,nj->ni", self._jv(Q), QD), bias

    def motion(self, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray):
        """(p, v, a) (n, 3) [m, m/s, m/s^2] of the TCP for joint samples (n, dof)."""
        v, bias = self.velocity_and_bias(Q, QD)
        return self.robot.fk_batch(Q)[:, :3, 3], v, np.einsum("nij,nj->ni", self._jv(Q), QDD) + bias

    def along(self, path: JointPath, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dp/ds, d2p/ds2) (n, 3) of the TCP along a joint path at s (n,) [m per unit s^k]."""
        def first(x):
            return np.einsum("nij,nj->ni", self._jv(path(x)), path(x, 1))

        low, high = np.clip(s - PATH_STEP, 0.0, 1.0), np.clip(s + PATH_STEP, 0.0, 1.0)
        return first(s), (first(high) - first(low)) / (high - low)[:, None]

    def samples(self, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray) -> TcpSamples:
        """The TCP's position, speed and acceleration at a profile's samples."""
        p, v, a = self.motion(Q, QD, QDD)
        return TcpSamples(p, np.linalg.norm(v, axis=1), np.linalg.norm(a, axis=1))

    def sample_ratios(self, limits: Limits, Q: np.ndarray, QD: np.ndarray,
                      QDD: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per sample (n,): the TCP speed and acceleration over their limits (0 where a limit is absent) [1]."""
        _, v, a = self.motion(Q, QD, QDD)
        none = np.zeros(len(Q))
        speed = np.linalg.norm(v, axis=1) / limits.tcp_speed_max if limits.tcp_speed_max else none
        accel = np.linalg.norm(a, axis=1) / limits.tcp_accel_max if limits.tcp_accel_max else none
        return speed, accel

    def ratios(self, limits: Limits, Q: np.ndarray, QD: np.ndarray, QDD: np.ndarray) -> tuple[float, float]:
        """The peak TCP speed and acceleration over their limits (0 where a limit is absent) [1]."""
        speed, accel = self.sample_ratios(limits, Q, QD, QDD)
        return float(speed.max()), float(accel.max())


def with_tcp(speed: float, accel: float, tcp: TcpMotion | None, limits: Limits, Q: np.ndarray, QD: np.ndarray,
             QDD: np.ndarray) -> tuple[float, float]:
    """Peak speed and acceleration ratios of the joints, raised to the TCP's at the same samples when
    ``tcp`` is given (what a uniform slow-down must bring down to 1) [1]."""
    if tcp is None:
        return speed, accel
    tcp_speed, tcp_accel = tcp.ratios(limits, Q, QD, QDD)
    return max(speed, tcp_speed), max(accel, tcp_accel)
