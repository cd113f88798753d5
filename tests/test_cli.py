"""The command line: show, check (exit codes, JSON reports), clear errors for bad input."""

from __future__ import annotations

import json

from pipeline.__main__ import main


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
