"""IK along a sequence of poses that keeps one branch and never jumps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigurationError
from ...files.arrays import float_array
from .branches import branch_change_reason, choose_solution, configuration_labels
from .result import FULL_POSE, IkResult

#: Largest change of any joint between consecutive poses that still counts as continuous [rad or m].
MAX_JOINT_STEP = 0.35


@dataclass(frozen=True, eq=False)
class PathIkResult:
    """Joint values along a pose sequence.

    ``Q`` (K, dof): the solved prefix (all K poses on success). ``failed_index``: the first pose
    where no continuous solution exists (None on success), with ``reason``. ``results``: each pose's
    IkResult. ``branches``: the branch label of each solved pose ("" for arms without named
    configurations).
    """

    success: bool
    Q: np.ndarray
    failed_index: int | None
    reason: str
    results: tuple[IkResult, ...]
    branches: tuple[str, ...]


def solve_ik_path(robot, X_path, q_start, method: str = "auto", target_kind: str = FULL_POSE,
                  max_joint_step: float = MAX_JOINT_STEP, allow_branch_change: bool = False, **options) -> PathIkResult:
    """Solve IK for poses X_path (K, 4, 4) in order, each seeded by the previous solution.

    ``q_start``: the configuration the path starts from. Each pose's solution is chosen by the rule of
    ``pipeline.model.ik.branches`` (nearest the previous joint values, each joint shifted by 2 pi to the
    representative nearest them). The path stops at the first
    pose that changes branch (unless ``allow_branch_change``) or moves a joint by more than
    ``max_joint_step`` [rad or m] (a finite number > 0; a singularity crossed).
    """
    from . import solve_ik, with_drake_model

    if isinstance(max_joint_step, bool) or not isinstance(max_joint_step, (int, float, np.integer, np.floating)) \
            or not np.isfinite(max_joint_step) or max_joint_step <= 0:
        raise ConfigurationError(f"max_joint_step must be a finite number > 0 [rad or m], got {max_joint_step!r}")
    options = with_drake_model(robot, method, options)
    X_path = float_array(X_path, "IK path poses", (None, 4, 4))
    q_previous = robot.as_configuration(q_start)
    branch = configuration_labels(robot, q_previous)[0]
    solved, results, branches = [], [], []

    def stop(k: int, reason: str) -> PathIkResult:
        return PathIkResult(False, np.array(solved).reshape(-1, robot.dof), k, f"pose {k}: {reason}", tuple(results),
                            tuple(branches))

    for k, X in enumerate(X_path):
        result = solve_ik(robot, X, q_previous, method=method, target_kind=target_kind, **options)
        results.append(result)
        if not result.success:
            return stop(k, f"no IK solution ({result.reason})")
        choice = choose_solution(robot, result, q_previous, branch)
        if choice.changed and not allow_branch_change:
            return stop(k, f"the branch changes from '{choice.previous}' to '{choice.branch}': "
                           f"{branch_change_reason(robot, choice, X, q_previous)}")
        step = np.abs(choice.q - q_previous)
        if step.max() > max_joint_step:
            joint = int(np.argmax(step))
            return stop(k, f"the nearest solution moves {robot.joint_names[joint]} by {step[joint]:.3g} "
                           f"(> {max_joint_step:g}): continuity is impossible here (a singularity crossed)")
        solved.append(choice.q)
        branches.append(choice.branch)
        q_previous, branch = choice.q, choice.branch
    return PathIkResult(True, np.array(solved).reshape(-1, robot.dof), None, "", tuple(results), tuple(branches))
