"""What a reachability map asks: the voxel grid, the tool orientations at every voxel, and the point
of the arm that is mapped.

The grid is a box of voxel centres ``step`` apart in the robot's base frame, wide enough for the ball
of the robot's reach bound (``RobotSpec.reach_bound``, every length added up: no pose beyond it is
reachable); only the voxels inside that ball are solved. Centres lie at whole multiples of ``step`` in
z (z = 0 is a plane of centres) and half a step off them in x and y, so the base's z axis (joint 1's,
for an arm standing on its base) runs between centres, never through one: on that axis q1 is free (a
shoulder singularity, where the closed form samples q1), and Drake's distance queries of an arm folded
onto its own axis take tens of milliseconds each. Orientations are drawn from one generator seeded
with ``seed``: uniform rotations over SO(3), or tool z axes in a cone about the base's -z (pointing
down: that axis itself, then uniform by area) with rolls about them evenly spaced.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ConfigurationError, ScaleInputError
from ..files.arrays import is_whole_number
from ..model.robot import robot_with_tool

#: Most voxels in a grid (each is a few bytes in every map array): a finer step is refused.
MAX_VOXELS = 50_000_000
#: Most tool orientations per voxel (each is a 3x3 matrix per roll in every chunk; 16 by default).
MAX_ORIENTATIONS = 10_000
#: Most IK targets in a map (voxels in the reach x orientations x rolls): about 40 times the default
#: map of the largest preset (irb1600, 24 million; with 10 mm voxels 376 million), some 29 core-hours
#: of closed-form IK at the 9,700 poses/s measured on a shared 2-core machine: work for a cluster.
MAX_POSES = 1_000_000_000
#: The cone's axis: the tool pointing down, along the base's -z.
CONE_AXIS = np.array([0.0, 0.0, -1.0])
#: Rolls about each tool axis tried by full-pose IK in a cone (every 360 / ROLLS deg).
ROLLS = 8
#: Axes this close [m] meet (the wrist centre of a spherical wrist).
MEET_TOLERANCE_M = 1e-9
#: Points of the arm a map can follow, and their names: its end frame, or its wrist centre (where
#: datasheets measure reach).
POINTS = {"end": "end frame", "wrist": "wrist centre"}


@dataclass(frozen=True, eq=False)
class VoxelGrid:
    """Voxel centres along x, y, z (``axes``, each (n,) [m], base frame) ``step`` [m] apart."""

    step: float
    axes: tuple[np.ndarray, np.ndarray, np.ndarray]

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(len(a) for a in self.axes)

    def centres(self, flat: np.ndarray) -> np.ndarray:
        """The centres (k, 3) [m] of the voxels with these flat (C-order) indices."""
        i, j, k = np.unravel_index(flat, self.shape)
        return np.column_stack([self.axes[0][i], self.axes[1][j], self.axes[2][k]])

    def within(self, radius: float) -> np.ndarray:
        """Flat indices, ascending, of the voxels whose centre is within ``radius`` [m] of the base origin."""
        x, y, z = (a ** 2 for a in self.axes)
        inside = (x[:, None, None] + y[None, :, None] + z[None, None, :]) <= radius ** 2
        return np.flatnonzero(inside)

    def count_within(self, radius: float) -> int:
        """How many voxels ``within`` gives, counted slice by slice (no array of the whole grid)."""
        across = np.sort((self.axes[0][:, None] ** 2 + self.axes[1][None, :] ** 2).ravel())
        return int(np.searchsorted(across, radius ** 2 - self.axes[2] ** 2, side="right").sum())


def check_step(step) -> float:
    """``step`` as a positive finite length [m]; ScaleInputError naming it otherwise."""
    if isinstance(step, bool) or not isinstance(step, (int, float, np.integer, np.floating)) \
            or not math.isfinite(step) or step <= 0:
        raise ScaleInputError("step", "must be a positive voxel size in metres", step)
    return float(step)


def reach_grid(robot, step: float) -> VoxelGrid:
    """The grid of voxel centres ``step`` [m] apart covering the ball of ``robot.spec.reach_bound`` (see
    the module docstring for where the centres lie)."""
    step = check_step(step)
    if step > robot.spec.reach_bound:
        raise ScaleInputError("step", f"is larger than the reach of {robot.name} ({robot.spec.reach_bound:.3g} m): "
                              "one voxel would hold the whole map; choose a smaller step", step)
    half = math.ceil(robot.spec.reach_bound / step)
    if 4 * half * half * (2 * half + 1) > MAX_VOXELS:
        raise ScaleInputError("step", f"gives {4 * half * half * (2 * half + 1):.3g} voxels over the reach of "
                              f"{robot.name} ({robot.spec.reach_bound:.3g} m), more than {MAX_VOXELS:,}: choose a "
                              "larger step", step)
    across = (np.arange(-half, half) + 0.5) * step
    return VoxelGrid(step, (across, across.copy(), np.arange(-half, half + 1) * step))


def check_orientations(orientations, tool_axis_cone) -> None:
    """ScaleInputError unless ``orientations`` is a whole number in [1, MAX_ORIENTATIONS] and
    ``tool_axis_cone`` None or an angle in (0, 180] deg."""
    if not is_whole_number(orientations, 1, MAX_ORIENTATIONS):
        raise ScaleInputError("orientations", f"must be a whole number in [1, {MAX_ORIENTATIONS:,}]", orientations)
    if tool_axis_cone is not None and (isinstance(tool_axis_cone, bool) or not isinstance(
            tool_axis_cone, (int, float, np.integer, np.floating)) or not 0 < tool_axis_cone <= 180):
        raise ScaleInputError("tool_axis_cone", "must be a half-angle in (0, 180] deg", tool_axis_cone)


def check_poses(voxels: int, per_voxel: int, step: float) -> None:
    """ScaleInputError unless ``voxels`` x ``per_voxel`` (orientations x rolls) IK targets are at most
    MAX_POSES (``step`` [m]: for the message)."""
    if voxels * per_voxel > MAX_POSES:
        raise ScaleInputError("step x orientations", f"gives {voxels:,} voxels x {per_voxel:,} orientations "
                              f"= {voxels * per_voxel:,} IK targets, more than {MAX_POSES:,}: choose a larger "
                              "step or fewer orientations", f"step {step * 1e3:g} mm")


def tool_orientations(count: int, tool_axis_cone: float | None, rolls: int, seed: int) -> np.ndarray:
    """Tool orientations (count, rolls, 3, 3) in the base frame: without a cone, ``count`` uniform random
    rotations (``rolls`` must be 1); with a cone of half-angle ``tool_axis_cone`` [deg] about CONE_AXIS,
    ``count`` tool z axes, the first CONE_AXIS itself and the others uniform in the cone by area, each
    turned about itself by ``rolls`` rolls 360/rolls deg apart from a random start."""
    rng = np.random.default_rng(seed)
    if tool_axis_cone is None:
        q = rng.standard_normal((count, 4))
        return Rotation.from_quat(q / np.linalg.norm(q, axis=1, keepdims=True)).as_matrix()[:, None]
    cos_theta = rng.uniform(math.cos(math.radians(tool_axis_cone)), 1.0, count)
    cos_theta[0] = 1.0                     # the cone's own axis first (a 5-axis arm points only in its radial plane)
    phi = rng.uniform(0.0, 2.0 * math.pi, count)
    start = rng.uniform(0.0, 2.0 * math.pi, count)
    sin_theta = np.sqrt(1.0 - cos_theta ** 2)
    # About the base's -z: z = (sin cos phi, sin sin phi, -cos); x, y complete it (x, y, z right-handed).
    z = np.column_stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), -cos_theta])
    x = np.column_stack([cos_theta * np.cos(phi), cos_theta * np.sin(phi), sin_theta])
    frames = np.stack([x, np.cross(z, x), z], axis=-1)                       # (count, 3, 3), columns x y z
    angles = start[:, None] + 2.0 * math.pi * np.arange(rolls)[None, :] / rolls
    about_z = Rotation.from_euler("z", angles.reshape(-1, 1)).as_matrix().reshape(count, rolls, 3, 3)
    return frames[:, None] @ about_z


def wrist_centre_robot(robot):
    """The robot whose end frame sits at its wrist centre, where the last three joint axes meet (the
    point datasheets give the reach of), with the orientation of its own end frame; ConfigurationError
    when those axes do not meet in one point."""
    frames, X_BE = robot.joint_frames(np.zeros(robot.dof))
    if robot.dof < 3:
        raise ConfigurationError(f"point 'wrist': {robot.name} has {robot.dof} joints, no wrist")
    points, axes = frames[-3:, :3, 3], frames[-3:, :3, 2]
    # The point nearest all three axis lines (least squares): sum (I - a a^T) (c - p) = 0.
    projectors = np.eye(3)[None] - axes[:, :, None] * axes[:, None, :]
    centre = np.linalg.lstsq(projectors.sum(axis=0), np.einsum("kij,kj->i", projectors, points), rcond=None)[0]
    miss = max(float(np.linalg.norm(P @ (centre - p))) for P, p in zip(projectors, points))
    if miss > MEET_TOLERANCE_M:
        raise ConfigurationError(f"point 'wrist': the last three joint axes of {robot.name} do not meet in one "
                                 f"point (they miss by {miss * 1e3:.3g} mm): it has no wrist centre; map its end frame")
    X_ET = np.eye(4)
    X_ET[:3, 3] = X_BE[:3, :3].T @ (centre - X_BE[:3, 3])
    return robot_with_tool(robot, X_ET)
