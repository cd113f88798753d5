"""NumPy reference kinematics for standard and modified DH chains.

This module never imports Drake: it is the independent oracle the Drake model is checked against.
Link transforms are the textbook DH matrices; everything is vectorised over a leading batch axis.
Jacobians are geometric, rows ``[v; w]``, expressed in the robot base frame at the end-frame origin.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigurationError
from ...files.arrays import MAX_MAGNITUDE, float_array
from ...files.robot_spec import DhJoint, RobotSpec


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


def joint_factors(joint: DhJoint, convention: str) -> tuple[np.ndarray, np.ndarray]:
    """Constant 4x4 factors (L, R) of one DH row, with ``A(q) = L @ M(sign * q) @ R``.

    ``M`` is a rotation about z (revolute) or a translation along z (prismatic), so the joint axis is
    the z axis of the frame ``X_{i-1} @ L``. Built from the textbook matrices above.
    """
    if convention == "standard":
        if joint.is_revolute:
            return dh_standard(joint.theta_offset, 0, 0, 0), dh_standard(0, joint.d, joint.a, joint.alpha)
        return dh_standard(joint.theta_offset, joint.d, 0, 0), dh_standard(0, 0, joint.a, joint.alpha)
    if joint.is_revolute:
        return dh_modified(joint.alpha, joint.a, joint.theta_offset, 0), dh_modified(0, 0, 0, joint.d)
    return dh_modified(joint.alpha, joint.a, joint.theta_offset, joint.d), np.eye(4)


class DhKinematics:
    """Forward kinematics and geometric Jacobian of one RobotSpec, in SI units.

    The chain ``base A_1 ... A_n tool`` is evaluated as ``K_0 (M_1 K_1) ... (M_n K_n)`` with constant
    ``K_0 = base L_1``, ``K_i = R_i L_{i+1}``, ``K_n = R_n tool``. Since ``M_i`` only mixes rows 0 and 1
    (rotation about z) or adds row 3 into row 2 (translation along z), each ``M_i K_i`` is
    ``P_i + cos(v_i) C_i + sin(v_i) S_i + v_i V_i`` with constant matrices and ``v_i = sign_i q_i``.
    Everything is vectorised over joints and over a leading batch axis.
    """

    def __init__(self, spec: RobotSpec):
        self.spec = spec
        self.dof = spec.dof
        factors = [joint_factors(j, spec.convention) for j in spec.joints]
        left = [L for L, _ in factors] + [spec.X_DnE]
        right = [spec.X_BaseD0] + [R for _, R in factors]
        K = np.array([R @ L for R, L in zip(right, left)])     # (dof + 1, 4, 4)
        self._K, self._K0 = K, K[0]
        self._R = np.array([R for _, R in factors])             # DH frame i = joint frame i @ M_i @ R_i
        self._sign = np.array([j.sign for j in spec.joints])
        self._revolute = np.array([j.is_revolute for j in spec.joints])
        self._all_revolute = bool(self._revolute.all())
        Kj = K[1:]
        rev = self._revolute[:, None, None]
        self._P = np.where(rev, Kj * [[0.0], [0.0], [1.0], [1.0]], Kj)
        self._C = np.where(rev, Kj * [[1.0], [1.0], [0.0], [0.0]], 0.0)
        self._S = np.where(rev, np.stack([-Kj[:, 1], Kj[:, 0], 0 * Kj[:, 0], 0 * Kj[:, 0]], axis=1), 0.0)
        self._V = np.where(rev, 0.0, np.stack([0 * Kj[:, 3], 0 * Kj[:, 3], Kj[:, 3], 0 * Kj[:, 3]], axis=1))

    # -- input checks ---------------------------------------------------------------------------
    def as_configuration(self, q) -> np.ndarray:
        """Validate one joint vector -> float array (dof,) [rad or m]."""
        return float_array(q, f"{self.spec.name}: q", (self.dof,), MAX_MAGNITUDE)

    def as_batch(self, Q) -> np.ndarray:
        """Validate a batch of joint vectors -> float array (N, dof)."""
        return float_array(Q, f"{self.spec.name}: Q", (None, self.dof), MAX_MAGNITUDE)

    # -- the chain ------------------------------------------------------------------------------
    def _moved_links(self, Q: np.ndarray) -> np.ndarray:
        """``M_i(q_i) K_i`` for a batch Q (..., dof) -> (..., dof, 4, 4)."""
        value = (Q * self._sign)[..., None, None]
        return self._P + np.cos(value) * self._C + np.sin(value) * self._S + value * self._V

    @property
    def revolute_mask(self) -> np.ndarray:
        """Boolean (dof,): True for revolute joints."""
        return self._revolute

    def joint_frames(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint frames (..., dof, 4, 4) (z = joint i's axis, before its motion) and the end pose (..., 4, 4)."""
        Q = float_array(Q, f"{self.spec.name}: q", None, MAX_MAGNITUDE)
        if Q.shape[-1:] != (self.dof,):
            raise ConfigurationError(f"{self.spec.name}: q must have {self.dof} values in its last axis, "
                                     f"got shape {Q.shape}")
        T = self._moved_links(Q)
        frames = np.empty_like(T)
        frames[..., 0, :, :] = self._K0
        X = self._K0 @ T[..., 0, :, :]
        for i in range(1, self.dof):
            frames[..., i, :, :] = X
            X = X @ T[..., i, :, :]
        return frames, X

    def fk_batch(self, Q) -> np.ndarray:
        """End-frame poses X_BE for a batch (N, dof) -> (N, 4, 4) [m]."""
        T = self._moved_links(self.as_batch(Q))
        X = self._K0 @ T[:, 0]
        for i in range(1, self.dof):
            X = X @ T[:, i]
        return X

    def fk(self, q) -> np.ndarray:
        """End-frame pose X_BE (4, 4) [m] at one configuration."""
        T = self._moved_links(self.as_configuration(q))
        X = self._K0
        for link in T:
            X = X @ link
        return X

    def frames_batch(self, Q) -> np.ndarray:
        """Poses in the base frame of DH frames 0..dof and the end frame -> (N, dof + 2, 4, 4) [m]."""
        Q = self.as_batch(Q)
        T = self._moved_links(Q)
        value = Q * self._sign
        frames, end = self.joint_frames(Q)
        X = np.empty((Q.shape[0], self.dof + 2, 4, 4))
        X[:, 0] = self.spec.X_BaseD0
        # DH frame i = joint frame i @ M_i @ R_i, and M_i = (M_i K_i) K_i^-1 is cheaper as a rotation:
        motion = np.zeros(T.shape)
        c, s = np.cos(value), np.sin(value)
        motion[..., 0, 0], motion[..., 0, 1], motion[..., 1, 0], motion[..., 1, 1] = c, -s, s, c
        motion[..., 2, 2] = motion[..., 3, 3] = 1.0
        rev = self._revolute
        motion[:, ~rev] = np.eye(4)
        motion[:, ~rev, 2, 3] = value[:, ~rev]
        X[:, 1:-1] = frames @ motion @ self._R
        X[:, -1] = end
        return X

    def fk_all(self, q) -> np.ndarray:
        """Poses of DH frames 0..dof and the end frame at one configuration -> (dof + 2, 4, 4) [m]."""
        return self.frames_batch(self.as_configuration(q)[None])[0]

    def _jacobian_from_frames(self, frames: np.ndarray, end: np.ndarray) -> np.ndarray:
        """Columns [axis x (p_E - p_axis); axis] (revolute) or [axis; 0] (prismatic) -> (..., 6, dof)."""
        axes = frames[..., :3, 2] * self._sign[:, None]                  # (..., dof, 3), sign applied
        lever = end[..., None, :3, 3] - frames[..., :3, 3]
        J = np.empty(axes.shape[:-2] + (6, self.dof))
        ax, ay, az = axes[..., 0], axes[..., 1], axes[..., 2]
        lx, ly, lz = lever[..., 0], lever[..., 1], lever[..., 2]
        J[..., 0, :], J[..., 1, :], J[..., 2, :] = ay * lz - az * ly, az * lx - ax * lz, ax * ly - ay * lx
        J[..., 3:, :] = axes.swapaxes(-1, -2)
        if not self._all_revolute:
            prismatic = ~self._revolute
            J[..., :3, prismatic] = J[..., 3:, prismatic]
            J[..., 3:, prismatic] = 0.0
        return J

    def jacobian_batch(self, Q) -> np.ndarray:
        """Geometric Jacobians, rows [v; w], base frame, at the end-frame origin -> (N, 6, dof)."""
        return self._jacobian_from_frames(*self.joint_frames(self.as_batch(Q)))

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian (6, dof), rows [v; w] in the base frame at the end-frame origin."""
        return self._jacobian_from_frames(*self.joint_frames(self.as_configuration(q)))

    def fk_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        """X_BE (4, 4) [m] and the Jacobian (6, dof) from one pass along the chain (no input check)."""
        frames, X = self.joint_frames(q)
        return X, self._jacobian_from_frames(frames, X)


def rotation_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle, angle in [0, pi]) [rad] of a rotation matrix, accurate at 0 and pi."""
    vee = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    sin_angle = 0.5 * np.linalg.norm(vee)
    cos_angle = 0.5 * (np.trace(R) - 1.0)
    angle = np.arctan2(sin_angle, cos_angle)
    if angle < 1e-6:
        return vee / 2.0
    if angle < np.pi - 1e-6:
        return vee * (angle / (2.0 * sin_angle))
    # Near pi the skew part vanishes: the axis is the dominant column of (R + I) / 2 = a a^T.
    B = (R + np.eye(3)) / 2.0
    k = int(np.argmax(np.diag(B)))
    axis = B[:, k] / np.sqrt(B[k, k])
    if axis @ vee < 0.0:
        axis = -axis
    return axis * angle


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
