"""`load_robot`: a robot file becomes an exact NumPy kinematic model (never imports Drake)."""

from __future__ import annotations

import dataclasses
from functools import cached_property
from pathlib import Path

import numpy as np

from ..files.robot_spec import Limits, RobotSpec, load_robot_spec
from .chain import compiled
from .chain.kinematics import DhKinematics

#: The single-call path looked up once: a module attribute costs as much as a tenth of an FK call.
_empty, _fk_into, _jacobian_into = np.empty, compiled.fk_into, compiled.jacobian_into
_POSE_SHAPE = (4, 4)


class Robot(DhKinematics):
    """A serial robot from a DH table: ``fk``, ``fk_all``, ``fk_batch``, ``jacobian`` in SI units.

    ``fk(q)``: pose X_BE (4x4) of the end frame E in the robot base frame B [m].
    ``jacobian(q)``: (6, dof) geometric Jacobian, rows [v; w], base frame, at E's origin.
    ``fk``, ``fk_batch``, ``jacobian``, ``jacobian_batch`` and ``fk_and_jacobian`` run compiled
    (``pipeline.model.chain.compiled``); the NumPy ones of ``DhKinematics`` are the oracle they are checked against.
    """

    def __init__(self, spec: RobotSpec):
        super().__init__(spec)
        self.name = spec.name
        self._chain = compiled.pack_chain(self._K, self._sign, self._revolute)
        self._jacobian_shape = (6, self.dof)
        #: q_min and q_max (2, dof) [rad or m] as the closed-form kernels take them.
        self._limit_rows = np.ascontiguousarray(np.vstack([spec.limits.q_min, spec.limits.q_max]))
        #: The default IK seed, the middle of the joint ranges, as the kernels take it (never written).
        self._q_middle = spec.limits.q_middle
        #: Where ``random_configurations`` draws each joint [rad or m]: its limits, [-pi, pi] if continuous.
        continuous = spec.limits.continuous
        self._sampled_ranges = (np.where(continuous, -np.pi, spec.limits.q_min),
                                np.where(continuous, np.pi, spec.limits.q_max))

    # -- the compiled core: float64 arrays of any layout go straight in; anything else (the kernel's
    # -- TypeError or ValueError) is checked by DhKinematics for the typed error, or converted --------
    def as_configuration(self, q) -> np.ndarray:
        """Validate one joint vector -> float array (dof,) [rad or m]; a float64 array the compiled check
        passes is returned as it is (C-contiguous: a strided one as a C-contiguous copy)."""
        if type(q) is np.ndarray and q.dtype == np.float64 and q.ndim == 1:
            q = q if q.flags.c_contiguous else np.ascontiguousarray(q)    # one compiled check for every layout
            try:
                compiled.check_configuration(q, self.dof)
                return q
            except ValueError:
                pass                                  # DhKinematics words the error
        return super().as_configuration(q)

    def _checked(self, q, batch: bool = False) -> np.ndarray:
        """q as the kernels take it (a C-contiguous float64 copy), or the typed error that names it."""
        return np.array(self.as_batch(q) if batch else self.as_configuration(q), dtype=np.float64, order="C")

    def fk(self, q) -> np.ndarray:
        X = _empty(_POSE_SHAPE)
        try:
            _fk_into(self._chain, q, X)
        except (TypeError, ValueError):
            _fk_into(self._chain, self._checked(q), X)
        return X

    def fk_batch(self, Q) -> np.ndarray:
        try:
            out = np.empty((len(Q), 4, 4))
            compiled.fk_batch_into(self._chain, Q, out)
        except (TypeError, ValueError):
            Q = self._checked(Q, batch=True)
            out = np.empty((len(Q), 4, 4))
            compiled.fk_batch_into(self._chain, Q, out)
        return out

    def jacobian(self, q) -> np.ndarray:
        J = _empty(self._jacobian_shape)
        try:
            _jacobian_into(self._chain, q, J)
        except (TypeError, ValueError):
            _jacobian_into(self._chain, self._checked(q), J)
        return J

    def jacobian_batch(self, Q) -> np.ndarray:
        try:
            out = np.empty((len(Q), *self._jacobian_shape))
            compiled.jacobian_batch_into(self._chain, Q, out)
        except (TypeError, ValueError):
            Q = self._checked(Q, batch=True)
            out = np.empty((len(Q), *self._jacobian_shape))
            compiled.jacobian_batch_into(self._chain, Q, out)
        return out

    def fk_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        X, J = np.empty((4, 4)), np.empty(self._jacobian_shape)
        try:
            compiled.fk_and_jacobian_into(self._chain, q, X, J)
        except (TypeError, ValueError):
            compiled.fk_and_jacobian_into(self._chain, self._checked(q), X, J)
        return X, J

    @cached_property
    def _analytic_solver(self):
        """The closed-form IK solver of this arm (``pipeline.model.ik.analytic.derive_solver``), derived on first use."""
        from .ik.analytic import derive_solver

        return derive_solver(self)

    @property
    def limits(self) -> Limits:
        """Joint limits in SI units (rad or m, per second)."""
        return self.spec.limits

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.spec.joints]

    def random_configurations(self, rng: np.random.Generator, count: int, margin: float = 0.0) -> np.ndarray:
        """Uniform random configurations (count, dof) inside the limits shrunk by ``margin`` of each range;
        a continuous joint (no limits) draws uniformly in [-pi, pi] [rad], whatever the margin (it has no
        limit to keep away from, and every angle it can take is there once)."""
        lo, hi = self._sampled_ranges
        if margin:
            inset = np.where(self.limits.continuous, 0.0, margin * (hi - lo))
            lo, hi = lo + inset, hi - inset
        return lo + (hi - lo) * rng.random((count, self.dof))       # rng.uniform's draws, without its overhead

    # -- inverse kinematics (pipeline.model.ik) ------------------------------------------------------
    def ik(self, X_target, q_seed=None, method: str = "auto", target_kind: str = "pose", **options):
        """IK for one end-frame pose X_BE (4x4, base frame, [m]) -> IkResult (never None).

        ``method``: ``auto`` | ``analytic`` | ``jacobian`` | ``drake``; ``target_kind``: ``pose`` |
        ``position+axis`` | ``position``. See ``pipeline.model.ik.solve_ik`` for the options.
        """
        from .ik import solve_ik

        return solve_ik(self, X_target, q_seed, method=method, target_kind=target_kind, **options)

    def ik_batch(self, X_targets, q_seeds=None, method: str = "auto", target_kind: str = "pose", **options):
        """IK for N poses (N, 4, 4); seeds (N, dof), one (dof,) for all, or None. Returns N IkResults.

        The closed form runs vectorised over all targets; the numeric methods solve one by one.
        """
        from .ik import solve_ik_batch

        return solve_ik_batch(self, X_targets, q_seeds, method=method, target_kind=target_kind, **options)

    def ik_path(self, X_path, q_start, method: str = "auto", target_kind: str = "pose", **options):
        """IK along poses (K, 4, 4) that keeps one branch and never jumps -> PathIkResult."""
        from .ik.sequence import solve_ik_path

        return solve_ik_path(self, X_path, q_start, method=method, target_kind=target_kind, **options)

    def joint_velocities(self, q, twist, **options):
        """Joint rates for an end-frame twist [v; w] (base frame) via the damped pseudo-inverse."""
        from .ik.velocity import joint_velocities

        return joint_velocities(self, q, twist, **options)

    def __str__(self) -> str:
        return self.spec.dh_table()

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {self.spec.convention} DH, dof={self.dof}, source={self.spec.source!r})"


def robot_with_tool(robot: Robot, X_ET: np.ndarray) -> Robot:
    """The robot whose end frame is a tool's TCP: its end frame E (the flange, or the robot file's own
    tool) times ``X_ET`` (4, 4) [m]."""
    return Robot(dataclasses.replace(robot.spec, X_DnE=robot.spec.X_DnE @ X_ET))


def load_robot(name_or_path: str | Path) -> Robot:
    """A preset name (``gp7``, ``lrmate200id``, ``irb1600``, ``ur5e``, ``arm5``, ``arm6``) or a robot file path."""
    return Robot(load_robot_spec(name_or_path))
