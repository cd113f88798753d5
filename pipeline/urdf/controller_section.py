"""The controller section of a robot imported from a URDF (``import-urdf --controller MAKER``), from the
conventions of the ROS-Industrial descriptions of that maker's arms (models/SOURCES.md, "Controller sections
of imported robots"):

* axis angles: the URDF's joint angles are the controller's (identity map), except a FANUC pendant's J3 = q3 - q2
  (ROS-Industrial's FANUC descriptions carry the serial J3);
* base: the URDF's ``base`` link (REP 199: the controller's base frame, KUKA's $ROBROOT) where the file has it,
  else our base frame;
* flange: KUKA's $FLANGE (x out of the flange) is kuka_experimental's ``flange`` link, and where a file has none,
  ``tool0`` turned -90 deg about its y axis (kuka_experimental's tool0 = flange turned +90 deg about y); the
  other makers' flange is ``tool0`` (REP 199: the controller's all-zero tool frame, z out of the flange);
* elbow up: KUKA's mastering pose A2 = -90, A3 = +90 deg (upper arm vertical, forearm forward); the other
  makers' zero pose.
"""

from __future__ import annotations

import numpy as np

from ..files.poses import make_pose
from ..files.robot_spec import CONTROLLER_MAKERS, ControllerSection
from ..errors import ConfigurationError
from .chain import SerialChain, link_pose

#: Link names of the ROS-Industrial descriptions (REP 199): the controller's base frame, KUKA's flange, tool0.
BASE_LINK, FLANGE_LINK, TOOL0_LINK = "base", "flange", "tool0"
#: KUKA's mastering pose, elbow up [deg]: A2 = -90, A3 = +90.
KUKA_ELBOW_UP_DEG = (0.0, -90.0, 90.0, 0.0, 0.0, 0.0)


def _ry(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return make_pose(np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]), np.zeros(3))


def controller_section(chain: SerialChain, maker: str) -> ControllerSection:
    """The controller section (SI) of the robot imported from ``chain`` for a ``maker`` controller (module
    docstring); ConfigurationError for an unknown maker."""
    if maker not in CONTROLLER_MAKERS:
        raise ConfigurationError(f"--controller must be one of {', '.join(CONTROLLER_MAKERS)}, got {maker!r}")
    dof = len(chain.joints)
    model, X_BE = chain.model, chain.X_BT
    X_B_base = link_pose(model, chain.base, BASE_LINK)
    X_B_flange = link_pose(model, chain.base, FLANGE_LINK if maker == "kuka" else TOOL0_LINK)
    if X_B_flange is None and maker == "kuka":
        tool0 = link_pose(model, chain.base, TOOL0_LINK)
        X_B_flange = None if tool0 is None else tool0 @ _ry(-np.pi / 2.0)
    X_E_flange = np.eye(4) if X_B_flange is None else np.linalg.inv(X_BE) @ X_B_flange
    elbow_up = np.radians(KUKA_ELBOW_UP_DEG) if maker == "kuka" and dof == 6 else np.zeros(dof)
    return ControllerSection(maker, (1,) * dof, (0.0,) * dof, "fanuc_j2_j3" if maker == "fanuc" else None,
                             np.eye(4) if X_B_base is None else X_B_base, X_E_flange, tuple(elbow_up.tolist()))
