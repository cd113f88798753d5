"""Work cells: cell files, the collision model, the clearance certificate, planning around a wall,
IK skipping colliding branches, tool moves checked, and the check-cell command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.cell.cell_file import load_cell, parse_cell
from pipeline.cell.clear_motion import collision_free_ik, time_clear
from pipeline.cell.collision import CollisionModel
from pipeline.cell.planning import plan_joint_path
from pipeline.errors import CellFileError, CollisionError, JobFileError, RobotFileError
from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.robot import load_robot
from pipeline.program.job import load_job, parse_job
from pipeline.runner import run_job
from pipeline.timing import retime
from pipeline.timing.profile import certify

ROOT = Path(__file__).resolve().parents[2]
WALL_CELL = ROOT / "models" / "cells" / "gp7_wall_cell.yaml"
#: The issue's example cell, exactly as written there.
CORE_CELL = """\
name: gp7_table_cell
length_unit: mm
angle_unit: deg
robot: gp7                                  # preset or robot file (relative to this file)
robot_base: {xyz: [0, 0, 0], rpy: [0, 0, 0]} # robot base frame B in the cell frame W (optional)
clearance: 10                               # the smallest distance any profile may come to an obstacle
objects:                                    # fixed obstacles, poses in W
  - {name: table, box: [800, 1200, 40], xyz: [650, 0, -20], rpy: [0, 0, 0]}   # full sizes x, y, z
  - {name: post, cylinder: [50, 900], xyz: [400, 300, 450]}                   # radius, length along z
  - {name: ball, sphere: 60, xyz: [300, -400, 200]}                           # radius
"""
#: Either side of the wall of the demo cell, the gripper above the table [deg].
PICK_DEG = [30, 20, 10, 0, -60, 0]
PLACE_DEG = [-30, 20, 10, 0, -60, 0]


@pytest.fixture(scope="module")
def wall():
    cell = load_cell(WALL_CELL)
    return CollisionModel(cell.load_robot(), cell)


def test_the_core_cell_format_is_accepted_as_written(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text(CORE_CELL)
    cell = load_cell(path)
    assert cell.robot == "gp7" and cell.clearance == pytest.approx(0.01)
    assert [(s.name, s.kind) for s in cell.objects] == [("table", "box"), ("post", "cylinder"), ("ball", "sphere")]
    np.testing.assert_allclose(cell.objects[0].size, [0.8, 1.2, 0.04])
    np.testing.assert_allclose(cell.objects[1].X[:3, 3], [0.4, 0.3, 0.45])
    model = CollisionModel(cell.load_robot(), cell)
    assert model.is_free(np.zeros(6))


def _core() -> dict:
    return yaml.safe_load(CORE_CELL)


def _with(change) -> dict:
    doc = _core()
    change(doc)
    return doc


@pytest.mark.parametrize("change, field, words", [
    (lambda d: d.pop("robot"), "robot", "required"),
    (lambda d: d.update(robot="gp8"), "robot", "unknown robot"),
    (lambda d: d.update(robot="missing.yaml"), "robot", "no robot file"),
    (lambda d: d.update(colour="red"), "colour", "unknown key"),
    (lambda d: d["objects"][0].update(box=[800, 1200]), "objects[0].box", "3 values"),
    (lambda d: d["objects"][1].update(cylinder=[-50, 900]), "objects[1].cylinder[0]", "> 0"),
    (lambda d: d["objects"][2].update(sphere="big"), "objects[2].sphere", "number"),
    (lambda d: d["objects"][2].update(box=[1, 1, 1]), "objects[2]", "exactly one of"),
    (lambda d: d["objects"][2].pop("sphere"), "objects[2]", "exactly one of"),
    (lambda d: d["objects"][1].update(name="table"), "objects[1].name", "unique"),
    (lambda d: d["objects"][1].update(name="link3"), "objects[1].name", "robot's own bodies"),
    (lambda d: d["objects"][0].update(size=3), "objects[0].size", "unknown key"),
    (lambda d: d.update(clearance=-1), "clearance", ">= 0"),
    (lambda d: d.update(length_unit="m"), "clearance", "is length_unit right"),
    (lambda d: d.update(length_unit="m", clearance=0.01), "objects[0].box[0]", "larger than any cell"),
    (lambda d: d.pop("angle_unit"), "robot_base.rpy", "angle_unit"),
    (lambda d: d.update(objects={"table": 1}), "objects", "list"),
    (lambda d: d["objects"].append(7), "objects[3]", "mapping"),
])
def test_bad_cell_files_name_the_field(change, field, words):
    with pytest.raises(CellFileError) as info:
        parse_cell(_with(change), "cell.yaml", ROOT)
    assert info.value.field == field and words in info.value.problem and "cell.yaml" in str(info.value)


def test_bad_cell_file_errors_carry_the_line(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text(CORE_CELL.replace("sphere: 60", "sphere: -60"))
    with pytest.raises(CellFileError) as info:
        load_cell(path)
    assert info.value.line == 10 and info.value.field == "objects[2].sphere"


def test_robot_file_radius_is_checked_and_written():
    doc = yaml.safe_load((ROOT / "models" / "arm5.yaml").read_text())
    doc["joints"][2]["radius"] = -5
    with pytest.raises(RobotFileError, match=r"joints\[2\]\.radius"):
        parse_robot_spec(doc)
    doc["joints"][2].pop("radius")
    with pytest.raises(RobotFileError, match=r"joints\[2\]\.radius: given for some joints"):
        parse_robot_spec(doc)
    from pipeline.files.robot_writer import robot_document

    spec = load_robot("gp7").spec
    assert [row["radius"] for row in robot_document(spec)["joints"]] == [90, 65, 60, 50, 45, 30]


def test_demo_cell_filters_and_home_pose(wall):
    assert ("link1", "floor") in wall.filtered_pairs             # the robot stands on the floor
    assert ("link4", "link6") in wall.filtered_pairs             # the wrist's links meet in its centre
    assert wall.is_free(np.zeros(6))
    clearance = wall.clearance(np.zeros(6))
    assert clearance.obstacle == pytest.approx(0.21, abs=1e-9) and clearance.obstacle_pair == ("link1", "table")


def test_self_collision_is_found_for_a_folded_arm():
    robot = load_robot("gp7")
    model = CollisionModel(robot)
    folded = np.radians([98, 101, -56, -50, -112, -221])      # the forearm down on the base
    assert model.is_free(np.zeros(6)) and not model.is_free(folded)
    assert model.clearance(folded).self_pair == ("link1", "link4")
    assert "links link1 and link4 touch" in model.why_not_free(folded)


def _dense_distances(model, profile, factor: int = 10) -> tuple[float, float]:
    """Obstacle and link distances [m] recomputed at ``factor`` times the sample rate (linear
    interpolation between samples), independently of the certificate."""
    t = np.linspace(profile.t[0], profile.t[-1], factor * (len(profile.t) - 1) + 1)
    Q = np.column_stack([np.interp(t, profile.t, column) for column in profile.q.T])
    distances = [model.clearance(q) for q in Q]
    return min(d.obstacle for d in distances), min(d.self for d in distances)


def test_a_profile_through_the_wall_is_refused_naming_the_pair(wall):
    robot = wall.robot
    q = np.radians([PICK_DEG, PLACE_DEG])
    assert wall.is_free(q[0]) and wall.is_free(q[1]) and not wall.edge_is_free(q[0], q[1])
    profile = retime(robot, q)
    report = certify(profile, scene=wall)
    assert not report.passed and report.clearance is not None and not report.clearance.passed
    assert "wall" in report.clearance.reason and report.clearance.failed_at_s is not None
    with pytest.raises(CollisionError, match=r"wall.*at t = .*plan: collision_free"):
        time_clear(wall, q, lambda vertices: retime(robot, vertices), refine=False)


def test_a_planned_move_around_the_wall_is_certified_on_dense_samples(wall):
    robot = wall.robot
    q_start, q_goal = np.radians(PICK_DEG), np.radians(PLACE_DEG)
    plan = plan_joint_path(wall, q_start, q_goal)
    assert plan.planner == "detour" and plan.length_after <= plan.length_before
    np.testing.assert_array_equal(plan.waypoints[[0, -1]], [q_start, q_goal])
    profile, _ = time_clear(wall, plan.waypoints, lambda vertices: retime(robot, vertices), refine=True)
    report = profile.certificate
    assert report.passed and report.clearance.passed and report.clearance.min_distance_m >= wall.clearance_m
    assert all(report.max_ratio(name) <= 1.0 + 1e-6 for name in report.ratios)          # joint limits kept
    np.testing.assert_allclose(profile.q[[0, -1]], [q_start, q_goal], atol=1e-9)   # starts and ends as asked
    np.testing.assert_allclose(profile.qd[[0, -1]], 0.0, atol=1e-9)
    obstacle, links = _dense_distances(wall, profile)
    assert obstacle >= wall.clearance_m and links > 0.0
    assert obstacle >= report.clearance.min_distance_m - report.clearance.tube_m - 1e-9


def test_planning_from_a_colliding_start_names_the_pair(wall):
    inside = np.radians([0, 60, 30, 0, 0, 0])                   # the arm down into the table
    assert not wall.is_free(inside)
    with pytest.raises(CollisionError, match="start configuration is not collision-free"):
        plan_joint_path(wall, inside, np.radians(PLACE_DEG))


def test_ik_skips_colliding_branches():
    robot = load_robot("gp7")
    q_target = np.radians([20, 10, 20, 30, 40, 10])
    X = robot.fk(q_target)
    result = robot.ik(X, q_seed=q_target, method="analytic")
    solutions = [s.q for s in result.solutions]
    assert len(solutions) >= 2
    elbow = robot.fk_all(solutions[0])[3, :3, 3]                 # the nearest solution's elbow (DH frame 3)
    cell = parse_cell({"name": "elbow", "length_unit": "m", "robot": "gp7", "clearance": 0.01,
                       "objects": [{"name": "block", "sphere": 0.05, "xyz": elbow.tolist()}]})
    model = CollisionModel(robot, cell)
    assert not model.is_free(solutions[0])
    free, why = collision_free_ik(robot, model, X, q_target, "analytic", "pose", {}, np.random.default_rng(0))
    assert free is not None and why == "" and len(free.solutions) < len(solutions)
    assert all(model.is_free(s.q) for s in free.solutions)
    assert not any(np.allclose(s.q, solutions[0]) for s in free.solutions)
    numeric, why = collision_free_ik(robot, model, X, solutions[0], "jacobian", "pose", {}, np.random.default_rng(0))
    assert numeric is not None and all(model.is_free(s.q) for s in numeric.solutions)


def _cell_job(tmp_path, **changes) -> dict:
    job = {"cell": str(WALL_CELL), "angle_unit": "deg", "waypoints": [PICK_DEG, PLACE_DEG], "outputs": ["json"]}
    job.update(changes)
    return job


def test_a_job_in_the_cell_plans_over_the_wall_and_reports_it(tmp_path):
    job = parse_job(_cell_job(tmp_path, plan="collision_free"), "job.yaml")
    assert job.robot.name == "gp7" and job.cell.name == "gp7_wall_cell"
    outcome = run_job(job, tmp_path / "out")
    cell = outcome.report["cell"]
    assert cell["clearance"]["passed"] and cell["clearance"]["min_distance_m"] >= 0.01
    assert [m["planned"]["planner"] for m in outcome.report["program"]["moves"]] == ["detour"]
    assert "clearance 10 mm: PASS" in outcome.summary()


def test_a_direct_job_through_the_wall_is_an_error_and_writes_nothing(tmp_path):
    job = parse_job(_cell_job(tmp_path), "job.yaml")
    with pytest.raises(CollisionError, match=r"job.yaml: .*wall"):
        run_job(job, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_tool_move_through_the_wall_is_refused_naming_the_move(tmp_path):
    poses = [{"xyz": [550, 300, 400], "rpy": [180, 0, 30]},
             {"xyz": [550, -300, 400], "rpy": [180, 0, -30], "move": "linear"}]
    job = parse_job(_cell_job(tmp_path, waypoints=poses, length_unit="mm", tcp_speed_max=500,
                              tool={"xyz": [0, 0, 120]}), "job.yaml")
    with pytest.raises(JobFileError, match=r"waypoints\[1\].*not collision-free: .*wall"):
        run_job(job, tmp_path / "out")


@pytest.mark.parametrize("changes, field", [
    ({"robot": "lrmate200id"}, "robot"),
    ({"cell": "nowhere.yaml"}, "cell"),
    ({"plan": "around"}, "plan"),
    ({"planner": "Dijkstra", "plan": "collision_free"}, "planner"),
    ({"planner": "RRT"}, "planner"),
    ({"plan_time_budget": 0, "plan": "collision_free"}, "plan_time_budget"),
])
def test_bad_cell_job_keys_name_the_field(tmp_path, changes, field):
    with pytest.raises(JobFileError) as info:
        parse_job(_cell_job(tmp_path, **changes), "job.yaml")
    assert info.value.field == field


def test_planning_keys_need_a_cell(tmp_path):
    with pytest.raises(JobFileError, match="needs a cell"):
        parse_job({"robot": "gp7", "angle_unit": "deg", "waypoints": [PICK_DEG, PLACE_DEG],
                   "plan": "collision_free"}, "job.yaml")


def test_a_colliding_joint_waypoint_is_named(tmp_path):
    job = parse_job(_cell_job(tmp_path, waypoints=[PICK_DEG, [0, 60, 30, 0, 0, 0]]), "job.yaml")
    with pytest.raises(JobFileError, match=r"waypoints\[1\]: is not collision-free"):
        run_job(job, tmp_path / "out")


def test_check_cell_command(tmp_path, capsys):
    assert main(["check-cell", str(WALL_CELL)]) == 0
    out = capsys.readouterr().out
    assert "gp7_wall_cell" in out and "q = 0 is collision-free" in out and "not checked: link1 - floor" in out
    doc = _core()
    doc["objects"].append({"name": "block", "box": [200, 200, 200], "xyz": [0, 0, 500]})
    path = tmp_path / "cell.yaml"
    path.write_text(yaml.safe_dump(doc))
    assert main(["check-cell", str(path)]) == 1
    assert "COLLISION at q = 0" in capsys.readouterr().out
    path.write_text("name: x\n")
    assert main(["check-cell", str(path)]) == 2


#: A tool move down at the pick, then a direct joint move through the wall (one waypoint per line).
PICK_AND_THROUGH = """\
cell: {cell}
length_unit: mm
angle_unit: deg
tool: {{xyz: [0, 0, 120]}}
tcp_speed_max: 500
waypoints:
  - {{xyz: [550, 300, 400], rpy: [180, 0, 30]}}
  - {{xyz: [550, 300, 330], rpy: [180, 0, 30], move: linear}}
  - {{xyz: [550, -300, 400], rpy: [180, 0, -30]}}
outputs: [json]
"""


def test_a_clearance_failure_names_the_waypoint_line_and_the_job_time(tmp_path):
    """The joint move after a tool move fails the clearance: the error names the line of the waypoint
    it goes to and the job's time (the tool move's duration plus the time into the joint move)."""
    path = tmp_path / "through.yaml"
    path.write_text(PICK_AND_THROUGH.format(cell=WALL_CELL))
    with pytest.raises(CollisionError) as error:
        run_job(load_job(path), tmp_path / "out")
    failure = error.value.__cause__
    tool_move_end, failed_at = failure.profile.details.passages_s[1], failure.report.failed_at_s
    assert tool_move_end > 0.1 and failed_at > tool_move_end              # after the tool move, in job time
    assert str(error.value).startswith(f"{path}:9: waypoints[2]: on the move to this waypoint")
    assert f"wall (clearance 10 mm) at t = {failed_at:.4f} s" in str(error.value)
    assert not (tmp_path / "out").exists()


def test_the_reported_smallest_distance_is_the_smallest_over_the_samples(wall):
    """min_distance_m is the smallest robot-obstacle distance over the profile's samples (to 1e-6 m),
    not the smallest at the certificate's own evaluations (up to 0.09 mm above it)."""
    robot = wall.robot
    profile, _ = time_clear(wall, np.radians([PICK_DEG, [40, 10, 0, 0, -50, 20]]),
                            lambda vertices: retime(robot, vertices), refine=False)
    clearance = profile.certificate.clearance
    distances = np.array([wall.clearance(q).obstacle for q in profile.q])
    k = int(np.argmin(distances))
    assert clearance.passed and clearance.min_distance_m == pytest.approx(distances[k], abs=1e-6)
    assert clearance.t_s in profile.t and clearance.t_s == pytest.approx(profile.t[k], abs=0.05)   # a sample's time
    assert 0 < clearance.sample_evaluations < len(profile.t) / 2


# -- fuzz findings 5 and 6 of issue 22: shape sizes checked in metres, a bounded count of shapes -----------
def cell_with(objects=(), tool_shapes=(), unit="mm") -> dict:
    doc = {"name": "c", "length_unit": unit, "robot": "gp7", "objects": list(objects)}
    return {**doc, "tool_shapes": list(tool_shapes)} if tool_shapes else doc


@pytest.mark.parametrize("doc, field", [
    (cell_with([{"name": "b", "box": [5e-324, 100, 100], "xyz": [900, 0, 0]}]), "objects[0].box[0]"),
    (cell_with([{"name": "s", "sphere": 1e-4, "xyz": [900, 0, 0]}]), "objects[0].sphere"),
    (cell_with([{"name": "c", "cylinder": [1e-9, 1], "xyz": [900, 0, 0]}], unit="m"), "objects[0].cylinder[0]"),
    (cell_with(tool_shapes=[{"name": "g", "capsule": [10, 5e-324]}]), "tool_shapes[0].capsule[1]"),
])
def test_a_size_that_is_zero_in_metres_is_a_cell_file_error(doc, field):
    """Finding 6: 5e-324 mm passed the "> 0" check and became 0 m; Drake's DRAKE_DEMAND then aborted the
    process (a SystemExit in Python, which also kills a Dask worker). Sizes are checked in metres."""
    import re

    with pytest.raises(CellFileError, match=rf"{re.escape(field)}: is .* m, smaller than any shape \(1e-06 m"):
        parse_cell(doc, "cell.yaml")


def test_shapes_and_link_radii_made_in_python_are_checked_before_drake():
    """Finding 6 through the Python API: a Shape or a link radius of 0 m is a ConfigurationError, not
    Drake's abort."""
    import dataclasses

    from pipeline.cell.cell_file import Shape
    from pipeline.errors import ConfigurationError
    from pipeline.model.robot import Robot

    with pytest.raises(ConfigurationError, match="shape 'b': a box needs sizes"):
        Shape("b", "box", (0.0, 1.0, 1.0), np.eye(4))
    robot = load_robot("gp7")
    thin = dataclasses.replace(robot.spec, joints=tuple(dataclasses.replace(j, radius=0.0) for j in robot.spec.joints))
    with pytest.raises(ConfigurationError, match="radius 0.0 m is not a finite size of at least 1e-06 m"):
        CollisionModel(Robot(thin))


def test_a_link_radius_that_is_zero_in_metres_is_a_robot_file_error():
    document = yaml.safe_load((ROOT / "models" / "gp7.yaml").read_text())
    document["joints"][0]["radius"] = 5e-324
    with pytest.raises(RobotFileError, match=r"joints\[0\]\.radius: is 0 m, thinner than any shape"):
        parse_robot_spec(document, "gp7.yaml")


def test_more_shapes_than_the_checker_can_hold_are_refused_by_count():
    """Finding 5: 5000 small boxes ran check-cell 48 s to 5.9 GB and std::bad_alloc in Drake's checker,
    whose time and memory grow with the square of the shapes (measured: 200 boxes 0.6 s, 800 boxes 15 s
    and +440 MB). The count is refused before any shape is read."""
    from pipeline.cell.cell_file import MAX_CELL_SHAPES

    boxes = [{"name": f"b{k}", "box": [10, 10, 10], "xyz": [2000 + 20 * k, 0, 0]} for k in range(MAX_CELL_SHAPES + 1)]
    with pytest.raises(CellFileError, match=rf"objects: has {MAX_CELL_SHAPES + 1} shapes, more than {MAX_CELL_SHAPES}"):
        parse_cell(cell_with(boxes), "cell.yaml")
    with pytest.raises(CellFileError, match=rf"tool_shapes: has {MAX_CELL_SHAPES + 1} shapes"):
        parse_cell(cell_with(tool_shapes=boxes), "cell.yaml")
    assert len(parse_cell(cell_with(boxes[:MAX_CELL_SHAPES]), "cell.yaml").objects) == MAX_CELL_SHAPES
