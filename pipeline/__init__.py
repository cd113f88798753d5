"""From a Denavit-Hartenberg table to an exact NumPy model, a Drake plant, checked Jacobians and
certified, collision-free, time-optimal joint profiles.

    >>> from pipeline import load_robot
    >>> robot = load_robot("gp7")
    >>> robot.fk([0, 0, 0, 0, 0, 0])[:3, 3]      # flange position [m]
    array([0.56 , 0.   , 0.815])

This module is the public front door: the robot, its files and errors are imported at once; the rest
(timing, jobs, cells, collision, planning, views, Dask) on first use, so ``import pipeline`` stays light.
"""

import importlib

from . import progress  # noqa: F401  (first: it says so while Numba compiles the kernels on first use)
from .errors import (
    CellFileError,
    CollisionError,
    ConfigurationError,
    InvalidValueError,
    JobFileError,
    MissingFieldError,
    PipelineError,
    PlanningError,
    RobotFileError,
    RobotNotFoundError,
    TimingError,
    UnknownFieldError,
)
from .files.poses import pose_to_quaternion_position, quaternion_position_to_pose, rpy_position_to_pose
from .files.robot_spec import RobotSpec, load_robot_spec, parse_robot_spec, preset_names
from .model.chain.singularity import compute_singularity
from .model.robot import Robot, load_robot, robot_with_tool

#: Public names loaded on first use: name -> the module (in this package) that defines it.
_LAZY = {
    "retime": "timing",
    "Profile": "timing.profile", "certify": "timing.profile", "jerk_reversal_rate": "timing.profile",
    "Job": "program.job", "load_job": "program.job", "parse_job": "program.job",
    "run_job": "runner", "run_job_file": "runner",
    "Program": "program.model", "compile_job": "program.compile", "time_program": "program.timing",
    "lower_bound": "program.bound",
    "cycle_report": "program.report", "cycle_lines": "program.report",
    "Tool": "cell.tool",
    "Cell": "cell.cell_file", "cell_names": "cell.cell_file", "load_cell": "cell.cell_file",
    "parse_cell": "cell.cell_file",
    "CollisionModel": "cell.collision",
    "plan_joint_path": "cell.planning",
    "check_robot": "model.jacobian_check",
    "build_drake_robot": "model.chain.drake_model",
    "standard_to_modified": "model.chain.dh_convert",
    "finite_difference_jacobian": "model.chain.kinematics",
    "arm_figure": "outputs.views", "motion_figure": "outputs.views", "profile_html": "outputs.views",
    "show_profile": "outputs.views",
    "profile_figure": "outputs.plots", "tcp_figure": "outputs.plots",
    "dask_client": "scale", "reachability_map": "scale", "run_batch": "scale",
    "slices_figure": "scale.figures",
}


def __getattr__(name: str):
    """A public name of ``_LAZY``, imported from its module the first time it is asked for."""
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__all__ = sorted([
    "CellFileError",
    "CollisionError",
    "ConfigurationError",
    "InvalidValueError",
    "JobFileError",
    "MissingFieldError",
    "PipelineError",
    "PlanningError",
    "Robot",
    "RobotFileError",
    "RobotNotFoundError",
    "RobotSpec",
    "TimingError",
    "UnknownFieldError",
    "compute_singularity",
    "load_robot",
    "load_robot_spec",
    "parse_robot_spec",
    "pose_to_quaternion_position",
    "preset_names",
    "quaternion_position_to_pose",
    "robot_with_tool",
    "rpy_position_to_pose",
    *_LAZY,
])
