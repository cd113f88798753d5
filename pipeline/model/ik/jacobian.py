"""The inverse-Jacobian method of seed 000 as damped least-squares (Levenberg-Marquardt) Newton steps.

Each descent runs compiled (``pipeline.model.ik.descent``); this module adds seeded random restarts inside
the limits, within an iteration and time budget (checked between descents); each descent's answer is
judged by the compiled FK (checked against the NumPy oracle by the tests).
"""

from __future__ import annotations

import time

import numpy as np

from ...files.choices import FULL_POSE, POSITION_AND_AXIS, POSITION_ONLY
from ..chain import compiled
from . import descent
from .branches import configuration_labels
from .prebuilt import python_entry
from .result import MATCHED_COMPONENTS, IkResult, IkTarget, Solution, check_search_budget, wrap_into_limits

#: The kernel's code of each target kind.
KIND_CODES = {FULL_POSE: compiled.POSE, POSITION_AND_AXIS: compiled.POSITION_AND_AXIS, POSITION_ONLY: compiled.POSITION}


def _descend(robot, target: IkTarget, q: np.ndarray, max_iterations: int):
    """One damped least-squares descent from q: (q, iterations, position error [m], rotation error
    [rad], strict)."""
    limits = robot.limits
    return python_entry(descent.descend)(robot._chain, limits.q_min, limits.q_max, target.X_BE,
                                         KIND_CODES[target.kind], q, max_iterations)


def nudged_position(robot, position: np.ndarray, q_seed: np.ndarray, iterations: int, tolerance: float,
                    damping: float) -> np.ndarray | None:
    """Joint values near ``q_seed`` whose end is at ``position`` (3,) [m], its orientation free: damped least
    squares on the position alone (``descent.nudge_position``: ``iterations`` steps of fixed ``damping`` [m], no
    restarts); None when it does not get within ``tolerance`` [m] or leaves the limits."""
    limits, q = robot.limits, np.array(q_seed, dtype=float)
    reached = descent.nudge_position(robot._chain, limits.q_min, limits.q_max, position, q, iterations, tolerance,
                                     damping)
    return q if reached else None


def _nearest_the_seed(robot, q: np.ndarray, q_seed: np.ndarray) -> np.ndarray:
    """q with each revolute joint shifted by 2 pi to the in-limit representative nearest the seed."""
    revolute = np.array([joint.is_revolute for joint in robot.spec.joints])
    return wrap_into_limits(q, revolute, robot.limits.q_min, robot.limits.q_max, q_seed)


def solve_jacobian(robot, target: IkTarget, q_seed: np.ndarray, rng: np.random.Generator | None = None,
                   max_restarts: int = 50, max_iterations: int = 200, time_budget: float = 0.5) -> IkResult:
    """Damped least-squares IK from the seed, then from seeded random in-limit restarts.

    ``max_restarts`` random restarts after the seed, ``max_iterations`` per descent (near a shoulder singularity
    a descent takes up to about 200 to follow the valley along q1 to the solution, ``pipeline.model.ik.descent``;
    a solve of a random reachable target takes 20-45 in all, restarts included), ``time_budget`` [s] for the
    whole solve. The answer is judged by our FK: strict errors and every joint in limits; each revolute joint is
    the in-limit representative (by 2 pi) nearest the seed (a restart starts elsewhere).
    """
    check_search_budget(max_restarts, time_budget, max_iterations)
    deadline = time.perf_counter() + time_budget
    start = q_seed                                   # the descent wraps and clamps it into the limits
    best = None
    total_iterations = 0
    for attempt in range(max_restarts + 1):
        if attempt > 0:
            if time.perf_counter() > deadline:
                break
            rng = np.random.default_rng(0) if rng is None else rng      # made only when a restart needs it
            start = robot.random_configurations(rng, 1)[0]
        q, iterations, position_error, rotation_error, strict = _descend(robot, target, start, max_iterations)
        q = _nearest_the_seed(robot, q, q_seed)
        total_iterations += iterations
        if best is None or position_error + rotation_error < best[1] + best[2]:
            best = (q, position_error, rotation_error)
        if strict:
            solution = Solution(q, position_error, rotation_error, configuration_labels(robot, q[None])[0])
            return IkResult(True, q, position_error, rotation_error, total_iterations, "jacobian", "", (solution,),
                            MATCHED_COMPONENTS[target.kind], {"restarts": attempt})
    q, position_error, rotation_error = best
    reason = (f"no strict solution after {attempt + 1} descent(s) and {total_iterations} iterations "
              f"(budget: {max_restarts} restarts, {max_iterations} iterations each, {time_budget:g} s): best position "
              f"error {position_error:.3g} m, rotation error {rotation_error:.3g} rad; the target may be out of reach "
              "or reachable only outside the joint limits")
    return IkResult(False, q, position_error, rotation_error, total_iterations, "jacobian", reason, (),
                    MATCHED_COMPONENTS[target.kind], {"restarts": attempt})
