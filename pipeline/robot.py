"""`load_robot`: a robot file becomes an exact NumPy kinematic model (never imports Drake)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .kinematics import DhKinematics
from .robot_spec import Limits, RobotSpec, load_robot_spec


class Robot(DhKinematics):
    """A serial robot from a DH table: ``fk``, ``fk_all``, ``fk_batch``, ``jacobian`` in SI units.

    ``fk(q)``: pose X_BE (4x4) of the end frame E in the robot base frame B [m].
    ``jacobian(q)``: (6, dof) geometric Jacobian, rows [v; w], base frame, at E's origin.
    """

    def __init__(self, spec: RobotSpec):
        super().__init__(spec)
        self.name = spec.name

    @property
    def limits(self) -> Limits:
        """Joint limits in SI units (rad or m, per second)."""
        return self.spec.limits

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.spec.joints]

    def random_configurations(self, rng: np.random.Generator, count: int, margin: float = 0.0) -> np.ndarray:
        """Uniform random configurations (count, dof) inside the limits shrunk by ``margin`` of each range."""
        lo, hi = self.limits.q_min, self.limits.q_max
        span = hi - lo
        return rng.uniform(lo + margin * span, hi - margin * span, size=(count, self.dof))

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
