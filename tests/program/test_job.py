"""Job files: units converted once, poses parsed, and every bad input a JobFileError naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import pipeline.runner
from pipeline.__main__ import main
from pipeline.errors import JobFileError, ProfileSizeError, RobotFileError
from pipeline.program.job import JointWaypoint, PoseWaypoint, load_job, parse_job
from pipeline.runner import run_job, run_job_file
from pipeline.timing.joint_path import PathError

JOBS_DIR = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"

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


#: A GP7 tool job (mm, deg) as a new user writes it; the unit mistakes below change one key of it.
TOOL_JOB = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tool": {"xyz": [0, 0, 120]},
            "tcp_speed_max": 500, "tcp_accel_max": 2500, "outputs": ["json"],
            "waypoints": [{"xyz": [500, 350, 330], "rpy": [180, 0, 35]},
                          {"xyz": [500, 350, 200], "rpy": [180, 0, 35], "move": "linear"}]}
RADIAN_POSES = [{"xyz": [500, 350, 330], "rpy": [3.1416, 0, 1.5708]},
                {"xyz": [500, 350, 200], "rpy": [3.1416, 0, 0.61], "move": "linear"}]
UNIT_MISTAKES = {
    "TCP speed in m/s": ({"tcp_speed_max": 0.25}, "tcp_speed_max", "is this m/s? Under length_unit: mm, 0.25 is "
                         "0.25 mm/s", "write 250"),
    "TCP acceleration in m/s^2": ({"tcp_accel_max": 2.5}, "tcp_accel_max", "is this m/s^2?", "write 2500"),
    "tool in metres": ({"tool": {"xyz": [0, 0, 0.1]}}, "tool.xyz", "0.1 mm from the end frame", "write [0, 0, 100]"),
    "rpy in radians": ({"waypoints": RADIAN_POSES}, "waypoints[0].rpy", "are these radians?", "[180, 0, 90"),
    "tool rpy in radians": ({"tool": {"xyz": [0, 0, 120], "rpy": [0, 0, 1.5708]}}, "tool.rpy", "is pi/2 in radians",
                            "[0, 0, 90.0002]"),
    "rpy in degrees under rad": ({"angle_unit": "rad"}, "waypoints[0].rpy", "are these degrees?", "full turn"),
}


@pytest.mark.parametrize("case", list(UNIT_MISTAKES), ids=list(UNIT_MISTAKES))
def test_unit_mistakes_are_refused_with_a_hint_and_nothing_written(tmp_path, capsys, case):
    """The CLI refuses each before any work (exit 2), naming the file, line, field and a hint."""
    change, field, problem, fix = UNIT_MISTAKES[case]
    path = write_job(tmp_path, {**TOOL_JOB, **change})
    out_dir = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out_dir)]) == 2
    message = capsys.readouterr().err
    key = field.split(".")[0].split("[")[0]
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if text.startswith(key))
    assert message.startswith(f"error: {path}:") and f": {field}: " in message and problem in message and fix in message
    assert int(message.split(f"{path}:")[1].split(":")[0]) >= line
    assert not out_dir.exists()


@pytest.mark.parametrize("change", [{"waypoints": [{"xyz": [500, 350, 330], "rpy": [180, 0, 90]},
                                                   {"xyz": [500, 350, 200], "rpy": [0, 0, 0], "move": "linear"}]},
                                    {"tool": {"xyz": [0, 0, 1.5], "rpy": [0, 0, 3]}}, {"tcp_speed_max": 1},
                                    {"tcp_accel_max": 10}])
def test_ordinary_values_near_the_unit_rules_are_accepted(change):
    """Degrees such as [180, 0, 90], [0, 0, 0] and whole small angles, a 1.5 mm tool, 1 mm/s, 10 mm/s^2."""
    assert parse_job({**TOOL_JOB, **change}).tcp_speed_max > 0


def test_small_values_are_stated_unambiguously_in_the_other_unit():
    """What the hints propose: a 0.1 mm tool and 0.25 mm/s in metres, small degree angles in radians."""
    job = parse_job({**TOOL_JOB, "length_unit": "m", "angle_unit": "rad", "tool": {"xyz": [0, 0, 0.0001]},
                     "tcp_speed_max": 0.00025, "tcp_accel_max": 2.5, "waypoints": [{"xyz": [0.5, 0.35, 0.33], "rpy": [3.14, 0, 0.61]},
                                                         {"xyz": [0.5, 0.35, 0.2], "rpy": [3.14, 0, 0.61]}]})
    assert job.tcp_speed_max == pytest.approx(0.00025) and job.tool[2, 3] == pytest.approx(1e-4)
    assert parse_job({**TOOL_JOB, "angle_unit": "rad", "waypoints": [
        {"xyz": [500, 350, 330], "rpy": [0.054831, 0, 0.027416]},
        {"xyz": [500, 350, 200], "rpy": [math.pi, 0, 0.61], "move": "linear"}]}).has_tool_moves


def test_a_waypoint_just_outside_a_limit_shows_by_how_much():
    """Not "-2.96706 is outside its limits [-2.96706, 2.96706]": the value in full and the excess."""
    q_min = load_job(JOBS_DIR / "gp7_pick_place.yaml").robot.limits.q_min[0]
    with pytest.raises(JobFileError) as error:
        parse_job({"robot": "gp7", "angle_unit": "rad", "waypoints": [[0] * 6, [q_min - 1e-9, 0, 0, 0, 0, 0]]})
    assert f"= {q_min - 1e-9!r} is outside" in str(error.value) and ": 1e-09 below" in str(error.value)
    assert "are these degrees" not in str(error.value)


def _without(robot_text: str, key: str) -> str:
    """A robot file's text with ``key: value`` dropped from every flow-style joint row."""
    return "\n".join(", ".join(part for part in line.split(", ") if not part.startswith(f"{key}:"))
                     .replace("}}", "}") if line.lstrip().startswith("- {") else line
                     for line in robot_text.splitlines())


@pytest.mark.parametrize("timing, key", [("toppra", "qdd_max"), ("ruckig", "qddd_max")])
def test_a_robot_without_the_limits_its_timing_needs_is_named(tmp_path, timing, key):
    """The error names the ROBOT file, the first joint row and its line, not the job."""
    text = (JOBS_DIR.parent.parent / "models" / "arm5.yaml").read_text()
    robot_file = tmp_path / "jobs" / "arm5_bare.yaml"
    robot_file.parent.mkdir()
    robot_file.write_text(_without(_without(text, "qddd_max"), key))
    path = write_job(tmp_path, changed(ARM5_JOB, robot="arm5_bare.yaml", timing=timing))
    with pytest.raises(RobotFileError) as error:
        run_job_file(path, tmp_path / "out")
    row = next(i for i, line in enumerate(robot_file.read_text().splitlines(), 1) if line.lstrip().startswith("- {"))
    assert (error.value.source, error.value.field, error.value.line) == (str(robot_file), f"joints[0].{key}", row)
    assert f"required by timing {timing}" in str(error.value) and str(path) in str(error.value)
    assert not (tmp_path / "out").exists()


def test_an_absurd_duration_is_refused_before_timing(tmp_path, monkeypatch):
    """tcp_speed_max: 1 (mm/s) on the demo pick and place: at least 1398 s of motion (its lines less their
    zones at 1 mm/s: the program's lower bound), refused in well under
    a second after reading (it ran for minutes and wrote hundreds of MB), naming the field and its line."""
    text = (JOBS_DIR / "gp7_pick_place.yaml").read_text()
    path = tmp_path / "slow.yaml"
    path.write_text(text.replace("tcp_speed_max: 500 ", "tcp_speed_max: 1 "))
    job = load_job(path)
    monkeypatch.setattr(pipeline.runner, "time_program", lambda *_: pytest.fail("the job was timed"))
    with pytest.raises(JobFileError) as error:
        run_job(job, tmp_path / "out")
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if text.startswith("tcp_speed_max"))
    assert (error.value.field, error.value.line) == ("tcp_speed_max", line)
    assert "would last at least 1398 s" in str(error.value) and "at 1 mm/s" in str(error.value)
    assert not (tmp_path / "out").exists()


def test_a_tiny_speed_scale_is_refused_naming_it(tmp_path):
    """A joint job whose moves take too long at qd_max x speed_scale, before timing: beyond the sample
    limit a ProfileSizeError (as timing would raise), beyond the duration limit a JobFileError."""
    path = write_job(tmp_path, changed(ARM5_JOB, speed_scale=1e-3))
    with pytest.raises(ProfileSizeError, match=r"would last \d+.*found before timing: .*: speed_scale: its joint"):
        run_job_file(path, tmp_path / "out", max_samples=1000)
    with pytest.raises(JobFileError) as error:
        run_job_file(path, tmp_path / "out")
    assert error.value.field == "speed_scale" and "joint moves take" in str(error.value)
    assert not (tmp_path / "out").exists()


def test_a_job_without_motion_gets_its_path_error_not_a_crash_in_the_duration_bound(tmp_path):
    """Two equal waypoints and no TCP limit: the duration bound is 0 for the TCP and the joints alike
    (it once multiplied the absent tcp_speed_max); the path's own error says there is nothing to time."""
    path = write_job(tmp_path, changed(ARM5_JOB, waypoints=[[0, 30, 30, 30, 0]] * 2))
    with pytest.raises(PathError, match="no motion to time"):
        run_job_file(path, tmp_path / "out")
    assert not (tmp_path / "out").exists()
