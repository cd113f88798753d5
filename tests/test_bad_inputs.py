"""Bad files through the command line, as a user meets them: a garbage robot file (from show, check and
a job), numbers written as 1e-7, and unit mistakes. Each is exit status 2 with one line naming the file,
line and field, no traceback, and nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pipeline.__main__ import main

from .files.test_schema import TWO_LINK

ROOT = Path(__file__).resolve().parent.parent


def fails_cleanly(capsys, args: list[str], *expected: str) -> str:
    """``main(args)`` exits 2 with one stderr line containing ``expected``; returns that line."""
    assert main(args) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    assert "Traceback" not in captured.err + captured.out
    for text in expected:
        assert text in lines[0], lines[0]
    return lines[0]


def job(tmp_path: Path, robot: str, **fields) -> Path:
    path = tmp_path / "job.yaml"
    path.write_text(yaml.safe_dump({"robot": robot, **fields}))
    return path


GARBAGE = {
    "binary": (bytes(range(256)) * 8, "document: is not UTF-8"),
    "png": (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00", "document: is not UTF-8"),
    "control bytes": (b"\x00\x01\x02\x03", "document: is not valid YAML"),
    "prose": ("Dear robot, please move.\n".encode(), "document: must be a mapping"),
}


@pytest.mark.parametrize("kind", list(GARBAGE))
@pytest.mark.parametrize("command", ["show", "check", "run"])
def test_garbage_robot_file(tmp_path, capsys, kind, command):
    content, problem = GARBAGE[kind]
    robot = tmp_path / "robot.yaml"
    robot.write_bytes(content)
    out = tmp_path / "out"
    if command == "run":
        args = ["run", str(job(tmp_path, "robot.yaml", angle_unit="deg", waypoints=[[0], [1]])), "--out", str(out)]
    else:
        args = [command, str(robot)] + (["--out", str(out)] if command == "check" else [])
    fails_cleanly(capsys, args, str(robot), problem)
    assert not out.exists() and not any(p.name.startswith(".") for p in tmp_path.iterdir())


def test_garbage_job_file(tmp_path, capsys):
    path = tmp_path / "job.yaml"
    path.write_bytes(b"\xff\xd8\xff\xe0 JFIF")
    fails_cleanly(capsys, ["run", str(path), "--out", str(tmp_path / "out")], str(path), "not UTF-8")
    assert not (tmp_path / "out").exists()


def test_exponent_numbers_are_numbers(tmp_path, capsys):
    robot = tmp_path / "two_link.yaml"
    robot.write_text(TWO_LINK.replace("qddd_max: 5000}", "qddd_max: 8e3}"))
    assert main(["show", str(robot)]) == 0                   # qddd_max: 8e3 is a number
    capsys.readouterr()
    path = tmp_path / "job.yaml"
    path.write_text("robot: two_link.yaml\nangle_unit: deg\nwaypoints: [[0, 0], [10, 20]]\ndt: 1e-7\n")
    fails_cleanly(capsys, ["run", str(path), "--out", str(tmp_path / "out")],
                  f"{path}:4: dt: must be in [0.0001, 0.1] s (got 1e-07)")
    assert not (tmp_path / "out").exists()
    path.write_text(path.read_text().replace("dt: 1e-7", "dt: 1e-2"))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0


@pytest.mark.parametrize("old, new, field, hint", [
    ("angle_unit: deg", "angle_unit: rad", "joints[0].q_max", "are these degrees? (angle_unit: rad)"),
    ("length_unit: mm", "length_unit: m", "joints[0].a", "is length_unit: m right?"),
    ("a: 300", "a: 0.3", "joints", "are the lengths in metres under length_unit: mm?"),
])
@pytest.mark.parametrize("command", ["show", "check"])
def test_unit_mistakes_in_robot_files(tmp_path, capsys, old, new, field, hint, command):
    robot = tmp_path / "robot.yaml"
    robot.write_text(TWO_LINK.replace(old, new).replace("a: 200", "a: 0.2" if new == "a: 0.3" else "a: 200"))
    args = [command, str(robot)] + (["--out", str(tmp_path / "out")] if command == "check" else [])
    fails_cleanly(capsys, args, str(robot), f": {field}: ", hint)
    assert not (tmp_path / "out").exists()


def test_gp7_in_radians_is_refused(tmp_path, capsys):
    robot = tmp_path / "gp7_rad.yaml"
    robot.write_text((ROOT / "models" / "gp7.yaml").read_text().replace("angle_unit: deg", "angle_unit: rad"))
    fails_cleanly(capsys, ["check", str(robot)], "are these degrees? (angle_unit: rad)")


def test_pose_in_metres_under_mm(tmp_path, capsys):
    path = job(tmp_path, "gp7", length_unit="mm", angle_unit="deg",
               waypoints=[{"xyz": [0.56, 0, 0.6], "rpy": [180, 0, 0]}, {"xyz": [0.5, 0.3, 0.45], "rpy": [180, 0, 0]}])
    fails_cleanly(capsys, ["run", str(path), "--out", str(tmp_path / "out")], "waypoints[0].xyz",
                  "closer than the end frame of gp7 comes", "is length_unit: mm right?")
    assert not (tmp_path / "out").exists()


def test_joint_degrees_under_rad(tmp_path, capsys):
    path = job(tmp_path, "arm6", angle_unit="rad", waypoints=[[0, 0, 0, 0, 0, 0], [0, 45, 30, 0, 0, 0]])
    fails_cleanly(capsys, ["run", str(path), "--out", str(tmp_path / "out")], "waypoints[1][1]",
                  "are these degrees?")


# -- issue 22: every count a user gives that multiplies work is bounded, refused at once ---------------------
@pytest.mark.parametrize("args, expected", [
    (["reach", "gp7", "--orientations", "1000000000", "--out", "never"], "orientations: must be a whole number in"),
    (["reach", "gp7", "--orientations", "2000", "--out", "never"], "step x orientations: gives 697,036 voxels"),
    (["reach", "gp7", "--workers", "1000000", "--out", "never"], "--workers: must be a whole number in [1, "),
    (["batch", str(ROOT / "trajectories" / "jobs"), "--workers", "1000000", "--out", "never"], "--workers: must be"),
])
def test_counts_that_multiply_work_are_refused_at_once(capsys, tmp_path, monkeypatch, args, expected):
    monkeypatch.chdir(tmp_path)
    fails_cleanly(capsys, args, expected)
    assert not (tmp_path / "never").exists()


def test_check_samples_are_bounded(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["check", "gp7", "--samples", "1000000000"])
    assert exit_.value.code == 2 and "--samples: must be in [1, 100,000]" in capsys.readouterr().err
