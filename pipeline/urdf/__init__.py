"""URDF in and out: ``write_urdf(robot, path)`` (a DH robot as a URDF for ROS, MoveIt, Drake) and
``robot_from_urdf(path)`` / ``import_urdf(path)`` (a URDF serial chain as a DH robot file)."""

from .importer import UrdfImport, import_urdf, robot_from_urdf
from .writer import urdf_text, write_urdf

__all__ = ["UrdfImport", "import_urdf", "robot_from_urdf", "urdf_text", "write_urdf"]
