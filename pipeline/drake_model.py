"""RobotSpec -> a finalised Drake MultibodyPlant with named frames, and its FK and Jacobian.

Each DH row is split as ``A_i(q) = pre_i * M(sign_i * q_i) * post_i``, where M is a rotation about
(or translation along) z: the joint frame on the parent is ``frame_{i-1} * pre_i`` and the link body
frame is DH frame i. This is the only module that turns Drake's ``[w; v]`` rows into our ``[v; w]``.
"""

from __future__ import annotations

import weakref

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    JacobianWrtVariable,
    MultibodyForces,
    PrismaticJoint,
    RevoluteJoint,
    RotationalInertia,
    SpatialInertia,
)

from .robot_spec import DhJoint, RobotSpec

BASE_FRAME = "base"
END_FRAME = "end"

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
    m = joint.inertia
    I = m.I_Lcm
    rotational = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    return SpatialInertia.MakeFromCentralInertia(m.mass, m.p_LoLcm, rotational)


def _as_rigid_transform(X: np.ndarray) -> RigidTransform:
    return RigidTransform(RotationMatrix(X[:3, :3]), X[:3, 3])


def build_plant(spec: RobotSpec) -> MultibodyPlant:
    """A finalised MultibodyPlant: bodies ``link1..n``, joints named as in the file, frames base/end."""
    plant = MultibodyPlant(time_step=0.0)
    base = plant.AddFrame(FixedOffsetFrame(BASE_FRAME, plant.world_frame(), RigidTransform()))
    parent = plant.AddFrame(FixedOffsetFrame("dh0", base, _as_rigid_transform(spec.X_BaseD0)))
    for i, joint in enumerate(spec.joints, start=1):
        body = plant.AddRigidBody(f"link{i}", link_inertia(joint))
        pre, post = joint_split(joint, spec.convention)
        on_parent = plant.AddFrame(FixedOffsetFrame(f"{joint.name}_parent", parent, pre))
        on_child = plant.AddFrame(FixedOffsetFrame(f"{joint.name}_child", body.body_frame(), post.inverse()))
        axis = np.array([0.0, 0.0, joint.sign])
        joint_type = RevoluteJoint if joint.is_revolute else PrismaticJoint
        drake_joint = plant.AddJoint(joint_type(joint.name, on_parent, on_child, axis, joint.q_min, joint.q_max))
        drake_joint.set_velocity_limits([-joint.qd_max], [joint.qd_max])
        if joint.qdd_max is not None:
            drake_joint.set_acceleration_limits([-joint.qdd_max], [joint.qdd_max])
        parent = body.body_frame()
    plant.AddFrame(FixedOffsetFrame(END_FRAME, parent, _as_rigid_transform(spec.X_DnE)))
    plant.Finalize()
    return plant


def angular_first_to_linear_first(J_wv: np.ndarray) -> np.ndarray:
    """Drake's spatial Jacobian rows [w; v] -> our [v; w]. The one place this happens."""
    return np.vstack([J_wv[3:], J_wv[:3]])


class DrakeRobot:
    """A Drake plant built from a RobotSpec, with its context: FK and Jacobian of the end frame."""

    def __init__(self, spec: RobotSpec):
        self.spec = spec
        self.plant = build_plant(spec)
        self.context = self.plant.CreateDefaultContext()
        self.base_frame = self.plant.GetFrameByName(BASE_FRAME)
        self.end_frame = self.plant.GetFrameByName(END_FRAME)
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

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Joint torques [N m or N] for (N, dof) or (dof,) positions, velocities, accelerations
        (gravity -9.81 m/s^2 along base z included)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q, qd, qdd))
        forces = MultibodyForces(self.plant)
        tau = np.empty_like(q)
        for k in range(len(q)):
            self.plant.SetPositions(self.context, q[k])
            self.plant.SetVelocities(self.context, qd[k])
            # CalcInverseDynamics applies only the forces passed in: gravity is added here.
            tau[k] = (self.plant.CalcInverseDynamics(self.context, qdd[k], forces)
                      - self.plant.CalcGravityGeneralizedForces(self.context))
        return tau

    def __repr__(self) -> str:
        return f"DrakeRobot({self.spec.name!r}, bodies={self.plant.num_bodies()}, dof={self.dof})"


def build_drake_robot(spec: RobotSpec) -> DrakeRobot:
    """Build the Drake model (plant + context + named frames) of a RobotSpec."""
    return DrakeRobot(spec)


_DRAKE_MODELS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def drake_robot_for(robot) -> DrakeRobot:
    """The DrakeRobot of a Robot (built on first use, then cached for the robot's lifetime)."""
    model = _DRAKE_MODELS.get(robot)
    if model is None:
        model = _DRAKE_MODELS[robot] = build_drake_robot(robot.spec)
    return model

