"""Inverse kinematics three ways, every answer verified by our own FK.

``solve_ik(robot, X_target, q_seed=None, method="auto", target_kind="pose", **options)``:
``analytic`` (closed form, every branch, for arms whose last three axes meet), ``jacobian`` (damped
least squares with restarts), ``drake`` (pydrake InverseKinematics), ``auto`` (analytic where it
applies, else jacobian).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..choices import IK_METHODS
from ..arrays import float_array
from ..errors import ConfigurationError
from ..progress import Progress
from .result import (FULL_POSE, MATCHED_COMPONENTS, POSITION_AND_AXIS, POSITION_ONLY, IkResult, IkTarget, Solution,
                     make_target)

METHODS = IK_METHODS
#: The options each method takes (``solve_jacobian``, ``solve_drake``); a call may give any of them.
OPTIONS = {"analytic": (), "jacobian": ("rng", "max_restarts", "max_iterations", "time_budget"),
           "drake": ("rng", "max_restarts", "time_budget", "solver", "drake")}


def solve_ik(robot, X_target, q_seed=None, method: str = "auto", target_kind: str = FULL_POSE, **options) -> IkResult:
    """Solve IK for one target pose X_BE (4x4, base frame, [m]); never returns None. Every solution
    carries its configuration label (``pipeline.ik.branches``; "" for arms without named ones).

    ``q_seed``: configuration to stay near (default: the middle of the joint ranges).
    ``options`` go to the method: ``rng`` (np.random.Generator for restarts), ``max_restarts``,
    ``max_iterations``, ``time_budget`` [s]; for ``drake``, ``solver`` and ``drake`` (the robot's
    DrakeRobot, to reuse one over many calls).
    """
    target = make_target(X_target, target_kind)
    seed = _seed(robot, q_seed)
    _check_options(options)
    requested, method = method, _resolve_method(robot, method, target.kind)
    if requested == "auto" and method == "analytic":
        return _with_fallback(robot, solve_ik(robot, target.X_BE, seed, "analytic", target.kind), target, seed, options)
    options = {name: value for name, value in options.items() if name in OPTIONS[method]}
    if method == "analytic":
        from .analytic import solve_analytic

        result = solve_analytic(robot, target, seed)
    elif method == "jacobian":
        from .jacobian import solve_jacobian

        result = solve_jacobian(robot, target, seed, **options)
    else:
        from .drake_ik import solve_drake

        result = solve_drake(robot, target, seed, **options)
    if method != "analytic" and result.solutions:
        from .branches import configuration_labels

        labels = configuration_labels(robot, np.array([s.q for s in result.solutions]))
        result = dataclasses.replace(result, solutions=tuple(s._replace(branch=label)
                                                             for s, label in zip(result.solutions, labels)))
    if not result.success and robot.dof < 6 and target.kind == FULL_POSE:
        result = dataclasses.replace(result, reason=f"{result.reason}; {robot.name} has {robot.dof} joints and cannot "
                                     "match a full pose (6 components) in general: ask for "
                                     f"{', '.join(MATCHED_COMPONENTS[POSITION_AND_AXIS])} (target_kind='position+axis') "
                                     f"or {', '.join(MATCHED_COMPONENTS[POSITION_ONLY])} (target_kind='position')")
    return result


def _with_fallback(robot, result: IkResult, target: IkTarget, seed: np.ndarray, options: dict) -> IkResult:
    """``auto``: a closed-form failure (a shoulder singularity whose free q1 was not sampled well, a
    numerical failure) is tried again by ``jacobian`` before it is reported; the closed form's reason
    stays in the details (or, when both fail, in the reason)."""
    if result.success:
        return result
    fallback = solve_ik(robot, target.X_BE, seed, "jacobian", target.kind, **options)
    if fallback.success:
        return dataclasses.replace(fallback, details={**fallback.details, "analytic_failed": result.reason})
    return dataclasses.replace(result, reason=f"{result.reason}; jacobian: {fallback.reason}")


def with_drake_model(robot, method: str, options: dict) -> dict:
    """``options`` with one DrakeRobot to share over many ``drake`` solves (unless they carry one)."""
    if method != "drake" or options.get("drake") is not None:
        return options
    from ..drake_model import build_drake_robot

    return {**options, "drake": build_drake_robot(robot.spec)}


def _check_options(options: dict) -> None:
    """``options`` for the method that runs: ConfigurationError for a name no method takes (a typo);
    the names of the other methods are dropped (one call can serve ``auto`` and every method)."""
    unknown = sorted(set(options) - {name for names in OPTIONS.values() for name in names})
    if unknown:
        known = sorted({name for names in OPTIONS.values() for name in names})
        raise ConfigurationError(f"unknown IK option {', '.join(map(repr, unknown))}; the options: {', '.join(known)}")


def _seed(robot, q_seed) -> np.ndarray:
    """The seed as a checked configuration; default the middle of the joint ranges (0 for a continuous joint)."""
    return robot.limits.q_middle if q_seed is None else robot.as_configuration(q_seed)


def _resolve_method(robot, method: str, kind: str) -> str:
    """Validate the method name; ``auto`` becomes ``analytic`` where the closed form fits, else ``jacobian``."""
    if method not in METHODS:
        raise ConfigurationError(f"unknown IK method {method!r}; choose one of {', '.join(METHODS)}")
    if method != "auto":
        return method
    return "analytic" if kind == FULL_POSE and has_closed_form(robot) else "jacobian"


def has_closed_form(robot) -> bool:
    """Whether the closed form (``analytic``: our spherical-wrist solver, else EAIK's) solves this arm."""
    from .analytic import analytic_solver_for

    if analytic_solver_for(robot).applicable:
        return True
    from .subproblem import subproblem_solver_for

    return subproblem_solver_for(robot).applicable


def solve_ik_batch(robot, X_targets, q_seeds=None, method: str = "auto", target_kind: str = FULL_POSE,
                   **options) -> list[IkResult]:
    """IK for N targets (N, 4, 4); ``q_seeds`` (N, dof), (dof,) or None. The closed form is vectorised."""
    X_targets = float_array(X_targets, "IK targets", (None, 4, 4))
    targets = [make_target(X, target_kind) for X in X_targets]
    if q_seeds is None or np.ndim(q_seeds) == 1:
        seeds = np.tile(_seed(robot, q_seeds), (len(targets), 1))
    else:
        seeds = robot.as_batch(q_seeds)
        if len(seeds) != len(targets):
            raise ConfigurationError(f"{len(targets)} targets but {len(seeds)} seeds")
    if _resolve_method(robot, method, target_kind) == "analytic":
        from .analytic import solve_analytic_batch

        results = solve_analytic_batch(robot, X_targets, seeds, target_kind)
        if method != "auto":
            return results
        return [_with_fallback(robot, result, target, seed, options)
                for result, target, seed in zip(results, targets, seeds)]
    options = with_drake_model(robot, method, options)
    results = []
    with Progress(len(targets), f"IK {method} {robot.name}") as tick:
        for target, seed in zip(targets, seeds):
            results.append(solve_ik(robot, target.X_BE, seed, method, target_kind, **options))
            tick()
    return results


__all__ = ["IkResult", "IkTarget", "METHODS", "Solution", "make_target", "solve_ik", "solve_ik_batch"]
