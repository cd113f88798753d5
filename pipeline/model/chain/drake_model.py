"""RobotSpec -> a finalised Drake MultibodyPlant with named frames, and its FK and Jacobian.

Each DH row is split as ``A_i(q) = pre_i * M(sign_i * q_i) * post_i``, where M is a rotation about
(or translation along) z: the joint frame on the parent is ``frame_{i-1} * pre_i`` and the link body
frame is DH frame i. This is the only module that turns Drake's ``[w; v]`` rows into our ``[v; w]``.

``build_plant`` makes the bare plant (no SceneGraph); ``build_visual_diagram`` makes a Diagram with
the same chain (the same ``add_robot``), simple visual shapes per link and, optionally, Meshcat.
"""

from __future__ import annotations

import logging
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from pydrake.geometry import Box, Capsule, Cylinder, Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, SceneGraph, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant
from pydrake.multibody.tree import (
    default_model_instance,
    FixedOffsetFrame,
    JacobianWrtVariable,
    MultibodyForces,
    PrismaticJoint,
    RevoluteJoint,
    RigidBody,
    RotationalInertia,
    SpatialInertia,
)
from pydrake.systems.framework import Diagram, DiagramBuilder

from ...files.robot_spec import DhJoint, RobotSpec
from .geometry import MIN_SEGMENT_M, body_polylines, visual_radius
from .kinematics import DhKinematics

BASE_FRAME = "base"
END_FRAME = "end"
#: The body welded to the end frame that stands for what the robot carries (``DrakeRobot.inverse_dynamics``).
PAYLOAD_BODY = "payload"

#: Placeholder mass properties for links whose file gives none: a 1 kg solid sphere of radius
#: 0.05 m centred on the link frame origin. Kinematics never depends on it; dynamics would.
PLACEHOLDER_MASS_KG = 1.0
PLACEHOLDER_RADIUS_M = 0.05


def _rot_z(angle: float) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeZRotation(angle), np.zeros(3))


def _rot_x(angle: float) -> RigidTransform:
    return RigidTransform(RotationMatrix.MakeXRotation(angle), np.zeros(3))


def _shift(x: float = 0.0, z: float = 0.0) -> RigidTransform:
    return RigidTransform(np.array([x, 0.0, z]))


def joint_split(joint: DhJoint, convention: str) -> tuple[RigidTransform, RigidTransform]:
    """The fixed transforms (pre, post) around the joint motion of one DH row."""
    rotate_fixed = _rot_z(joint.theta_offset)
    if convention == "standard":
        if joint.is_revolute:
            return rotate_fixed, _shift(z=joint.d) @ _shift(x=joint.a) @ _rot_x(joint.alpha)
        return rotate_fixed @ _shift(z=joint.d), _shift(x=joint.a) @ _rot_x(joint.alpha)
    pre = _rot_x(joint.alpha) @ _shift(x=joint.a) @ rotate_fixed
    if joint.is_revolute:
        return pre, _shift(z=joint.d)
    return pre @ _shift(z=joint.d), RigidTransform()


def link_inertia(joint: DhJoint) -> SpatialInertia:
    """The link's spatial inertia about its frame origin, or the documented placeholder."""
    if joint.inertia is None:
        return SpatialInertia.SolidSphereWithMass(PLACEHOLDER_MASS_KG, PLACEHOLDER_RADIUS_M)
    return central_spatial_inertia(joint.inertia.mass, joint.inertia.p_LoLcm, joint.inertia.I_Lcm)


def central_spatial_inertia(mass: float, com: np.ndarray, I: np.ndarray) -> SpatialInertia:
    """A body's spatial inertia about its frame origin: ``mass`` [kg], centre of mass ``com`` (3,) [m] and (3, 3)
    inertia ``I`` [kg m^2] about it, in the body frame."""
    rotational = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    return SpatialInertia.MakeFromCentralInertia(mass, np.asarray(com, dtype=float), rotational)


def as_rigid_transform(X: np.ndarray) -> RigidTransform:
    return RigidTransform(RotationMatrix(X[:3, :3]), X[:3, 3])


def add_robot(plant: MultibodyPlant, spec: RobotSpec, model_instance=None, mount=None) -> list[RigidBody]:
    """Add the chain of a RobotSpec to an unfinalised plant: bodies ``link1..n``, joints named as in the
    file (limits set; a continuous joint has no position limits: Drake's -inf, +inf), frames ``base``,
    ``dh0``, ``<joint>_parent``, ``<joint>_child`` and ``end``, in ``model_instance`` (default: the
    plant's default instance), the base frame on ``mount`` (a frame; default the world frame). Returns
    the link bodies in order. The one place the DH kinematics become Drake joints."""
    instance = default_model_instance() if model_instance is None else model_instance
    base = plant.AddFrame(FixedOffsetFrame(BASE_FRAME, plant.world_frame() if mount is None else mount,
                                           RigidTransform(), instance))
    parent = plant.AddFrame(FixedOffsetFrame("dh0", base, as_rigid_transform(spec.X_BaseD0), instance))
    bodies = []
    for i, joint in enumerate(spec.joints, start=1):
        body = plant.AddRigidBody(f"link{i}", instance, link_inertia(joint))
        pre, post = joint_split(joint, spec.convention)
        on_parent = plant.AddFrame(FixedOffsetFrame(f"{joint.name}_parent", parent, pre))
        on_child = plant.AddFrame(FixedOffsetFrame(f"{joint.name}_child", body.body_frame(), post.inverse()))
        axis = np.array([0.0, 0.0, joint.sign])
        joint_type = RevoluteJoint if joint.is_revolute else PrismaticJoint
        drake_joint = plant.AddJoint(joint_type(joint.name, on_parent, on_child, axis, joint.q_min, joint.q_max))
        drake_joint.set_velocity_limits([-joint.qd_max], [joint.qd_max])
        if joint.qdd_max is not None:
            drake_joint.set_acceleration_limits([-joint.qdd_max], [joint.qdd_max])
        bodies.append(body)
        parent = body.body_frame()
    plant.AddFrame(FixedOffsetFrame(END_FRAME, parent, as_rigid_transform(spec.X_DnE), instance))
    return bodies


def build_plant(spec: RobotSpec) -> MultibodyPlant:
    """A finalised MultibodyPlant: bodies ``link1..n``, joints named as in the file, frames base/end
    (no geometry; ``build_visual_diagram`` makes the same plant with visual geometry)."""
    plant = MultibodyPlant(time_step=0.0)
    add_robot(plant, spec)
    plant.Finalize()
    return plant


# -- visual geometry ------------------------------------------------------------------------------
LINK_COLOURS = ((0.93, 0.55, 0.13, 1.0), (0.75, 0.75, 0.78, 1.0))   # alternate: orange, light grey
JOINT_COLOUR = (0.25, 0.25, 0.28, 1.0)
BASE_COLOUR = (0.35, 0.35, 0.38, 1.0)
FLANGE_COLOUR = (0.20, 0.45, 0.85, 1.0)
OBSTACLE_COLOUR = (0.55, 0.60, 0.65, 0.6)
#: A job's tool: the stem from the end frame to the TCP, and the TCP's x, y, z axes (red, green, blue).
TOOL_COLOUR = (0.15, 0.65, 0.75, 1.0)
TCP_AXIS_COLOURS = ((0.85, 0.15, 0.15, 1.0), (0.15, 0.65, 0.20, 1.0), (0.15, 0.30, 0.90, 1.0))
#: The tool stem's radius and the TCP axes' length and radius, in link radii (``visual_radius``).
TOOL_STEM_RADII, TCP_AXIS_RADII, TCP_AXIS_WIDTH_RADII = 0.5, 3.0, 0.2


def pose_between(p: np.ndarray, r: np.ndarray) -> RigidTransform:
    """Pose of a shape centred between p and r with its z along r - p (a cylinder or capsule spanning
    the segment; at p itself when the segment has no length)."""
    axis = r - p
    if np.linalg.norm(axis) < MIN_SEGMENT_M:
        return RigidTransform(p)
    return RigidTransform(RotationMatrix.MakeFromOneVector(axis, 2), (p + r) / 2.0)


def _on_z(X: np.ndarray, offset: float = 0.0) -> RigidTransform:
    """Pose X (4, 4) shifted by ``offset`` along its own z."""
    return as_rigid_transform(X) @ _shift(z=offset)


def register_visual_geometry(plant: MultibodyPlant, spec: RobotSpec, bodies: list[RigidBody]) -> int:
    """Register simple shapes on an unfinalised plant that has a SceneGraph: per link, cylinders along
    the segments between its joint frame and the next (DH offsets drawn as separate legs, zero-length
    segments skipped, a sphere at each corner); per joint, a short cylinder along its axis on the parent
    body; a base disc (and pedestal) on the world body; a flange disc at the end frame. Placed from the
    NumPy FK at q = 0 expressed in each body's frame (the body frame is DH frame i). Returns the count."""
    robot = DhKinematics(spec)
    q0 = np.zeros(robot.dof)
    radius = visual_radius(robot)
    X_BD = robot.fk_all(q0)                   # DH frames 0..dof, then the end frame
    joint_frames, X_BE = robot.joint_frames(q0)
    owners = [plant.world_body(), *bodies]
    X_owner = [np.eye(4), *X_BD[1:-1]]        # body frames in the base frame at q = 0
    count = 0

    def add(body, X_BG: RigidTransform, shape, name: str, colour) -> None:
        nonlocal count
        plant.RegisterVisualGeometry(body, X_BG, shape, name, np.array(colour))
        count += 1

    add(plant.world_body(), RigidTransform(np.array([0.0, 0.0, -radius / 2.0])), Cylinder(3.0 * radius, radius),
        "base_disc", BASE_COLOUR)
    for i, (body, local) in enumerate(zip(owners, body_polylines(robot))):
        colour = BASE_COLOUR if i == 0 else LINK_COLOURS[(i - 1) % len(LINK_COLOURS)]
        name = "pedestal" if i == 0 else f"link{i}"
        for k, (p, r) in enumerate(zip(local[:-1], local[1:])):
            length = float(np.linalg.norm(r - p))
            if length < MIN_SEGMENT_M:
                continue
            add(body, pose_between(p, r), Cylinder(radius, length), f"{name}_segment{k}", colour)
        for k, p in enumerate(local[1:-1]):                     # round the corners
            add(body, RigidTransform(p), Sphere(radius), f"{name}_corner{k}", colour)
    for i, joint in enumerate(spec.joints):
        X_parent = np.linalg.inv(X_owner[i]) @ joint_frames[i]
        add(owners[i], as_rigid_transform(X_parent), Cylinder(1.5 * radius, 4.0 * radius),
            f"{joint.name}_axis", JOINT_COLOUR)
    X_DnE = np.linalg.inv(X_owner[-1]) @ X_BE
    add(bodies[-1], _on_z(X_DnE, -radius / 4.0), Cylinder(1.6 * radius, radius / 2.0), "flange", FLANGE_COLOUR)
    return count


@dataclass(frozen=True, eq=False)
class VisualModel:
    """A diagram of the robot's plant (same kinematics as ``build_plant``) with visual geometry in a
    SceneGraph, and a MeshcatVisualizer when built with a Meshcat (else ``visualizer`` is None)."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    visualizer: MeshcatVisualizer | None
    geometry_count: int


def drake_shape(shape):
    """The Drake shape of a cell's Shape (box full sizes; cylinder and capsule radius, length; sphere)."""
    make = {"box": Box, "cylinder": Cylinder, "sphere": Sphere, "capsule": Capsule}[shape.kind]
    return make(*shape.size)


def register_cell_geometry(plant: MultibodyPlant, spec: RobotSpec, bodies: list[RigidBody], cell) -> int:
    """Visual shapes of a cell on an unfinalised plant whose robot stands at the world origin: its
    obstacles (posed in the robot's base frame) on the world body, its tool shapes on the last link.
    Returns the count."""
    X_BW = np.linalg.inv(cell.X_WB)
    for shape in cell.objects:
        plant.RegisterVisualGeometry(plant.world_body(), as_rigid_transform(X_BW @ shape.X), drake_shape(shape),
                                     f"obstacle_{shape.name}", np.array(OBSTACLE_COLOUR))
    for shape in cell.tool_shapes:
        plant.RegisterVisualGeometry(bodies[-1], as_rigid_transform(spec.X_DnE @ shape.X), drake_shape(shape),
                                     f"tool_{shape.name}", np.array(FLANGE_COLOUR))
    return len(cell.objects) + len(cell.tool_shapes)


def register_tool_geometry(plant: MultibodyPlant, spec: RobotSpec, bodies: list[RigidBody], X_ET: np.ndarray) -> int:
    """Visual shapes of a job's tool X_ET (4, 4) [m] (the TCP T in the end frame E of ``spec``) on an
    unfinalised plant, on the last link: a thin stem from E's origin to T's (none when they coincide)
    and T's axes as a small red, green, blue triad. Returns the count."""
    radius = visual_radius(DhKinematics(spec))
    X_DnT = spec.X_DnE @ X_ET
    p_E, p_T = spec.X_DnE[:3, 3], X_DnT[:3, 3]
    shapes = []
    stem = float(np.linalg.norm(p_T - p_E))
    if stem >= MIN_SEGMENT_M:
        shapes.append(("tool_stem", pose_between(p_E, p_T), Cylinder(TOOL_STEM_RADII * radius, stem), TOOL_COLOUR))
    length = TCP_AXIS_RADII * radius
    for k, (axis, colour) in enumerate(zip("xyz", TCP_AXIS_COLOURS)):
        shapes.append((f"tcp_{axis}", pose_between(p_T, p_T + length * X_DnT[:3, k]),
                       Cylinder(TCP_AXIS_WIDTH_RADII * radius, length), colour))
    for name, X_DnG, shape, colour in shapes:
        plant.RegisterVisualGeometry(bodies[-1], X_DnG, shape, name, np.array(colour))
    return len(shapes)


def build_visual_diagram(spec: RobotSpec, meshcat: Meshcat | None = None,
                         params: MeshcatVisualizerParams | None = None, cell=None,
                         tool: np.ndarray | None = None) -> VisualModel:
    """The robot in a Diagram: ``AddMultibodyPlantSceneGraph``, the chain of ``add_robot``, the shapes
    of ``register_visual_geometry`` (and of ``register_cell_geometry`` with a cell, of
    ``register_tool_geometry`` with a job's ``tool`` X_ET (4, 4) [m] in the end frame of ``spec``), and a
    MeshcatVisualizer (with ``params``, if given) publishing to ``meshcat`` if given."""
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    bodies = add_robot(plant, spec)
    count = register_visual_geometry(plant, spec, bodies)
    if cell is not None:
        count += register_cell_geometry(plant, spec, bodies, cell)
    if tool is not None:
        count += register_tool_geometry(plant, spec, bodies, tool)
    plant.Finalize()
    visualizer = None
    if meshcat is not None:
        visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat,
                                                    params if params is not None else MeshcatVisualizerParams())
    diagram = builder.Build()
    return VisualModel(diagram, plant, scene_graph, visualizer, count)


@contextmanager
def quiet_drake_log():
    """Drake's log (Python's ``drake`` logger, which pydrake keeps in step with Drake's C++ log) at
    WARNING inside the block: Meshcat announces its URL and the collision checker its
    contexts at INFO."""
    drake_log = logging.getLogger("drake")
    previous = drake_log.level
    drake_log.setLevel(max(logging.WARNING, previous))
    try:
        yield
    finally:
        drake_log.setLevel(previous)


def angular_first_to_linear_first(J_wv: np.ndarray) -> np.ndarray:
    """Drake's spatial Jacobian rows [w; v] -> our [v; w]. The one place this happens."""
    return np.vstack([J_wv[3:], J_wv[:3]])


class DrakeRobot:
    """A Drake plant built from a RobotSpec, with its context: FK and Jacobian of the end frame, and inverse
    dynamics with a payload (a body ``payload`` welded to the end frame, massless until a payload is given)."""

    def __init__(self, spec: RobotSpec):
        self.spec = spec
        self.plant = MultibodyPlant(time_step=0.0)
        add_robot(self.plant, spec)
        self.end_frame = self.plant.GetFrameByName(END_FRAME)
        self.payload_body = self.plant.AddRigidBody(PAYLOAD_BODY, SpatialInertia.Zero())
        self.plant.WeldFrames(self.end_frame, self.payload_body.body_frame())
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.base_frame = self.plant.GetFrameByName(BASE_FRAME)
        self.dof = self.plant.num_positions()

    def set_positions(self, q) -> None:
        """Set the joint positions [rad or m] in the context."""
        self.plant.SetPositions(self.context, np.asarray(q, dtype=float))

    def fk(self, q) -> np.ndarray:
        """Pose X_BE (4, 4) of the end frame in the base frame [m]."""
        self.set_positions(q)
        return self.plant.CalcRelativeTransform(self.context, self.base_frame, self.end_frame).GetAsMatrix4()

    def jacobian(self, q) -> np.ndarray:
        """Geometric Jacobian (6, dof), rows [v; w], in the base frame at the end-frame origin."""
        self.set_positions(q)
        J_wv = self.plant.CalcJacobianSpatialVelocity(
            self.context, JacobianWrtVariable.kQDot, self.end_frame, np.zeros(3), self.base_frame, self.base_frame
        )
        return angular_first_to_linear_first(J_wv)

    def set_payload(self, payload) -> None:
        """Make the payload body ``payload`` (``pipeline.program.payload.Payload``: mass [kg], centre of mass [m] and
        inertia [kg m^2] in the end frame; None: nothing carried)."""
        inertia = SpatialInertia.Zero() if payload is None else \
            central_spatial_inertia(payload.mass, payload.com, payload.inertia)
        self.payload_body.SetSpatialInertiaInBodyFrame(self.context, inertia)

    def inverse_dynamics(self, q, qd, qdd, payload=None) -> np.ndarray:
        """Joint torques [N m or N] for (N, dof) or (dof,) positions, velocities, accelerations (gravity -9.81
        m/s^2 along base z included), the end frame carrying ``payload`` (``set_payload``; None: nothing)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, qd, qdd))
        self.set_payload(payload)
        forces = MultibodyForces(self.plant)
        tau = np.empty_like(q)
        for k in range(len(q)):
            self.plant.SetPositions(self.context, q[k])
            self.plant.SetVelocities(self.context, qd[k])
            # CalcInverseDynamics applies only the forces passed in: gravity is added here.
            tau[k] = (self.plant.CalcInverseDynamics(self.context, qdd[k], forces)
                      - self.plant.CalcGravityGeneralizedForces(self.context))
        return tau

    def carrying(self, payload) -> "CarriedDynamics":
        """This robot's inverse dynamics with ``payload`` on its end frame (what ``pipeline.timing`` calls)."""
        return CarriedDynamics(self, payload)

    def __repr__(self) -> str:
        return f"DrakeRobot({self.spec.name!r}, bodies={self.plant.num_bodies()}, dof={self.dof})"


@dataclass(frozen=True)
class CarriedDynamics:
    """A DrakeRobot's inverse dynamics with one payload (None: nothing carried)."""

    drake: DrakeRobot
    payload: object

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Joint torques [N m or N] (``DrakeRobot.inverse_dynamics``) with this payload."""
        return self.drake.inverse_dynamics(q, qd, qdd, self.payload)


def build_drake_robot(spec: RobotSpec) -> DrakeRobot:
    """Build the Drake model (plant + context + named frames) of a RobotSpec."""
    return DrakeRobot(spec)
