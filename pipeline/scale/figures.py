"""A reachability map drawn: slices as a PNG (matplotlib, no pyplot) and a point cloud in a standalone
Meshcat HTML page (Drake), both in the robot's base frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .grid import POINTS

#: The Meshcat page shows at most this many voxels (a regular subsample beyond it: every k-th voxel
#: along each axis), so the page stays a few MB.
MAX_CLOUD_POINTS = 200_000


def slices_figure(reach_map):
    """The map through the base -> matplotlib Figure: the horizontal plane of centres z = 0 (or, when
    nothing is reached there, the one with the most voxels reached) and the vertical one nearest y = 0
    (half a voxel beside the base), the fraction of orientations reached and the best manipulability,
    each with its colour bar and units (white: not reached)."""
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    x, y, z = reach_map.grid.axes
    k0, j0 = int(np.argmin(np.abs(z))), int(np.argmin(np.abs(y)))
    if not np.any(reach_map.fraction[:, :, k0] > 0):       # a robot on a floor reaches nothing at z = 0
        k0 = int(np.argmax(np.count_nonzero(reach_map.fraction > 0, axis=(0, 1))))
    figure = Figure(figsize=(11.0, 9.0), layout="constrained")
    axes = figure.subplots(2, 2)
    cmap = colormaps["viridis"].with_extremes(under="white")
    quantities = (("fraction", "reachable fraction of orientations [1]", 1.0),
                  ("manipulability", f"best manipulability [{reach_map.manipulability_unit}]",
                   max(float(reach_map.manipulability.max()), 1e-12)))
    for row, (name, label, top) in enumerate(quantities):
        values = getattr(reach_map, name)
        for column, (plane, extent, xlabel, ylabel, where) in enumerate((
                (values[:, :, k0].T, (x[0], x[-1], y[0], y[-1]), "x [m]", "y [m]", f"horizontal, z = {z[k0]:.3f} m"),
                (values[:, j0, :].T, (x[0], x[-1], z[0], z[-1]), "x [m]", "z [m]", f"vertical, y = {y[j0]:.3f} m"))):
            ax = axes[row, column]
            half = reach_map.step / 2.0
            image = ax.imshow(plane, origin="lower", cmap=cmap, vmin=1e-12, vmax=top, interpolation="nearest",
                              extent=(extent[0] - half, extent[1] + half, extent[2] - half, extent[3] + half))
            ax.plot(0.0, 0.0, "r+", markersize=10)
            _crop(ax, reach_map.fraction[:, :, k0] if column == 0 else reach_map.fraction[:, j0, :],
                  x, y if column == 0 else z, reach_map.step)
            ax.set_xlabel(xlabel)
            ax.set_ylabel(ylabel)
            ax.set_aspect("equal")
            ax.set_title(f"{name}, {where} (base frame)", fontsize=9)
            figure.colorbar(image, ax=ax, label=label, shrink=0.85)
    where = "" if reach_map.cell is None else f" in {reach_map.cell.name}"
    figure.suptitle(f"{reach_map.robot.name}{where}: reachability of its {POINTS[reach_map.point]}, "
                    f"{reach_map.asked}, {reach_map.step * 1e3:g} mm voxels; "
                    f"reach {reach_map.reach_m:.3f} m (+ marks the base)", fontsize=10)
    return figure


def _crop(ax, fraction: np.ndarray, first: np.ndarray, second: np.ndarray, step: float) -> None:
    """Limit the axes to the voxels reached in a plane (``fraction`` (len(first), len(second))) and two
    voxels around them, and the base."""
    i, j = np.nonzero(fraction > 0)
    if len(i):
        ax.set_xlim(min(first[i].min(), 0.0) - 2 * step, max(first[i].max(), 0.0) + 2 * step)
        ax.set_ylim(min(second[j].min(), 0.0) - 2 * step, max(second[j].max(), 0.0) + 2 * step)


def plot_slices(path: str | Path, reach_map) -> None:
    """Write ``slices_figure(reach_map)`` as a PNG at ``path``."""
    slices_figure(reach_map).savefig(path, dpi=100, format="png")


def cloud_points(reach_map) -> tuple[np.ndarray, np.ndarray]:
    """The reachable voxel centres (k, 3) [m] shown (MAX_CLOUD_POINTS at most) and their fractions (k,)."""
    stride = 1
    while np.count_nonzero(reach_map.fraction[::stride, ::stride, ::stride] > 0) > MAX_CLOUD_POINTS:
        stride += 1
    fraction = np.zeros_like(reach_map.fraction)
    fraction[::stride, ::stride, ::stride] = reach_map.fraction[::stride, ::stride, ::stride]
    flat = np.flatnonzero(fraction > 0)
    return reach_map.grid.centres(flat), fraction.ravel()[flat]


def map_html(reach_map) -> str:
    """A standalone HTML page (no server, no network) of the robot at q = 0 (with the cell's obstacles)
    and the reachable voxel centres as a point cloud, points half a voxel wide (so the arm shows through),
    coloured by fraction (viridis: dark few, yellow all). A Meshcat server runs on an ephemeral localhost
    port only while the page is built."""
    from matplotlib import colormaps
    from pydrake.perception import BaseField, Fields, PointCloud

    from ..model.chain.drake_model import build_visual_diagram
    from ..outputs.views import static_meshcat_html

    points, fraction = cloud_points(reach_map)

    def draw(meshcat) -> None:
        model = build_visual_diagram(reach_map.robot.spec, meshcat, None, reach_map.cell)
        model.diagram.ForcedPublish(model.diagram.CreateDefaultContext())
        cloud = PointCloud(len(points), Fields(BaseField.kXYZs | BaseField.kRGBs))
        cloud.mutable_xyzs()[:] = points.T
        cloud.mutable_rgbs()[:] = np.round(255 * colormaps["viridis"](fraction)[:, :3]).astype(np.uint8).T
        meshcat.SetObject("/reachability", cloud, point_size=reach_map.step / 2.0)

    return static_meshcat_html(draw)
