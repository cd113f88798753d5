"""A robot's controller as its robot file describes it (the ``controller`` section, models/README.md): the
maker, how the controller's axis angles follow from our joint values, where its base and flange frames sit
in ours, and a pose the maker calls elbow up.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...files.poses import rotation_to_rpy
from ...files.robot_spec import ControllerSection


@dataclass(frozen=True, eq=False)
class Controller:
    """The robot file's controller ``section`` (SI units: ``pipeline.files.robot_spec.ControllerSection``, the maker,
    the axis map, ``X_B_base`` the controller's base frame ($ROBROOT, the robot frame) in our base frame and
    ``X_E_flange`` its flange frame ($FLANGE, tool0) in our end frame) and ``source``, the file that says so; the
    axis map's ``offset`` and the ``elbow_up`` pose's axis angles in degrees, as controllers write them."""

    section: ControllerSection
    source: str

    maker = property(lambda self: self.section.maker)
    direction = property(lambda self: self.section.direction)
    coupling = property(lambda self: self.section.coupling)
    X_B_base = property(lambda self: self.section.X_B_base)
    X_E_flange = property(lambda self: self.section.X_E_flange)

    @property
    def offset(self) -> tuple[float, ...]:
        """Axis angle at q = 0 per joint [deg]."""
        return tuple(float(np.degrees(v)) for v in self.section.offset)

    @property
    def elbow_up(self) -> tuple[float, ...]:
        """The axis angles [deg] of a pose the maker calls elbow up."""
        return tuple(float(np.degrees(v)) for v in self.section.elbow_up)

    def describe(self) -> str:
        """One line: what the section says of the frames (for a program's header)."""
        def words(X, ours):
            if np.allclose(X, np.eye(4), atol=1e-12):
                return ours
            xyz = np.round(X[:3, 3] * 1e3, 3) + 0.0
            rpy = np.round(np.degrees(rotation_to_rpy(X[:3, :3])), 4) + 0.0
            return f"xyz {xyz.tolist()} mm, rpy {rpy.tolist()} deg in {ours}"
        return (f"{self.source}: {self.maker} base frame = {words(self.X_B_base, 'our base frame')}, flange = "
                f"{words(self.X_E_flange, 'our end frame')}")


def controller_of(robot) -> Controller | None:
    """The controller of ``robot`` (a Robot) from its robot file's ``controller`` section, None without one."""
    section = robot.spec.controller
    if section is None:
        return None
    return Controller(section, f"the controller section of {Path(robot.spec.source).name}")


def controller_for(robot, vendor: str) -> Controller | None:
    """The robot's controller when its maker is ``vendor``, else None."""
    controller = controller_of(robot)
    return controller if controller is not None and controller.maker == vendor else None


def controller_frames(robot, vendor: str) -> tuple[np.ndarray, np.ndarray]:
    """(X_B_base, X_E_flange) (4, 4) [m] of the robot's ``vendor`` controller section, identities without one."""
    controller = controller_for(robot, vendor)
    return (np.eye(4), np.eye(4)) if controller is None else (controller.X_B_base, controller.X_E_flange)


def tool_on_flange(robot, vendor: str, X_FT: np.ndarray) -> np.ndarray:
    """A tool X_FT (4, 4) [m] on our end frame -> on the ``vendor`` controller's flange frame (its tool data)."""
    return np.linalg.inv(controller_frames(robot, vendor)[1]) @ X_FT


def frames_words(robot, vendor: str, base: str, flange: str, fields: str) -> str:
    """One header line of a ``vendor`` program saying where its ``base`` and ``flange`` frames (their names in
    the vendor's language) and its configuration ``fields`` come from."""
    controller = controller_for(robot, vendor)
    if controller is None:
        return (f"no {vendor} controller section in the robot file: {fields} from the model's joint values as axis "
                f"angles, {base} = our base frame, {flange} = our end frame without the tool")
    return f"{base}, {flange}, {fields}: {controller.describe()}"
