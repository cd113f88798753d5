"""From a Denavit-Hartenberg table to an exact NumPy model, a Drake plant and checked Jacobians.

    >>> from pipeline import load_robot
    >>> robot = load_robot("gp7")
    >>> robot.fk([0, 0, 0, 0, 0, 0])[:3, 3]      # flange position [m]
    array([0.56 , 0.   , 0.815])
"""

from .errors import (
    ConfigurationError,
    InvalidValueError,
    MissingFieldError,
    PipelineError,
    RobotFileError,
    RobotNotFoundError,
    UnknownFieldError,
)
from .poses import pose_to_quaternion_position, quaternion_position_to_pose
from .robot import Robot, load_robot
from .robot_spec import RobotSpec, load_robot_spec, parse_robot_spec, preset_names
from .singularity import compute_singularity

__all__ = [
    "ConfigurationError",
    "InvalidValueError",
    "MissingFieldError",
    "PipelineError",
    "Robot",
    "RobotFileError",
    "RobotNotFoundError",
    "RobotSpec",
    "UnknownFieldError",
    "compute_singularity",
    "load_robot",
    "load_robot_spec",
    "parse_robot_spec",
    "pose_to_quaternion_position",
    "preset_names",
    "quaternion_position_to_pose",
]
