"""Every IK branch of a TCP target, as the page's draggable target and its ghost arms show it (and
``python -m pipeline ik`` prints it): per branch the configuration nearest a reference, our branch name,
the maker's controller configuration, and its state in the cell (free, colliding, near a singularity).

Near a singularity means a smallest singular value of the Jacobian below ``NEAR_SINGULAR`` [m/rad or 1,
the Jacobian's mixed units], the package's one threshold (``pipeline.model.ik.velocity``: below it the damped
inverse starts damping): some 7 % of random GP7 configurations, a wrist within about half a degree of
q5 = 0. ``pipeline.model.chain.singularity`` counts rank as lost only far below it (1e-9 of the largest singular
value), so a singular branch is always near singular.

Arms with a closed form (``pipeline.model.ik.has_closed_form``) give every in-limit branch; each keeps the 2 pi
variant nearest the reference configuration and counts the others. Arms without one get the numeric IK's
answer from the reference (one branch), within NUMERIC_TIME_BUDGET_S. A target no branch reaches is a
result with a reason, never an error. Built for a drag: about 0.6 ms per target, plus in a cell 0.1 ms
per branch for its collision checks and 0.7 ms per branch that collides or comes close for its clearance
(``CollisionModel.clearance``, which the far ones skip).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..files.branch_names import SPHERICAL_WRIST
from ..files.poses import check_pose, rotation_to_rpy
from ..model.ik import has_closed_form, solve_ik
from ..model.ik.analytic import analytic_solver_for
from ..model.ik.branches import configuration_labels
from ..model.ik.result import MAX_TARGET_COORDINATE_M, Solutions, limit_variants
from ..model.ik.velocity import NEAR_SINGULAR
from ..model.vendors import configurations, format_configuration
from ..model.vendors.axes import VENDORS
from ..model.vendors.controller import controller_of

if TYPE_CHECKING:                     # Drake's collision module is imported only where a scene is used
    from ..cell.collision import Clearance

#: States of a branch; colliding wins over near_singular.
FREE, COLLIDING, NEAR_SINGULAR_STATE = "free", "colliding", "near_singular"
STATES = (FREE, COLLIDING, NEAR_SINGULAR_STATE)
#: How long the numeric IK of an arm without a closed form searches one target [s] (a drag's share).
NUMERIC_TIME_BUDGET_S = 0.005
#: A branch this much farther from every obstacle than the cell's clearance gets no ``clearance`` [m].
CLEARANCE_SHOWN_WITHIN_M = 0.05
#: Two unnamed solutions whose joints differ by a multiple of 2 pi within this are one branch [rad or m].
SAME_BRANCH_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class Branch:
    """One IK branch of a target: ``q`` (dof,) [rad or m] its 2 pi variant nearest the reference; ``name``
    our branch label (``pipeline.model.ik.branches``, "" for arms without named branches); ``variants`` how many
    in-limit 2 pi variants it has (>= 1; math.inf with a continuous joint); ``vendor_config`` the maker's
    controller configuration text of ``q`` (None without one); ``state`` free | colliding | near_singular
    (colliding wins); ``sigma_min`` the smallest singular value of the Jacobian at q [m/rad or 1];
    ``clearance`` at q in the cell (closest pairs and distances [m]) where it collides or comes within
    CLEARANCE_SHOWN_WITHIN_M beyond the cell's clearance; None for the others and without a scene."""

    q: np.ndarray
    name: str
    variants: int | float
    vendor_config: str | None
    state: str
    sigma_min: float
    clearance: Clearance | None


@dataclass(frozen=True, eq=False)
class TargetBranches:
    """The branches of the TCP target ``X_BT`` (4, 4) [m, base frame], nearest the reference first;
    ``vendor`` whose configuration text they carry (the robot's maker) or None; ``reason`` why there is
    no branch, else None; ``revolute`` (dof,) which joints ``describe`` shows in deg (the others in mm;
    empty: all in deg)."""

    X_BT: np.ndarray
    branches: tuple[Branch, ...]
    vendor: str | None
    reason: str | None
    revolute: tuple[bool, ...] = ()

    def describe(self) -> str:
        """The target and one row per branch (mm, deg) as ``python -m pipeline ik`` prints them."""
        lines = [f"TCP target (base frame): {pose_words(self.X_BT)}"]
        if not self.branches:
            return "\n".join(lines + [f"no branch: {self.reason}"])
        lines.append(f"{len(self.branches)} branch(es), nearest the reference first"
                     + (f"; configuration: {self.vendor}" if self.vendor else ""))
        revolute = np.array(self.revolute or [True] * self.branches[0].q.size)
        unit = "q [deg]" if revolute.all() else "q [deg; mm]"
        rows = [("#", "branch", self.vendor or "configuration", unit, "variants", "state", "sigma_min", "closest")]
        for k, b in enumerate(self.branches):
            q = np.round(np.where(revolute, np.degrees(b.q), b.q * 1e3), 3) + 0.0     # + 0.0: no "-0.000"
            rows.append((str(k + 1), b.name or "-", b.vendor_config or "-", " ".join(f"{v:.3f}" for v in q),
                         f"{b.variants:g}", b.state, f"{b.sigma_min:.3g}", closest_words(b.clearance)))
        widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
        lines += ["  " + "  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
        return "\n".join(lines)


def pose_words(X: np.ndarray) -> str:
    """A pose (4, 4) [m] as its position [mm] and roll, pitch, yaw [deg]."""
    xyz = ", ".join(f"{v:.3f}" for v in np.round(X[:3, 3] * 1e3, 3) + 0.0)
    rpy = ", ".join(f"{v:.3f}" for v in np.round(np.degrees(rotation_to_rpy(X[:3, :3])), 3) + 0.0)
    return f"xyz [{xyz}] mm, rpy [{rpy}] deg"


def closest_words(clearance: Clearance | None) -> str:
    """The closest pair of a Clearance and its distance [mm]: touching links first, else the nearest
    obstacle; "-" without one."""
    if clearance is None:
        return "-"
    from ..cell.collision import SELF_CLEARANCE_M

    if clearance.self_pair is not None and clearance.self <= SELF_CLEARANCE_M:
        return f"links {clearance.self_pair[0]} - {clearance.self_pair[1]} {clearance.self * 1e3:.1f} mm"
    if clearance.obstacle_pair is None:
        return "no obstacle in reach"
    return f"{clearance.obstacle_pair[0]} - {clearance.obstacle_pair[1]} {clearance.obstacle * 1e3:.1f} mm"


def maker_vendor(robot) -> str | None:
    """The maker of the robot file's controller section (``model.vendors.controller.controller_of``) where this
    package computes its configuration data (``model.vendors.axes.VENDORS``), or None."""
    controller = controller_of(robot)
    return controller.maker if controller is not None and controller.maker in VENDORS else None


def branch_names(robot, Q: np.ndarray) -> tuple[list[str], str | None, list[str | None]]:
    """For configurations Q (N, dof) [rad or m]: our branch names, the vendor whose configuration text is
    shown (the maker, where its configuration data applies: a 6R arm with a spherical wrist) and the texts
    (None each without a vendor)."""
    names = configuration_labels(robot, Q)
    vendor = shown_vendor(robot)
    if vendor is None:
        return names, None, [None] * len(names)
    return names, vendor, [format_configuration(vendor, row) for row in configurations(robot, Q, vendor)]


def shown_vendor(robot) -> str | None:
    """The maker's vendor (``maker_vendor``) where its configuration data applies (a 6R arm with a
    spherical wrist: ``model.vendors.sides``), else None."""
    vendor = maker_vendor(robot)
    solver = analytic_solver_for(robot)
    return vendor if vendor is not None and solver.applicable and solver.family == SPHERICAL_WRIST else None


def target_branches(robot, X_BT, q_reference=None, scene=None) -> TargetBranches:
    """Every IK branch of the TCP target X_BT (4, 4) [m, base frame] of ``robot`` (its end frame the TCP:
    ``pipeline.model.robot.robot_with_tool``), each at its 2 pi variant nearest ``q_reference`` (dof,) [rad or m]
    (default: the middle of the joint ranges), checked against ``scene`` (a ``CollisionModel`` of the robot
    in its cell, or None). ConfigurationError for a target that is no pose or a bad reference."""
    X_BT = check_pose(X_BT, "TCP target X_BT", MAX_TARGET_COORDINATE_M)
    q_reference = robot.limits.q_middle if q_reference is None else robot.as_configuration(q_reference)
    if has_closed_form(robot):
        result = solve_ik(robot, X_BT, q_reference, method="analytic")
    else:
        result = solve_ik(robot, X_BT, q_reference, method="jacobian", time_budget=NUMERIC_TIME_BUDGET_S)
    revolute = tuple(robot.revolute_mask.tolist())
    if not result.success:
        return TargetBranches(X_BT, (), shown_vendor(robot), f"no in-limit IK solution of the TCP target at "
                              f"{pose_words(X_BT)}: {result.reason}", revolute)
    Q, variants = _nearest_per_branch(robot, result)
    names, vendor, texts = branch_names(robot, Q)
    sigma = np.linalg.svd(robot.jacobian_batch(Q), compute_uv=False)[:, -1]
    branches = []
    for q, name, count, text, s in zip(Q, names, variants, texts, sigma.tolist()):
        colliding = scene is not None and not scene.is_free(q)
        state = COLLIDING if colliding else NEAR_SINGULAR_STATE if s < NEAR_SINGULAR else FREE
        q.flags.writeable = False
        branches.append(Branch(q, name, count, text, state, s, _clearance(scene, q, colliding)))
    return TargetBranches(X_BT, tuple(branches), vendor, None, revolute)


def _clearance(scene, q: np.ndarray, colliding: bool) -> Clearance | None:
    """The clearance of q in ``scene`` where it collides or comes within CLEARANCE_SHOWN_WITHIN_M beyond the
    cell's clearance (a padded check of 0.05 ms decides), else None: ``CollisionModel.clearance`` costs
    0.6 ms, a drag's budget for some 10 branches."""
    if scene is None:
        return None
    from ..cell.collision import SELF_CLEARANCE_M

    if colliding or not scene.padded_checker(CLEARANCE_SHOWN_WITHIN_M, SELF_CLEARANCE_M).CheckConfigCollisionFree(q):
        return scene.clearance(q)
    return None


def _nearest_per_branch(robot, result) -> tuple[np.ndarray, list[int | float]]:
    """Of an IK result's solutions (nearest the reference first), the first of each branch (Q (B, dof), a
    copy) and its count of in-limit 2 pi variants: the closed-form kernel's where it counts them, else
    ``limit_variants``'s. Named branches are told apart by name (a shoulder singularity's sampled q1
    values are one branch), unnamed ones by their joint values modulo 2 pi."""
    solutions = list(result.solutions)
    counted = result.solutions.variants if isinstance(result.solutions, Solutions) else []
    revolute = robot.revolute_mask
    kept: list[int] = []
    for i, solution in enumerate(solutions):
        if not any(_same_branch(solution, solutions[k], revolute) for k in kept):
            kept.append(i)
    Q = np.array([solutions[i].q for i in kept], dtype=float)
    if counted:
        return Q, [_as_count(counted[i]) for i in kept]
    if robot.limits.continuous.any():
        return Q, [math.inf] * len(kept)
    _, valid = limit_variants(Q, revolute, robot.limits.q_min, robot.limits.q_max)
    return Q, valid.sum(axis=1).tolist()


def _same_branch(a, b, revolute: np.ndarray) -> bool:
    """Whether two solutions are one branch: the same name, or both unnamed and equal modulo 2 pi."""
    if a.branch or b.branch:
        return a.branch == b.branch
    difference = np.where(revolute, np.remainder(a.q - b.q + np.pi, 2.0 * np.pi) - np.pi, a.q - b.q)
    return bool(np.abs(difference).max() <= SAME_BRANCH_TOLERANCE)


def _as_count(value: float) -> int | float:
    """A kernel's variant count: an int, math.inf with a continuous joint."""
    return value if math.isinf(value) else int(value)
