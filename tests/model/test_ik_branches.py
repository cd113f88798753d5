"""IK branches under the user's control: configurations by name, one rule for keeping a branch (job
runner and ik_path alike), branch changes refused unless allowed, target kinds in job files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import ConfigurationError, JobFileError
from pipeline.files.poses import rotation_to_rpy
from pipeline.files.branch_names import matches, parse_configuration
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.robot import load_robot
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import load_job
from pipeline.runner import run_job, run_job_file

from ..conftest import DATA_DIR

ROOT = Path(__file__).resolve().parents[2]
BRANCH_JOB = DATA_DIR / "gp7_branch_change.yaml"
FRONT, BACK = "shoulder front, elbow up, wrist flip", "shoulder back, elbow up, wrist flip"


def job_variant(tmp_path: Path, **changes) -> Path:
    """The branch-change job with top-level ``changes`` (a waypoint change as waypoint_<k>=dict)."""
    doc = yaml.safe_load(BRANCH_JOB.read_text())
    for key, value in changes.items():
        if key.startswith("waypoint_"):
            doc["waypoints"][int(key.split("_")[1])].update(value)
        else:
            doc[key] = value
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_a_forced_branch_change_is_refused_naming_both_branches_and_the_joint(tmp_path):
    with pytest.raises(JobFileError) as error:
        run_job_file(BRANCH_JOB, tmp_path / "out")
    message = str(error.value)
    assert "waypoints[1]" in message and f"from '{FRONT}' to '{BACK}'" in message
    assert "S would be 175.9 deg there, outside its limits [-170, 170] deg" in message
    assert "allow_branch_change: true" in message
    assert not (tmp_path / "out").exists()


def test_an_allowed_branch_change_is_reported(tmp_path):
    outcome = run_job_file(job_variant(tmp_path, allow_branch_change=True), tmp_path / "out")
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    first, second = report["waypoints"]
    assert (first["branch"], first["branch_changed"]) == (FRONT, False)
    assert (second["branch"], second["branch_changed"]) == (BACK, True)
    assert first["matched"] == ["x", "y", "z", "roll", "pitch", "yaw"] and first["target"] == "pose"
    assert outcome.profile.certificate.passed


def test_a_named_configuration_is_kept_or_refused(tmp_path):
    job = load_job(job_variant(tmp_path, waypoint_1={"config": "F U B"}, allow_branch_change=True))
    assert solve_waypoints(job)[1].branch == BACK
    with pytest.raises(JobFileError, match=r"waypoints\[1\]\.config: no in-limit solution has the configuration "
                                           r"asked for \(shoulder front\); the solutions: shoulder back"):
        solve_waypoints(load_job(job_variant(tmp_path, waypoint_1={"config": {"shoulder": "front"}})))


@pytest.mark.parametrize("config, match", [
    ("N U", "3 letters"), ("X U T", "the wrist letter"), ({"shoulder": "left"}, "front or back"),
    ({"knee": "up"}, "unknown configuration key"), (7, "a mapping"), ({}, "a mapping"),
])
def test_bad_configurations_name_the_field(tmp_path, config, match):
    with pytest.raises(JobFileError, match=r"waypoints\[0\]\.config: .*" + match):
        load_job(job_variant(tmp_path, waypoint_0={"config": config}))


def test_configuration_parsing_and_matching():
    assert parse_configuration("N U T") == {"wrist": "noflip", "elbow": "up", "shoulder": "front"}
    assert parse_configuration("f,d,b") == {"wrist": "flip", "elbow": "down", "shoulder": "back"}
    assert parse_configuration({"elbow": "down"}) == {"elbow": "down"}
    assert matches("shoulder back, elbow down, wrist flip", {"elbow": "down", "wrist": "flip"})
    assert not matches("shoulder back, elbow down, wrist flip", {"shoulder": "front"})
    with pytest.raises(ConfigurationError):
        parse_configuration("N U T B")


def test_labels_of_any_configuration_agree_with_the_closed_form():
    robot = load_robot("irb1600")
    for q in robot.random_configurations(np.random.default_rng(4), 20):
        (label,) = configuration_labels(robot, q[None])
        result = robot.ik(robot.fk(q), q_seed=q, method="analytic")
        assert label in {s.branch for s in result.solutions}
        assert result.solutions[0].branch == label          # the nearest solution is q itself
    assert configuration_labels(load_robot("arm5"), np.zeros((2, 5))) == ["", ""]


def test_ik_path_and_the_job_runner_share_the_rule(tmp_path):
    job = load_job(job_variant(tmp_path, allow_branch_change=True))
    poses = np.array([w.X_BE for w in job.waypoints])
    refused = job.robot.ik_path(poses, job.start)
    assert not refused.success and refused.failed_index == 1 and f"from '{FRONT}' to '{BACK}'" in refused.reason
    allowed = job.robot.ik_path(poses, job.start, allow_branch_change=True, max_joint_step=2.0 * np.pi)
    assert allowed.success and allowed.branches == (FRONT, BACK)
    np.testing.assert_allclose(allowed.Q, [w.q for w in solve_waypoints(job)], atol=1e-12)


def test_ik_path_keeps_a_wide_joint_continuous_across_pi():
    """IRB 1600 axis 4 (+-200 deg) through 180 deg with the numeric method: the solver's answer may come
    back 2 pi away; the rule takes the representative nearest the previous configuration."""
    robot = load_robot("irb1600")
    Q = np.radians([[10, 20, 10, q4, 40, 30] for q4 in np.arange(170, 192, 2)])
    result = robot.ik_path(robot.fk_batch(Q), Q[0], method="jacobian", rng=np.random.default_rng(0))
    assert result.success, result.reason
    np.testing.assert_allclose(result.Q, Q, atol=1e-6)


@pytest.mark.parametrize("bad", [float("nan"), 0.0, -1.0, float("inf"), True, "0.3"])
def test_max_joint_step_must_be_a_positive_number(bad):
    robot = load_robot("gp7")
    with pytest.raises(ConfigurationError, match="max_joint_step"):
        robot.ik_path(robot.fk(np.zeros(6))[None], np.zeros(6), max_joint_step=bad)


@pytest.mark.slow
def test_five_axis_arm_with_position_and_axis_targets(tmp_path):
    outcome = run_job_file(ROOT / "trajectories" / "jobs" / "arm5_position_axis.yaml", tmp_path / "out")
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    for waypoint in report["waypoints"]:
        assert waypoint["target"] == "position+axis" and waypoint["matched"] == ["x", "y", "z", "axis_z"]
        assert waypoint["position_error_m"] <= 1e-6 and waypoint["rotation_error_rad"] <= 1e-6
        assert waypoint["branch"] is None                   # a 5-axis arm has no named configurations
    assert outcome.profile.certificate.passed


def test_five_axis_arm_given_an_unreachable_full_pose_is_told_what_it_can_match(tmp_path):
    doc = {"robot": "arm5", "length_unit": "mm", "angle_unit": "deg", "ik": "jacobian",
           "waypoints": [{"xyz": [400, 0, 100], "rpy": [180, 0, 0]}, {"xyz": [350, 200, 50], "rpy": [180, 0, 0]}]}
    path = tmp_path / "arm5.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(JobFileError, match=r"waypoints\[0\]: .*cannot match a full pose .*x, y, z, axis_z "
                                           r"\(target_kind='position\+axis'\)"):
        run_job(load_job(path), tmp_path / "out")
    doc["waypoints"][1]["target"] = "position+axis"
    doc["waypoints"][0]["target"] = "position+axis"
    path.write_text(yaml.safe_dump(doc))
    assert run_job(load_job(path), tmp_path / "out").profile.certificate.passed


def test_unknown_target_kind_names_the_field(tmp_path):
    with pytest.raises(JobFileError, match=r"waypoints\[0\]\.target"):
        load_job(job_variant(tmp_path, waypoint_0={"target": "orientation"}))


def test_the_rule_takes_the_2_pi_representative_nearest_the_previous_configuration():
    """A solver answer 2 pi away from the previous joint value (IRB 1600 axis 4, +-200 deg, at 190 deg
    returned as -170 deg) is taken as the in-limit value next to the previous one, not as a jump."""
    from pipeline.model.ik.branches import choose_solution
    from pipeline.model.ik.result import IkResult, Solution

    robot = load_robot("irb1600")
    q = np.radians([10.0, 20.0, 10.0, 190.0, 40.0, 30.0])
    shifted = q - np.array([0, 0, 0, 2 * np.pi, 0, 0])
    result = IkResult(True, shifted, 0.0, 0.0, 1, "jacobian", solutions=(Solution(shifted, 0.0, 0.0),))
    choice = choose_solution(robot, result, q + np.radians([0, 0, 0, -2.0, 0, 0]))
    np.testing.assert_allclose(choice.q, q, atol=1e-12)
    assert not choice.changed and choice.solutions == 1



@pytest.mark.parametrize("robot_name", ["gp7", "irb1600"])
def test_poses_at_a_singular_wrist_keep_axes_4_and_6(tmp_path, robot_name):
    """Pose waypoints with axes 4 and 6 aligned, written as a job writes them (xyz to 0.1 um, rpy to 1e-6 deg: the
    wrist a rounding away from the singularity) keep q4 and q6 where the previous waypoint has them; without the
    rule the split the rounding decides swung them by up to 2.9 rad between neighbours."""
    robot = load_robot(robot_name)
    rng = np.random.default_rng(3)
    start = np.array([0.0, 0.1, -0.1, 0.4, 0.0, -0.3])
    Q = start + np.column_stack([rng.uniform(-0.4, 0.4, (12, 3)), np.zeros((12, 3))])
    waypoints = []
    for q in Q:
        X = robot.fk(q)
        waypoints.append({"xyz": np.round(X[:3, 3] * 1e3, 4).tolist(),
                          "rpy": np.round(np.degrees(rotation_to_rpy(X[:3, :3])), 6).tolist()})
    doc = {"robot": robot_name, "length_unit": "mm", "angle_unit": "deg", "start": np.degrees(start).tolist(),
           "waypoints": waypoints, "ik": "analytic", "timing": "toppra", "outputs": ["json"]}
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump(doc))
    solved = solve_waypoints(load_job(path))
    wrists = np.array([start[[3, 5]], *(s.q[[3, 5]] for s in solved)])
    assert np.abs(np.diff(wrists, axis=0)).max() < 0.1
    assert all(s.wrist_singular for s in solved)
    assert max(s.rotation_error for s in solved) < 1e-6
