"""The scaling benchmark on a tiny map: its rates, speed-up, overhead, 64-worker estimate and goals, its
report and the CLI."""

from __future__ import annotations

import json
import math

import pytest

from pipeline.__main__ import main
from pipeline.bench.scale import CLUSTER_WORKERS, SPEEDUP_GOAL, UR_RATE_GOAL, run_scale_benchmark, step_for
from pipeline.model.robot import load_robot
from pipeline.scale.reach import plan_map


@pytest.fixture(scope="module")
def report():
    return run_scale_benchmark(poses=12_000, measure_poses=6_000, orientations=2, seed=1, overhead_tasks=10)


def test_the_step_gives_about_the_poses_asked_for():
    robot = load_robot("irb1600")
    step = step_for(robot, 50_000, 4)
    assert plan_map(robot, step=step, orientations=4).poses == pytest.approx(50_000, rel=0.1)


@pytest.mark.slow
def test_the_report_has_every_figure_and_an_honest_verdict(report):
    assert report.identical and report.robot == "irb1600"
    assert report.measure_poses == pytest.approx(6_000, rel=0.2) and report.map_poses == pytest.approx(12_000, rel=0.2)
    assert min(report.rate_in_process, report.rate_1_worker, report.rate_2_workers) > 0
    assert report.speedup == pytest.approx(report.rate_2_workers / report.rate_1_worker) and report.ceiling > 0
    assert report.map_s > 0 and report.overhead_ms > 0 and 0 < report.overhead_fraction
    rounds = math.ceil(report.map_chunks / CLUSTER_WORKERS)
    expected = rounds * (report.map_poses / report.map_chunks / (report.rate_1_worker * min(report.speedup / 2, 1))
                         + report.overhead_ms / 1e3)
    assert report.estimate_64_s == pytest.approx(expected)
    assert report.full_poses > report.map_poses and report.full_step_m == 0.025
    assert report.full_here_s == pytest.approx(report.full_poses / report.rate_2_workers) and report.full_64_s > 0
    (speedup, identical, ur) = report.goals
    assert speedup.passed == (report.speedup >= SPEEDUP_GOAL) and identical.passed
    assert report.ur_robot == "ur5" and ur.value == pytest.approx(report.ur_rate_in_process / report.rate_in_process)
    assert ur.passed == (ur.value >= UR_RATE_GOAL) and "ur5" in ur.bound
    text = report.format_table()
    assert "speed-up" in text and "per-chunk overhead" in text and "estimate for 64 workers" in text
    assert "what this machine gives 2 processes now" in text
    assert text.count("  PASS  ") + text.count("  FAIL  ") == 3 and "the UR family: ur5's map" in text
    assert report.to_dict()["passed"] == report.passed


@pytest.mark.slow
def test_without_a_ur_arm_its_goal_is_not_measured():
    """Two more Dask clusters (about 9 s): the slow suite."""
    report = run_scale_benchmark(poses=3_000, measure_poses=2_000, orientations=2, seed=1, overhead_tasks=2,
                                 ur_robot=None)
    ur = report.goals[2]
    assert ur.value is None and not ur.passed and "not measured" in ur.bound and report.ur_rate_in_process is None


def test_the_cli_refuses_no_poses(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "scale", "--poses", "0"])
    assert "--poses" in capsys.readouterr().err


@pytest.mark.slow
def test_the_cli_runs_the_suite_with_its_options_and_writes_json(report, tmp_path, monkeypatch, capsys):
    import pipeline.bench.scale

    asked = {}

    def recorded(**kwargs):
        asked.update(kwargs)
        return report

    monkeypatch.setattr(pipeline.bench.scale, "run_scale_benchmark", recorded)
    out = tmp_path / "scale.json"
    assert main(["bench", "scale", "--poses", "5000", "--robot", "gp7", "--seed", "3", "--out", str(out)]) == 0
    assert asked == {"robot": "gp7", "poses": 5000, "seed": 3}
    assert json.loads(out.read_text())["speedup"] == report.speedup and "Goals:" in capsys.readouterr().out
