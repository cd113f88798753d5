"""The Cartesian benchmark: report structure, certified profiles, the peer when installed, JSON, the
table, the CLI (a tiny run)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pipeline.bench.cartesian as cartesian
from pipeline.bench.cartesian import (
    MOVE_LENGTH_M,
    PEER,
    TCP_SPEED,
    run_cartesian_benchmark,
    segment_distance,
)
from pipeline.errors import ConfigurationError
from pipeline.timing.profile import CERTIFY_TOLERANCE

MOVES = 2


@pytest.fixture(scope="module")
def report():
    return run_cartesian_benchmark(robots=("gp7",), moves=MOVES, seed=0)


def test_report_structure(report):
    assert report.moves == MOVES and report.move_length_m == MOVE_LENGTH_M and report.tcp_speed_max == TCP_SPEED
    (robot,) = report.robots
    assert robot.robot_name == "gp7" and robot.dof == 6 and robot.moves == MOVES
    assert len(robot.records) == MOVES and robot.redraws == sum(r.redraws for r in robot.records)
    assert sum(robot.redraw_reasons.values()) == robot.redraws
    assert set(robot.redraw_reasons) <= {"ToolMoveError", "TimingError"}
    assert 0 < robot.ik_median_ms <= robot.ik_p95_ms and 0 < robot.timing_median_ms <= robot.timing_p95_ms
    assert 0 < robot.total_median_ms <= robot.total_p95_ms
    assert robot.certified == MOVES and robot.failures == 0
    for record in robot.records:
        ours = record.ours
        assert ours.certified and not ours.failure
        assert ours.ik_ms > 0 and ours.timing_ms > 0 and ours.total_ms == pytest.approx(ours.ik_ms + ours.timing_ms)
        assert ours.samples >= 2 and ours.profile_samples >= 2 and ours.duration_s > 0
        assert 0.0 <= ours.cruise_fraction <= 1.0
        assert 0.0 < ours.peak_speed_ratio <= 1.0 + CERTIFY_TOLERANCE       # certified: within the TCP limit
        assert 0.0 <= ours.line_deviation_mm <= 1.0 and 0.0 <= ours.dense_line_deviation_mm <= 1.0
        assert 0.0 <= ours.path_position_error_mm <= 0.1 + 1e-9             # joint_path_along's tolerance
        assert len(record.q0) == 6 and np.linalg.norm(record.direction) == pytest.approx(1.0)
    assert 0 <= robot.peak_at_limit <= MOVES
    assert [goal.name.split(":")[0] for goal in report.goals] == [
        "certified 0.5 m move under 50 ms", "TCP at >= 99 % of its speed limit on the straight part"]


def test_peer(report):
    robot = report.robots[0]
    if PEER in robot.unavailable:
        pytest.skip(robot.unavailable[PEER])
    assert robot.peer_median_ms > 0 and robot.peer_ratio_total > 0 and robot.peer_ratio_ik > 0
    assert 0 <= robot.peer_successes <= MOVES
    for record in robot.records:
        peer = record.peer
        assert peer.time_ms > 0 and peer.poses == record.ours.samples    # the same density as ours
        if peer.success:
            assert peer.solved == peer.poses and peer.midpoint_deviation_mm >= 0.0


def test_json_and_table(report):
    data = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    assert data["robots"][0]["robot_name"] == "gp7" and len(data["robots"][0]["records"]) == MOVES
    assert isinstance(data["passed"], bool) and len(data["goals"]) == 2
    table = report.format_table()
    assert "gp7" in table and "median ms" in table and "Goals" in table
    assert "no timing, no certification" in table
    goal_lines = table.split("Goals over all robots and moves:")[1].splitlines()
    verdicts = [line.split()[0] for line in goal_lines if line.strip() and not line.startswith("versions")]
    assert verdicts == ["PASS" if goal.passed else "FAIL" for goal in report.goals]


def test_segment_distance():
    p0, p1 = np.zeros(3), np.array([1.0, 0.0, 0.0])
    points = np.array([[0.5, 0.2, 0.0], [-0.3, 0.0, 0.4], [1.0, 0.0, 0.0]])
    assert segment_distance(points, p0, p1) == pytest.approx([0.2, 0.5, 0.0])


def test_missing_peer_is_reported(monkeypatch):
    def missing(robot):
        raise ImportError("No module named 'roboticstoolbox'")

    monkeypatch.setattr(cartesian, "rtb_path_solver", missing)
    report = run_cartesian_benchmark(robots=("gp7",), moves=1, seed=5)
    robot = report.robots[0]
    assert "roboticstoolbox" in robot.unavailable[PEER] and robot.peer_median_ms is None
    assert robot.records[0].peer is None and robot.certified == 1
    assert "unavailable" in report.format_table()
    json.dumps(report.to_dict(), allow_nan=False)


def test_bad_arguments():
    with pytest.raises(ConfigurationError, match="moves"):
        run_cartesian_benchmark(robots=("gp7",), moves=0)


def test_cli_bench_cartesian(tmp_path, capsys):
    from pipeline.__main__ import main

    out = tmp_path / "cartesian.json"
    assert main(["bench", "cartesian", "--robots", "gp7", "--moves", "1", "--out", str(out)]) == 0
    assert "Goals" in capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["moves"] == 1 and data["robots"][0]["robot_name"] == "gp7"
