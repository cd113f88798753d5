"""``ReachabilityMap``: a reachability map's arrays, its figures of merit, and its files.

Reach is measured on the voxel centres that count as reachable (fraction > 0): ``reach_m`` is the
largest distance of one from the axis of joint 1 (the vertical through the base for a floor-standing
arm: the radius datasheets give), ``reach_from_base_origin_m`` the largest from the base origin. A
voxel centre is an exact IK answer, so the true reach lies at or beyond ``reach_m``, by less than the
voxel's diagonal (``step * sqrt(3)``). Datasheets give the reach of the wrist centre (ABB: axis 5,
FANUC: the J5 axis, Yaskawa: the P-point): map it with ``point="wrist"``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..files.atomic import staged_output
from ..outputs.formats import write_json
from .grid import POINTS

#: The files ``write_into`` makes.
FILES = {"npz": "map.npz", "png": "slices.png", "html": "map.html", "json": "summary.json"}
#: Fractions of the orientations at which the reachable volume is reported [1].
THRESHOLDS = (0.25, 0.5, 0.75, 1.0)


@dataclass(frozen=True, eq=False)
class ReachabilityMap:
    """A map over ``grid`` (``pipeline.scale.grid.VoxelGrid``, base frame): per voxel ``fraction`` of the
    orientations reached [1], best ``manipulability`` (0 where none is reached) and most IK ``branches``
    of one orientation, each of ``grid.shape``. What was asked: ``robot`` (a Robot), ``cell`` (or None),
    ``point`` (``end`` | ``wrist``), ``rotations`` (count, 3, 3) (the tool orientations, or with
    ``tool_axis_cone`` [deg] the first roll of each tool axis), ``rolls`` per axis, the IK ``method`` and
    target ``kind``, ``seed``. How it ran: ``poses`` (IK targets), ``chunks``, ``elapsed_s`` [s],
    ``workers``."""

    robot: object
    cell: object
    point: str
    grid: object
    rotations: np.ndarray
    tool_axis_cone: float | None
    rolls: int
    method: str
    kind: str
    seed: int
    poses: int
    chunks: int
    elapsed_s: float
    workers: int
    fraction: np.ndarray
    manipulability: np.ndarray
    branches: np.ndarray

    @property
    def step(self) -> float:
        """Voxel size [m]."""
        return self.grid.step

    @property
    def manipulability_unit(self) -> str:
        return "m^3" if self.robot.dof >= 6 else "1 (mixed: J rows in m/rad and rad/rad)"

    @property
    def asked(self) -> str:
        """The orientations asked for, in words."""
        if self.tool_axis_cone is None:
            return f"{len(self.rotations)} orientations"
        return f"{len(self.rotations)} tool axes within {self.tool_axis_cone:g} deg of down, {self.rolls} roll(s) each"

    def reachable_centres(self, threshold: float = 0.0) -> np.ndarray:
        """Centres (k, 3) [m] of the voxels whose fraction is above 0 (``threshold`` 0) or at least ``threshold``."""
        mask = self.fraction > 0.0 if threshold <= 0.0 else self.fraction >= threshold
        return self.grid.centres(np.flatnonzero(mask))

    @property
    def reach_m(self) -> float:
        """The largest distance of a reachable voxel centre from joint 1's axis [m] (0 when none is)."""
        frame = self.robot.joint_frames(np.zeros(self.robot.dof))[0][0]
        offsets = self.reachable_centres() - frame[:3, 3]
        radial = offsets - np.outer(offsets @ frame[:3, 2], frame[:3, 2])
        return float(np.linalg.norm(radial, axis=1).max(initial=0.0))

    @property
    def reach_from_base_origin_m(self) -> float:
        """The largest distance of a reachable voxel centre from the base origin [m]."""
        return float(np.linalg.norm(self.reachable_centres(), axis=1).max(initial=0.0))

    def volume_m3(self, threshold: float = 0.0) -> float:
        """Volume of the voxels reached (fraction > 0 for ``threshold`` 0, else >= ``threshold``) [m^3]."""
        mask = self.fraction > 0.0 if threshold <= 0.0 else self.fraction >= threshold
        return float(np.count_nonzero(mask)) * self.step ** 3

    def summary(self) -> dict:
        """The JSON summary: what was asked, the reach, the volume by fraction, the run."""
        best = int(np.argmax(self.manipulability))
        return {
            "robot": self.robot.name, "cell": None if self.cell is None else self.cell.name, "point": self.point,
            "frame": "robot base", "step_m": self.step, "grid_shape": list(self.grid.shape),
            "orientations": len(self.rotations), "tool_axis_cone_deg": self.tool_axis_cone, "rolls": self.rolls,
            "ik_method": self.method, "target_kind": self.kind, "seed": self.seed, "poses": self.poses,
            "reach_m": self.reach_m, "reach_from_base_origin_m": self.reach_from_base_origin_m,
            "reach_measured": "largest distance of a reachable voxel centre (fraction > 0) from joint 1's axis; the "
                              "true reach is at most a voxel diagonal beyond it",
            "volume_m3": {"fraction > 0": self.volume_m3(), **{f"fraction >= {t:g}": self.volume_m3(t)
                                                               for t in THRESHOLDS}},
            "manipulability_max": float(self.manipulability.flat[best]),
            "manipulability_max_at_m": (self.grid.centres(np.array([best]))[0].tolist()
                                        if self.manipulability.flat[best] > 0 else None),
            "manipulability_unit": self.manipulability_unit, "branches_max": int(self.branches.max(initial=0)),
            "run": {"elapsed_s": self.elapsed_s, "workers": self.workers, "chunks": self.chunks,
                    "poses_per_s": self.poses / self.elapsed_s if self.elapsed_s > 0 else None},
        }

    def describe(self) -> str:
        """A few lines: what was mapped, how fast, the reach and the volumes."""
        where = "" if self.cell is None else f" in {self.cell.name}"
        volumes = ", ".join(f"{label} {value:.3f}" for label, value in self.summary()["volume_m3"].items())
        return "\n".join([
            f"reachability of {self.robot.name}{where}, its {POINTS[self.point]}: {self.grid.shape} voxels of "
            f"{self.step * 1e3:g} mm, {self.asked}, IK {self.method} ({self.kind})",
            f"{self.poses:,} poses in {self.chunks} chunks on {self.workers} worker(s): {self.elapsed_s:.1f} s "
            f"({self.poses / max(self.elapsed_s, 1e-9):,.0f} poses/s)",
            f"reach {self.reach_m:.4f} m from joint 1's axis ({self.reach_from_base_origin_m:.4f} m from the base "
            f"origin), reachable volume [m^3]: {volumes}",
            *([] if self.volume_m3() > 0 or self.robot.dof >= 6 else [
                f"no voxel reached: {self.robot.name} has {self.robot.dof} joints and turns its tool axis only within "
                "a plane or cone of its own, which random axes miss; a tool-axis cone starts with its own axis "
                "(straight down)"])])

    def write_into(self, folder: str | Path) -> tuple[Path, ...]:
        """Write the map's files (FILES) into an existing folder; returns their paths."""
        from .figures import map_html, plot_slices

        folder = Path(folder)
        units = {"x": "m", "y": "m", "z": "m", "step": "m", "fraction": "1", "branches": "1",
                 "manipulability": self.manipulability_unit, "rotations": "1 (tool orientations, base frame)",
                 "X_WB": "m (the robot base in the cell frame)"}
        X_WB = np.eye(4) if self.cell is None else self.cell.X_WB
        with open(folder / FILES["npz"], "wb") as handle:
            np.savez(handle, fraction=self.fraction, manipulability=self.manipulability, branches=self.branches,
                     x=self.grid.axes[0], y=self.grid.axes[1], z=self.grid.axes[2], step=self.step,
                     rotations=self.rotations, X_WB=X_WB, units=json.dumps(units),
                     summary=json.dumps({k: v for k, v in self.summary().items() if k != "run"}))
        plot_slices(folder / FILES["png"], self)
        (folder / FILES["html"]).write_text(map_html(self), encoding="utf-8")
        write_json(folder / FILES["json"], self.summary())
        return tuple(folder / name for name in FILES.values())

    def save(self, out_dir: str | Path) -> tuple[Path, ...]:
        """Write the files into ``out_dir``, replaced whole (``pipeline.files.atomic.staged_output``); returns their paths."""
        with staged_output(out_dir) as staging:
            self.write_into(staging)
        return tuple(Path(out_dir) / name for name in FILES.values())
