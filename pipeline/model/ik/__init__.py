"""Inverse kinematics three ways, every answer verified by our own FK.

``solve_ik(robot, X_target, q_seed=None, method="auto", target_kind="pose", **options)``:
``analytic`` (closed form, every branch, for arms whose last three axes meet or whose axes 2, 3, 4 are
parallel: the UR family; EAIK's for other arms it decomposes), ``jacobian`` (damped least squares with
restarts), ``drake`` (pydrake InverseKinematics), ``auto`` (analytic where it applies, else jacobian).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import ConfigurationError
from ...files.choices import IK_METHODS
from ...progress import Progress
from .analytic import analytic_solver_for, solve_analytic, solve_analytic_batch, solve_analytic_unchecked
from .jacobian import solve_jacobian
from .result import (FULL_POSE, MATCHED_COMPONENTS, POSITION_AND_AXIS, POSITION_ONLY, IkResult, IkTarget, Solution,
                     check_targets, make_target)

METHODS = IK_METHODS
#: The methods that try the closed form first.
CLOSED_FORM_FIRST = ("auto", "analytic")
#: The options each method takes (``solve_jacobian``, ``solve_drake``); a call may give any of them.
OPTIONS = {"analytic": (), "jacobian": ("rng", "max_restarts", "max_iterations", "time_budget"),
           "drake": ("rng", "max_restarts", "time_budget", "solver", "drake")}


def solve_ik(robot, X_target, q_seed=None, method: str = "auto", target_kind: str = FULL_POSE, **options) -> IkResult:
    """Solve IK for one target pose X_BE (4x4, base frame, [m]); never returns None. Every solution
    carries its configuration label (``pipeline.model.ik.branches``; "" for arms without named ones).

    ``q_seed``: configuration to stay near (default: the middle of the joint ranges).
    ``options`` go to the method: ``rng`` (np.random.Generator for restarts), ``max_restarts``,
    ``max_iterations``, ``time_budget`` [s]; for ``drake``, ``solver`` and ``drake`` (the robot's
    DrakeRobot, to reuse one over many calls).
    """
    if method in CLOSED_FORM_FIRST and target_kind == FULL_POSE and not options:
        result = solve_analytic_unchecked(robot, X_target, q_seed)      # the fast path of single calls
        if result is not None:
            if result.success or method == "analytic":
                return result
            return _with_fallback(robot, result, make_target(X_target), _seed(robot, q_seed), options)
    target = make_target(X_target, target_kind)
    seed = _seed(robot, q_seed)
    if options:
        _check_options(options)
    resolved = _resolve_method(robot, method, target.kind)
    result = _solve(robot, target, seed, resolved, options)
    if method == "auto" and resolved == "analytic":
        result = _with_fallback(robot, result, target, seed, options)
    if not result.success and robot.dof < 6 and target.kind == FULL_POSE:
        result = dataclasses.replace(result, reason=f"{result.reason}; {robot.name} has {robot.dof} joints and cannot "
                                     "match a full pose (6 components) in general: ask for "
                                     f"{', '.join(MATCHED_COMPONENTS[POSITION_AND_AXIS])} (target_kind='position+axis') "
                                     f"or {', '.join(MATCHED_COMPONENTS[POSITION_ONLY])} (target_kind='position')")
    return result


def _solve(robot, target: IkTarget, seed: np.ndarray, method: str, options: dict) -> IkResult:
    """One method on a checked target and seed."""
    if method == "analytic":
        if analytic_solver_for(robot).applicable:
            return solve_analytic(robot, target, seed)
        return solve_closed_form_batch(robot, target.X_BE[None], seed[None], target.kind)[0]
    options = {name: value for name, value in options.items() if name in OPTIONS[method]}
    if method == "jacobian":
        return solve_jacobian(robot, target, seed, **options)
    from .drake_ik import solve_drake

    return solve_drake(robot, target, seed, **options)


def _with_fallback(robot, result: IkResult, target: IkTarget, seed: np.ndarray, options: dict) -> IkResult:
    """``auto``: a closed-form failure (a shoulder singularity whose free q1 was not sampled well, a
    numerical failure) is tried again by ``jacobian`` before it is reported; the closed form's reason
    stays in the details (or, when both fail, in the reason)."""
    if result.success:
        return result
    fallback = _solve(robot, target, seed, "jacobian", options)
    if fallback.success:
        return dataclasses.replace(fallback, details={**fallback.details, "analytic_failed": result.reason})
    return dataclasses.replace(result, reason=f"{result.reason}; jacobian: {fallback.reason}")


def with_drake_model(robot, method: str, options: dict) -> dict:
    """``options`` with one DrakeRobot to share over many ``drake`` solves (unless they carry one)."""
    if method != "drake" or options.get("drake") is not None:
        return options
    from ..chain.drake_model import build_drake_robot

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


def solve_closed_form_batch(robot, X_targets: np.ndarray, seeds: np.ndarray, kind: str = FULL_POSE) -> list[IkResult]:
    """Closed-form IK of N checked targets (N, 4, 4) with seeds (N, dof): our compiled solvers where they fit,
    else EAIK's subproblem decomposition for the full poses of arms it decomposes, else a failure with the
    reason (``solve_analytic_batch``'s)."""
    if kind == FULL_POSE and not analytic_solver_for(robot).applicable:
        from .subproblem import solve_subproblem_batch, subproblem_solver_for   # EAIK only where it is used

        if subproblem_solver_for(robot).applicable:
            return solve_subproblem_batch(robot, X_targets, seeds, kind)
    return solve_analytic_batch(robot, X_targets, seeds, kind)


def has_closed_form(robot) -> bool:
    """Whether the closed form (``analytic``: our compiled solvers of spherical wrists and of the UR family,
    else EAIK's) solves this arm."""
    if analytic_solver_for(robot).applicable:
        return True
    from .subproblem import subproblem_solver_for

    return subproblem_solver_for(robot).applicable


def solve_ik_batch(robot, X_targets, q_seeds=None, method: str = "auto", target_kind: str = FULL_POSE,
                   **options) -> list[IkResult]:
    """IK for N targets (N, 4, 4); ``q_seeds`` (N, dof), (dof,) or None. The closed form is vectorised."""
    X_targets = check_targets(X_targets, target_kind)
    if q_seeds is None or np.ndim(q_seeds) == 1:
        seeds = np.tile(_seed(robot, q_seeds), (len(X_targets), 1))
    else:
        seeds = robot.as_batch(q_seeds)
        if len(seeds) != len(X_targets):
            raise ConfigurationError(f"{len(X_targets)} targets but {len(seeds)} seeds")
    if options:
        _check_options(options)
    resolved = _resolve_method(robot, method, target_kind)
    if resolved == "analytic":
        results = solve_closed_form_batch(robot, X_targets, seeds, target_kind)
        if method != "auto":
            return results
        return [_with_fallback(robot, result, IkTarget(X, target_kind), seed, options)
                for result, X, seed in zip(results, X_targets, seeds)]
    options = with_drake_model(robot, method, options)
    results = []
    with Progress(len(X_targets), f"IK {method} {robot.name}") as tick:
        for X, seed in zip(X_targets, seeds):
            results.append(solve_ik(robot, X, seed, method, target_kind, **options))
            tick()
    return results


__all__ = ["IkResult", "IkTarget", "METHODS", "Solution", "make_target", "solve_ik", "solve_ik_batch"]
