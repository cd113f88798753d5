"""A URDF serial chain -> a robot file (DH table, limits, mass properties, provenance) and its Robot.

The DH table comes from the joint axes at q = 0 (``dh_from_axes``); every sign is +1 and every offset
is the joint value at the URDF's zero, so q is the URDF's own joint vector. Limits are copied
(position, velocity; effort as ``tau_max`` when every joint has one and every link its inertia); a
continuous joint becomes ``continuous: true``.
Mass properties of the links welded to each moving link are summed into its DH frame. The robot-file
document goes through the strict robot-file reader, and the imported FK is compared with the URDF's
own chain on random configurations (``max_fk_error_m``), so an import never hands over a different
robot silently: above ``fk_tolerance`` it is a UrdfChainError, and no robot file is written.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ConfigurationError, UrdfChainError
from ..files.poses import make_pose
from ..files.robot_spec import CONVENTIONS, DhJoint, LinkInertia, RobotSpec, parse_robot_spec
from ..files.robot_writer import robot_document, write_robot_file
from ..model.chain.dh_convert import standard_to_modified
from ..model.chain.kinematics import DhKinematics, rotation_log
from ..model.robot import Robot
from .chain import SerialChain, serial_chain
from .controller_section import controller_section
from .dh_from_axes import dh_from_axes
from .reader import read_urdf

#: Longest time to full speed ``import_urdf`` accepts [s]: an arm that needs longer is a mistake.
MAX_TIME_TO_FULL_SPEED_S = 10.0
#: ... and at the least [s]: no drive reaches full speed sooner.
MIN_TIME_TO_FULL_SPEED_S = 0.01
#: Configurations on which the imported FK is compared with the URDF chain's, and the seed.
CHECK_CONFIGURATIONS = 200
CHECK_SEED = 0
#: Largest FK difference (see UrdfImport) an import may have where no axes were snapped to parallel:
#: round-off is ~1e-15 m per metre of reach, so more is a wrong robot [m].
FK_TOLERANCE_M = 1e-6


@dataclass(frozen=True, eq=False)
class UrdfImport:
    """The imported ``robot``, its robot-file ``document`` (a mapping, mm and deg), the ``chain`` it
    came from, and ``max_fk_error_m``: the largest distance between the imported end frame and the
    URDF tip (position, plus 1 m x rotation angle) over CHECK_CONFIGURATIONS random configurations."""

    robot: Robot
    document: dict
    chain: SerialChain
    max_fk_error_m: float

    def write(self, path: str | Path, replace: bool = False) -> Path:
        """Write the robot file (atomically; a file the package did not write only with ``replace``)."""
        return write_robot_file(self.document, path, replace)


def _limits(joint, source: str) -> tuple[float, float, float]:
    """(q_min, q_max, qd_max) [rad or m] of a URDF joint (-inf, +inf for a continuous joint: a robot file's
    ``continuous: true``); UrdfChainError naming it when absent."""
    field = f"joint[{joint.name}].limit"
    if joint.kind == "continuous":
        lower, upper = -math.inf, math.inf
    else:
        lower, upper = joint.lower or 0.0, joint.upper or 0.0
        if not lower < upper:
            raise UrdfChainError(source, f"{field}.lower", f"must be below upper ({upper!r}): "
                                 "a robot file needs the joint's range", lower)
    if joint.velocity is None or not joint.velocity > 0.0:
        raise UrdfChainError(source, f"{field}.velocity", "must be > 0: a robot file needs the "
                             "joint's speed limit", joint.velocity)
    return lower, upper, joint.velocity


def _body_inertia(parts, X_BD: np.ndarray) -> LinkInertia | None:
    """The mass properties of welded links [(X_BL, UrdfInertial)] summed, in frame D (pose X_BD)."""
    parts = [(X_BL, inertial) for X_BL, inertial in parts if inertial.mass > 0.0]
    if not parts:
        return None
    X_DB = np.linalg.inv(X_BD)
    masses, coms, inertias = [], [], []
    for X_BL, inertial in parts:
        X_DI = X_DB @ X_BL @ inertial.X_LI
        R = X_DI[:3, :3]
        masses.append(inertial.mass)
        coms.append(X_DI[:3, 3])
        inertias.append(R @ inertial.I @ R.T)
    mass = float(sum(masses))
    com = sum(m * c for m, c in zip(masses, coms)) / mass
    I = sum(I_k + m * ((c - com) @ (c - com) * np.eye(3) - np.outer(c - com, c - com))
            for m, c, I_k in zip(masses, coms, inertias))
    return LinkInertia(mass=mass, p_LoLcm=com, I_Lcm=(I + I.T) / 2.0)


def _chain_fk(chain: SerialChain, q: np.ndarray) -> np.ndarray:
    """The URDF tip pose in the base link frame at q, straight from the chain's joint frames [m]."""
    X = np.eye(4)
    X_prev_J = np.eye(4)
    for joint, value in zip(chain.joints, q):
        X_J = joint.X_BJ
        X = X @ np.linalg.inv(X_prev_J) @ X_J
        if joint.joint.kind == "prismatic":
            motion = make_pose(np.eye(3), joint.joint.axis * value)
        else:
            motion = make_pose(Rotation.from_rotvec(joint.joint.axis * value).as_matrix(), np.zeros(3))
        X = X @ motion
        X_prev_J = X_J
    return X @ np.linalg.inv(X_prev_J) @ chain.X_BT


def _fk_error(robot: Robot, chain: SerialChain) -> float:
    """Largest pose difference between the imported robot and the URDF chain (see UrdfImport)."""
    Q = robot.random_configurations(np.random.default_rng(CHECK_SEED), CHECK_CONFIGURATIONS)
    worst = 0.0
    for q in Q:
        X_ours, X_urdf = robot.fk(q), _chain_fk(chain, q)
        error = np.linalg.norm(X_ours[:3, 3] - X_urdf[:3, 3]) + np.linalg.norm(
            rotation_log(X_ours[:3, :3].T @ X_urdf[:3, :3]))
        worst = max(worst, float(error))
    return worst


def import_urdf(path: str | Path, base: str | None = None, tip: str | None = None, convention: str = "standard",
                name: str | None = None, time_to_full_speed: float | None = None,
                controller: str | None = None) -> UrdfImport:
    """Import the serial chain from ``base`` to ``tip`` of a URDF file (see the module docstring).
    ``time_to_full_speed`` [s] (a URDF has no acceleration limits): each joint's ``qdd_max`` is
    ``qd_max / time_to_full_speed``, recorded in the file's provenance (None: no qdd_max). ``controller``: a
    maker (kuka, abb, fanuc, yaskawa, ur) whose controller section the file gets from the conventions of
    ROS-Industrial's descriptions (``pipeline.urdf.controller_section``; None: no section)."""
    if convention not in CONVENTIONS:
        raise ConfigurationError(f"convention must be one of {', '.join(CONVENTIONS)}, got {convention!r}")
    if time_to_full_speed is not None and not MIN_TIME_TO_FULL_SPEED_S <= time_to_full_speed <= \
            MAX_TIME_TO_FULL_SPEED_S:
        raise ConfigurationError(f"time_to_full_speed must be in [{MIN_TIME_TO_FULL_SPEED_S:g}, "
                                 f"{MAX_TIME_TO_FULL_SPEED_S:g}] s (is it in seconds?), got {time_to_full_speed!r}")
    model = read_urdf(path)
    chain = serial_chain(model, base, tip)
    assumptions: list[str] = []
    points = np.array([j.X_BJ[:3, 3] for j in chain.joints])
    axes = np.array([j.axis_B for j in chain.joints])
    geometry = dh_from_axes(points, axes, chain.X_BT)
    joints = []
    for chain_joint, row in zip(chain.joints, geometry.rows):
        joint = chain_joint.joint
        q_min, q_max, qd_max = _limits(joint, model.source)
        joints.append(DhJoint(name=joint.name, kind="prismatic" if joint.kind == "prismatic" else "revolute",
                              a=row.a, alpha=row.alpha, d=row.d, theta_offset=row.theta_offset, sign=1.0,
                              q_min=q_min, q_max=q_max, qd_max=qd_max, inertia=None, qddd_max=None,
                              qdd_max=None if time_to_full_speed is None else qd_max / time_to_full_speed))
    spec = RobotSpec(name=name or model.name, convention="standard", joints=tuple(joints), X_BaseD0=geometry.X_BD0,
                     X_DnE=geometry.X_DnT, source=str(path), length_unit="mm", angle_unit="deg",
                     provenance=_provenance(chain, convention, time_to_full_speed))
    if convention == "modified":
        spec = dataclasses.replace(standard_to_modified(spec), name=spec.name)
    spec = _with_mass_properties(spec, chain, assumptions)
    if controller is not None:
        spec = dataclasses.replace(spec, controller=controller_section(chain, controller))
        assumptions.append(f"controller: a {controller} controller, its section from the conventions of "
                           "ROS-Industrial's descriptions (pipeline.urdf.controller_section, models/SOURCES.md)")
    for i, angle in geometry.snapped:
        assumptions.append(f"the axes of joints {chain.joints[i].joint.name} and {chain.joints[i + 1].joint.name} "
                           f"are {math.degrees(angle):.3g} deg from parallel: treated as parallel")
    if chain.ignored:
        assumptions.append("moving joints off the chain are not part of this robot: " + ", ".join(chain.ignored))
    assumptions.append("a URDF has no acceleration or jerk limits: add qdd_max (and qddd_max) to time with them"
                       if time_to_full_speed is None else f"a URDF has no acceleration limits: qdd_max = qd_max / "
                       f"{time_to_full_speed:g} s, the time to full speed given to import-urdf; no jerk limits "
                       "(qddd_max) for ruckig and topp3")
    document = robot_document(spec, description=f"imported from the URDF {Path(path).name} (robot {model.name!r})",
                              assumptions=assumptions)
    robot = Robot(parse_robot_spec(document, source=str(path)))
    imported = UrdfImport(robot, document, chain, _fk_error(robot, chain))
    _check_fk(imported, fk_tolerance(robot, geometry.snapped))
    return imported


def fk_tolerance(robot: Robot, snapped) -> float:
    """The largest FK difference [m] an import may have: FK_TOLERANCE_M, plus per pair of axes treated
    as parallel (``snapped``: (index, angle [rad])) twice its angle times (the reach bound + 1 m)
    (what turning the later axes by that angle can move the end frame, position plus 1 m x angle)."""
    return FK_TOLERANCE_M + 2.0 * sum(angle for _, angle in snapped) * (robot.spec.reach_bound + 1.0)


def _check_fk(imported: UrdfImport, tolerance: float) -> None:
    """UrdfChainError when the imported robot's FK differs from the URDF chain's by more than ``tolerance``."""
    if not imported.max_fk_error_m <= tolerance:
        chain = imported.chain
        raise UrdfChainError(chain.model.source, f"link[{chain.tip}]", f"the imported DH robot's end frame differs "
                             f"from the URDF chain {chain.base} -> {chain.tip} by {imported.max_fk_error_m:.3g} m on "
                             f"random configurations (tolerance {tolerance:.3g} m): the chain cannot be imported "
                             "as DH; nothing written")


def _provenance(chain: SerialChain, convention: str, time_to_full_speed: float | None) -> dict:
    acceleration = {} if time_to_full_speed is None else {
        "qdd_max": f"qd_max / {time_to_full_speed:g} s (import-urdf --time-to-full-speed {time_to_full_speed:g}: "
                   "the time each joint takes to reach full speed, an assumption)"}
    return {
        "source": f"URDF {chain.model.source}, robot {chain.model.name!r}, chain {chain.base} -> {chain.tip}",
        "dh": f"{convention} DH extracted from the joint axes at q = 0 by python -m pipeline import-urdf "
              "(common normals; every sign +1, q is the URDF's joint vector)",
        "limits": "position and velocity limits copied from the URDF's <limit> elements",
        **acceleration,
    }


def _with_mass_properties(spec: RobotSpec, chain: SerialChain, assumptions: list[str]) -> RobotSpec:
    """The spec with each link's welded mass properties in its DH frame, and ``tau_max`` from the
    URDF's efforts when every joint has one and every link its inertia."""
    frames = DhKinematics(spec).fk_all(np.zeros(spec.dof))          # DH frames 0..n (+ end) at q = 0
    inertias = [_body_inertia(parts, frames[i + 1]) for i, parts in enumerate(chain.bodies)]
    efforts = [j.joint.effort for j in chain.joints]
    complete = all(inertia is not None for inertia in inertias)
    if complete and all(efforts):
        taus = efforts
    else:
        taus = [None] * spec.dof
        if any(efforts):
            missing = "the links' inertias" if not complete else "an effort for every joint"
            assumptions.append(f"effort limits of the URDF not copied as tau_max: they need {missing}")
    if any(inertia is None for inertia in inertias) and any(inertia is not None for inertia in inertias):
        assumptions.append("some links have no <inertial> in the URDF: the Drake model uses placeholders for them")
    joints = tuple(dataclasses.replace(joint, inertia=inertia, tau_max=tau)
                   for joint, inertia, tau in zip(spec.joints, inertias, taus))
    return dataclasses.replace(spec, joints=joints)


def robot_from_urdf(path: str | Path, base: str | None = None, tip: str | None = None,
                    convention: str = "standard", name: str | None = None) -> Robot:
    """The Robot of a URDF's serial chain (``import_urdf(...).robot``)."""
    return import_urdf(path, base, tip, convention, name).robot
