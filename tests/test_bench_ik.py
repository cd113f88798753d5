"""The IK benchmark: report structure, strict judging, JSON, the table (a tiny run)."""

from __future__ import annotations

import json

import pytest

from pipeline.bench.ik import DRAKE_RAW, PEERS, RTB_1, RTB_100, ours_name, run_ik_benchmark
from pipeline.errors import ConfigurationError

TARGETS = 5


@pytest.fixture(scope="module")
def report():
    return run_ik_benchmark(robots=("gp7",), targets=TARGETS, seed=3, methods=("drake",))


def test_report_structure(report):
    assert report.targets == TARGETS and report.methods == ("drake",)
    (robot,) = report.robots
    assert robot.robot_name == "gp7" and robot.dof == 6
    names = [row.name for row in robot.rows]
    assert names[0] == ours_name("drake")
    assert set(names[1:]) | set(robot.unavailable) == set(PEERS)
    assert DRAKE_RAW in names
    for row in robot.rows:
        assert row.targets == TARGETS and row.errors == 0
        assert 0 <= row.strict <= TARGETS and 0 <= row.reported <= TARGETS
        assert row.reported_not_strict <= row.reported
        assert row.strict_pct == pytest.approx(100.0 * row.strict / TARGETS)
        assert 0 < row.median_us <= row.p95_us
    ours = robot.rows[0]
    assert ours.ours and ours.reported_not_strict == 0 and ours.strict == TARGETS
    peers = [row for row in robot.rows if not row.ours]
    assert robot.fastest_peer == min(peers, key=lambda r: r.median_us).name
    assert set(robot.ratio) == {ours.name} and set(robot.ratio[ours.name]) == {r.name for r in peers}
    if RTB_100 in names:
        rtb = next(row for row in robot.rows if row.name == RTB_100)
        assert rtb.reported_not_strict == 0     # its tolerance implies our strict test
        assert RTB_1 in names


def test_json_and_table(report):
    data = json.loads(json.dumps(report.to_dict()))
    assert data["robots"][0]["rows"][0]["name"] == ours_name("drake")
    table = report.format_table()
    assert "strict" in table and "gp7" in table and "median" in table
    assert "fastest numeric peer median" in table


def test_unknown_method_is_a_configuration_error():
    with pytest.raises(ConfigurationError, match="unknown IK method"):
        run_ik_benchmark(robots=("gp7",), targets=1, methods=("nope",))


def test_unavailable_method_is_reported(monkeypatch):
    import pipeline.ik as ik

    real = ik.solve_ik

    def solve_ik(robot, X, q_seed=None, method="auto", **options):
        if method == "jacobian":
            raise NotImplementedError("not written yet")
        return real(robot, X, q_seed=q_seed, method=method, **options)

    monkeypatch.setattr(ik, "solve_ik", solve_ik)
    report = run_ik_benchmark(robots=("gp7",), targets=2, seed=1, methods=("jacobian", "drake"))
    robot = report.robots[0]
    assert "NotImplementedError" in robot.unavailable[ours_name("jacobian")]
    assert ours_name("jacobian") not in [row.name for row in robot.rows]


def test_cli_bench_ik(tmp_path, capsys):
    from pipeline.__main__ import main

    out = tmp_path / "ik.json"
    code = main(["bench", "ik", "--robots", "gp7", "--targets", "2", "--methods", "drake", "--seed", "4",
                 "--out", str(out)])
    assert code == 0
    assert "strict" in capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["targets"] == 2 and data["robots"][0]["robot_name"] == "gp7"
