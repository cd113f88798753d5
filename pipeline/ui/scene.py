"""The page's 3-D scene on a viser server, in the cell frame W [m]: the arm as its collision capsules
(``pipeline.model.chain.geometry.link_capsules``, the geometry the clearance is computed on), the tool (its shapes and
the TCP's axes), the cell's obstacles, the IK branches of a target as ghost arms coloured by state, and
the TCP's trace of a profile. Nothing here computes kinematics beyond placing what it is given.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..cell.tool import Tool
from ..files.poses import pose_to_quaternion_position
from ..model.chain.geometry import body_polylines, link_capsules, visual_radius
from .branches import closest_words

#: Colours (RGB 0-255): the arm, the tool, obstacles, the TCP's trace, and a ghost arm per branch state.
ARM_RGB, TOOL_RGB, OBSTACLE_RGB, TRACE_RGB = (235, 140, 45), (70, 90, 200), (160, 165, 175), (200, 40, 160)
STATE_RGB = {"free": (40, 170, 80), "colliding": (215, 40, 40), "near_singular": (230, 170, 20)}
#: Ghost arms drawn at most (a 6R arm has at most 8 branches); their lines [m] and handle size [radii].
MAX_GHOSTS, GHOST_THICKNESS_PX, HANDLE_RADII = 8, 4.0, 0.6
#: Sides of a capsule's circle (trimesh's count) and the obstacles' opacity.
CAPSULE_SIDES, OBSTACLE_OPACITY = 12, 0.55


def _pose(X: np.ndarray) -> dict:
    """viser's wxyz and position of a pose (4, 4) [m]."""
    quaternion, position = pose_to_quaternion_position(X)
    return {"wxyz": quaternion, "position": position}


def _place(node, X: np.ndarray) -> None:
    """Move a scene node to pose X (4, 4) [m] in its parent's frame."""
    node.wxyz, node.position = pose_to_quaternion_position(X)


def _segment_pose(p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The pose (4, 4) whose z axis runs along p -> r (3,) and whose origin is their middle."""
    X = np.eye(4)
    X[:3, 3] = (p + r) / 2.0
    axis = r - p
    length = np.linalg.norm(axis)
    if length > 0.0:
        z = axis / length
        helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        X[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return X


def shape_mesh(kind: str, size) -> trimesh.Trimesh:
    """A mesh of a cell shape centred at its pose: box (full sizes), sphere (radius), cylinder and capsule
    (radius, length along z) [m]."""
    if kind == "box":
        return trimesh.creation.box(extents=size)
    if kind == "sphere":
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == "cylinder":
        return trimesh.creation.cylinder(radius=size[0], height=size[1], sections=2 * CAPSULE_SIDES)
    return trimesh.creation.capsule(height=size[1], radius=size[0], count=[CAPSULE_SIDES, CAPSULE_SIDES])


class ArmScene:
    """The arm, its tool and its cell in a viser scene. ``robot``'s end frame is the TCP (a job's robot),
    ``tool`` the Tool it carries, ``cell`` a Cell or None; ``X_WB`` (4, 4) [m] the base in W."""

    def __init__(self, server, robot, tool: Tool, cell=None):
        self.server, self.robot, self.tool = server, robot, tool
        self.flange = tool.flange_robot(robot)
        self.X_WB = np.eye(4) if cell is None else cell.X_WB
        scene = server.scene
        scene.set_up_direction("+z")
        self.bodies = [scene.add_frame(f"/arm/body{i}", show_axes=False) for i in range(self.flange.dof + 1)]
        for k, capsule in enumerate(link_capsules(self.flange)):
            mesh = trimesh.creation.capsule(height=capsule.length, radius=capsule.radius,
                                            count=[CAPSULE_SIDES, CAPSULE_SIDES])
            mesh.apply_transform(_segment_pose(capsule.p, capsule.r))
            scene.add_mesh_simple(f"/arm/body{capsule.body}/capsule{k}", mesh.vertices, mesh.faces, color=ARM_RGB)
        self.flange_frame = scene.add_frame("/arm/flange", show_axes=False)
        for shape in tool.shapes:
            mesh = shape_mesh(shape.kind, shape.size)
            scene.add_mesh_simple(f"/arm/flange/{shape.name}", mesh.vertices, mesh.faces, color=TOOL_RGB,
                                  **_pose(shape.X))
        size = visual_radius(self.flange)
        self.tcp_frame = scene.add_frame("/arm/flange/tcp", axes_length=4.0 * size, axes_radius=0.15 * size,
                                         **_pose(tool.X_FT))
        if cell is not None:
            for shape in cell.objects:
                mesh = shape_mesh(shape.kind, shape.size)
                scene.add_mesh_simple(f"/cell/{shape.name}", mesh.vertices, mesh.faces, color=OBSTACLE_RGB,
                                      opacity=OBSTACLE_OPACITY, **_pose(shape.X))
        self.ghosts = GhostArms(server, self.flange, self.X_WB, size)
        self.trace = None

    def show(self, q: np.ndarray) -> None:
        """Place the arm at q (dof,) [rad or m]."""
        X_WD = self.X_WB @ self.flange.fk_all(q)                 # DH frames 0..dof, then the flange
        for body, X in zip(self.bodies, [self.X_WB, *X_WD[1:-1]]):  # the base's capsules sit in B
            _place(body, X)
        _place(self.flange_frame, X_WD[-1])

    def show_trace(self, tcp_W: np.ndarray | None) -> None:
        """The TCP's trace (N, 3) [m, W] as a line, or none."""
        if self.trace is not None:
            self.trace.remove()
            self.trace = None
        if tcp_W is not None and len(tcp_W) > 1:
            segments = np.stack([tcp_W[:-1], tcp_W[1:]], axis=1)
            self.trace = self.server.scene.add_line_segments("/trace", segments, TRACE_RGB, thickness=2.0,
                                                             thickness_units="screen")


def ghost_label(k: int, branch) -> str:
    """A ghost's label: its number, branch name and vendor configuration, and why it is not free (the
    closest pair and its distance, or the smallest singular value)."""
    text = f"{k + 1}: {branch.name or 'solution'}" + (f" {branch.vendor_config}" if branch.vendor_config else "")
    if branch.state == "colliding":
        return f"{text} · {closest_words(branch.clearance)}"
    if branch.state == "near_singular":
        return f"{text} · σmin {branch.sigma_min:.3g}"
    return text


class GhostArms:
    """Up to MAX_GHOSTS ghost arms (stick figures) with a clickable handle and a label each, made once and
    then only moved, recoloured and shown or hidden: a drag update sends no new geometry."""

    def __init__(self, server, flange_robot, X_WB: np.ndarray, radius: float):
        self.robot, self.X_WB = flange_robot, X_WB
        self.polylines = body_polylines(flange_robot)          # each body's stick figure in its own frame
        segments = sum(len(points) for points in self.polylines) - 1
        scene = server.scene
        self.lines = [scene.add_line_segments(f"/ghosts/{k}/arm", np.zeros((segments, 2, 3)), STATE_RGB["free"],
                                              thickness=GHOST_THICKNESS_PX, thickness_units="screen", visible=False)
                      for k in range(MAX_GHOSTS)]
        self.handles = [scene.add_icosphere(f"/ghosts/{k}/handle", radius=HANDLE_RADII * radius,
                                            color=STATE_RGB["free"], visible=False) for k in range(MAX_GHOSTS)]
        self.labels = [scene.add_label(f"/ghosts/{k}/handle/label", "", visible=False) for k in range(MAX_GHOSTS)]
        self.offset = 2.5 * radius
        self.colours = {state: np.broadcast_to(np.array(rgb, dtype=np.uint8), (segments, 2, 3))
                        for state, rgb in STATE_RGB.items()}                 # each segment's two ends

    def points(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the stick figure (k, 3), the handle (3,)) [m, W] of configuration q. The handle sits half way
        from the elbow (frame 3) to the wrist (frame 5), moved off along axis 5: every branch of a target
        shares the wrist centre; the elbow tells the shoulder and elbow branches apart, the side of axis 5
        the two wrist branches (axis 5 turns over with the flip)."""
        X_WD = self.X_WB @ self.robot.fk_all(q)                 # DH frames 0..dof, then the flange
        owners = [self.X_WB, *X_WD[1:-1]]
        path = np.vstack([points @ X[:3, :3].T + X[:3, 3] for X, points in zip(owners, self.polylines)])
        dof = self.robot.dof
        middle = (X_WD[min(3, dof), :3, 3] + X_WD[min(5, dof), :3, 3]) / 2.0
        return path, middle + self.offset * X_WD[min(4, dof), :3, 2]

    def show(self, branches) -> None:
        """Draw each branch (``pipeline.ui.branches.Branch``: q, state, name, vendor_config); hide the rest.
        viser sends a property only when its value changed."""
        for k in range(MAX_GHOSTS):
            visible = k < len(branches)
            if visible:
                branch = branches[k]
                path, handle = self.points(branch.q)
                self.lines[k].points = np.stack([path[:-1], path[1:]], axis=1)
                self.lines[k].colors = self.colours[branch.state]
                self.handles[k].position = handle
                self.handles[k].color = STATE_RGB[branch.state]
                self.labels[k].text = ghost_label(k, branch)
            for node in (self.lines[k], self.handles[k], self.labels[k]):
                node.visible = visible
