"""The command line: show, check (exit codes, JSON reports), one-line errors for bad input (exit 2) and
for internal errors (exit 1), interrupts (exit 130), help texts."""

from __future__ import annotations

import json
import logging
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

import pipeline.__main__
import pipeline.runner
from pipeline.__main__ import build_parser, main
from pipeline.errors import TimingError
from pipeline.files.atomic import OWNER_MARKER

ROOT = Path(__file__).resolve().parent.parent


def test_show_prints_dh_table_and_pose(capsys):
    assert main(["show", "gp7"]) == 0
    out = capsys.readouterr().out
    assert "alpha[deg]" in out and "0.56" in out and "Singularity" in out


def test_check_writes_reports_and_exits_zero(tmp_path, capsys):
    assert main(["check", "arm5", "--samples", "20", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "arm5_jacobian_check.json").read_text())
    assert report["passed"] and report["samples"] == 20
    assert "all checks passed" in capsys.readouterr().out


def test_unknown_robot_exits_2_with_a_message(capsys):
    assert main(["check", "nope"]) == 2
    assert "nope" in capsys.readouterr().err


def test_bad_robot_file_exits_2_naming_the_field(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("name: x\nconvention: standard\nlength_unit: mm\nangle_unit: deg\njoints:\n"
                    "  - {a: 1, alpha: 0, d: 0, q_min: 10, q_max: -10, qd_max: 1}\n")
    assert main(["show", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "joints[0].q_min" in err


def test_check_out_replaces_the_report_folder_whole(tmp_path):
    out = tmp_path / "check"
    assert main(["check", "arm5", "--samples", "5", "--out", str(out)]) == 0
    assert main(["check", "arm6", "--samples", "5", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [OWNER_MARKER, "arm6_jacobian_check.json"]
    assert [p.name for p in tmp_path.iterdir()] == ["check"]


@pytest.mark.parametrize("args, option", [
    (["check", "gp7", "--samples", "0"], "--samples"),
    (["check", "gp7", "--samples", "-3"], "--samples"),
    (["check", "gp7", "--seed", "-1"], "--seed"),
    (["bench", "ik", "--targets", "0"], "--targets"),
    (["bench", "timing", "--paths", "-1"], "--paths"),
    (["bench", "kinematics", "--batch", "0"], "--batch"),
    (["bench", "kinematics", "--calls", "x"], "--calls"),
    (["run", "job.yaml", "--out", "o", "--max-samples", "0"], "--max-samples"),
])
def test_bad_numbers_exit_2_with_one_line_naming_the_option(args, option, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([*args, "--out", str(tmp_path / "out")] if args[0] == "check" else args)
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and err.count("\n") == 1 and err.startswith("error: ") and option in err
    assert list(tmp_path.iterdir()) == []


def test_an_internal_error_is_one_line_with_a_hint_and_a_traceback_with_v(monkeypatch, capsys):
    def broken(name):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(pipeline.__main__, "load_robot", broken)
    assert main(["show", "gp7"]) == 1
    err = capsys.readouterr().err
    assert err == "internal error: RuntimeError: boom second line (run with -v for the traceback)\n"
    assert main(["-v", "show", "gp7"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("Traceback (most recent call last)") and "in broken" in err
    assert err.endswith("internal error: RuntimeError: boom second line (run with -v for the traceback)\n")


def test_an_interrupt_exits_130_and_removes_the_staging(tmp_path, monkeypatch, capsys):
    def interrupted(job, scene=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline.runner, "compile_job", interrupted)
    assert main(["run", str(ROOT / "trajectories" / "jobs" / "arm5_joint_spline.yaml"), "--out",
                 str(tmp_path / "out")]) == 130
    assert capsys.readouterr().err.count("\n") == 1 and list(tmp_path.iterdir()) == []


def test_help_names_every_command_and_an_existing_job(capsys):
    assert ("{run,program,read-program,check-program,show,fk,ik,check,export,import-urdf,check-cell,bench,build-kernels,"
            "batch,reach,ui}" in build_parser().format_help())
    assert ("{run,program,read-program,check-program,show,fk,ik,check,check-cell,bench,build-kernels,export,import-urdf,"
            "batch,reach,ui}") in "".join(pipeline.__main__.__doc__.split())
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    example = re.search(r"trajectories/jobs/\S+\.yaml", out).group(0)
    assert (ROOT / example).is_file() and "--max-samples" in out


def test_bench_out_that_is_a_folder_fails_before_the_benchmark(tmp_path, monkeypatch, capsys):
    import pipeline.bench.kinematics

    monkeypatch.setattr(pipeline.bench.kinematics, "run_kinematics_benchmark",
                        lambda *args, **kwargs: pytest.fail("the benchmark ran"))
    assert main(["bench", "kinematics", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == f"error: {tmp_path}: is a folder; give a file name for this output\n"


# -- the first hour: help for users, the console script, demo cells by name ------------------------------
VERBS = ("run", "program", "read-program", "show", "fk", "ik", "check", "export", "import-urdf", "check-cell", "bench",
         "batch", "reach", "ui")


@pytest.mark.parametrize("verb", ["", *VERBS])
def test_every_help_is_for_users_and_shows_an_example(verb, capsys):
    with pytest.raises(SystemExit) as leaving:
        main([verb, "--help"] if verb else ["--help"])
    assert leaving.value.code == 0
    out = capsys.readouterr().out
    assert "`" not in out and "configures logging" not in out       # not the developers' docstring (RST)
    assert f"examples:\n  python -m pipeline {verb}".rstrip() in out


def test_the_console_script_is_main_under_its_own_name(capsys):
    tomllib = pytest.importorskip("tomllib")
    target = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]["dh-pipeline"]
    module, function = target.split(":")
    assert module == "pipeline.__main__" and getattr(pipeline.__main__, function) is pipeline.__main__.console_script
    with pytest.raises(SystemExit):
        main(["--help"], prog="dh-pipeline")
    out = capsys.readouterr().out
    assert out.startswith("usage: dh-pipeline") and "  dh-pipeline run trajectories/" in out


def test_demo_cells_resolve_by_name_and_an_unknown_name_lists_them(capsys):
    from pipeline.cell.cell_file import cell_names, load_cell, resolve_cell_path

    names = sorted(path.stem for path in (ROOT / "models" / "cells").glob("*.yaml"))
    assert cell_names() == names and {"gp7_shelf_cell", "gp7_wall_cell", "irb1600_bookshelf"} <= set(names)
    assert resolve_cell_path("gp7_wall_cell").samefile(ROOT / "models" / "cells" / "gp7_wall_cell.yaml")
    assert load_cell("gp7_shelf_cell").name == "gp7_shelf_cell"
    assert main(["check-cell", "gp7_wal"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: gp7_wal: ") and f"demo cells: {', '.join(names)}" in err


def test_a_job_names_a_demo_cell_from_any_directory(tmp_path, monkeypatch):
    from pipeline.errors import JobFileError
    from pipeline.program.job import parse_job

    monkeypatch.chdir(tmp_path)
    doc = {"cell": "gp7_wall_cell", "angle_unit": "deg", "waypoints": [[0, 0, 0, 0, -90, 0], [10, 0, 0, 0, -90, 0]]}
    job = parse_job(doc, "job.yaml", base_dir=tmp_path)
    assert job.cell.name == "gp7_wall_cell" and job.robot.name == "gp7"
    with pytest.raises(JobFileError, match=r"job.yaml:.*cell: .*demo cells: gp7_bookshelf, gp7_box, gp7_machine_door, "
                                           r"gp7_rack, gp7_shelf_cell, gp7_table_clutter, gp7_tote, "
                                           r"gp7_wall_cell, irb1600_"):
        parse_job({**doc, "cell": "gp7_wal"}, "job.yaml", base_dir=tmp_path)


def test_toppra_own_log_lines_show_only_with_v(monkeypatch, capsys, caplog):
    """toppra logs its failures itself before ours is raised: without -v only our one error line."""
    def failing(name):
        logging.getLogger("toppra.algorithm.algorithm").warning("Fail to parametrize path. Return code: 1")
        raise TimingError("toppra found no profile")

    monkeypatch.setattr(pipeline.__main__, "load_robot", failing)
    assert main(["show", "gp7"]) == 2
    assert capsys.readouterr().err == "error: toppra found no profile\n"
    assert not [r for r in caplog.records if r.name.startswith("toppra")]
    assert main(["-v", "show", "gp7"]) == 2
    assert [r.getMessage() for r in caplog.records if r.name.startswith("toppra")] == [
        "Fail to parametrize path. Return code: 1"]


@pytest.mark.parametrize("args, message", [
    (["ik", "gp7", "--", "500", "0", "400", "180", "0", "--"], "the TCP pose is six numbers X Y Z ROLL PITCH YAW"),
    (["reach", "gp7", "--step", "1e308", "--out", "map"], "step: is larger than the reach of gp7"),
    (["check-cell", "gp7_wall_cell", "--q", "0", "0", "0"], "--q: gp7 has 6 joints"),
])
def test_bad_input_is_one_error_line_never_an_internal_error(args, message, tmp_path, monkeypatch, capsys):
    """Each was an internal error (exit 1: ValueError, OverflowError after numpy warnings)."""
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert err.startswith("error: ") and err.count("\n") == 1 and message in err and "internal" not in err
    assert list(tmp_path.iterdir()) == []


def test_a_reader_that_leaves_ends_the_command_quietly(tmp_path):
    """``dh-pipeline ik ... | head -1``: an internal error (BrokenPipeError, exit 1) before; now the exit of a
    process ended by SIGPIPE, nothing on stderr."""
    command = [sys.executable, "-m", "pipeline", "ik", "gp7", "500", "0", "400", "180", "0", "0"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path)
    process.stdout.close()                              # the reader is gone before the first line
    _, err = process.communicate(timeout=300)
    assert process.returncode == 128 + signal.SIGPIPE and b"error" not in err


def test_check_cell_checks_a_home_pose(capsys):
    """KUKA's zero pose is stretched into most cells: --q checks the pose the robot really starts from."""
    assert main(["check-cell", "gp7_wall_cell", "--q", "0", "-30", "30", "0", "60", "0"]) == 0
    out = capsys.readouterr().out
    assert "at q = [0, -30, 30, 0, 60, 0] deg: closest obstacle" in out and "is collision-free" in out
