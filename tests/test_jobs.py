"""Job files: units converted once, poses parsed, and every bad input a JobFileError naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import JobFileError
from pipeline.jobs import JointWaypoint, PoseWaypoint, load_job, parse_job
from pipeline.runner import run_job_file

JOBS_DIR = Path(__file__).resolve().parent.parent / "trajectories" / "jobs"

ARM5_JOB = {
    "robot": "arm5",
    "angle_unit": "deg",
    "waypoints": [[0, 30, 30, 30, 0], [40, 50, 20, 10, 30], [0, 45, 45, 0, 0]],
    "speed_scale": 0.8,
    "outputs": ["csv", "json"],
}
GP7_POSES = {
    "robot": "gp7",
    "length_unit": "mm",
    "angle_unit": "deg",
    "waypoints": [{"xyz": [560, 0, 600], "rpy": [180, 0, 0]}, {"xyz": [500, 350, 450], "rpy": [180, 0, 35]}],
    "outputs": ["json"],
}


def write_job(tmp_path: Path, doc: dict, name: str = "job") -> Path:
    path = tmp_path / "jobs" / f"{name}.yaml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(yaml.safe_dump(doc))
    return path


def changed(doc: dict, **changes) -> dict:
    out = {key: value for key, value in doc.items() if key not in changes or changes[key] is not None}
    out.update({key: value for key, value in changes.items() if value is not None})
    return out


def test_every_demo_job_loads():
    paths = sorted(JOBS_DIR.glob("*.yaml"))
    assert len(paths) >= 5
    robots = {load_job(path).robot.name for path in paths}
    assert robots >= {"gp7", "lrmate200id", "irb1600", "arm5", "arm6"}


def test_joint_waypoints_are_converted_to_radians_once():
    job = parse_job(ARM5_JOB)
    assert all(isinstance(w, JointWaypoint) for w in job.waypoints)
    np.testing.assert_allclose(job.waypoints[1].q, np.deg2rad([40, 50, 20, 10, 30]), atol=1e-15)
    assert (job.ik, job.timing, job.path, job.speed_scale, job.dt) == ("auto", "toppra", "monotone", 0.8, 0.004)
    assert job.outputs == ("csv", "json") and not job.has_poses


def test_rpy_degrees_and_millimetres_equal_radians_and_metres():
    in_mm_deg = parse_job(GP7_POSES)
    in_m_rad = parse_job(changed(GP7_POSES, length_unit="m", angle_unit="rad", waypoints=[
        {"xyz": [0.56, 0, 0.6], "rpy": [math.pi, 0, 0]},
        {"xyz": [0.5, 0.35, 0.45], "rpy": [math.pi, 0, math.radians(35)]}]))
    for a, b in zip(in_mm_deg.waypoints, in_m_rad.waypoints):
        assert isinstance(a, PoseWaypoint)
        np.testing.assert_allclose(a.X_BE, b.X_BE, atol=1e-12)


def test_quaternion_equals_rpy_and_is_normalised():
    half = math.radians(35) / 2
    by_quaternion = parse_job(changed(GP7_POSES, angle_unit=None, waypoints=[
        {"xyz": [560, 0, 600], "quaternion": [0, 1, 0, 0]},
        {"xyz": [500, 350, 450], "quaternion": [0, round(math.cos(half), 4), round(math.sin(half), 4), 0]}]))
    for a, b in zip(by_quaternion.waypoints, parse_job(GP7_POSES).waypoints):
        np.testing.assert_allclose(a.X_BE, b.X_BE, atol=1e-4)
        np.testing.assert_allclose(a.X_BE[:3, :3].T @ a.X_BE[:3, :3], np.eye(3), atol=1e-12)


def test_relative_robot_path_is_relative_to_the_job_file_and_hashed(tmp_path):
    robot_file = tmp_path / "jobs" / "my_arm.yaml"
    robot_file.parent.mkdir()
    robot_file.write_text((JOBS_DIR.parent.parent / "models" / "arm5.yaml").read_text())
    job = load_job(write_job(tmp_path, changed(ARM5_JOB, robot="my_arm.yaml")))
    assert job.robot.name == "arm5" and job.name == "job"
    before = job.inputs_sha256
    robot_file.write_text(robot_file.read_text() + "\n# changed\n")
    assert load_job(tmp_path / "jobs" / "job.yaml").inputs_sha256 != before


BAD_JOBS = {
    "unknown robot": (changed(ARM5_JOB, robot="no_such_robot"), "robot", "unknown robot"),
    "wrong waypoint length": (changed(ARM5_JOB, waypoints=[[0, 0, 0, 0, 0], [1, 2, 3, 4]]),
                              "waypoints[1]", "must have 5 values"),
    "NaN": (changed(ARM5_JOB, waypoints=[[0, 0, 0, 0, 0], [1, 2, 3, 4, 5], [0, 0, float("nan"), 0, 0]]),
            "waypoints[2][2]", "finite"),
    "negative speed scale": (changed(ARM5_JOB, speed_scale=-0.5), "speed_scale", "(0, 1]"),
    "zero speed scale": (changed(ARM5_JOB, speed_scale=0), "speed_scale", "(0, 1]"),
    "speed scale above 1": (changed(ARM5_JOB, speed_scale=1.5), "speed_scale", "(0, 1]"),
    "unknown key": (changed(ARM5_JOB, speed=0.5), "speed", "unknown key"),
    "unknown timing method": (changed(ARM5_JOB, timing="bang-bang"), "timing", "toppra"),
    "unknown IK method": (changed(ARM5_JOB, ik="magic"), "ik", "analytic"),
    "unknown path shape": (changed(ARM5_JOB, path="bezier"), "path", "spline"),
    "topp3 on a linear path": (changed(ARM5_JOB, timing="topp3", path="linear"), "path", "not linear"),
    "branch changes not a boolean": (changed(ARM5_JOB, allow_branch_change="yes"), "allow_branch_change",
                                     "true or false"),
    "bad angle unit": (changed(ARM5_JOB, angle_unit="grad"), "angle_unit", "deg, rad"),
    "missing angle unit": (changed(ARM5_JOB, angle_unit=None), "angle_unit", "required"),
    "bad length unit": (changed(GP7_POSES, length_unit="inch"), "length_unit", "mm, m"),
    "joint outside limits": (changed(ARM5_JOB, waypoints=[[0, 0, 0, 0, 0], [0, 0, 160, 0, 0]]),
                             "waypoints[1][2]", "outside its limits"),
    "one waypoint": (changed(ARM5_JOB, waypoints=[[0, 0, 0, 0, 0]]), "waypoints", "at least 2"),
    "rpy and quaternion": (changed(GP7_POSES, waypoints=[{"xyz": [560, 0, 600], "rpy": [180, 0, 0],
                                                          "quaternion": [0, 1, 0, 0]}] * 2),
                           "waypoints[0]", "exactly one of rpy or quaternion"),
    "non-unit quaternion": (changed(GP7_POSES, waypoints=[{"xyz": [560, 0, 600], "quaternion": [0, 2, 0, 0]}] * 2),
                            "waypoints[0].quaternion", "unit length"),
    "unknown pose key": (changed(GP7_POSES, waypoints=[{"xyz": [560, 0, 600], "rpy": [0, 0, 0], "frame": "W"}] * 2),
                         "waypoints[0].frame", "unknown key"),
    "unknown output": (changed(ARM5_JOB, outputs=["csv", "pdf"]), "outputs[1]", "csv, npz, json, png"),
    "dt too large": (changed(ARM5_JOB, dt=1.0), "dt", "[0.0001, 0.1]"),
    "path with ruckig": (changed(ARM5_JOB, timing="ruckig", path="linear"), "path", "no effect with timing ruckig"),
    "start of wrong length": (changed(GP7_POSES, start=[0, 0, 0]), "start", "must have 6 values"),
}


@pytest.mark.parametrize("case", list(BAD_JOBS), ids=list(BAD_JOBS))
def test_bad_job_file_names_file_and_field_and_writes_nothing(tmp_path, case):
    doc, field, problem = BAD_JOBS[case]
    path = write_job(tmp_path, doc)
    out_dir = tmp_path / "out" / "job"
    with pytest.raises(JobFileError) as error:
        run_job_file(path, out_dir)
    message = str(error.value)
    assert message.startswith(f"{path}:{error.value.line}: {field}:") and problem in message
    assert error.value.field == field and error.value.line >= 1
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_job_file_that_is_not_a_mapping(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- robot: arm5\n")
    with pytest.raises(JobFileError, match="document: must be a mapping"):
        load_job(path)


def test_missing_job_file_is_a_job_file_error(tmp_path):
    with pytest.raises(JobFileError, match="cannot read"):
        load_job(tmp_path / "absent.yaml")
