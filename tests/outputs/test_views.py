"""3-D views: the visual Drake model (same kinematics, geometry on every link, placed on the stick
figure), the matplotlib drawings, the standalone Meshcat HTML, and the runner's html/arm_png outputs."""

from __future__ import annotations

import base64
import logging
import os
import re
from pathlib import Path

import msgpack
import numpy as np
import pytest
import yaml
from pydrake.geometry import Cylinder, Role

from pipeline.cell.cell_file import load_cell
from pipeline.files.atomic import OWNER_MARKER
from pipeline.files.poses import rpy_position_to_pose
from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.chain.drake_model import BASE_FRAME, END_FRAME, build_visual_diagram
from pipeline.model.chain.geometry import compute_arm_path, compute_link_polylines
from pipeline.model.robot import Robot, load_robot, robot_with_tool
from pipeline.outputs.views import (
    CAMERA_ASPECT,
    CAMERA_FILL,
    CAMERA_FOV_DEG,
    TRACE_PATH,
    arm_figure,
    camera_pose,
    motion_figure,
    profile_html,
    sample_profile,
)
from pipeline.program.job import load_job, parse_job
from pipeline.runner import FILE_NAMES, run_job
from pipeline.timing import retime

ROOT = Path(__file__).resolve().parents[2]
JOB_FILES = sorted((ROOT / "trajectories" / "jobs").glob("*.yaml"))
EXACT = 1e-12
#: Geometry placed from FK at q = 0, moved by Drake to q [m].
PLACEMENT = 1e-9
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def mixed_robot(convention: str) -> Robot:
    """Revolute and prismatic rows with every offset, a base and a tool (as in test_drake_model)."""
    joints = [
        {"a": 50, "alpha": -90, "d": 300, "theta_offset": 30, "sign": -1, "q_min": -170, "q_max": 170, "qd_max": 90},
        {"type": "prismatic", "a": 20, "alpha": 90, "d": 100, "theta_offset": -45, "sign": -1,
         "q_min": -200, "q_max": 200, "qd_max": 500},
        {"a": 200, "alpha": 0, "d": 40, "theta_offset": 90, "q_min": -170, "q_max": 170, "qd_max": 90},
    ]
    return Robot(parse_robot_spec({
        "name": f"mixed_{convention}", "convention": convention, "length_unit": "mm", "angle_unit": "deg",
        "joints": joints, "base": {"xyz": [10, -20, 30], "rpy": [5, -10, 15]},
        "tool": {"xyz": [0, 15, 120], "rpy": [90, 0, -30]}}))


@pytest.fixture(params=["standard", "modified"])
def mixed(request) -> Robot:
    return mixed_robot(request.param)


def check_visual_model(robot: Robot, rng, samples: int = 20) -> None:
    """Same FK as NumPy (end frame and every link body); geometry on every link; every link cylinder
    lies on that link's stick-figure polyline at random q."""
    model = build_visual_diagram(robot.spec)
    plant = model.plant
    context = plant.CreateDefaultContext()
    inspector = model.scene_graph.model_inspector()
    base, end = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(END_FRAME)
    bodies = [plant.GetBodyByName(f"link{i}") for i in range(1, robot.dof + 1)]
    geometry = {i: inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(body.index()), Role.kIllustration)
                for i, body in enumerate([plant.world_body(), *bodies])}
    assert all(len(ids) >= 1 for ids in geometry.values()), {i: len(ids) for i, ids in geometry.items()}
    assert sum(map(len, geometry.values())) == model.geometry_count == inspector.NumGeometriesWithRole(
        Role.kIllustration)
    for q in robot.random_configurations(rng, samples):
        plant.SetPositions(context, q)
        np.testing.assert_allclose(plant.CalcRelativeTransform(context, base, end).GetAsMatrix4(), robot.fk(q),
                                   atol=EXACT, rtol=0)
        X_BD = robot.fk_all(q)
        polylines = compute_link_polylines(robot, q)
        for i, body in enumerate([plant.world_body(), *bodies]):
            X_WB = plant.EvalBodyPoseInWorld(context, body).GetAsMatrix4()
            if i:
                np.testing.assert_allclose(X_WB, X_BD[i], atol=EXACT, rtol=0)
            for gid in geometry[i]:
                shape = inspector.GetShape(gid)
                if not (isinstance(shape, Cylinder) and "segment" in inspector.GetName(gid)):
                    continue
                X_WG = X_WB @ inspector.GetPoseInFrame(gid).GetAsMatrix4()
                ends = X_WG[:3, 3] + np.outer([-0.5, 0.5], X_WG[:3, 2] * shape.length())
                distances = np.linalg.norm(ends[:, None, :] - polylines[i][None, :, :], axis=2).min(axis=1)
                assert distances.max() < PLACEMENT, f"{robot.name} link {i} {inspector.GetName(gid)}"


def test_visual_plant_matches_numpy_and_has_geometry_on_every_link(robot, rng):
    check_visual_model(robot, rng)


def test_visual_plant_with_prismatic_joints_base_and_tool(mixed, rng):
    check_visual_model(mixed, rng)


def test_link_polylines_run_from_the_base_to_the_end_frame(robot, rng):
    for q in robot.random_configurations(rng, 5):
        polylines = compute_link_polylines(robot, q)
        assert len(polylines) == robot.dof + 1
        for before, after in zip(polylines[:-1], polylines[1:]):
            np.testing.assert_allclose(before[-1], after[0], atol=EXACT)
        path = compute_arm_path(robot, q)
        np.testing.assert_allclose(path[0], 0.0, atol=EXACT)
        np.testing.assert_allclose(path[-1], robot.fk(q)[:3, 3], atol=EXACT)


def test_standard_offsets_are_drawn_as_two_legs():
    robot = load_robot("gp7")                  # row 1: d = 0.33 m, a = 0.04 m
    link1 = compute_link_polylines(robot, np.zeros(robot.dof))[1]
    np.testing.assert_allclose(link1, [[0, 0, 0], [0, 0, 0.33], [0.04, 0, 0.33]], atol=EXACT)


def test_arm_figure_draws_the_arm_to_the_end_frame(robot, rng):
    q = robot.random_configurations(rng, 1)[0]
    figure = arm_figure(robot, q)
    (ax,) = figure.axes
    assert ax.name == "3d" and ax.get_xlabel() == "x [m]" and robot.name in ax.get_title()
    (links,) = [line for line in ax.lines if line.get_label() == "links"]
    xyz = np.array(links.get_data_3d()).T
    np.testing.assert_allclose(xyz[-1], robot.fk(q)[:3, 3], atol=EXACT)
    np.testing.assert_allclose(xyz[0], 0.0, atol=EXACT)
    spans = [np.diff(limits)[0] for limits in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-9)            # equal aspect


def short_profile(name: str = "arm5"):
    robot = load_robot(name)
    lo, hi = robot.limits.q_min, robot.limits.q_max
    waypoints = np.array([lo + 0.4 * (hi - lo), lo + 0.6 * (hi - lo)])
    return robot, retime(robot, waypoints, method="toppra")


def test_motion_figure_draws_poses_and_the_end_frame_path():
    robot, profile = short_profile()
    figure = motion_figure(robot, profile, poses=4)
    ax = figure.axes[0]
    labels = [line.get_label() for line in ax.lines]
    assert sum(label.startswith("t = ") for label in labels) == 4 and "end-frame path" in labels
    (path,) = [line for line in ax.lines if line.get_label() == "end-frame path"]
    np.testing.assert_allclose(np.array(path.get_data_3d()).T[-1], robot.fk(profile.q[-1])[:3, 3], atol=EXACT)


def test_sample_profile_covers_the_whole_profile():
    _, profile = short_profile()
    t, q = sample_profile(profile, fps=30)
    assert t[0] == 0.0 and t[-1] == pytest.approx(profile.duration) and np.all(np.diff(t) <= 1 / 30 + 1e-12)
    np.testing.assert_allclose(q[[0, -1]], profile.q[[0, -1]], atol=EXACT)


def own_sockets() -> set[str]:
    """Inodes of this process's open sockets (Linux /proc)."""
    links = (os.readlink(fd) for fd in Path("/proc/self/fd").iterdir() if fd.is_symlink())
    return {link[len("socket:["):-1] for link in links if link.startswith("socket:[")}


def listening_ports() -> set[int]:
    """TCP ports this process listens on (Linux /proc; other processes' servers are left out)."""
    ports, mine = set(), own_sockets()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in mine:
                ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def test_profile_html_keeps_meshcats_address_out_of_the_log(caplog, capfd):
    """Meshcat announces its URL at INFO through the public ``drake`` logger; profile_html hides it
    (and only it: the logger's level is restored)."""
    robot, profile = short_profile()
    caplog.set_level(logging.INFO, logger="drake")
    profile_html(robot, profile, fps=5)
    assert not [r for r in caplog.records if "Meshcat listening" in r.getMessage()]
    assert "Meshcat listening" not in capfd.readouterr().err
    assert logging.getLogger("drake").level == logging.INFO


def test_profile_html_is_standalone_and_holds_the_animation():
    robot, profile = short_profile()
    before = listening_ports()
    html = profile_html(robot, profile, fps=20)
    if Path("/proc/net/tcp").exists():
        assert listening_ports() <= before, "the Meshcat server is still listening"
    assert html.lstrip().startswith("<!DOCTYPE html>") and "<html" in html and html.rstrip().endswith("</html>")
    # Standalone: the JavaScript is inlined (no external scripts), no server address is baked in.
    assert "<script src" not in html and "http://localhost" not in html and "127.0.0.1" not in html
    assert "Meshcat listening" not in html
    payloads = b"".join(base64.b64decode(data) for data in
                        re.findall(r'data:application/octet-[a-z]+;base64,([A-Za-z0-9+/=\s]*)"', html))
    assert b"set_animation" in payloads
    for i in range(1, robot.dof + 1):
        assert f"/drake/visualizer/link{i}".encode() in payloads


def test_every_demo_job_asks_for_the_views():
    for path in JOB_FILES:
        assert {"html", "arm_png"} <= set(load_job(path).outputs), path.name


def test_a_job_with_html_and_arm_png_writes_view_html_and_arm_png(tmp_path):
    job = parse_job(yaml.safe_load("""
        robot: arm6
        angle_unit: deg
        length_unit: mm
        tool: {xyz: [0, 0, 100]}
        waypoints: [[0, 30, 30, 0, 30, 0], [20, 40, 10, 20, -20, 40]]
        outputs: [html, arm_png]
    """))
    outcome = run_job(job, tmp_path / "out")
    assert [p.name for p in outcome.files] == [FILE_NAMES["html"], FILE_NAMES["arm_png"]] == ["view.html", "arm.png"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [OWNER_MARKER, "arm.png", "view.html"]
    assert (tmp_path / "out" / "arm.png").read_bytes()[:8] == PNG_MAGIC
    html = (tmp_path / "out" / "view.html").read_text(encoding="utf-8")
    assert "<html" in html and len(html) > 100_000
    assert {"/drake/visualizer/link6/tool_stem", TRACE_PATH} <= paths_of(meshcat_messages(html), "set_object")


# -- the camera, the TCP's trace and the tool in the Meshcat page -------------------------------------
def meshcat_messages(html: str) -> list[dict]:
    """The Meshcat commands a static page replays (msgpack maps: type, path, ...)."""
    return [msgpack.unpackb(base64.b64decode(data), raw=False, strict_map_key=False)
            for data in re.findall(r'data:application/octet-[a-z]+;base64,([A-Za-z0-9+/=\s]*)"', html)]


def recorded_camera(messages: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, target) (3,) [m] in Drake's z-up world from the page's commands (three.js's
    y-up frame: (x, y, z) three = (x, z, -y) Drake), the last of each."""
    position = [m["value"] for m in messages if m.get("path") == "/Cameras/default/rotated/<object>"
                and m.get("property") == "position"][-1]
    target = [m["value"] for m in messages if m["type"] == "set_target"][-1]
    to_drake = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
    return to_drake @ position, to_drake @ target


def view_fractions(points: np.ndarray, camera: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Where points (k, 3) [m] appear in a perspective view (CAMERA_FOV_DEG up, CAMERA_ASPECT across)
    from ``camera`` towards ``target`` with its up towards +z: (k, 2) right and up, from -1 to 1 at the
    view's edges (inside when both are within [-1, 1] and the point is in front)."""
    back = (camera - target) / np.linalg.norm(camera - target)
    right = np.cross([0.0, 0.0, 1.0], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    relative = points - camera
    depth = -relative @ back
    assert np.all(depth > 0), "a point is behind the camera"
    half = np.tan(np.radians(CAMERA_FOV_DEG) / 2.0)
    return np.column_stack([relative @ right / (CAMERA_ASPECT * half), relative @ up / half]) / depth[:, None]


def paths_of(messages: list[dict], kind: str) -> set[str]:
    return {m["path"] for m in messages if m["type"] == kind}


def transform_of(messages: list[dict], path: str) -> np.ndarray:
    """The last 4x4 transform recorded for ``path`` (three.js matrices are column-major)."""
    matrix = [m["matrix"] for m in messages if m["type"] == "set_transform" and m["path"] == path][-1]
    return np.array(matrix).reshape(4, 4).T


def shown_arm(robot: Robot, profile, every: int = 5) -> np.ndarray:
    """The stick figure at every ``every``-th profile sample and the last, and the TCP at every sample (k, 3) [m]."""
    samples = [*profile.q[::every], profile.q[-1]]
    return np.vstack([*(compute_arm_path(robot, q) for q in samples), robot.fk_batch(profile.q)[:, :3, 3]])


def test_camera_pose_frames_spheres_up_to_the_fill_and_centres_them(rng):
    """Every point of every sphere lies within CAMERA_FILL of the view's half-widths, the farthest touch it
    (to the sampling of the spheres' surfaces), and the spheres are centred along that view axis."""
    centres = rng.uniform(-1.0, 1.0, (6, 3)) * [2.0, 1.0, 0.5] + [0.5, 0.0, 0.3]
    radii = rng.uniform(0.0, 0.3, 6)
    camera, target = camera_pose(centres, radii)
    directions = rng.normal(size=(20_000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    surfaces = (centres[:, None, :] + radii[:, None, None] * directions[None]).reshape(-1, 3)
    fractions = view_fractions(surfaces, camera, target) / CAMERA_FILL
    reach = np.abs(fractions).max(axis=0)
    assert reach.max() <= 1.0 + 1e-9 and reach.max() > 0.995, reach
    binding = int(np.argmax(reach))
    assert fractions[:, binding].max() + fractions[:, binding].min() == pytest.approx(0.0, abs=0.01)


def tool_job_view(fps: float = 10.0):
    """A gp7 with a 150 mm tool (tilted, offset) and no cell: (flange robot, TCP robot, X_ET, profile,
    the page's Meshcat commands)."""
    flange = load_robot("gp7")
    X_ET = rpy_position_to_pose(np.radians([0.0, 30.0, 0.0]), [0.02, 0.0, 0.15])
    robot = robot_with_tool(flange, X_ET)
    lo, hi = robot.limits.q_min, robot.limits.q_max
    profile = retime(robot, np.array([lo + 0.35 * (hi - lo), lo + 0.65 * (hi - lo)]), method="toppra")
    return flange, robot, X_ET, profile, meshcat_messages(profile_html(robot, profile, fps=fps, tool=X_ET))


def test_view_of_a_tool_job_frames_the_motion_and_draws_the_trace_and_the_tool():
    flange, robot, X_ET, profile, messages = tool_job_view()
    camera, target = recorded_camera(messages)
    fractions = np.abs(view_fractions(shown_arm(robot, profile), camera, target))
    assert fractions.max() <= CAMERA_FILL and fractions.max() > 0.6, fractions.max(axis=0)   # fits, fills most
    # The TCP's trace: the TCP at the profile's samples (float32 in the page).
    (trace,) = [m for m in messages if m["type"] == "set_object" and m["path"] == TRACE_PATH]
    vertices = np.frombuffer(trace["object"]["geometries"][0]["data"]["attributes"]["position"]["array"].data,
                             dtype=np.float32).reshape(-1, 3)
    tcp = robot.fk_batch(profile.q)[:, :3, 3]
    assert len(vertices) == len(tcp)
    np.testing.assert_allclose(vertices, tcp, atol=1e-6)
    # The tool on the last link: a stem from the flange to the TCP, and the TCP's axes.
    drawn = paths_of(messages, "set_object")
    assert {f"/drake/visualizer/link6/{name}" for name in ("flange", "tool_stem", "tcp_x", "tcp_y", "tcp_z")} <= drawn
    X_6E = flange.spec.X_DnE
    stem = transform_of(messages, "/drake/visualizer/link6/tool_stem")
    np.testing.assert_allclose(stem[:3, 3], (X_6E[:3, 3] + (X_6E @ X_ET)[:3, 3]) / 2.0, atol=EXACT)
    np.testing.assert_allclose(stem[:3, 2], (X_6E @ X_ET)[:3, 3] / np.linalg.norm((X_6E @ X_ET)[:3, 3]), atol=1e-9)
    np.testing.assert_allclose(transform_of(messages, "/drake/visualizer/link6/flange")[:3, 3], X_6E[:3, 3],
                               atol=0.01)                 # the flange disc at the flange, not at the TCP


def test_view_in_a_cell_frames_the_nearby_obstacles_and_carries_the_tool_shapes_on_the_flange():
    cell = load_cell(ROOT / "models" / "cells" / "gp7_wall_cell.yaml")
    X_ET = rpy_position_to_pose(np.zeros(3), [0.0, 0.0, 0.12])
    robot = robot_with_tool(cell.load_robot(), X_ET)
    q0 = np.radians([40.0, 10.0, 0.0, 0.0, -60.0, 0.0])
    profile = retime(robot, np.array([q0, q0 * [-1, 1, 1, 1, 1, 1]]), method="toppra")
    messages = meshcat_messages(profile_html(robot, profile, fps=10, cell=cell, tool=X_ET))
    drawn = paths_of(messages, "set_object")
    assert {f"/drake/visualizer/obstacle_{shape.name}" for shape in cell.objects} <= drawn
    assert {"/drake/visualizer/link6/tool_gripper", "/drake/visualizer/link6/tool_stem", TRACE_PATH} <= drawn
    (gripper,) = cell.tool_shapes                 # in the robot file's end frame, before the job's tool
    np.testing.assert_allclose(transform_of(messages, "/drake/visualizer/link6/tool_gripper"),
                               cell.load_robot().spec.X_DnE @ gripper.X, atol=EXACT)
    camera, target = recorded_camera(messages)
    (wall,) = [shape for shape in cell.objects if shape.name == "wall"]
    half = np.array(wall.size) / 2.0
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    wall_corners = (np.linalg.inv(cell.X_WB) @ wall.X @ np.column_stack([corners, np.ones(8)]).T).T[:, :3]
    fractions = np.abs(view_fractions(np.vstack([shown_arm(robot, profile), wall_corners]), camera, target))
    assert fractions.max() <= CAMERA_FILL and fractions.max() > 0.6, fractions.max(axis=0)
