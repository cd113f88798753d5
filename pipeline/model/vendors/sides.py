"""The two geometric configuration bits every vendor uses, from our FK rather than from joint thresholds:
which side of axis 1 the wrist centre is on (shoulder), and which side of the lower arm (elbow).

For a 6R arm with a spherical wrist (``pipeline.model.ik.analytic``: its joint screws at q = 0, unit axes w_i
through points r_i, and the wrist centre c):

* shoulder: the wrist centre's coordinate along the arm's forward direction, the horizontal part of
  c - r1 at q = 0 turned by q1 about axis 1 ("x of the wrist centre in the frame that turns with axis
  1"). "Behind" is < 0. It is 0 on the shoulder singular set (the wrist centre on axis 1).
* elbow: the orientation of the triangle (a point on axis 2, a point on axis 3, the wrist centre) about
  axis 2, compared with the zero pose's. It changes sign only where the forearm (axis 3 to the wrist
  centre) lines up with the lower arm (axis 2 to axis 3), the elbow singular set (stretched or folded),
  so it is the vendors' "elbow up / down", "wrist centre in front of / behind the lower arm" and KUKA's
  "A3 against phi" with any A3-A4 offset (phi) taken into account. "Up" is the side of the pose the maker
  calls elbow up: the robot file's controller section's ``elbow_up`` axis angles mapped back to our q
  (``axes.joint_values``), else q = 0 (every other preset's zero pose has the upper arm vertical and the
  forearm forward; KUKA's zero pose has the upper arm horizontal, its elbow-up mastering pose is A2 = -90,
  A3 = +90 deg).

Both come with a margin (the distance from the singular set: [m] for the shoulder, the sine of the
elbow angle off stretched/folded for the elbow) so callers and tests can tell how decided a bit is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import VendorConfigurationError
from ...files.branch_names import SPHERICAL_WRIST
from ..ik.analytic import analytic_solver_for
from .axes import VENDORS, joint_values
from .controller import controller_of


@dataclass(frozen=True)
class ArmSides:
    """Per configuration (N,): ``behind`` (wrist centre behind axis 1), ``elbow_down`` (the elbow on the
    other side than at the elbow-up pose, ``elbow_up_q``), ``shoulder_margin`` [m] (the wrist centre's distance from axis 1)
    and ``elbow_margin`` [1] (|sin| of the angle between the lower arm and the forearm)."""

    behind: np.ndarray
    elbow_down: np.ndarray
    shoulder_margin: np.ndarray
    elbow_margin: np.ndarray


def _rotations(w: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations (N, 3, 3) about the unit axis w (3,) by angles (N,) [rad] (Rodrigues)."""
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def _solver(robot):
    """The closed-form geometry of a robot, or VendorConfigurationError: the bits need a spherical wrist."""
    solver = analytic_solver_for(robot)
    if not solver.applicable or solver.family != SPHERICAL_WRIST:
        raise VendorConfigurationError(f"{robot.name}: vendor configuration data needs a 6R arm with a spherical "
                                       f"wrist ({solver.reason or solver.family})")
    return solver


def wrist_centres(robot, Q: np.ndarray) -> np.ndarray:
    """Wrist centres (N, 3) [m, base frame] of configurations Q (N, 6) by our FK: the centre is fixed in
    the end frame, where it is R0^T (c0 - p0) from the zero pose (R0, p0) and the zero pose's centre c0."""
    solver = _solver(robot)
    X0 = solver.X_BE0
    in_end = X0[:3, :3].T @ (solver.wrist_centre - X0[:3, 3])
    X = robot.fk_batch(Q)
    return X[:, :3, :3] @ in_end + X[:, :3, 3]


def elbow_up_q(robot) -> np.ndarray:
    """Our joint values (6,) [rad] of the pose the maker calls elbow up: the controller section's
    ``elbow_up`` axis angles through its maker's axis map, else q = 0 (module docstring)."""
    controller = controller_of(robot)
    if controller is None or controller.maker not in VENDORS:
        return np.zeros(robot.dof)
    return joint_values(robot, controller.elbow_up, controller.maker)


def arm_sides(robot, Q) -> ArmSides:
    """The shoulder and elbow sides of configurations Q (N, 6) [rad] (module docstring)."""
    solver = _solver(robot)
    Q = robot.as_batch(np.atleast_2d(Q))
    w, r, c0 = solver.axes, solver.points, solver.wrist_centre
    c = wrist_centres(robot, Q)
    R1 = _rotations(w[0], Q[:, 0])
    forward0 = (c0 - r[0]) - w[0] * (w[0] @ (c0 - r[0]))
    if np.linalg.norm(forward0) == 0.0:
        raise VendorConfigurationError(f"{robot.name}: the zero pose has the wrist centre on axis 1, so it cannot "
                                       "tell front from back")
    forward = R1 @ forward0
    along = np.einsum("ij,ij->i", forward, c - r[0]) / np.linalg.norm(forward0)
    radial = (c - r[0]) - np.outer((c - r[0]) @ w[0], w[0])
    orientation, margin = _elbow_side(solver, Q, c)
    q_up = elbow_up_q(robot)
    reference, _ = _elbow_side(solver, q_up[None], wrist_centres(robot, q_up[None]))
    if reference[0] == 0.0:
        raise VendorConfigurationError(f"{robot.name}: its elbow-up pose q = {np.degrees(q_up).round(4).tolist()} deg "
                                       "is on the elbow singular set (forearm in line with the lower arm), so it "
                                       "cannot tell elbow up from down")
    return ArmSides(along < 0.0, orientation != reference[0], np.linalg.norm(radial, axis=1), margin)


def _elbow_side(solver, Q: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``_elbow`` of configurations Q (N, 6) [rad] with wrist centres c (N, 3) [m]: the lower arm from axis 2
    to axis 3, the forearm from axis 3 to the wrist centre, about axis 2."""
    w, r = solver.axes, solver.points
    R1 = _rotations(w[0], Q[:, 0])
    p2 = r[0] + R1 @ (r[1] - r[0])
    upper = (r[1] - r[0]) + _rotations(w[1], Q[:, 1]) @ (r[2] - r[1])
    p3 = r[0] + np.einsum("nij,nj->ni", R1, upper)
    return _elbow(p3 - p2, c - p3, R1 @ w[1])


def _elbow(lower: np.ndarray, forearm: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sign of (lower x forearm) . axis, |sin| of the angle between the arms in the plane normal to
    axis) for the lower arm (axis 2 to 3) and forearm (axis 3 to the wrist centre) vectors (N, 3)."""
    lower = lower - axis * np.einsum("ij,ij->i", lower, axis)[:, None]
    forearm = forearm - axis * np.einsum("ij,ij->i", forearm, axis)[:, None]
    triple = np.einsum("ij,ij->i", np.cross(lower, forearm), axis)
    return np.sign(triple), np.abs(triple) / (np.linalg.norm(lower, axis=1) * np.linalg.norm(forearm, axis=1))
