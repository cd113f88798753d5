"""check-program: an existing program checked in a cell as the controller runs it (limits, clearance with the
closest pair, cycle time per move), exit 1 when it would collide."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from pipeline.__main__ import main
from pipeline.program.job import parse_job
from pipeline.runner import program_texts, reported_program

CELLS = Path(__file__).resolve().parents[2] / "models" / "cells"
#: Over the pick, down to it (a stop), back up: straight tool moves beside the wall of gp7_wall_cell.
JOB = {"robot": "gp7", "cell": str(CELLS / "gp7_wall_cell.yaml"), "length_unit": "mm", "angle_unit": "deg",
       "tool": {"xyz": [0, 0, 120], "rpy": [0, 0, 0]}, "tcp_speed_max": 500, "start": [0, 0, 0, 0, -90, 0],
       "waypoints": [{"xyz": [550, 300, 400], "rpy": [180, 0, 30]},
                     {"xyz": [550, 300, 250], "rpy": [180, 0, 30], "move": "linear"},
                     {"xyz": [550, 300, 400], "rpy": [180, 0, 30], "move": "linear"},
                     {"xyz": [550, 100, 400], "rpy": [180, 0, 30], "move": "joint"}],
       "outputs": ["json"]}


@pytest.fixture(scope="module")
def timed():
    """(job, program, certified profile) of JOB."""
    job = parse_job(JOB, "<check>", "check_pick")
    program, profile, _ = reported_program(job)
    return job, program, profile


@pytest.fixture(scope="module")
def written(timed, tmp_path_factory):
    """(the JBI program's path, the certified duration [s]) of JOB."""
    job, program, profile = timed
    texts = program_texts(job, "jbi", program, profile)
    folder = tmp_path_factory.mktemp("check")
    path = folder / "CHECK_PICK.JBI"
    path.write_text(texts[".jbi"])
    return path, profile.duration


def blocked_cell(folder: Path) -> Path:
    """gp7_wall_cell with a fixture where the pick now is (the tool reaching down to z = 250 mm runs into it)."""
    cell = yaml.safe_load((CELLS / "gp7_wall_cell.yaml").read_text())
    cell["name"] = "gp7_wall_cell_moved"
    cell["objects"].append({"name": "fixture", "box": [80, 80, 200], "xyz": [550, 300, 200]})
    path = folder / "moved_cell.yaml"
    path.write_text(yaml.safe_dump(cell))
    return path


def test_a_program_in_a_free_cell_gets_its_cycle_time_as_written(written, capsys):
    path, certified_s = written
    assert main(["check-program", str(path), "--robot", "gp7", "--cell", str(CELLS / "gp7_wall_cell.yaml")]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert sum(line.lstrip().startswith("move ") for line in lines) == 3
    cycle = next(line for line in lines if line.startswith("cycle as written"))
    assert 0.95 * certified_s <= float(cycle.split()[3]) <= 1.15 * certified_s
    assert "clearance 10 mm: PASS; closest" in out and "FAIL" not in out


def test_a_target_that_now_collides_fails_naming_move_pair_and_time(written, tmp_path, capsys):
    path, _ = written
    report = tmp_path / "check.json"
    code = main(["check-program", str(path), "--robot", "gp7", "--cell", str(blocked_cell(tmp_path)),
                 "--out", str(report)])
    out = capsys.readouterr().out
    assert code == 1
    failure = next(line for line in out.splitlines() if line.startswith("FAIL: "))
    assert failure.startswith("FAIL: move 1 (linear) fails the clearance at ") and "tool is" in failure
    assert "from fixture" in failure
    saved = json.loads(report.read_text())
    assert saved["passed"] is False and saved["problems"] == [failure.removeprefix("FAIL: ")]
    assert [m["move"] for m in saved["moves"]] == [1, 2, 3]


def test_a_tool_option_is_six_numbers(written, capsys):
    path, _ = written
    with pytest.raises(SystemExit) as exit_:
        main(["check-program", str(path), "--robot", "gp7", "--tool", "0", "0", "120"])
    assert exit_.value.code == 2
    assert "--tool: expected 6 arguments" in capsys.readouterr().err


FANUC = Path(__file__).resolve().parents[1] / "data" / "programs" / "fanuc"


def test_a_frame_and_tool_selected_by_number_come_from_the_options(tmp_path, capsys):
    """TMPA.LS (a real program, Apache-2.0) selects user frame 1 and tool 1 without their data: refused naming the
    line, read with --frame and --tool (its source's README puts UF 1 670 mm below the base)."""
    robot = str(FANUC / "r2000ic165f_test.yaml")
    program = str(FANUC / "TMPA.LS")
    assert main(["read-program", program, "--robot", robot]) == 2
    assert "TMPA.LS" in capsys.readouterr().err
    out = tmp_path / "tmpa.yaml"
    assert main(["read-program", program, "--robot", robot, "--tool", "0", "0", "0", "0", "0", "0",
                 "--frame", "0", "0", "-670", "0", "0", "0", "--out", str(out)]) == 0
    assert yaml.safe_load(out.read_text())["waypoints"]


def test_a_frame_option_for_a_language_that_selects_none_is_refused(written, capsys):
    path, _ = written
    rapid = path.with_name("check.mod")
    rapid.write_text("MODULE m\nENDMODULE\n")
    assert main(["check-program", str(rapid), "--robot", "gp7", "--frame", "0", "0", "0", "0", "0", "0"]) == 2
    assert "--frame: a rapid program does not select a frame by number" in capsys.readouterr().err

