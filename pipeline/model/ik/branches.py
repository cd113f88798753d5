"""IK branches (configurations) by name, and the one rule for keeping a branch along a pose sequence.

For 6R arms the closed form solves every joint vector has a configuration: with a spherical wrist
shoulder front|back, elbow up|down, wrist flip|noflip (``closed_form.label_code``); in the UR family
(axes 2, 3, 4 parallel) shoulder left|right, elbow up|down, wrist up|down (``three_parallel``'s
definitions). How a user names one: ``pipeline.files.branch_names``.

The rule (``choose_solution``), used by the job runner and ``robot.ik_path`` alike: among a pose's
in-limit solutions, each revolute joint shifted by 2 pi to the representative nearest the previous
configuration, those of the configuration the waypoint names (all when it names none); of these the
nearest to the previous configuration (joint-space norm) wins, so the arm moves as little as it can.
When its branch differs from the previous pose's, that is a branch change (an error for the callers
unless allowed), explained by ``branch_change_reason``: either no in-limit solution is left on the
previous branch (the joint whose limit rules it out is named), or staying on it would swing a joint
further (typically the wrist through q5 = 0: staying "noflip" turns J4 and J6 by half a turn).
Preferring the old branch instead would make exactly that swing silently.

At a wrist singularity (axes 4 and 6 aligned: ``wrist_singular``) a pose fixes only q4 +- q6: the closed form
splits its change from the seed (the previous waypoint) evenly between q4 and q6, also for a pose a rounding
away from it (``closed_form.WRIST_SINGULAR_TOLERANCE``), so consecutive targets there do not swing the wrist. Such a
configuration is on both wrist branches (flip or not is the sign of a q5 rounding decides): it keeps the
previous pose's wrist branch, and leaving it for either is no branch change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...files.branch_names import FAMILY_TITLES, SPHERICAL_WRIST, label_parts, matches
from .analytic import analytic_solver_for, closest_limit_violation, configuration_labels_of, solve_branches
from .closed_form import WRIST_SINGULAR_TOLERANCE
from .result import IkResult, wrap_into_limits


def configuration_family(robot) -> tuple[str, str]:
    """(the family whose configuration names a robot takes, its name) for ``parse_configuration``:
    the closed form's family, a spherical wrist's names for arms of neither (they have none, and
    ``choose_solution`` says so)."""
    solver = analytic_solver_for(robot)
    return (solver.family if solver.applicable else SPHERICAL_WRIST), robot.name


def wrist_singular(robot, q: np.ndarray) -> bool:
    """Whether q has a spherical wrist at its singularity: axes 4 and 6 aligned within
    ``WRIST_SINGULAR_TOLERANCE`` (the sine of their angle), where the closed form keeps q4 and q6 nearest its seed's."""
    if analytic_solver_for(robot).family != SPHERICAL_WRIST or robot.dof != 6:
        return False
    axes = robot.jacobian(q)[3:]
    return float(np.linalg.norm(np.cross(axes[:, 3], axes[:, 5]))) < WRIST_SINGULAR_TOLERANCE


def configuration_labels(robot, Q) -> list[str]:
    """The configuration label of each joint vector Q (N, dof) ("" for arms without named
    configurations: neither a spherical wrist nor the UR family)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    solver = analytic_solver_for(robot)
    return configuration_labels_of(robot, solver, Q) if solver.applicable else [""] * len(Q)


@dataclass(frozen=True)
class BranchChoice:
    """The solution the rule kept: ``q`` [rad or m], its ``branch`` label, the ``previous`` branch
    ("" for none), ``changed`` (a branch change from the previous pose), ``stay``: the nearest in-limit
    solution on the previous branch when it changed (None: there is none), and ``solutions``, how many
    in-limit solutions it chose from. ``q`` None when nothing was allowed, with ``reason``."""

    q: np.ndarray | None
    branch: str
    previous: str
    changed: bool
    solutions: int
    stay: np.ndarray | None = None
    reason: str = ""


def choose_solution(robot, result: IkResult, previous_q: np.ndarray, previous_branch: str = "",
                    config: dict[str, str] | None = None) -> BranchChoice:
    """The rule of this module for one pose's successful IK ``result``, given the previous joint values
    and branch ("" for the first pose) and the configuration the pose names (None: any)."""
    limits = robot.limits
    revolute = np.array([j.is_revolute for j in robot.spec.joints])
    raw = [s.q for s in result.solutions] or [result.q]
    Q = np.array([wrap_into_limits(q, revolute, limits.q_min, limits.q_max, previous_q) for q in raw])
    labels = configuration_labels(robot, Q)
    if previous_branch:
        labels = [_wrist_as(previous_branch, label) if wrist_singular(robot, q) else label
                  for q, label in zip(Q, labels)]
    allowed = [k for k, label in enumerate(labels) if not config or matches(label, config)]
    if not allowed:
        named = ", ".join(f"{k} {v}" for k, v in config.items())
        reason = (f"{robot.name} has no named configurations (they need 6 revolute joints with "
                  f"{' or '.join(FAMILY_TITLES.values())})" if not any(labels) else
                  f"no in-limit solution has the configuration asked for ({named}); the solutions: "
                  f"{'; '.join(sorted(set(labels)))}")
        return BranchChoice(None, "", previous_branch, False, len(Q), reason=reason)
    distance = np.linalg.norm(Q - previous_q, axis=1)
    k = min(allowed, key=lambda i: distance[i])
    before = _wrist_as(labels[k], previous_branch) if wrist_singular(robot, previous_q) else previous_branch
    changed = bool(previous_branch) and labels[k] != before
    same = [i for i, label in enumerate(labels) if label == previous_branch]
    stay = Q[min(same, key=lambda i: distance[i])] if changed and same else None
    return BranchChoice(Q[k], labels[k], previous_branch, changed, len(Q), stay)


def _wrist_as(model: str, label: str) -> str:
    """``label`` with the wrist part of ``model`` (a singular wrist, axes 4 and 6 aligned, is on both wrist
    branches: it keeps the one it came from, or takes the one it goes to)."""
    parts, wrist = label_parts(label), label_parts(model).get("wrist")
    if "wrist" not in parts or wrist is None:
        return label
    return ", ".join(f"{key} {wrist if key == 'wrist' else value}" for key, value in parts.items())


def branch_change_reason(robot, choice: BranchChoice, X_target: np.ndarray, previous_q: np.ndarray) -> str:
    """Why the rule left the previous branch, naming the joint: the one whose limit rules the previous
    branch out, or the one that would swing most to stay on it."""
    if choice.stay is None:
        return why_not_on_branch(robot, X_target, choice.previous, previous_q)
    stay_move, chosen_move = np.abs(choice.stay - previous_q), np.abs(choice.q - previous_q)
    j = int(np.argmax(stay_move))
    revolute = robot.spec.joints[j].is_revolute
    unit, scale = ("deg", np.degrees(1.0)) if revolute else ("m", 1.0)
    return (f"staying on '{choice.previous}' would move {robot.joint_names[j]} by {stay_move[j] * scale:.4g} {unit} "
            f"(the nearest solution moves it by {chosen_move[j] * scale:.4g} {unit})")


def why_not_on_branch(robot, X_target: np.ndarray, branch: str, seed: np.ndarray) -> str:
    """Why the pose X_target has no in-limit solution on ``branch``: the joint whose limit rules the
    branch's exact solution out (name, value, limits), or that the branch does not reach the pose."""
    solver = analytic_solver_for(robot)
    if not solver.applicable or not branch:
        return "no in-limit solution on that branch was found"
    branches = solve_branches(robot, solver, np.asarray(X_target, dtype=float), np.asarray(seed, dtype=float))
    on_branch = [b for b, label in enumerate(branches.labels) if label == branch and branches.reachable[b]]
    if not on_branch:
        return "the pose is out of reach on that branch"
    limits = robot.limits
    j, value, _ = closest_limit_violation(robot, branches.Q[on_branch])
    return (f"{robot.joint_names[j]} would be {np.degrees(value):.4g} deg there, outside its limits "
            f"[{np.degrees(limits.q_min[j]):.4g}, {np.degrees(limits.q_max[j]):.4g}] deg")
