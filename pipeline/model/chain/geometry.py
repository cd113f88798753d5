"""The arm's link geometry in NumPy (no Drake, no matplotlib): what the Drake model's visual shapes,
the matplotlib drawings and the Meshcat view all draw from.

The stick figure: per link, the points fixed on it from its joint frame to the next joint frame, with
the DH offsets ``d`` and ``a`` drawn as separate legs; consecutive points are the link's segments (the
natural unit for shapes with a radius around them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigurationError
from ...files.robot_spec import MIN_SIZE_M

#: Points closer than this are merged in a polyline [m].
MERGE_TOLERANCE_M = 1e-9
#: Link radius as a fraction of the robot's size (the farthest drawn point from the base origin at
#: q = 0), clipped to VISUAL_RADIUS_RANGE [m]. Joints, base and flange are sized from it.
VISUAL_RADIUS_FRACTION = 0.04
VISUAL_RADIUS_RANGE = (0.004, 0.05)


def _merge(points) -> np.ndarray:
    """Points (k, 3) with consecutive duplicates (within MERGE_TOLERANCE_M) removed."""
    points = np.asarray(points, dtype=float)
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > MERGE_TOLERANCE_M
    return points[keep]


def compute_link_polylines(robot, q) -> list[np.ndarray]:
    """The arm as polylines in the base frame [m] at q: ``dof + 1`` arrays (k, 3), k >= 1.

    Entry 0 is fixed on the base: base origin, DH frame 0, joint 1's frame. Entry i (1..dof) is fixed
    on link i: joint i's frame origin (after its motion: a prismatic joint's slide is part of the
    link), the corner where the DH ``d`` offset ends (standard revolute rows), DH frame i, and joint
    i+1's frame origin (the end frame for the last link). ``robot``: a Robot (or DhKinematics).
    Successive polylines meet, so concatenated they run from the base origin to the end frame.
    """
    q = robot.as_configuration(q)
    spec = robot.spec
    X_BD = robot.fk_all(q)                       # DH frames 0..dof, then the end frame
    J, X_BE = robot.joint_frames(q)              # joint frames (z = axis, before the motion)
    ends = [J[i, :3, 3] for i in range(1, robot.dof)] + [X_BE[:3, 3]]
    polylines = [_merge([np.zeros(3), X_BD[0, :3, 3], J[0, :3, 3]])]
    for i, joint in enumerate(spec.joints):
        p, z = J[i, :3, 3], J[i, :3, 2]
        if not joint.is_revolute:
            step = joint.sign * q[i]             # the slide
        elif spec.convention == "standard":
            step = joint.d                       # Tz(d) before Tx(a)
        else:
            step = 0.0                           # modified: DH frame i is the end of the d leg
        polylines.append(_merge([p, p + step * z, X_BD[i + 1, :3, 3], ends[i]]))
    return polylines


def compute_arm_path(robot, q) -> np.ndarray:
    """The stick figure as one polyline (k, 3) [m] from the base origin to the end-frame origin."""
    return _merge(np.vstack(compute_link_polylines(robot, q)))


def robot_size(robot) -> float:
    """The farthest stick-figure point from the base origin at q = 0 [m] (at least 1 mm)."""
    points = compute_arm_path(robot, np.zeros(robot.dof))
    return max(float(np.linalg.norm(points, axis=1).max()), 1e-3)


def visual_radius(robot) -> float:
    """The link radius [m] used for a robot's visual geometry (see VISUAL_RADIUS_FRACTION)."""
    return float(np.clip(VISUAL_RADIUS_FRACTION * robot_size(robot), *VISUAL_RADIUS_RANGE))


def link_radii(robot) -> np.ndarray:
    """The capsule radius of each body [m], (dof + 1,): body 0 (the fixed base) takes joint 1's, link i
    the radius of row i; rows without one take ``visual_radius``."""
    default = visual_radius(robot)
    radii = [default if j.radius is None else j.radius for j in robot.spec.joints]
    return np.array([radii[0], *radii])


@dataclass(frozen=True)
class Capsule:
    """A capsule fixed on body ``body`` (0: the robot's base, i: link i): the segment ``p`` -> ``r``
    (3,) in the body frame [m] (base frame B for 0, DH frame i for link i) and its ``radius`` [m], at
    least MIN_SIZE_M (ConfigurationError otherwise: Drake aborts the process on a radius of 0)."""

    body: int
    p: np.ndarray
    r: np.ndarray
    radius: float

    def __post_init__(self):
        if not MIN_SIZE_M <= self.radius < np.inf:
            raise ConfigurationError(f"link capsule of body {self.body}: radius {self.radius!r} m is not a finite "
                                     f"size of at least {MIN_SIZE_M:g} m")

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.r - self.p))


#: Segments shorter than this are points: not drawn, a sphere of the radius instead of a capsule [m].
MIN_SEGMENT_M = 1e-6


def body_polylines(robot) -> list[np.ndarray]:
    """``compute_link_polylines`` at q = 0, each in its own body's frame [m] (see Capsule)."""
    q0 = np.zeros(robot.dof)
    X_owner = [np.eye(4), *robot.fk_all(q0)[1:-1]]
    out = []
    for X, points in zip(X_owner, compute_link_polylines(robot, q0)):
        X_inv = np.linalg.inv(X)
        out.append(points @ X_inv[:3, :3].T + X_inv[:3, 3])
    return out


def link_capsules(robot) -> list[Capsule]:
    """The collision geometry: one capsule per segment of each body's polyline (a zero-length capsule,
    a sphere, for a body whose polyline is one point other than the base's)."""
    radii = link_radii(robot)
    capsules = []
    for body, points in enumerate(body_polylines(robot)):
        segments = [(p, r) for p, r in zip(points[:-1], points[1:]) if np.linalg.norm(r - p) >= MIN_SEGMENT_M]
        if not segments and body > 0:
            segments = [(points[0], points[0])]
        capsules += [Capsule(body, p, r, float(radii[body])) for p, r in segments]
    return capsules


def lever_arms(robot, tool_reach: float = 0.0) -> np.ndarray:
    """For each joint, an upper bound of how far any point of the capsules it moves travels per unit of
    its motion, at any configuration (dof,) [m/rad, or 1 m/m for a prismatic joint]: the polylines beyond
    a joint run on from a point of its axis, so no point is farther from the axis than their length added
    up plus the largest radius (or ``tool_reach``, the farthest point of tool shapes from the end frame
    [m], added to the length). ``sum_j |dq_j| * lever_arms[j]`` bounds every point's displacement."""
    capsules = link_capsules(robot)
    levers = []
    for i, joint in enumerate(robot.spec.joints):
        later = [c for c in capsules if c.body > i]
        reach = sum(c.length for c in later) + max(max(c.radius for c in later), tool_reach)
        levers.append(reach if joint.is_revolute else 1.0)
    return np.array(levers)


#: Points per circle of a shape's outline.
OUTLINE_POINTS = 24


def _circle(radius: float, z: float, axis: int = 2) -> np.ndarray:
    """A circle (OUTLINE_POINTS + 1, 3) of ``radius`` at height z along ``axis`` (closed)."""
    angle = np.linspace(0.0, 2.0 * np.pi, OUTLINE_POINTS + 1)
    u, v = radius * np.cos(angle), radius * np.sin(angle)
    w = np.full_like(angle, z)
    return np.column_stack([(w, u, v), (u, w, v), (u, v, w)][axis])


def shape_outline(kind: str, size, X: np.ndarray) -> list[np.ndarray]:
    """Line drawing of a box (full sizes), cylinder or capsule (radius, length along z) or sphere
    (radius) centred at pose X (4, 4): polylines (k, 3) in X's parent frame [m]."""
    if kind == "box":
        h = np.asarray(size) / 2.0
        corners = np.array([[x, y, z] for x in (-h[0], h[0]) for y in (-h[1], h[1]) for z in (-h[2], h[2])])
        edges = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]
        lines = [corners[[a, b]] for a, b in edges]
    elif kind == "sphere":
        lines = [_circle(size[0], 0.0, axis) for axis in range(3)]
    else:
        radius, half = size[0], size[1] / 2.0
        lines = [_circle(radius, z) for z in (-half, half)]
        lines += [np.array([[x, y, -half], [x, y, half]]) for x, y in ((radius, 0), (-radius, 0), (0, radius),
                                                                      (0, -radius))]
        if kind == "capsule":
            lines += [_circle(radius, z, axis) + [0.0, 0.0, z] - ([z, 0, 0] if axis == 0 else [0, z, 0])
                      for z in (-half, half) for axis in (0, 1)]
    return [points @ X[:3, :3].T + X[:3, 3] for points in lines]
