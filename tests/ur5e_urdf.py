"""A reference for the ur5e preset's dynamics that shares none of its code: Drake's plant parsed from Universal Robots'
own URDF (tests/data/ur5e_description/, see PROVENANCE.md there), each load a body welded to its ``tool0`` frame.

The URDF's world is UR's ``base_link``; the preset's base frame is UR's ``base`` (``base_link`` turned half a turn about
z, as is ``base_link_inertia``, which the shoulder joint sits on), so poses are compared in ``base`` and torques need no
conversion (gravity, -9.81 m/s^2 along z, is the same in both).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import MultibodyForces, RotationalInertia, SpatialInertia

URDF = Path(__file__).parent / "data" / "ur5e_description" / "ur5e.urdf"
#: The URDF's joint origins that round UR's DH table (from the description's default_kinematics.yaml, a calibration
#: format): pi/2 as 1.570796327 (2.1e-10 rad off) and 1.570796326589793, two offsets of 2e-11 m. ``UrdfArm(exact=True)``
#: parses the file with these made exact (pi/2, 0), so that only the DH table's own numbers remain.
ROUNDED = {'rpy="1.570796327 0 0"': f'rpy="{np.pi / 2!r} 0 0"',
           'xyz="0 -0.0997 -2.044881182297852e-11"': 'xyz="0 -0.0997 0"',
           'rpy="1.570796326589793 3.141592653589793 3.141592653589793" xyz="0 0.0996 -2.042830148012698e-11"':
           f'rpy="{np.pi / 2!r} {np.pi!r} {np.pi!r}" xyz="0 0.0996 0"'}
#: The URDF's joints in the preset's order (q1..q6).
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
#: Loads the reference carries at once, each a body of its own welded to tool0.
MAX_LOADS = 2


def spatial_inertia(load) -> SpatialInertia:
    """A Payload's spatial inertia about tool0's origin (None: zero)."""
    if load is None:
        return SpatialInertia.Zero()
    I = load.inertia
    return SpatialInertia.MakeFromCentralInertia(load.mass, np.asarray(load.com, dtype=float),
                                                 RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))


def urdf_text(exact: bool) -> str:
    """The URDF as UR's description gives it, or with its ROUNDED origins exact."""
    text = URDF.read_text(encoding="utf-8")
    if exact:
        for rounded, value in ROUNDED.items():
            assert text.count(rounded) >= 1, rounded
            text = text.replace(rounded, value)
    return text


class UrdfArm:
    """UR's URDF in a Drake plant with MAX_LOADS bodies ``load0``, ``load1`` welded to ``tool0`` (massless until loads
    are given); ``exact``: its ROUNDED origins made exact."""

    def __init__(self, exact: bool = False):
        self.plant = MultibodyPlant(time_step=0.0)
        (arm,) = Parser(self.plant).AddModelsFromString(urdf_text(exact), "urdf")
        self.bodies = [self.plant.AddRigidBody(f"load{k}", arm, SpatialInertia.Zero()) for k in range(MAX_LOADS)]
        for body in self.bodies:
            self.plant.WeldFrames(self.plant.GetFrameByName("tool0"), body.body_frame())
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        starts = [self.plant.GetJointByName(name).position_start() for name in JOINTS]
        assert starts == list(range(6)) and self.plant.num_positions() == 6, starts

    def tool0(self, q) -> np.ndarray:
        """(4, 4) pose of ``tool0`` in UR's ``base`` frame [m] at joint values ``q`` [rad]."""
        self.plant.SetPositions(self.context, np.asarray(q, dtype=float))
        return self.plant.CalcRelativeTransform(self.context, self.plant.GetFrameByName("base"),
                                                self.plant.GetFrameByName("tool0")).GetAsMatrix4()

    def inverse_dynamics(self, q, qd, qdd, *loads) -> np.ndarray:
        """(6,) joint torques [N m] with gravity at joint values [rad], speeds [rad/s] and accelerations [rad/s^2], each
        of ``loads`` (``pipeline.program.payload.Payload``: mass, centre of mass and inertia in tool0; None: nothing)
        a body on ``tool0``."""
        assert len(loads) <= MAX_LOADS
        for body, load in zip(self.bodies, list(loads) + [None] * (MAX_LOADS - len(loads))):
            body.SetSpatialInertiaInBodyFrame(self.context, spatial_inertia(load))
        self.plant.SetPositions(self.context, np.asarray(q, dtype=float))
        self.plant.SetVelocities(self.context, np.asarray(qd, dtype=float))
        return (self.plant.CalcInverseDynamics(self.context, np.asarray(qdd, dtype=float), MultibodyForces(self.plant))
                - self.plant.CalcGravityGeneralizedForces(self.context))
