"""The tool as one value (pipeline.cell.tool.Tool): X_FT and the shapes on the flange F, read the same way by
collision and the views (the cell's tool shapes are drawn where they are checked, not beyond the job's
tool)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from pydrake.geometry import Role

from pipeline.cell.cell_file import load_cell
from pipeline.cell.collision import CollisionModel
from pipeline.cell.tool import Tool, rigid_inverse
from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.chain.geometry import shape_outline
from pipeline.outputs.views import motion_figure, profile_html
from pipeline.program.job import load_job, parse_job
from pipeline.timing import retime

from ..outputs.test_views import meshcat_messages, transform_of

ROOT = Path(__file__).resolve().parents[2]
CELL_JOB = ROOT / "trajectories" / "jobs" / "gp7_cell_pick_place.yaml"
#: The visual and the collision pose of a tool shape are one composition of the same transforms [m].
AGREE_M = 1e-9
#: The job's gripper: the TCP 120 mm along the flange's z, where the cell's gripper cylinder ends.
X_FT_120 = rpy_position_to_pose(np.zeros(3), [0.0, 0.0, 0.12])


def random_pose(rng) -> np.ndarray:
    return rpy_position_to_pose(rng.uniform(-np.pi, np.pi, 3), rng.uniform(-0.3, 0.3, 3))


def test_flange_and_tcp_poses_round_trip(rng):
    tool = Tool(random_pose(rng))
    X_BT = np.stack([random_pose(rng) for _ in range(5)])
    X_BF = tool.X_BF(X_BT)
    np.testing.assert_allclose(X_BF @ tool.X_FT, X_BT, atol=1e-15)
    np.testing.assert_allclose(tool.X_BT(X_BF), X_BT, atol=1e-15)
    np.testing.assert_allclose(tool.X_BF(X_BT[2]), X_BF[2], atol=0)
    np.testing.assert_allclose(tool.X_TF, np.linalg.inv(tool.X_FT), atol=1e-15)
    assert np.array_equal(rigid_inverse(tool.X_FT)[3], [0.0, 0.0, 0.0, 1.0])


def test_tcp_and_flange_robots_differ_by_the_tool(rng):
    tool = Tool(random_pose(rng))
    cell = load_cell("gp7_wall_cell")
    arm = cell.load_robot()
    tcp = tool.tcp_robot(arm)
    for q in arm.random_configurations(rng, 3):
        np.testing.assert_allclose(tcp.fk(q), tool.X_BT(arm.fk(q)), atol=1e-12)
        np.testing.assert_allclose(tool.flange_robot(tcp).fk(q), arm.fk(q), atol=1e-12)
    np.testing.assert_allclose(Tool.of_robot_in_cell(tcp, cell).X_FT, tool.X_FT, atol=1e-12)


def test_a_job_without_a_tool_has_the_identity_and_the_cells_shapes():
    doc = yaml.safe_load(CELL_JOB.read_text())
    del doc["tool"]
    job = parse_job(doc, base_dir=CELL_JOB.parent)
    tool = Tool.of_job(job)
    assert job.tool is None and tool.at_flange and np.array_equal(tool.X_FT, np.eye(4))
    assert tool.shapes == job.cell.tool_shapes and len(tool.shapes) == 1
    assert tool.flange_robot(job.robot) is job.robot
    with_tool = Tool.of_job(load_job(CELL_JOB))
    np.testing.assert_allclose(with_tool.X_FT, X_FT_120, atol=1e-15)
    assert not with_tool.at_flange


def test_a_tool_pose_is_checked_and_read_only():
    with pytest.raises(ConfigurationError, match="tool X_FT"):
        Tool(np.diag([1.0, 1.0, -1.0, 1.0]))
    tool = Tool(X_FT_120)
    with pytest.raises(ValueError):
        tool.X_FT[0, 3] = 1.0


def checked_shape_poses(cell, tool: Tool, q) -> dict[str, np.ndarray]:
    """Each tool shape's pose in the robot's base frame (4, 4) [m] as the CollisionModel checks it at q."""
    model = CollisionModel(cell.load_robot(), cell, tool)
    plant, scene_graph = model.diagram.plant(), model.diagram.scene_graph()
    context = model.diagram.CreateDefaultContext()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q)
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    frame = plant.GetBodyFrameIdOrThrow(plant.GetBodyByName("tool").index())
    X_BW = np.linalg.inv(cell.X_WB)
    return {shape.name: X_BW @ query.GetPoseInWorld(query.inspector().GetGeometryIdByName(
        frame, Role.kProximity, f"robot::{shape.name}")).GetAsMatrix4() for shape in tool.shapes}


@pytest.fixture(scope="module")
def gripper_job():
    """The GP7 wall cell with the job's 120 mm tool: (cell, Tool, the job's robot (end frame T), profile)."""
    cell = load_cell("gp7_wall_cell")
    tool = Tool.from_job_and_cell(X_FT_120, cell)
    robot = tool.tcp_robot(cell.load_robot())
    q0 = np.radians([40.0, 10.0, 0.0, 0.0, -60.0, 0.0])
    return cell, tool, robot, retime(robot, np.array([q0, q0 * [-1, 1, 1, 1, 1, 1]]), method="toppra")


@pytest.mark.parametrize("how", ["Tool", "X_FT", "no tool"])
def test_the_view_draws_the_gripper_where_collision_checks_it(gripper_job, how):
    """The page's gripper (its pose on link 6 times link 6's pose at q) against the CollisionModel's at the
    same q. Before the Tool, a view handed the job's robot without ``tool=`` drew it 120 mm beyond."""
    cell, tool, robot, profile = gripper_job
    given = {"Tool": tool, "X_FT": tool.X_FT, "no tool": None}[how]
    messages = meshcat_messages(profile_html(robot, profile, fps=5, cell=cell, tool=given))
    q = profile.q[0]
    X_B6 = robot.fk_all(q)[6]                   # link 6 (the DH frame before the end frame): tool-independent
    drawn = X_B6 @ transform_of(messages, "/drake/visualizer/link6/tool_gripper")
    checked = checked_shape_poses(cell, tool, q)["gripper"]
    assert np.abs(drawn - checked).max() < AGREE_M, 1e3 * np.linalg.norm(drawn[:3, 3] - checked[:3, 3])


def test_the_arm_drawing_draws_the_gripper_where_collision_checks_it(gripper_job):
    cell, tool, robot, profile = gripper_job
    figure = motion_figure(robot, profile, poses=2, cell=cell, tool=tool)
    (ax,) = [ax for ax in figure.axes if ax.name == "3d"]
    lines = [line for line in ax.lines if line.get_label() == "tool shapes"]
    assert len(lines) == 1                      # the first pose's outline carries the label
    drawn = np.array(lines[0].get_data_3d()).T
    (gripper,) = cell.tool_shapes
    expected = shape_outline(gripper.kind, gripper.size, checked_shape_poses(cell, tool, profile.q[0])["gripper"])
    np.testing.assert_allclose(drawn, expected[0], atol=AGREE_M)


def test_a_view_refuses_a_tool_the_robot_does_not_carry(gripper_job):
    cell, tool, robot, profile = gripper_job
    with pytest.raises(ConfigurationError, match="120 mm from the end frame"):
        motion_figure(tool.flange_robot(robot), profile, cell=cell, tool=tool)
