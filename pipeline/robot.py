"""`load_robot`: a robot file becomes an exact NumPy kinematic model (never imports Drake)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from . import compiled
from .errors import ConfigurationError
from .kinematics import DhKinematics
from .robot_spec import Limits, RobotSpec, load_robot_spec


class Robot(DhKinematics):
    """A serial robot from a DH table: ``fk``, ``fk_all``, ``fk_batch``, ``jacobian`` in SI units.

    ``fk(q)``: pose X_BE (4x4) of the end frame E in the robot base frame B [m].
    ``jacobian(q)``: (6, dof) geometric Jacobian, rows [v; w], base frame, at E's origin.
    ``fk``, ``fk_batch``, ``jacobian``, ``jacobian_batch`` and ``fk_and_jacobian`` run compiled
    (``pipeline.compiled``); the NumPy ones of ``DhKinematics`` are the oracle they are checked against.
    """

    def __init__(self, spec: RobotSpec):
        super().__init__(spec)
        self.name = spec.name
        self._chain, self._axes = compiled.pack_chain(self._P, self._C, self._S, self._V, self._K0, self._sign,
                                                      self._revolute)

    # -- the compiled core: float64 arrays go straight in; anything else, or a kernel's ValueError,
    # -- gets the typed check of DhKinematics -------------------------------------------------------
    def _vector(self, q) -> np.ndarray:
        return q if type(q) is np.ndarray and q.dtype == np.float64 and q.ndim == 1 else self.as_configuration(q)

    def _batch(self, Q) -> np.ndarray:
        return Q if type(Q) is np.ndarray and Q.dtype == np.float64 and Q.ndim == 2 else self.as_batch(Q)

    def _refused(self, q, batch: bool = False) -> ConfigurationError:
        """The typed error for an input a kernel refused (raised by the NumPy check itself)."""
        (self.as_batch if batch else self.as_configuration)(q)
        return ConfigurationError(f"{self.name}: the compiled kinematics refused q of shape {np.shape(q)}")

    def fk(self, q) -> np.ndarray:
        try:
            return compiled.fk(self._chain, self._vector(q))
        except ValueError:
            raise self._refused(q) from None

    def fk_batch(self, Q) -> np.ndarray:
        try:
            return compiled.fk_batch(self._chain, self._batch(Q))
        except ValueError:
            raise self._refused(Q, batch=True) from None

    def jacobian(self, q) -> np.ndarray:
        try:
            return compiled.jacobian(self._chain, self._axes, self._vector(q))
        except ValueError:
            raise self._refused(q) from None

    def jacobian_batch(self, Q) -> np.ndarray:
        try:
            return compiled.jacobian_batch(self._chain, self._axes, self._batch(Q))
        except ValueError:
            raise self._refused(Q, batch=True) from None

    def fk_and_jacobian(self, q) -> tuple[np.ndarray, np.ndarray]:
        try:
            return compiled.fk_and_jacobian(self._chain, self._axes, self._vector(q))
        except ValueError:
            raise self._refused(q) from None

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
        continuous = self.limits.continuous
        lo = np.where(continuous, -np.pi, self.limits.q_min)
        hi = np.where(continuous, np.pi, self.limits.q_max)
        inset = np.where(continuous, 0.0, margin * (hi - lo))
        return rng.uniform(lo + inset, hi - inset, size=(count, self.dof))

    # -- inverse kinematics (pipeline.ik) ------------------------------------------------------
    def ik(self, X_target, q_seed=None, method: str = "auto", target_kind: str = "pose", **options):
        """IK for one end-frame pose X_BE (4x4, base frame, [m]) -> IkResult (never None).

        ``method``: ``auto`` | ``analytic`` | ``jacobian`` | ``drake``; ``target_kind``: ``pose`` |
        ``position+axis`` | ``position``. See ``pipeline.ik.solve_ik`` for the options.
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
    """A preset name (``gp7``, ``lrmate200id``, ``irb1600``, ``arm5``, ``arm6``) or a robot file path."""
    return Robot(load_robot_spec(name_or_path))
