"""Inverse kinematics three ways, every answer verified by our own FK.

``solve_ik(robot, X_target, q_seed=None, method="auto", target_kind="pose", **options)``:
``analytic`` (closed form, every branch, for arms whose last three axes meet), ``jacobian`` (damped
least squares with restarts), ``drake`` (pydrake InverseKinematics), ``auto`` (analytic where it
applies, else jacobian).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigurationError
from .result import FULL_POSE, IkResult, IkTarget, Solution, make_target

METHODS = ("auto", "analytic", "jacobian", "drake")


def solve_ik(robot, X_target, q_seed=None, method: str = "auto", target_kind: str = FULL_POSE, **options) -> IkResult:
    """Solve IK for one target pose X_BE (4x4, base frame, [m]); never returns None.

    ``q_seed``: configuration to stay near (default: the middle of the joint ranges).
    ``options`` go to the method: ``rng`` (np.random.Generator for restarts), ``max_restarts``,
    ``max_iterations``, ``time_budget`` [s].
    """
    if method not in METHODS:
        raise ConfigurationError(f"unknown IK method {method!r}; choose one of {', '.join(METHODS)}")
    target = make_target(X_target, target_kind)
    limits = robot.limits
    seed = (limits.q_min + limits.q_max) / 2.0 if q_seed is None else robot.as_configuration(q_seed)
    if method == "auto":
        from .analytic import analytic_solver_for

        method = "analytic" if analytic_solver_for(robot).applicable and target.kind == FULL_POSE else "jacobian"
    if method == "analytic":
        from .analytic import solve_analytic

        return solve_analytic(robot, target, seed)
    if method == "jacobian":
        from .jacobian import solve_jacobian

        return solve_jacobian(robot, target, seed, **options)
    from .drake_ik import solve_drake

    return solve_drake(robot, target, seed, **options)


__all__ = ["IkResult", "IkTarget", "METHODS", "Solution", "solve_ik", "make_target"]
