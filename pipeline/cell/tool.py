"""The tool: where its centre point sits on the flange and the shapes the flange carries, one value that
IK, collision and every view read.

Frames (DESIGN.md, "Frames, one meaning per letter"): ``B`` the robot's base, ``F`` the flange (the end frame
the robot file gives, its own tool included), ``T`` the tool centre point: ``X_BF @ X_FT = X_BT``. A job's
``tool:`` is ``X_FT``; a cell's ``tool_shapes:`` are posed in F. A job's robot (``robot_with_tool``) has T as
its end frame, the cell's robot (``Cell.load_robot``) F.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..files.poses import check_pose, make_pose
from ..model.robot import Robot, robot_with_tool

if TYPE_CHECKING:
    from .cell_file import Cell, Shape


def rigid_inverse(X: np.ndarray) -> np.ndarray:
    """The inverse of a rigid pose (4, 4) [m], exact in its last row: [R^T, -R^T p; 0 1]."""
    R = X[:3, :3]
    return make_pose(R.T, -R.T @ X[:3, 3])


@dataclass(frozen=True, eq=False)
class Tool:
    """``X_FT`` (4, 4) [m]: the TCP in the flange frame (identity: no job tool); ``shapes``: the cell's tool
    shapes (``pipeline.cell.cell_file.Shape``, poses in F [m]); ``name``: where it comes from, for messages."""

    X_FT: np.ndarray = field(default_factory=lambda: np.eye(4))
    shapes: tuple[Shape, ...] = ()
    name: str = ""

    def __post_init__(self):
        X_FT = check_pose(self.X_FT, "tool X_FT").copy()
        X_FT.flags.writeable = False
        object.__setattr__(self, "X_FT", X_FT)
        object.__setattr__(self, "shapes", tuple(self.shapes))

    @classmethod
    def from_job_and_cell(cls, X_FT: np.ndarray | None, cell: Cell | None = None, name: str = "") -> Tool:
        """The tool of a job: its ``tool`` X_FT (4, 4) [m] (None: the identity) and the tool shapes of its
        ``cell`` (a ``pipeline.cell.cell_file.Cell``; None: no shapes)."""
        return cls(np.eye(4) if X_FT is None else X_FT, () if cell is None else cell.tool_shapes, name)

    @classmethod
    def coerce(cls, tool: Tool | np.ndarray | None, cell: Cell | None = None) -> Tool:
        """``tool`` itself if it is a Tool; else ``from_job_and_cell(tool, cell)``: a job's ``tool`` X_FT
        (4, 4) [m] or None, as the views took it before the Tool (the shapes then from ``cell``)."""
        return tool if isinstance(tool, cls) else cls.from_job_and_cell(tool, cell)

    @classmethod
    def of_job(cls, job) -> Tool:
        """The tool of a ``pipeline.program.job.Job`` (its ``tool`` and its cell's tool shapes)."""
        return cls.from_job_and_cell(job.tool, job.cell, job.name)

    @classmethod
    def of_robot_in_cell(cls, robot: Robot, cell: Cell, name: str = "") -> Tool:
        """The tool that ``robot`` (end frame T: a job's robot) carries in ``cell``: F is the end frame of the
        cell's robot file, so X_FT = inv(X_DnF) @ X_DnT (Dn: the last link's frame), and the cell's shapes."""
        X_DnF = cell.load_robot().spec.X_DnE
        return cls(rigid_inverse(X_DnF) @ robot.spec.X_DnE, cell.tool_shapes, name)

    @property
    def at_flange(self) -> bool:
        """True when the TCP is the flange (X_FT the identity: a job without ``tool``)."""
        return bool(np.array_equal(self.X_FT, np.eye(4)))

    @property
    def X_TF(self) -> np.ndarray:
        """The flange in the TCP frame (4, 4) [m]: inv(X_FT)."""
        return rigid_inverse(self.X_FT)

    def X_BF(self, X_BT: np.ndarray) -> np.ndarray:
        """Flange poses from TCP poses (..., 4, 4) [m]: X_BT @ inv(X_FT)."""
        return np.asarray(X_BT, dtype=float) @ self.X_TF

    def X_BT(self, X_BF: np.ndarray) -> np.ndarray:
        """TCP poses from flange poses (..., 4, 4) [m]: X_BF @ X_FT."""
        return np.asarray(X_BF, dtype=float) @ self.X_FT

    def shape_poses(self, X_BF: np.ndarray) -> np.ndarray:
        """Each shape's pose in B (..., k, 4, 4) [m] for flange poses X_BF (..., 4, 4) [m]."""
        X_BF = np.asarray(X_BF, dtype=float)
        return np.stack([X_BF @ shape.X for shape in self.shapes], axis=-3) if self.shapes else \
            np.zeros((*X_BF.shape[:-2], 0, 4, 4))

    def tcp_robot(self, robot: Robot) -> Robot:
        """The robot whose end frame is T (IK's), from ``robot`` whose end frame is F (the cell's robot)."""
        return robot_with_tool(robot, self.X_FT)

    def flange_robot(self, robot: Robot) -> Robot:
        """The robot whose end frame is F (where the shapes sit), from ``robot`` whose end frame is T (a
        job's robot); ``robot`` itself when the TCP is the flange."""
        return robot if self.at_flange else robot_with_tool(robot, self.X_TF)
