"""3-D views of the arm: static matplotlib drawings (no Drake, no browser) and Meshcat playback of a
profile, live in a notebook or saved as one standalone HTML file.

The drawings and the visual geometry of the Drake model share one stick figure,
``pipeline.model.chain.geometry.compute_link_polylines``. Matplotlib is imported only when a
figure is drawn, and it is used through ``matplotlib.figure.Figure`` (no pyplot, no global backend,
so a notebook's inline backend is untouched); Drake only when Meshcat is used.
"""

from __future__ import annotations

import dataclasses
import gc
import logging
from pathlib import Path

import numpy as np

from ..cell.tool import Tool
from ..errors import ConfigurationError
from ..model.chain.geometry import compute_arm_path, robot_size, shape_outline, visual_radius
from ..timing.profile import Profile

log = logging.getLogger(__name__)

#: Frames per second of the Meshcat animation [1/s].
DEFAULT_FPS = 30.0
#: Arm poses drawn along a profile by ``motion_figure``.
DEFAULT_POSES = 6
#: Joint-axis arrows and frame triads, as fractions of the robot's size at q = 0.
AXIS_ARROW_FRACTION = 0.12
TRIAD_FRACTION = 0.15
TRIAD_COLOURS = ("tab:red", "tab:green", "tab:blue")
#: Obstacles are drawn within this fraction of the robot's size around the drawn arm.
CELL_MARGIN_FRACTION = 0.25
#: Meshcat's default camera: three.js ``PerspectiveCamera(75, aspect, ...)``, 75 deg vertically [deg],
#: across as much wider as the window is (width / height; framed for a window at least 4:3).
CAMERA_FOV_DEG = 75.0
CAMERA_ASPECT = 4.0 / 3.0
#: What a view shows reaches this fraction of the way from the view's centre to its edge.
CAMERA_FILL = 0.85
#: The camera looks at the scene from this direction: a 3/4 view from the front (+x), right (-y), above.
CAMERA_AZIMUTH_DEG = -40.0
CAMERA_ELEVATION_DEG = 30.0
#: The visual geometry reaches this many link radii (``visual_radius``) beyond the stick figure (the
#: base disc's radius).
VISUAL_REACH_RADII = 3.0
#: The TCP's trace in Meshcat: path, colour (magenta), width [px], most points drawn.
TRACE_PATH = "/tcp_trace"
TRACE_RGBA = (0.90, 0.10, 0.70, 1.0)
TRACE_WIDTH_PX = 3.0
TRACE_MAX_POINTS = 2000
#: A tool handed to a view with a cell must agree with the TCP the robot's end frame implies (``view_tool``)
#: within this, in each entry of X_FT [m, or a rotation entry].
TOOL_AGREEMENT = 1e-9


def view_tool(robot, cell=None, tool: Tool | np.ndarray | None = None) -> Tool:
    """The tool a view draws on ``robot`` (its end frame the TCP: a job's robot). ``tool``: a Tool, or as
    before a job's X_FT (4, 4) [m] or None (``Tool.coerce``). With a ``cell`` the flange is its robot file's
    end frame, so the robot's end frame fixes X_FT (``Tool.of_robot_in_cell``): a missing tool is that one,
    and a tool that disagrees with it (by more than TOOL_AGREEMENT) is refused (ConfigurationError)."""
    if cell is None:
        return Tool.coerce(tool)
    implied = Tool.of_robot_in_cell(robot, cell)
    if tool is None:
        return implied
    tool = Tool.coerce(tool, cell)
    if np.abs(tool.X_FT - implied.X_FT).max() > TOOL_AGREEMENT:
        gap_mm = 1e3 * np.linalg.norm(tool.X_FT[:3, 3] - implied.X_FT[:3, 3])
        raise ConfigurationError(
            f"tool: its X_FT puts the TCP {gap_mm:.6g} mm from the end frame of robot {robot.spec.name!r} (position "
            f"{np.round(implied.X_FT[:3, 3] * 1e3, 3).tolist()} mm from the flange of cell {cell.name!r}'s robot, "
            f"the tool's {np.round(tool.X_FT[:3, 3] * 1e3, 3).tolist()} mm): pass the job's robot (its end frame the "
            "TCP) with its own tool, e.g. Tool.of_job(job)")
    return tool


# -- matplotlib -------------------------------------------------------------------------------------
def _new_axes(ax, figsize=(7.0, 6.0)):
    """(figure, 3-D axes): the given axes and its figure, or a new Figure (not pyplot) with one."""
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure
    import mpl_toolkits.mplot3d  # noqa: F401  (registers the 3-D projection)

    figure = Figure(figsize=figsize)
    return figure, figure.add_subplot(projection="3d")


def _triad(ax, X: np.ndarray, length: float, label: str | None = None) -> np.ndarray:
    """Draw the x, y, z axes of pose X (4, 4) in red, green, blue; returns their tips (3, 3)."""
    origin = X[:3, 3]
    tips = origin + length * X[:3, :3].T
    for tip, colour in zip(tips, TRIAD_COLOURS):
        ax.plot(*np.column_stack([origin, tip]), color=colour, linewidth=1.5)
    if label:
        ax.text(*origin, f" {label}", fontsize=8)
    return tips


def _draw_arm(ax, robot, q, colour="tab:orange", linewidth=4.0, alpha=1.0, details=True,
              label: str | None = "links") -> np.ndarray:
    """Draw the arm at q: the stick figure (one line, labelled ``label``), and with ``details`` the joint
    axes as arrows and the base and end frames as triads. Returns every drawn point (k, 3) [m]."""
    path = compute_arm_path(robot, q)
    ax.plot(path[:, 0], path[:, 1], path[:, 2], color=colour, linewidth=linewidth, alpha=alpha,
            marker="o", markersize=linewidth, solid_capstyle="round", label=label)
    drawn = [path]
    if details:
        size = robot_size(robot)
        J, X_BE = robot.joint_frames(robot.as_configuration(q))
        axes = J[:, :3, 2] * np.array([j.sign for j in robot.spec.joints])[:, None]
        length = AXIS_ARROW_FRACTION * size
        origins = J[:, :3, 3]
        ax.quiver(origins[:, 0], origins[:, 1], origins[:, 2], axes[:, 0], axes[:, 1], axes[:, 2],
                  length=length, normalize=True, color="0.2", linewidth=1.2, arrow_length_ratio=0.25)
        for k, p in enumerate(origins, start=1):
            ax.text(*p, f" {k}", fontsize=8, color="0.2")
        drawn += [origins + length * axes / np.linalg.norm(axes, axis=1)[:, None]]
        drawn += [_triad(ax, np.eye(4), TRIAD_FRACTION * size, "base"),
                  _triad(ax, X_BE, TRIAD_FRACTION * size, "end")]
    return np.vstack(drawn)


def _finish_axes(ax, points: np.ndarray, title: str) -> None:
    """Equal aspect (a cube around ``points`` and the base origin), axis labels in m, the title."""
    points = np.vstack([points, np.zeros(3)])
    low, high = points.min(axis=0), points.max(axis=0)
    centre, half = (low + high) / 2.0, 0.55 * float((high - low).max())
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(title, fontsize=10)


def _format_q(robot, q) -> str:
    revolute = np.array([j.is_revolute for j in robot.spec.joints])
    if revolute.all():
        return "q = (" + ", ".join(f"{v:.1f}" for v in np.degrees(q)) + ") deg"
    return "q = (" + ", ".join(f"{v:.3f}" for v in q) + ") rad or m"


def arm_figure(robot, q, ax=None, title: str | None = None):
    """A static 3-D line drawing of the arm at q [rad or m] -> matplotlib Figure.

    Links between successive frame origins (the line labelled ``links`` ends at ``fk(q)``'s
    position), joint axes as short arrows (numbered), base and end frames as red/green/blue triads,
    equal aspect, axes in m. Draws into ``ax`` (a 3-D axes) when given, else into a new Figure.
    """
    q = robot.as_configuration(q)
    figure, ax = _new_axes(ax)
    points = _draw_arm(ax, robot, q)
    _finish_axes(ax, points, title if title is not None else f"{robot.spec.name}: {_format_q(robot, q)}")
    return figure


def cell_outlines(cell, low: np.ndarray, high: np.ndarray) -> list[np.ndarray]:
    """The cell's obstacles as line drawings in the robot's base frame [m], clipped to the box
    ``low``..``high`` (3,) [m] (a floor would dwarf the arm)."""
    X_BW = np.linalg.inv(cell.X_WB)
    return [np.clip(points, low, high) for shape in cell.objects
            for points in shape_outline(shape.kind, shape.size, X_BW @ shape.X)]


def _draw_cell(ax, robot, cell, drawn: np.ndarray) -> np.ndarray:
    """Draw the cell's obstacles in grey around the ``drawn`` points (k, 3) [m] (a margin of
    CELL_MARGIN_FRACTION of the robot's size); returns the drawn points (k, 3) [m]."""
    margin = CELL_MARGIN_FRACTION * robot_size(robot)
    lines = cell_outlines(cell, drawn.min(axis=0) - margin, drawn.max(axis=0) + margin)
    for k, points in enumerate(lines):
        ax.plot(points[:, 0], points[:, 1], points[:, 2], color="0.55", linewidth=0.8,
                label="obstacles" if k == 0 else None)
    return np.vstack(lines) if lines else np.zeros((0, 3))


def _draw_tool(ax, tool: Tool, X_BF: np.ndarray, colour, label: str | None) -> np.ndarray:
    """Draw the tool's shapes on the flange at X_BF (4, 4) [m]; returns the drawn points (k, 3) [m]."""
    lines = [points for shape, X_BS in zip(tool.shapes, tool.shape_poses(X_BF))
             for points in shape_outline(shape.kind, shape.size, X_BS)]
    for k, points in enumerate(lines):
        ax.plot(points[:, 0], points[:, 1], points[:, 2], color=colour, linewidth=0.8,
                label=label if k == 0 else None)
    return np.vstack(lines) if lines else np.zeros((0, 3))


def motion_figure(robot, profile: Profile, poses: int = DEFAULT_POSES, ax=None, title: str | None = None,
                  cell=None, tool: Tool | np.ndarray | None = None):
    """The arm along a profile -> matplotlib Figure: ``poses`` configurations evenly spaced in time,
    coloured by time (the first with its joint axes and frames), the end frame's path dashed, the tool's
    shapes on the flange at each pose, and the obstacles of ``cell`` (a Cell) in grey. ``robot``'s end frame
    is the TCP (a job's robot); ``tool``: a Tool, a job's X_FT (4, 4) [m] or None (``view_tool``)."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    figure, ax = _new_axes(ax)
    indices = np.unique(np.linspace(0, len(profile.t) - 1, max(poses, 1)).round().astype(int))
    norm = Normalize(float(profile.t[0]), float(profile.t[-1]) if profile.duration > 0 else float(profile.t[0]) + 1)
    cmap = colormaps["viridis"]
    tool = view_tool(robot, cell, tool)
    X_BE = robot.fk_batch(profile.q)
    X_BF = tool.X_BF(X_BE)
    drawn = []
    for k in (*indices[1:], indices[0]):        # the first pose last, on top (a motion often ends there)
        first = k == indices[0]
        drawn.append(_draw_arm(ax, robot, profile.q[k], colour=cmap(norm(profile.t[k])),
                               linewidth=4.0 if first else 2.5, alpha=1.0 if first else 0.75, details=first,
                               label=f"t = {profile.t[k]:.2f} s"))
    for k in indices:
        drawn.append(_draw_tool(ax, tool, X_BF[k], cmap(norm(profile.t[k])),
                                "tool shapes" if k == indices[0] else None))
    end = X_BE[:, :3, 3]
    ax.plot(end[:, 0], end[:, 1], end[:, 2], "k--", linewidth=1.0, label="end-frame path")
    drawn.append(end)
    if cell is not None:
        drawn.append(_draw_cell(ax, robot, cell, np.vstack(drawn)))
    handles, labels = ax.get_legend_handles_labels()
    order = [len(indices) - 1, *range(len(indices) - 1), *range(len(indices), len(handles))]   # by time
    ax.legend([handles[i] for i in order], [labels[i] for i in order], loc="upper left", fontsize=7)
    figure.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.6, pad=0.1, label="t [s]")
    _finish_axes(ax, np.vstack(drawn), title if title is not None else
                 f"{robot.spec.name}: {len(indices)} poses over {profile.duration:.2f} s")
    return figure


def plot_arm_motion(path: str | Path, robot, profile: Profile, title: str | None = None, cell=None,
                    tool: Tool | np.ndarray | None = None) -> None:
    """Write ``motion_figure(robot, profile, cell=cell, tool=tool)`` as a PNG at ``path``."""
    motion_figure(robot, profile, title=title, cell=cell, tool=tool).savefig(path, dpi=100, format="png")


# -- Meshcat ----------------------------------------------------------------------------------------
def sample_profile(profile: Profile, fps: float = DEFAULT_FPS) -> tuple[np.ndarray, np.ndarray]:
    """Times from the profile's start (N,) [s] every 1/fps and the last sample, with q (N, dof)
    interpolated linearly between the profile's samples."""
    if not fps > 0:
        raise ConfigurationError(f"fps must be positive, got {fps!r}")
    t = np.arange(0.0, profile.duration, 1.0 / fps)
    t = np.append(t, profile.duration) if len(t) == 0 or profile.duration - t[-1] > 1e-9 else t
    t_profile = profile.t - profile.t[0]
    q = np.column_stack([np.interp(t, t_profile, profile.q[:, j]) for j in range(profile.dof)])
    return t, q


def scene_spheres(robot, Q: np.ndarray, cell=None, tool: Tool | np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Spheres that hold what a view shows over the configurations Q (N, dof): centres (k, 3) [m] in the
    base frame and radii (k,) [m]. The arm's visual geometry (its stick figure from the base to the TCP,
    through which the TCP's trace runs, widened by VISUAL_REACH_RADII link radii), the tool's shapes on
    the flange, and the cell's obstacles within CELL_MARGIN_FRACTION of the robot's size around them (a
    floor would dwarf the arm). ``robot``'s end frame is the TCP, ``tool`` as ``show_profile`` takes it."""
    tool = view_tool(robot, cell, tool)
    flange = tool.flange_robot(robot)
    centres = [np.vstack([compute_arm_path(robot, q) for q in Q])]
    radii = [np.full(len(centres[0]), VISUAL_REACH_RADII * visual_radius(flange))]
    X_BS = tool.shape_poses(tool.X_BF(robot.fk_batch(Q)))         # (N, shapes, 4, 4)
    for k, shape in enumerate(tool.shapes):
        centres.append(X_BS[:, k, :3, 3])
        radii.append(np.full(len(Q), shape.bounding_radius))
    if cell is not None:
        shown = np.vstack(centres)
        margin = CELL_MARGIN_FRACTION * robot_size(flange)
        obstacles = cell_outlines(cell, shown.min(axis=0) - margin, shown.max(axis=0) + margin)
        centres += obstacles
        radii += [np.zeros(len(points)) for points in obstacles]
    return np.vstack(centres), np.concatenate(radii)


def view_direction() -> np.ndarray:
    """Unit vector (3,) from the camera's target towards the camera (CAMERA_AZIMUTH_DEG, _ELEVATION_DEG)."""
    azimuth, elevation = np.radians(CAMERA_AZIMUTH_DEG), np.radians(CAMERA_ELEVATION_DEG)
    return np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])


def camera_axes(towards_camera: np.ndarray) -> np.ndarray:
    """The camera's right, up and backward unit vectors as rows (3, 3), for a camera looking along
    ``-towards_camera`` with its up as close to +z as possible (as Meshcat's SetCameraPose)."""
    back = towards_camera / np.linalg.norm(towards_camera)
    right = np.cross(np.array([0.0, 0.0, 1.0]), back)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(back, right), back])


def camera_pose(centres: np.ndarray, radii: np.ndarray, fov_deg: float = CAMERA_FOV_DEG,
                aspect: float = CAMERA_ASPECT, fill: float = CAMERA_FILL) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, target) (3,) [m] framing the spheres (centres (k, 3), radii (k,) [m]) seen along
    ``-view_direction()`` with a vertical field of view of ``fov_deg`` [deg] in a view ``aspect`` times as
    wide as tall: the nearest camera that has every sphere within ``fill`` of the way from the view's
    centre to its edge, the spheres centred; the farthest spheres up and down (or left and right) touch
    that frame. The target is the view's centre at the middle of the spheres' bounding box in depth
    (where Meshcat's camera orbits).

    Per view axis, a sphere at lateral offset x, depth z = D - a (D: the camera's distance back from the
    box's middle, a: the sphere's offset towards the camera) is inside the frame |x - c| <= s z (s: the
    frame's slope, c: the target's lateral shift) when it keeps its radius r from both of its planes:
    x + r sqrt(1 + s^2) + s a - s D <= c <= x - r sqrt(1 + s^2) - s a + s D."""
    middle = ((centres - radii[:, None]).min(axis=0) + (centres + radii[:, None]).max(axis=0)) / 2.0
    axes = camera_axes(view_direction())
    right_up_back = (centres - middle) @ axes.T
    slopes = fill * np.tan(np.radians(fov_deg) / 2.0) * np.array([aspect, 1.0])     # right, up
    margins = radii[:, None] * np.hypot(1.0, slopes) + right_up_back[:, 2:] * slopes
    highest = (right_up_back[:, :2] + margins).max(axis=0)
    lowest = (right_up_back[:, :2] - margins).min(axis=0)
    distance = float(((highest - lowest) / (2.0 * slopes)).max())
    target = middle + ((highest + lowest) / 2.0) @ axes[:2]
    return target + distance * axes[2], target


def show_tcp_trace(meshcat, tcp: np.ndarray) -> None:
    """Draw the TCP positions (N, 3) [m] as a line (TRACE_PATH, TRACE_RGBA; at most TRACE_MAX_POINTS)."""
    from pydrake.geometry import Rgba

    keep = np.unique(np.linspace(0, len(tcp) - 1, min(len(tcp), TRACE_MAX_POINTS)).round().astype(int))
    meshcat.SetLine(TRACE_PATH, np.asfortranarray(tcp[keep].T), TRACE_WIDTH_PX, Rgba(*TRACE_RGBA))


def _visual_cell(cell, tool: Tool):
    """The cell the visual model draws: ``cell`` carrying the tool's shapes (a cell of only those
    shapes when there is no cell and the tool has shapes; None when neither)."""
    if cell is not None:
        return dataclasses.replace(cell, tool_shapes=tool.shapes)
    if not tool.shapes:
        return None
    from ..cell.cell_file import Cell

    return Cell(name=tool.name or "tool", source="<tool>", robot="", X_WB=np.eye(4), clearance=0.0, objects=(),
                tool_shapes=tool.shapes)


def show_profile(robot, profile: Profile, meshcat, fps: float = DEFAULT_FPS, cell=None,
                 tool: Tool | np.ndarray | None = None):
    """Play a profile in a running Meshcat (e.g. ``pydrake.geometry.StartMeshcat()`` in a notebook): the
    arm (replacing one shown before under the visualizer's path) is drawn at the first sample and the
    motion published as an animation sampled at ``fps`` [1/s] (play, pause, scrub in Meshcat's
    Animations controls), with the obstacles of ``cell`` (a Cell) if given, the ``tool`` (a Tool: a stem
    from the flange to the TCP, the TCP's axes, and its shapes on the flange; or, as before, a job's X_FT
    (4, 4) [m] or None: ``view_tool``), and the TCP's trace; the camera frames all of it (``scene_spheres``,
    ``camera_pose``). ``robot``'s end frame is the TCP (a job's robot: the robot file's with the tool's
    X_FT). Returns the VisualModel (diagram, plant, scene graph, visualizer)."""
    from pydrake.geometry import MeshcatVisualizerParams

    from ..model.chain.drake_model import build_visual_diagram

    params = MeshcatVisualizerParams()
    params.publish_period = 1.0 / fps          # the visualizer records at 1 / publish_period frames/s
    params.delete_on_initialization_event = False
    tool = view_tool(robot, cell, tool)
    stem = None if tool.at_flange else tool.X_FT            # no stem nor TCP axes without a job tool
    model = build_visual_diagram(tool.flange_robot(robot).spec, meshcat, params, _visual_cell(cell, tool), stem)
    times, Q = sample_profile(profile, fps)
    context = model.diagram.CreateDefaultContext()
    plant_context = model.plant.GetMyMutableContextFromRoot(context)
    model.visualizer.Delete()                   # a robot shown before in this Meshcat
    model.plant.SetPositions(plant_context, Q[0])
    model.diagram.ForcedPublish(context)        # geometry, and the arm at rest at the start
    show_tcp_trace(meshcat, robot.fk_batch(profile.q)[:, :3, 3])
    meshcat.SetCameraPose(*camera_pose(*scene_spheres(robot, Q, cell, tool)))
    model.visualizer.StartRecording(set_transforms_while_recording=False)
    for t, q in zip(times, Q):
        context.SetTime(float(t))
        model.plant.SetPositions(plant_context, q)
        model.diagram.ForcedPublish(context)
    model.visualizer.StopRecording()
    model.visualizer.PublishRecording()
    log.debug("published a %d-frame Meshcat animation of %s (%.3f s at %g frames/s)", len(times),
              robot.spec.name, profile.duration, fps)
    return model


def profile_html(robot, profile: Profile, fps: float = DEFAULT_FPS, cell=None,
                 tool: Tool | np.ndarray | None = None) -> str:
    """A standalone HTML page (its JavaScript inlined, no server needed) of a Meshcat animation of the
    profile (``show_profile``: the arm with its visual geometry, the cell, the tool, the TCP's trace, the
    camera framing them), ``fps`` frames per second, played once on opening (replay it from the
    Animations controls)."""
    return static_meshcat_html(lambda meshcat: show_profile(robot, profile, meshcat, fps, cell, tool))


def static_meshcat_html(draw) -> str:
    """The standalone HTML page of what ``draw(meshcat)`` puts into a Meshcat. The Meshcat server runs
    on an ephemeral localhost port only while the page is built."""
    from pydrake.geometry import Meshcat, MeshcatParams

    from ..model.chain.drake_model import quiet_drake_log

    params = MeshcatParams()
    params.host = "localhost"
    params.port = 0
    with quiet_drake_log():
        meshcat = Meshcat(params)
    try:
        draw(meshcat)                          # what it builds is not kept
        return meshcat.StaticHtml()
    finally:
        # The diagram's Python objects hold the Meshcat (through the visualizer) in reference cycles:
        # drop ours and collect them, so the server thread stops and the port closes now.
        del meshcat
        gc.collect()
