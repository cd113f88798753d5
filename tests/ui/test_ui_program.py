"""The page's program (pipeline.ui.program): built in code, planned and timed, saved and run from the
command line's path with equal samples; loaded from a job file; reordered, deleted and edited, with every
refused edit naming its field as a job file would and changing nothing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import ConfigurationError, JobFileError, OutputError
from pipeline.files.poses import make_pose, rpy_to_rotation
from pipeline.program.job import JointWaypoint, load_job, parse_job
from pipeline.runner import run_job_file
from pipeline.ui.program import DEG, PageProgram

ROOT = Path(__file__).resolve().parents[2]
PICK_PLACE = ROOT / "trajectories" / "jobs" / "gp7_pick_place.yaml"
#: The TCP 120 mm out of the flange along z, as in the demo jobs.
TOOL = make_pose(np.eye(3), [0.0, 0.0, 0.12])
#: Poses of the round trip agree to this [m, rad] (FK of IK, rpy and back).
POSE_TOL = 1e-9
#: Joint values read back from degrees in the file: within a unit in the last place (not every double
#: [rad] is a double [deg] times pi/180).
ULP = 2.3e-16


def tcp_q(program: PageProgram, xyz_mm, rpy_deg, seed) -> np.ndarray:
    """The joint values that put the program's TCP at a pose, nearest the seed (as a user's jog would)."""
    X = make_pose(rpy_to_rotation(*np.radians(rpy_deg)), np.array(xyz_mm) * 1e-3)
    result = program.robot.ik(X, q_seed=seed, method="analytic")
    assert result.success, result.reason
    return result.q


def build(program: PageProgram, poses) -> PageProgram:
    """A start, a joint move, a linear move with a zone and a circular move through a via point."""
    (start, joint, linear, circular, via) = poses
    q = np.radians([0.0, 0.0, 0.0, 0.0, -90.0, 0.0])
    qs = []
    for pose in (start, joint, linear, circular, via):
        q = tcp_q(program, *pose, seed=q)
        qs.append(q)
    program.add(qs[0])
    program.add(qs[1], "joint", speed=0.8)
    program.add(qs[2], "linear", speed=0.3, zone=0.03)
    index = program.add(qs[3], "circular")
    program.set_via(index, qs[4])
    return program


OPEN_POSES = (([560, 0, 480], [180, 0, 0]), ([500, 350, 330], [180, 0, 35]), ([500, 350, 200], [180, 0, 35]),
              ([500, -350, 330], [180, 0, -35]), ([700, 0, 380], [180, 0, 0]))
CELL_POSES = (([550, 300, 400], [180, 0, 30]), ([550, -300, 400], [180, 0, -30]), ([550, -300, 250], [180, 0, -30]),
              ([550, -450, 400], [180, 0, -45]), ([600, -400, 300], [180, 0, -35]))


def check_reproduced(program: PageProgram, tmp_path: Path):
    outcome = program.plan_and_time()
    assert outcome.limit_report.passed
    assert outcome.files == ()
    saved = program.save(tmp_path / "jobs" / "page.yaml")
    cli = run_job_file(saved, tmp_path / "cli")
    assert np.array_equal(cli.profile.t, outcome.profile.t)
    assert np.array_equal(cli.profile.q, outcome.profile.q)
    assert (tmp_path / "cli" / "profile.npz").is_file() and (tmp_path / "cli" / "report.json").is_file()
    return outcome, yaml.safe_load(saved.read_text())


def test_page_program_saved_and_run_from_the_cli_gives_equal_samples(tmp_path):
    program = build(PageProgram("gp7", tool=TOOL, name="page"), OPEN_POSES)
    outcome, document = check_reproduced(program, tmp_path)
    assert [m["kind"] for m in outcome.report["program"]["moves"]] == ["joint", "linear", "circular"]
    assert (document["length_unit"], document["angle_unit"], document["robot"]) == ("mm", "deg", "gp7")
    assert document["tool"] == {"xyz": [0.0, 0.0, 120.0], "rpy": [0.0, 0.0, 0.0]}
    start, joint, linear, circular = document["waypoints"]
    assert isinstance(start, list) and np.allclose(np.array(start) * DEG, program.waypoints[0].q, rtol=ULP, atol=0)
    assert joint["speed"] == 80.0 and isinstance(joint["joints"], list)
    assert (linear["move"], linear["speed"], linear["zone"]) == ("linear", 300.0, 30.0)
    assert linear["config"] == {"shoulder": "front", "elbow": "up", "wrist": "flip"}
    assert np.allclose(linear["xyz"], [500, 350, 200], atol=1e-9) and np.allclose(linear["rpy"], [180, 0, 35])
    assert circular["move"] == "circular" and np.allclose(circular["via"]["xyz"], [700, 0, 380], atol=1e-9)
    assert "plan" not in document and document["outputs"] == ["json", "npz"]


def test_page_program_in_a_cell_is_planned_and_reproduced(tmp_path):
    program = build(PageProgram("gp7", "gp7_wall_cell", TOOL, "page_cell"), CELL_POSES)
    outcome, document = check_reproduced(program, tmp_path)
    assert (document["cell"], document["plan"]) == ("gp7_wall_cell", "collision_free")
    assert outcome.limit_report.clearance.passed
    assert outcome.report["program"]["moves"][0]["planned"]["planner"] != "direct"     # over the wall


def test_job_file_round_trip_keeps_the_waypoints():
    original = load_job(PICK_PLACE)
    program = PageProgram.from_job_file(PICK_PLACE)
    document = program.to_document()
    again = parse_job(document, base_dir=PICK_PLACE.parent)
    assert isinstance(again.waypoints[0], JointWaypoint)       # the start, as joints
    assert len(again.waypoints) == len(original.waypoints)
    for before, after in zip(original.waypoints, again.waypoints):
        X_after = again.robot.fk(after.q) if isinstance(after, JointWaypoint) else after.X_BE
        assert np.abs(X_after[:3, 3] - before.X_BE[:3, 3]).max() < POSE_TOL
        assert np.abs(X_after[:3, :3] - before.X_BE[:3, :3]).max() < POSE_TOL
        assert (after.move, after.zone, after.speed) == (before.move, before.zone, before.speed)
        if before.via is not None:
            assert np.abs(after.via - before.via).max() < POSE_TOL
    for key in ("tcp_speed_max", "tcp_accel_max", "speed_scale", "dt", "timing", "outputs"):
        assert getattr(again, key) == getattr(original, key), key
    assert np.array_equal(again.tool, original.tool)


def test_job_file_round_trip_keeps_the_tools_load(tmp_path):
    document = yaml.safe_load(PICK_PLACE.read_text())
    document["payload"] = {"mass": 1.5, "com": [0, 10, 60], "inertia": [0.004, 0.004, 0.002, 0, 0, 0],
                           "source": "gripper datasheet"}
    path = tmp_path / "with_payload.yaml"
    path.write_text(yaml.safe_dump(document))
    again = parse_job(PageProgram.from_job_file(path).to_document(), base_dir=PICK_PLACE.parent).payload
    assert again.mass == 1.5 and np.allclose(again.com, [0, 0.010, 0.060], atol=1e-12)
    assert np.allclose(again.inertia, np.diag([0.004, 0.004, 0.002])) and again.source == "gripper datasheet"


def test_job_file_with_targets_the_page_cannot_hold_is_refused():
    with pytest.raises(JobFileError) as refused:
        PageProgram.from_job_file(ROOT / "trajectories" / "jobs" / "arm5_position_axis.yaml")
    assert refused.value.field == "waypoints[0].target"


def test_job_file_with_actions_is_refused_rather_than_saved_without_them():
    with pytest.raises(JobFileError, match="cannot show or save a waypoint's actions") as refused:
        PageProgram.from_job_file(ROOT / "tests" / "data" / "gp7_gripper_pick_place.yaml")
    assert refused.value.field == "waypoints[0].do"


def test_reorder_delete_and_edit_change_the_document():
    program = build(PageProgram("gp7", tool=TOOL), OPEN_POSES)
    q = [w.q for w in program.waypoints]
    program.move_to(1, 3)                                    # the joint move goes last
    assert [w.move for w in program.waypoints] == ["joint", "linear", "circular", "joint"]
    assert program.waypoints[3].q is q[1]
    program.move_to(1, 0)                                    # the linear move becomes the start: joints
    assert (program.waypoints[0].move, program.waypoints[0].speed, program.waypoints[0].zone) == ("joint", None, 0.0)
    assert np.allclose(np.array(program.to_document()["waypoints"][0]) * DEG, q[2], rtol=ULP, atol=0)
    program.delete(0)
    assert [w.q for w in program.waypoints] == [q[0], q[3], q[1]]
    program.edit(1, "zone", "25")
    program.edit(2, "speed", "40 %")
    program.edit(1, "speed", " 150 mm/s")
    waypoints = program.to_document()["waypoints"]
    assert (waypoints[1]["zone"], waypoints[1]["speed"], waypoints[2]["speed"]) == (25.0, 150.0, 40.0)
    assert (program.waypoints[1].zone, program.waypoints[1].speed, program.waypoints[2].speed) == (0.025, 0.15, 0.4)
    program.edit(1, "move", "linear")                        # circular -> linear: a tool move, speed kept
    assert program.to_document()["waypoints"][1]["move"] == "linear" and program.waypoints[1].speed == 0.15
    program.edit(1, "move", "joint")                         # tool -> joint: the speed's unit changes, reset
    assert isinstance(program.to_document()["waypoints"][1], dict) and program.waypoints[1].speed is None
    program.edit(1, "zone", "")
    assert isinstance(program.to_document()["waypoints"][1], list)


@pytest.mark.parametrize("index, field, text, named", [
    (2, "zone", "abc", "waypoints[2].zone"),                 # not a number
    (2, "zone", "-5", "waypoints[2].zone"),                  # negative
    (3, "zone", "10", "waypoints[3].zone"),                  # on the last waypoint
    (0, "zone", "10", "waypoints[0].zone"),                  # on the start
    (2, "speed", "25000", "waypoints[2].speed"),             # above any arm's TCP speed (mm/s)
    (1, "speed", "150", "waypoints[1].speed"),               # above 100 %
    (1, "speed", "0", "waypoints[1].speed"),
    (0, "speed", "50", "waypoints[0].speed"),                # the start has no move
    (2, "move", "circular", "waypoints[2].via"),             # a circular move without via
    (2, "move", "spline", "waypoints[2].move"),
    (0, "move", "linear", "waypoints[0].move"),
])
def test_refused_edit_names_the_field_and_changes_nothing(index, field, text, named):
    program = build(PageProgram("gp7", tool=TOOL), OPEN_POSES)
    before, document = list(program.waypoints), program.to_document()
    with pytest.raises(JobFileError) as refused:
        program.edit(index, field, text)
    assert refused.value.field == named
    assert all(a is b for a, b in zip(program.waypoints, before)) and len(program.waypoints) == len(before)
    assert program.to_document() == document


def test_edit_checks_only_its_own_field_while_the_program_is_unfinished():
    """A circular move still without via and a zone on the (so far) last waypoint do not block editing
    another waypoint, and do not hide that waypoint's own problems."""
    program = build(PageProgram("gp7", tool=TOOL), OPEN_POSES)
    program.waypoints[3] = type(program.waypoints[3])("circular", program.waypoints[3].q, None, None, 0.02)
    program.edit(2, "zone", "20")
    assert program.waypoints[2].zone == 0.02
    with pytest.raises(JobFileError) as refused:
        program.edit(2, "zone", "-1")
    assert refused.value.field == "waypoints[2].zone"


def test_a_robot_file_is_named_so_that_the_saved_job_loads(tmp_path):
    program = build(PageProgram(str(ROOT / "models" / "gp7.yaml"), tool=TOOL), OPEN_POSES)
    saved = program.save(tmp_path / "elsewhere" / "job.yaml")
    again = PageProgram.from_job_file(saved)
    assert again.robot_reference == program.robot_reference == str(ROOT / "models" / "gp7.yaml")
    assert [w.move for w in again.waypoints] == [w.move for w in program.waypoints]


def test_add_typed_takes_a_zone_for_the_corner_into_the_next_move():
    program = build(PageProgram("gp7", tool=TOOL), OPEN_POSES)
    q = program.waypoints[1].q
    assert program.add_typed(q, "joint", "50", "20 mm") == 4
    assert (program.waypoints[4].speed, program.waypoints[4].zone) == (0.5, 0.02)
    for speed, zone, named in (("", "-3", "waypoints[5].zone"), ("500", "", "waypoints[5].speed")):
        with pytest.raises(JobFileError) as refused:
            program.add_typed(q, "joint", speed, zone)
        assert refused.value.field == named and len(program.waypoints) == 5
    empty = PageProgram("gp7")
    with pytest.raises(JobFileError) as refused:
        empty.add_typed(q, "linear", "", "10")               # the start: no move into it, no zone
    assert refused.value.field == "waypoints[0].zone" and empty.waypoints == []


@pytest.mark.parametrize("call, message", [
    (lambda p: p.add(np.zeros(6), "joint", speed="50"), "speed must be a positive number"),
    (lambda p: p.add(np.zeros(6), "joint", zone=None), "zone must be a finite number"),
    (lambda p: p.add(["a"] * 6), "q must hold numbers"),
    (lambda p: p.add(np.zeros(5)), "q must have shape (6,)"),
])
def test_the_page_api_refuses_mistyped_arguments_with_a_typed_error(call, message):
    """They escaped as TypeError / ValueError, and the page showed nothing."""
    program = PageProgram("gp7")
    with pytest.raises(ConfigurationError) as error:
        call(program)
    assert message in str(error.value) and program.waypoints == []


def test_save_keeps_a_file_it_did_not_write(tmp_path):
    """The page's Save replaced any file at the typed path (a notes.yaml became a job file)."""
    notes = tmp_path / "notes.yaml"
    notes.write_text("my notes\n")
    program = PageProgram("gp7")
    program.add(np.zeros(6))
    program.add(np.full(6, 0.1))
    with pytest.raises(OutputError, match="notes.yaml: exists and was not written by dh-pipeline"):
        program.save(notes)
    assert notes.read_text() == "my notes\n"
    program.save(notes, replace=True)
    program.save(notes)                                 # ours now: saved again without asking
    assert load_job(notes).robot.name == "gp7"
