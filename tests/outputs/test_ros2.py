"""The controller outputs: a job's profile as a ROS 2 trajectory_msgs/msg/JointTrajectory in YAML
(``ros2_yaml``) and JSON (``json_trajectory``), read back into exactly the profile's numbers, with
time_from_start rounded to whole ns and strictly increasing, and refused (no file) when it is not."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

import pipeline.runner
from pipeline.errors import InvalidValueError, JobFileError, OutputError
from pipeline.files.atomic import OWNER_MARKER
from pipeline.outputs.ros2 import joint_trajectory, time_from_start, write_json_trajectory, write_ros2_yaml
from pipeline.program.job import DEFAULT_OUTPUTS, OUTPUTS, load_job, parse_job
from pipeline.runner import FILE_NAMES, run_job, run_job_file

ROOT = Path(__file__).resolve().parents[2]
ARM6_JOB = ROOT / "trajectories" / "jobs" / "arm6_joint_rad.yaml"
TORQUE_ROBOT = ROOT / "tests" / "data" / "arm2_dynamics.yaml"
CONTROLLER_OUTPUTS = ["ros2_yaml", "json_trajectory"]
HEADER = {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}
POINT_FIELDS = ["positions", "velocities", "accelerations", "effort", "time_from_start"]


def write_job(folder: Path, doc: dict, name: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def run_controller_job(folder: Path, doc: dict, name: str):
    """Run ``doc`` with only the controller outputs; (outcome, YAML message, JSON message)."""
    outcome = run_job_file(write_job(folder, {**doc, "outputs": CONTROLLER_OUTPUTS}, name), folder / "out")
    text = (folder / "out" / "trajectory.ros2.yaml").read_text()
    return outcome, yaml.safe_load(text), json.loads((folder / "out" / "trajectory.json").read_text())


@pytest.fixture(scope="module")
def arm6(tmp_path_factory):
    """The arm6 demo job (joint waypoints, ruckig) writing ros2_yaml and json_trajectory."""
    folder = tmp_path_factory.mktemp("arm6")
    return (folder, *run_controller_job(folder, yaml.safe_load(ARM6_JOB.read_text()), "arm6"))


def assert_message_is_profile(message: dict, profile) -> None:
    """Every number of ``message`` is the profile's, exactly; the times to the nearest ns."""
    assert list(message) == ["header", "joint_names", "points"]
    assert message["header"] == HEADER
    assert message["joint_names"] == list(profile.joint_names)
    points = message["points"]
    assert len(points) == len(profile.t)
    assert all(list(point) == POINT_FIELDS for point in points)
    for field, values in (("positions", profile.q), ("velocities", profile.qd), ("accelerations", profile.qdd)):
        written = [point[field] for point in points]
        assert written == values.tolist(), field                      # exact: floats round-trip
        assert all(type(value) is float for row in written for value in row), field
    assert all(point["effort"] == [] for point in points)      # the controller refuses efforts it does not command
    stamps = [point["time_from_start"] for point in points]
    assert all(list(stamp) == ["sec", "nanosec"] and type(stamp["sec"]) is int and type(stamp["nanosec"]) is int
               for stamp in stamps)
    assert all(0 <= stamp["nanosec"] < 1_000_000_000 and stamp["sec"] >= 0 for stamp in stamps)
    ns = np.array([stamp["sec"] * 1_000_000_000 + stamp["nanosec"] for stamp in stamps])
    assert (np.diff(ns) > 0).all()                                    # strictly increasing
    seconds = np.array([stamp["sec"] + stamp["nanosec"] * 1e-9 for stamp in stamps])
    assert np.abs(seconds - profile.t).max() <= 0.5e-9 + 1e-12        # nearest ns (+ float sum round-off)


def test_yaml_reads_back_as_the_profile(arm6):
    folder, outcome, from_yaml, _ = arm6
    assert outcome.profile.tau is None and len(outcome.profile.t) > 100
    assert_message_is_profile(from_yaml, outcome.profile)
    assert from_yaml["points"][0]["time_from_start"] == {"sec": 0, "nanosec": 0}   # the first point is at 0
    assert from_yaml["points"][0]["positions"] == outcome.profile.q[0].tolist()


def test_json_holds_the_same_message_as_the_yaml(arm6):
    folder, outcome, from_yaml, from_json = arm6
    assert from_json == from_yaml == joint_trajectory(outcome.profile)


def test_the_files_are_named_and_listed_like_every_output(arm6):
    folder, outcome, _, _ = arm6
    assert [p.name for p in outcome.files] == ["trajectory.ros2.yaml", "trajectory.json"]
    assert [FILE_NAMES[kind] for kind in CONTROLLER_OUTPUTS] == ["trajectory.ros2.yaml", "trajectory.json"]
    assert {p.name for p in (folder / "out").iterdir()} == {"trajectory.ros2.yaml", "trajectory.json", OWNER_MARKER}
    text = (folder / "out" / "trajectory.ros2.yaml").read_text()
    assert text.startswith("header:\n  stamp: {sec: 0, nanosec: 0}\n  frame_id: ''\njoint_names: [J1, J2,")
    assert set(CONTROLLER_OUTPUTS) <= set(OUTPUTS) and not set(CONTROLLER_OUTPUTS) & set(DEFAULT_OUTPUTS)


def test_a_torque_limited_profile_sends_no_effort(tmp_path):
    doc = {"robot": str(TORQUE_ROBOT), "angle_unit": "deg", "waypoints": [[0, 0], [90, -60]], "dt": 0.01}
    outcome, from_yaml, from_json = run_controller_job(tmp_path, doc, "arm2")
    assert outcome.profile.tau is not None
    assert_message_is_profile(from_yaml, outcome.profile)
    assert from_json == from_yaml


def first_samples(profile, count: int):
    """The first ``count`` samples of ``profile``."""
    return dataclasses.replace(profile, **{name: getattr(profile, name)[:count] for name in ("t", "q", "qd", "qdd",
                                                                                            "qddd")})


def test_awkward_floats_and_joint_names_read_back_exactly(arm6, tmp_path):
    profile = first_samples(arm6[1].profile, 4)
    values = [5e-324, 1e-300, 1 / 3, -0.0, 1e16, -2.5e-7]
    q = profile.q.copy()
    q[:2] = np.resize(values, (2, q.shape[1]))
    odd = dataclasses.replace(profile, q=q, joint_names=("1", "yes", "null", "j: 4", "- j5", "'j6'"))
    write_ros2_yaml(tmp_path / "t.yaml", odd)
    write_json_trajectory(tmp_path / "t.json", odd)
    for message in (yaml.safe_load((tmp_path / "t.yaml").read_text()), json.loads((tmp_path / "t.json").read_text())):
        assert message["joint_names"] == list(odd.joint_names)
        assert [point["positions"] for point in message["points"]] == q.tolist()
        assert np.signbit(message["points"][0]["positions"][3])       # -0.0 stays -0.0


def test_time_from_start_rounds_to_the_nearest_ns_and_carries_into_sec():
    stamps = time_from_start(np.array([0.0, 0.9999999996, 1.5, 2.000000001, 3.0000000014]))
    assert stamps == [{"sec": 0, "nanosec": 0}, {"sec": 1, "nanosec": 0}, {"sec": 1, "nanosec": 500_000_000},
                      {"sec": 2, "nanosec": 1}, {"sec": 3, "nanosec": 1}]


def sub_ns_profile(profile):
    """``profile`` with its samples 0.4 ns apart: samples 0 and 1 both round to 0 ns."""
    return dataclasses.replace(profile, t=np.arange(len(profile.t)) * 0.4e-9)


@pytest.mark.parametrize("writer", [write_ros2_yaml, write_json_trajectory], ids=["yaml", "json"])
def test_samples_closer_than_1_ns_are_refused_and_nothing_is_written(arm6, tmp_path, writer):
    path = tmp_path / "trajectory"
    with pytest.raises(OutputError, match=r"samples 0 and 1 .* strictly increase"):
        writer(path, sub_ns_profile(arm6[1].profile))
    assert not path.exists()


def test_a_job_whose_times_collide_fails_and_leaves_no_output(arm6, tmp_path, monkeypatch):
    bad = sub_ns_profile(arm6[1].profile)
    monkeypatch.setattr(pipeline.runner, "time_program", lambda program, scene=None, max_samples=0: bad)
    job = load_job(write_job(tmp_path, {**yaml.safe_load(ARM6_JOB.read_text()), "outputs": ["csv", "ros2_yaml"]},
                             "arm6"))
    with pytest.raises(OutputError, match="strictly increase"):
        run_job(job, tmp_path / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm6.yaml"]


@pytest.mark.parametrize("change, match", [
    (lambda p: {"t": p.t - 1.0}, "negative or not finite"),
    (lambda p: {"t": np.where(np.arange(len(p.t)) == 3, np.nan, p.t)}, "sample 3: time nan"),
    (lambda p: {"qd": np.where(np.arange(len(p.t))[:, None] == 2, np.inf, p.qd)}, "sample 2: qd of joint J1 is inf"),
    (lambda p: {"q": p.q[:, :5]}, r"q has shape \(\d+, 5\), not \(\d+, 6\)"),
])
def test_a_message_the_controller_would_reject_is_never_written(arm6, tmp_path, change, match):
    profile = arm6[1].profile
    bad = dataclasses.replace(profile, **change(profile))
    with pytest.raises(OutputError, match=match):
        write_ros2_yaml(tmp_path / "t.yaml", bad)
    assert not (tmp_path / "t.yaml").exists()


def test_an_unknown_output_kind_is_still_a_job_file_error(tmp_path):
    doc = {**yaml.safe_load(ARM6_JOB.read_text()), "outputs": ["ros2_yaml", "ros2"]}
    with pytest.raises(JobFileError) as error:
        parse_job(doc)
    assert isinstance(error.value, InvalidValueError) and error.value.field == "outputs[1]"
    assert "ros2_yaml, json_trajectory" in str(error.value) and error.value.value == "ros2"
