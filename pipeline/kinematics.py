"""NumPy reference kinematics for standard and modified DH chains.

This module never imports Drake: it is the independent oracle the Drake model is checked against.
Link transforms are the textbook DH matrices; everything is vectorised over a leading batch axis.
Jacobians are geometric, rows ``[v; w]``, expressed in the robot base frame at the end-frame origin.
"""

from __future__ import annotations

import numpy as np

from .errors import ConfigurationError
from .robot_spec import RobotSpec


def dh_standard(theta, d, a, alpha) -> np.ndarray:
    """Standard DH link transform ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``; inputs broadcast -> (..., 4, 4)."""
    theta, d, a, alpha = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (theta, d, a, alpha)))
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    A = np.zeros(theta.shape + (4, 4))
    A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa, ca, d
    A[..., 3, 3] = 1.0
    return A


def dh_modified(alpha_prev, a_prev, theta, d) -> np.ndarray:
    """Modified (Craig) DH link transform ``Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta) Tz(d)`` -> (..., 4, 4)."""
    alpha, a, theta, d = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (alpha_prev, a_prev, theta, d))
    )
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    A = np.zeros(theta.shape + (4, 4))
    A[..., 0, 0], A[..., 0, 1], A[..., 0, 3] = ct, -st, a
    A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st * ca, ct * ca, -sa, -sa * d
    A[..., 2, 0], A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = st * sa, ct * sa, ca, ca * d
    A[..., 3, 3] = 1.0
    return A


class DhKinematics:
    """Forward kinematics and geometric Jacobian of one RobotSpec, in SI units."""

    def __init__(self, spec: RobotSpec):
        self.spec = spec
        self.dof = spec.dof
        joints = spec.joints
        self._a = np.array([j.a for j in joints])
        self._alpha = np.array([j.alpha for j in joints])
        self._d = np.array([j.d for j in joints])
        self._offset = np.array([j.theta_offset for j in joints])
        self._sign = np.array([j.sign for j in joints])
        self._revolute = np.array([j.is_revolute for j in joints])
        self._X_BaseD0 = spec.X_BaseD0
        self._X_DnE = spec.X_DnE
        self._modified = spec.convention == "modified"

    # -- input checks ---------------------------------------------------------------------------
    def as_configuration(self, q) -> np.ndarray:
        """Validate one joint vector -> float array (dof,) [rad or m]."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.dof,):
            raise ConfigurationError(f"{self.spec.name}: q must have shape ({self.dof},), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ConfigurationError(f"{self.spec.name}: q has non-finite values: {q}")
        return q

    def as_batch(self, Q) -> np.ndarray:
        """Validate a batch of joint vectors -> float array (N, dof)."""
        Q = np.asarray(Q, dtype=float)
        if Q.ndim != 2 or Q.shape[1] != self.dof:
            raise ConfigurationError(f"{self.spec.name}: Q must have shape (N, {self.dof}), got {Q.shape}")
        if not np.all(np.isfinite(Q)):
            raise ConfigurationError(f"{self.spec.name}: Q has non-finite values")
        return Q

    # -- kinematics -----------------------------------------------------------------------------
    def link_transforms(self, Q: np.ndarray) -> np.ndarray:
        """DH link transforms A_i(q_i) for a batch Q (N, dof) -> (N, dof, 4, 4)."""
        joint_value = self._sign * Q
        theta = np.where(self._revolute, joint_value + self._offset, self._offset)
        d = np.where(self._revolute, self._d, joint_value + self._d)
        if self._modified:
            return dh_modified(self._alpha, self._a, theta, d)
        return dh_standard(theta, d, self._a, self._alpha)

    def frames_batch(self, Q: np.ndarray) -> np.ndarray:
        """Poses in the base frame of DH frames 0..dof and the end frame -> (N, dof + 2, 4, 4) [m]."""
        A = self.link_transforms(Q)
        X = np.empty((Q.shape[0], self.dof + 2, 4, 4))
        X[:, 0] = self._X_BaseD0
        for i in range(self.dof):
            X[:, i + 1] = X[:, i] @ A[:, i]
        X[:, -1] = X[:, -2] @ self._X_DnE
        return X

    def fk_batch(self, Q) -> np.ndarray:
        """End-frame poses X_BE for a batch (N, dof) -> (N, 4, 4) [m]."""
        Q = self.as_batch(Q)
        A = self.link_transforms(Q)
        X = np.broadcast_to(self._X_BaseD0, (Q.shape[0], 4, 4))
        for i in range(self.dof):
            X = X @ A[:, i]
        return X @ self._X_DnE

    def fk(self, q) -> np.ndarray:
        """End-frame pose X_BE (4, 4) [m] at one configuration."""
        return self.fk_batch(self.as_configuration(q)[None])[0]

    def fk_all(self, q) -> np.ndarray:
        """Poses of DH frames 0..dof and the end frame at one configuration -> (dof + 2, 4, 4) [m]."""
        return self.frames_batch(self.as_configuration(q)[None])[0]

    def joint_axes_batch(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """From frames_batch output: unit axes (N, dof, 3) with the sign applied, and points on them."""
        # Standard DH: joint i moves about/along z of frame i-1; modified DH: z of frame i.
        frames = X[:, 1:-1] if self._modified else X[:, :-2]
        axes = frames[..., :3, 2] * self._sign[:, None]
        return axes, frames[..., :3, 3]

    def jacobian_batch(self, Q) -> np.ndarray:
        """Geometric Jacobians, rows [v; w], base frame, at the end-frame origin -> (N, 6, dof)."""
        Q = self.as_batch(Q)
        X = self.frames_batch(Q)
        axes, points = self.joint_axes_batch(X)
        p_BE = X[:, -1, :3, 3]
        J = np.zeros((Q.shape[0], 6, self.dof))
        rev = self._revolute
        J[:, :3, rev] = np.cross(axes[:, rev], p_BE[:, None, :] - points[:, rev]).transpose(0, 2, 1)
        J[:, 3:, rev] = axes[:, rev].transpose(0, 2, 1)
        J[:, :3, ~rev] = axes[:, ~rev].transpose(0, 2, 1)
        return J

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian (6, dof), rows [v; w] in the base frame at the end-frame origin."""
        return self.jacobian_batch(self.as_configuration(q)[None])[0]


def rotation_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle) [rad] of a rotation matrix, for small and moderate angles."""
    cos_angle = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos_angle)
    vee = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-8:
        return vee / 2.0
    return vee * angle / (2.0 * np.sin(angle))


def finite_difference_jacobian(fk, q: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """Central-difference Jacobian of a pose function ``fk(q) -> (4, 4)``, rows [v; w] in the base frame.

    The angular rows are ``log(R(q + h e_i) R(q - h e_i)^T) / 2h``: no analytic formula is used.
    """
    q = np.asarray(q, dtype=float)
    J = np.zeros((6, q.size))
    for i in range(q.size):
        dq = np.zeros_like(q)
        dq[i] = step
        X_plus, X_minus = fk(q + dq), fk(q - dq)
        J[:3, i] = (X_plus[:3, 3] - X_minus[:3, 3]) / (2.0 * step)
        J[3:, i] = rotation_log(X_plus[:3, :3] @ X_minus[:3, :3].T) / (2.0 * step)
    return J
