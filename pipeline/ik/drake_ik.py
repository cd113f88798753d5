"""IK with pydrake's ``InverseKinematics``, every answer verified by our own FK.

The program has the end frame's origin pinned to the target position (equality bounds), then per
target kind: an orientation constraint with ``theta_bound = 0`` (``pose``), an angle of 0 between the
end frame's z axis and the target's (``position+axis``), or nothing more (``position``). Joint limits
come from the plant. The seed is the initial guess; when a solve gives no strict answer, the next one
starts from a random in-limit configuration, within ``max_restarts`` and ``time_budget``.

Why the tight solver options: Drake imposes an orientation as ``trace(R_AB) >= 2 cos(theta_bound) + 1``
and an axis as ``cos(angle) >= cos(angle_upper)``. With a bound of 0 both are met only at their
maximum, where their gradient vanishes, so a constraint violation of ``eps`` is an angle error of
about ``sqrt(2 eps)``. With SNOPT's default tolerances (1e-6) Drake reports success with orientation
errors up to ~1e-3 rad (on 200 GP7 targets from random seeds: 73 reported successes, 35 of them not
strict, worst 1.0e-3 rad). ``Major optimality tolerance`` 1e-10 is what makes SNOPT keep going to
~1e-7 rad (worst 8.3e-7 rad on the same targets, and every reported success strict); the feasibility
tolerance alone does not help, and theta_bound > 0 only loosens it. A second solve restarted from a
reported but not strict answer does not reliably polish it either. Whatever the solver says, only
answers that pass our FK check (``is_strict`` and ``within_limits``) count.
"""

from __future__ import annotations

import logging
import time
import weakref

import numpy as np

from .result import (
    FULL_POSE,
    MATCHED_COMPONENTS,
    POSITION_AND_AXIS,
    POSITION_TOLERANCE,
    ROTATION_TOLERANCE,
    IkResult,
    IkTarget,
    Solution,
    distinct_solutions,
    is_strict,
    pose_errors,
    within_limits,
)

log = logging.getLogger(__name__)

SNOPT = "SNOPT"
IPOPT = "IPOPT"

#: Solver options per solver (see the module docstring for why and what was measured).
SOLVER_OPTIONS = {
    SNOPT: {"Major feasibility tolerance": 1e-10, "Major optimality tolerance": 1e-10},
    IPOPT: {"tol": 1e-12, "constr_viol_tol": 1e-12, "print_level": 0},
}

#: Drake models built once per robot object (dropped with the robot).
_DRAKE_MODELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def drake_robot_for(robot):
    """The DrakeRobot of ``robot`` (built on first use, then cached for the robot's lifetime)."""
    model = _DRAKE_MODELS.get(robot)
    if model is None:
        from ..drake_model import build_drake_robot

        model = _DRAKE_MODELS[robot] = build_drake_robot(robot.spec)
    return model


def pick_solver(name: str = "auto"):
    """(label, solver instance): SNOPT when available (``auto``), else IPOPT; or the one asked for."""
    from pydrake.solvers import IpoptSolver, SnoptSolver

    candidates = {SNOPT: SnoptSolver, IPOPT: IpoptSolver}
    order = [SNOPT, IPOPT] if name == "auto" else [name.upper()]
    for label in order:
        if label not in candidates:
            raise ValueError(f"unknown Drake solver {name!r}; choose auto, snopt or ipopt")
        solver = candidates[label]()
        if solver.available() and solver.enabled():
            return label, solver
    raise RuntimeError(f"Drake solver {name!r} is not available in this pydrake build")


def build_ik_program(drake_robot, target: IkTarget):
    """An ``InverseKinematics`` (own context, joint limits on) with the constraints of ``target``."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.inverse_kinematics import InverseKinematics

    plant, B, E = drake_robot.plant, drake_robot.base_frame, drake_robot.end_frame
    ik = InverseKinematics(plant, with_joint_limits=True)
    p_BT = np.asarray(target.X_BE[:3, 3], dtype=float)
    ik.AddPositionConstraint(E, np.zeros(3), B, p_BT, p_BT)
    if target.kind == FULL_POSE:
        ik.AddOrientationConstraint(B, RotationMatrix(target.X_BE[:3, :3]), E, RotationMatrix(), 0.0)
    elif target.kind == POSITION_AND_AXIS:
        ik.AddAngleBetweenVectorsConstraint(B, np.array(target.X_BE[:3, 2], dtype=float), E,
                                            np.array([0.0, 0.0, 1.0]), 0.0, 0.0)
    return ik


def _solver_options(label: str, solver):
    from pydrake.solvers import SolverOptions

    options = SolverOptions()
    for key, value in SOLVER_OPTIONS[label].items():
        options.SetOption(solver.solver_id(), key, value)
    return options


def _solver_info(label: str, result) -> str:
    details = result.get_solver_details()
    if label == SNOPT:
        return f"SNOPT info {details.info}"
    return f"IPOPT status {details.status}"


def _score(position_error: float, rotation_error: float) -> float:
    """How far from strict an attempt is, in units of the tolerances (<= 1: strict)."""
    return max(position_error / POSITION_TOLERANCE, rotation_error / ROTATION_TOLERANCE)


def solve_drake(robot, target: IkTarget, q_seed: np.ndarray, rng: np.random.Generator | None = None,
                max_restarts: int = 20, time_budget: float = 1.0, solver: str = "auto", **_ignored) -> IkResult:
    """Solve one IK target with Drake's InverseKinematics, judged by our FK.

    ``q_seed`` (dof,): first initial guess [rad or m]; ``rng``: for the restart seeds (default: a
    generator seeded with 0, so results are repeatable); ``max_restarts``: random restarts after the
    seeded solve; ``time_budget`` [s]: no new solve starts after it (a solve in progress finishes);
    ``solver``: ``auto`` (SNOPT if available, else IPOPT), ``snopt`` or ``ipopt``.
    On success ``q`` is the strict solution nearest the seed (usually the only one found).
    """
    rng = np.random.default_rng(0) if rng is None else rng
    q_seed = np.asarray(q_seed, dtype=float)
    q_min, q_max = robot.limits.q_min, robot.limits.q_max
    label, drake_solver = pick_solver(solver)
    options = _solver_options(label, drake_solver)
    drake_robot = drake_robot_for(robot)

    start = time.perf_counter()
    solves = reported_not_strict = 0
    strict: list[Solution] = []
    best = None   # (score, q, position error, rotation error, solver info)
    guess = q_seed
    while True:
        ik = build_ik_program(drake_robot, target)
        result = drake_solver.Solve(ik.prog(), guess, options)
        solves += 1
        q = np.asarray(result.GetSolution(ik.q()), dtype=float)
        if not np.isfinite(q).all():
            q = np.clip(guess, q_min, q_max)
        position_error, rotation_error = pose_errors(robot.fk(q), target)
        ok = is_strict(position_error, rotation_error) and within_limits(q, q_min, q_max)
        info = _solver_info(label, result)
        if result.is_success() and not ok:
            reported_not_strict += 1
            log.debug("%s reported success but is not strict: %.2e m, %.2e rad (%s)",
                      label, position_error, rotation_error, info)
        score = _score(position_error, rotation_error) + (0.0 if within_limits(q, q_min, q_max) else 1e12)
        if best is None or score < best[0]:
            best = (score, q, position_error, rotation_error, info)
        if ok:
            strict.append(Solution(q, position_error, rotation_error, branch=f"drake solve {solves}"))
            break
        elapsed = time.perf_counter() - start
        if solves > max_restarts or elapsed >= time_budget:
            break
        guess = robot.random_configurations(rng, 1)[0]

    elapsed = time.perf_counter() - start
    details = {"solver": label, "solves": solves, "reported_success_but_not_strict": reported_not_strict,
               "time_s": elapsed, "solver_options": dict(SOLVER_OPTIONS[label])}
    matched = MATCHED_COMPONENTS[target.kind]
    if strict:
        solutions = distinct_solutions(strict, q_seed)
        first = solutions[0]
        return IkResult(True, first.q, first.position_error, first.rotation_error, solves, "drake",
                        solutions=solutions, matched=matched, details=details)
    _, q, position_error, rotation_error, info = best
    stopped = "time budget of %.3g s used up after" % time_budget if solves <= max_restarts else "no strict solution in"
    reason = (f"{stopped} {solves} Drake solve(s) ({label}): best position error {position_error:.3g} m, "
              f"rotation error {rotation_error:.3g} rad ({info})")
    if reported_not_strict:
        reason += f"; {reported_not_strict} reported success but failed our FK check"
    return IkResult(False, q, position_error, rotation_error, solves, "drake", reason=reason,
                    matched=matched, details=details)
