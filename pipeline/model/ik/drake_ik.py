"""IK with pydrake's ``InverseKinematics``, every answer verified by our own FK.

The program has the end frame's origin pinned to the target position (equality bounds), then per
target kind: an orientation constraint with ``theta_bound = 0`` (``pose``), an angle of 0 between the
end frame's z axis and the target's (``position+axis``), or nothing more (``position``). Joint limits
come from the plant. The seed is the initial guess; when a solve gives no strict answer, the next one
starts from a random in-limit configuration, within ``max_restarts`` and ``time_budget``.

Why the polish, and its tight solver options: Drake imposes an orientation as
``trace(R_AB) >= 2 cos(theta_bound) + 1`` and an axis as ``cos(angle) >= cos(angle_upper)``. With a
bound of 0 both are met only at their maximum, where their gradient vanishes, so a constraint
violation of ``eps`` is an angle error of about ``sqrt(2 eps)``. With SNOPT's default tolerances
(1e-6) Drake reports success with orientation errors up to ~1e-3 rad (200 GP7 targets from random
seeds: 73 reported successes, 35 of them not strict, worst 1.0e-3 rad). Tightening SNOPT helps only
so far: ``Major optimality tolerance`` 1e-10 takes the same solves to ~5e-7 rad (the feasibility
tolerance alone does not help, theta_bound > 0 only loosens it), about the floor of the trace form
in double precision, so some answers still miss 1e-6 rad (more for the axis form: up to 1e-5 rad on
arm5); and tight tolerances make the failing solves (SNOPT info 13, a local minimum of the
infeasibility) grind on: 2-3x the mean time per target, 3-5x the p95. So the main solves use the
solver's defaults, and a near miss (within ``POLISH_POSITION`` and ``POLISH_ROTATION``) is polished
by one more solve from it, with ``POLISH_OPTIONS`` and a first-order form of the same constraints:
points of the end frame pinned in the target frame (x axis tip: y = z = 0; y axis tip: z = 0; for an
axis, z axis tip: x = y = 0), whose violation is linear in the angle error (results ~1e-9 rad). That
form alone converges from fewer random seeds (18.5 % vs 36.5 % on the GP7 targets), hence the two
steps. Whatever the solver says, only answers that pass our FK check (``is_strict`` and
``within_limits``) count.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from ...errors import ConfigurationError

from .branches import configuration_labels
from .result import (
    FULL_POSE,
    MATCHED_COMPONENTS,
    POSITION_AND_AXIS,
    POSITION_ONLY,
    POSITION_TOLERANCE,
    ROTATION_TOLERANCE,
    IkResult,
    IkTarget,
    Solution,
    check_search_budget,
    distinct_order,
    is_strict,
    pose_errors,
    within_limits,
)

log = logging.getLogger(__name__)

SNOPT = "SNOPT"
IPOPT = "IPOPT"

#: Solver options of the main solves (the solvers' defaults: tight ones make failing solves slow)
#: and of the polish solves (see the module docstring for why and what was measured).
MAIN_OPTIONS = {SNOPT: {}, IPOPT: {"print_level": 0}}
POLISH_OPTIONS = {
    SNOPT: {"Major feasibility tolerance": 1e-10, "Major optimality tolerance": 1e-10},
    IPOPT: {"tol": 1e-12, "constr_viol_tol": 1e-12, "print_level": 0},
}

#: Near misses worth one polish solve (see the module docstring) [m], [rad].
POLISH_POSITION = 1e-3
POLISH_ROTATION = 1e-2

_UNIT = np.eye(3)

def pick_solver(name: str = "auto"):
    """(label, solver instance): SNOPT when available (``auto``), else IPOPT; or the one asked for."""
    from pydrake.solvers import IpoptSolver, SnoptSolver

    candidates = {SNOPT: SnoptSolver, IPOPT: IpoptSolver}
    order = [SNOPT, IPOPT] if name == "auto" else [name.upper()]
    for label in order:
        if label not in candidates:
            raise ConfigurationError(f"unknown Drake solver {name!r}; choose auto, snopt or ipopt")
        solver = candidates[label]()
        if solver.available() and solver.enabled():
            return label, solver
    raise ConfigurationError(f"Drake solver {name!r} is not available in this pydrake build")


def build_ik_program(drake_robot, target: IkTarget, first_order: bool = False):
    """An ``InverseKinematics`` (own context, joint limits on) with the constraints of ``target``.

    ``first_order=False``: Drake's orientation / angle-between-vectors constraints with a bound of 0.
    ``first_order=True``: the same targets as unit points of the end frame pinned in the target
    frame T (the polish step; see the module docstring).
    """
    from pydrake.math import RigidTransform, RotationMatrix
    from pydrake.multibody.inverse_kinematics import InverseKinematics

    plant, B, E = drake_robot.plant, drake_robot.base_frame, drake_robot.end_frame
    ik = InverseKinematics(plant, with_joint_limits=True)
    p_BT = np.array(target.X_BE[:3, 3], dtype=float)
    R_BT = RotationMatrix(np.array(target.X_BE[:3, :3], dtype=float))
    ik.AddPositionConstraint(E, np.zeros(3), B, p_BT, p_BT)
    if target.kind == FULL_POSE and not first_order:
        ik.AddOrientationConstraint(B, R_BT, E, RotationMatrix(), 0.0)
    elif target.kind == POSITION_AND_AXIS and not first_order:
        ik.AddAngleBetweenVectorsConstraint(B, R_BT.col(2), E, _UNIT[2], 0.0, 0.0)
    elif target.kind == FULL_POSE:
        X_BT = RigidTransform(R_BT, p_BT)
        # x axis tip at (x >= 0, 0, 0) in T, y axis tip at (any, y >= 0, 0): 6 independent equalities.
        ik.AddPositionConstraint(E, _UNIT[0], B, X_BT, np.zeros(3), np.array([np.inf, 0.0, 0.0]))
        ik.AddPositionConstraint(E, _UNIT[1], B, X_BT, np.array([-np.inf, 0.0, 0.0]),
                                 np.array([np.inf, np.inf, 0.0]))
    elif target.kind == POSITION_AND_AXIS:
        ik.AddPositionConstraint(E, _UNIT[2], B, RigidTransform(R_BT, p_BT), np.zeros(3),
                                 np.array([0.0, 0.0, np.inf]))
    return ik


def _solver_options(solver, values: dict):
    from pydrake.solvers import SolverOptions

    options = SolverOptions()
    for key, value in values.items():
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
                max_restarts: int = 20, time_budget: float = 1.0, solver: str = "auto", drake=None) -> IkResult:
    """Solve one IK target with Drake's InverseKinematics, judged by our FK.

    ``q_seed`` (dof,): first initial guess [rad or m]; ``rng``: for the restart seeds (default: a
    generator seeded with 0, so results are repeatable); ``max_restarts``: random restarts after the
    seeded solve; ``time_budget`` [s]: no new solve starts after it (a solve in progress finishes);
    ``solver``: ``auto`` (SNOPT if available, else IPOPT), ``snopt`` or ``ipopt``; ``drake``: the robot's
    DrakeRobot (built here when None; pass one to reuse it over many targets).
    On success ``q`` is the strict solution nearest the seed (usually the only one found).
    """
    check_search_budget(max_restarts, time_budget)
    rng = np.random.default_rng(0) if rng is None else rng
    q_seed = np.asarray(q_seed, dtype=float)
    q_min, q_max = robot.limits.q_min, robot.limits.q_max
    label, drake_solver = pick_solver(solver)
    main_options = _solver_options(drake_solver, MAIN_OPTIONS[label])
    polish_options = _solver_options(drake_solver, POLISH_OPTIONS[label])
    from ..chain.drake_model import build_drake_robot

    drake_robot = drake if drake is not None else build_drake_robot(robot.spec)

    start = time.perf_counter()
    solves = polish_solves = reported_not_strict = 0
    strict: list[Solution] = []
    best = None   # (score, q, position error, rotation error, solver info)
    guess = q_seed

    def attempt(initial_guess: np.ndarray, first_order: bool):
        nonlocal solves, reported_not_strict, best
        ik = build_ik_program(drake_robot, target, first_order)
        result = drake_solver.Solve(ik.prog(), initial_guess, polish_options if first_order else main_options)
        solves += 1
        q = np.asarray(result.GetSolution(ik.q()), dtype=float)
        if not np.isfinite(q).all():
            q = np.clip(initial_guess, q_min, q_max)
        position_error, rotation_error = pose_errors(robot.fk(q), target)
        in_limits = within_limits(q, q_min, q_max)
        ok = is_strict(position_error, rotation_error) and in_limits
        info = _solver_info(label, result)
        if result.is_success() and not ok:
            reported_not_strict += 1
            log.debug("%s reported success but is not strict: %.2e m, %.2e rad (%s)",
                      label, position_error, rotation_error, info)
        score = _score(position_error, rotation_error) + (0.0 if in_limits else 1e12)
        if best is None or score < best[0]:
            best = (score, q, position_error, rotation_error, info)
        if ok:
            strict.append(Solution(q, position_error, rotation_error))
        return q, ok, in_limits and position_error <= POLISH_POSITION and rotation_error <= POLISH_ROTATION

    starts, out_of_time = 0, False
    while True:
        starts += 1
        q, ok, near = attempt(guess, first_order=False)
        if not ok and near and target.kind != POSITION_ONLY:
            polish_solves += 1
            q, ok, _ = attempt(q, first_order=True)
        out_of_time = time.perf_counter() - start >= time_budget
        if ok or starts > max_restarts or out_of_time:
            break
        guess = robot.random_configurations(rng, 1)[0]

    elapsed = time.perf_counter() - start
    details = {"solver": label, "solves": solves, "starts": starts, "polish_solves": polish_solves,
               "reported_success_but_not_strict": reported_not_strict,
               "time_s": elapsed, "main_options": dict(MAIN_OPTIONS[label]),
               "polish_options": dict(POLISH_OPTIONS[label])}
    matched = MATCHED_COMPONENTS[target.kind]
    if strict:
        distinct = [strict[i] for i in distinct_order(np.array([s.q for s in strict]), q_seed)]
        labels = configuration_labels(robot, np.array([s.q for s in distinct]))
        solutions = tuple(s._replace(branch=label) for s, label in zip(distinct, labels))
        first = solutions[0]
        return IkResult(True, first.q, first.position_error, first.rotation_error, solves, "drake",
                        solutions=solutions, matched=matched, details=details)
    _, q, position_error, rotation_error, info = best
    stopped = f"time budget of {time_budget:g} s used up after" if out_of_time else "no strict solution in"
    reason = (f"{stopped} {solves} Drake solves ({label}, {starts} starts): best position error "
              f"{position_error:.3g} m, rotation error {rotation_error:.3g} rad ({info})")
    if reported_not_strict:
        reason += f"; {reported_not_strict} reported success but failed our FK check"
    return IkResult(False, q, position_error, rotation_error, solves, "drake", reason=reason,
                    matched=matched, details=details)
