"""IK along a sequence of poses that keeps one branch and never jumps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..arrays import float_array
from .result import FULL_POSE, IkResult

#: Largest change of any joint between consecutive poses that still counts as continuous [rad or m].
MAX_JOINT_STEP = 0.35


@dataclass(frozen=True, eq=False)
class PathIkResult:
    """Joint values along a pose sequence.

    ``Q`` (K, dof): the solved prefix (all K poses on success). ``failed_index``: the first pose
    where no continuous solution exists (None on success), with ``reason``. ``results``: each pose's
    IkResult. ``branches``: the branch label of each solved pose (closed form; "" otherwise).
    """

    success: bool
    Q: np.ndarray
    failed_index: int | None
    reason: str
    results: tuple[IkResult, ...]
    branches: tuple[str, ...]


def _nearest_continuous(result: IkResult, q_previous: np.ndarray) -> tuple[np.ndarray, str, float]:
    """The solution of a successful result nearest q_previous, its branch, and its largest joint change."""
    best = min(result.solutions, key=lambda s: float(np.abs(s.q - q_previous).max()))
    return best.q, best.branch, float(np.abs(best.q - q_previous).max())


def solve_ik_path(robot, X_path, q_start, method: str = "auto", target_kind: str = FULL_POSE,
                  max_joint_step: float = MAX_JOINT_STEP, **options) -> PathIkResult:
    """Solve IK for poses X_path (K, 4, 4) in order, each seeded by the previous solution.

    ``q_start``: the configuration the path starts from (its branch is kept). Among each pose's
    solutions the one nearest the previous configuration is taken; a change above ``max_joint_step``
    in any joint (a branch switch, or a singularity crossed) stops the path at that index.
    """
    from . import solve_ik, with_drake_model

    options = with_drake_model(robot, method, options)
    X_path = float_array(X_path, "IK path poses", (None, 4, 4))
    q_previous = robot.as_configuration(q_start)
    solved, results, branches = [], [], []
    for k, X in enumerate(X_path):
        result = solve_ik(robot, X, q_previous, method=method, target_kind=target_kind, **options)
        results.append(result)
        if not result.success:
            return PathIkResult(False, np.array(solved).reshape(-1, robot.dof), k,
                                f"pose {k}: no IK solution ({result.reason})", tuple(results), tuple(branches))
        q, branch, step = _nearest_continuous(result, q_previous)
        if step > max_joint_step:
            joint = int(np.argmax(np.abs(q - q_previous)))
            return PathIkResult(
                False, np.array(solved).reshape(-1, robot.dof), k,
                f"pose {k}: the nearest solution moves {robot.joint_names[joint]} by {step:.3g} "
                f"(> {max_joint_step:g}): continuity is impossible here (branch switch or singularity)",
                tuple(results), tuple(branches))
        solved.append(q)
        branches.append(branch)
        q_previous = q
    return PathIkResult(True, np.array(solved).reshape(-1, robot.dof), None, "", tuple(results), tuple(branches))
