"""The kinematics benchmark: its report, peers built from the spec that agree with our model, the
first calls in a fresh process and the goals."""

from __future__ import annotations

import json
import sys
import tempfile

import numpy as np
import pytest

import pipeline.bench.kinematics as kinematics_bench
from pipeline.bench.kinematics import (
    DRAKE,
    OURS,
    PINOCCHIO,
    RTB,
    VERIFY_CONFIGURATIONS,
    Implementation,
    drake_implementation,
    first_call_seconds,
    kinematics_goals,
    pinocchio_implementation,
    rtb_implementation,
    run_kinematics_benchmark,
    verify_implementation,
)
from pipeline.files.robot_spec import parse_robot_spec, preset_names
from pipeline.model.robot import Robot, load_robot


def _mixed_robots() -> list[Robot]:
    """Both conventions with every row type: prismatic, sign -1, offsets, base and tool transforms."""
    joints = [
        {"a": 50, "alpha": -90, "d": 300, "theta_offset": 30, "sign": -1, "q_min": -170, "q_max": 170, "qd_max": 90},
        {"type": "prismatic", "a": 20, "alpha": 90, "d": 100, "theta_offset": -45, "sign": -1,
         "q_min": -200, "q_max": 200, "qd_max": 500},
        {"type": "prismatic", "a": 0, "alpha": -30, "d": 10, "q_min": 0, "q_max": 300, "qd_max": 500},
        {"a": 200, "alpha": 0, "d": 40, "theta_offset": 90, "q_min": -170, "q_max": 170, "qd_max": 90},
    ]
    return [
        Robot(parse_robot_spec({
            "name": f"mixed_{convention}", "convention": convention, "length_unit": "mm", "angle_unit": "deg",
            "joints": joints,
            "base": {"xyz": [10, -20, 30], "rpy": [5, -10, 15]},
            "tool": {"xyz": [0, 15, 120], "rpy": [90, 0, -30]},
        }))
        for convention in ("standard", "modified")
    ]


@pytest.mark.parametrize("name", ["gp7", "arm5"])
def test_benchmark_report(name):
    report = run_kinematics_benchmark(name, batch=200, single_calls=50, first_calls=False)
    rows = {row.name: row for row in report.rows}
    assert report.rows[0].name == OURS
    drake = rows[DRAKE]
    assert drake.fk_single_us > 0 and drake.jacobian_single_us > 0
    assert drake.fk_batch_us is None and drake.jacobian_batch_us is None
    assert rows[OURS].fk_batch_us > 0 and rows[OURS].jacobian_batch_us > 0
    assert set(report.ratio) == set(rows) - {OURS}
    assert all(ratio > 0 for ratios in report.ratio.values() for ratio in ratios.values())
    assert set(rows) | set(report.unavailable) == {OURS, DRAKE, RTB, PINOCCHIO}
    table = report.format_table()
    assert name in table and DRAKE in table and "ours / Drake" in table
    assert "First calls in a fresh process: not measured" in table
    data = json.loads(json.dumps(report.to_dict()))
    assert data["robot_name"] == name and data["first_call"] is None
    fk, jacobian = report.goals
    if PINOCCHIO in report.ratio:
        assert fk.value == report.ratio[PINOCCHIO]["fk_single"]
        assert jacobian.value == report.ratio[PINOCCHIO]["jacobian_single"]
        assert data["passed"] == (fk.value <= 1.0 and jacobian.value <= 1.0)
    assert f"  {'PASS' if fk.passed else 'FAIL'}  FK single call, ours / {PINOCCHIO} [x]: " in table


def test_missing_optional_peers_are_reported_not_fatal(monkeypatch):
    monkeypatch.setitem(sys.modules, "roboticstoolbox", None)
    monkeypatch.setitem(sys.modules, "pinocchio", None)
    report = run_kinematics_benchmark("arm5", batch=50, single_calls=10, first_calls=False)
    assert set(report.unavailable) == {RTB, PINOCCHIO}
    assert [row.name for row in report.rows] == [OURS, DRAKE]
    table = report.format_table()
    assert f"unavailable: {RTB}" in table
    assert not report.passed and all(goal.value is None and not goal.passed for goal in report.goals)
    assert f"FAIL  Jacobian single call, ours / {PINOCCHIO} [x]: - (<= 1; not measured, {PINOCCHIO} unavailable: " \
           in table


def test_goals_verdicts():
    ratio = {PINOCCHIO: {"fk_single": 0.8, "jacobian_single": 1.2, "fk_per_config": 0.1, "jacobian_per_config": 0.1}}
    fk, jacobian = kinematics_goals(ratio, {})
    assert (fk.value, fk.passed, fk.bound) == (0.8, True, "<= 1")
    assert (jacobian.value, jacobian.passed) == (1.2, False)


@pytest.mark.slow
def test_first_calls_share_one_new_cache_directory_and_remove_it(monkeypatch, tmp_path):
    """The cold run finds the cache empty, the warm one finds what the cold one left; then it is gone."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(kinematics_bench, "FIRST_CALL_SCRIPT", (
        "import json, os, sys\n"
        "cache = os.environ['NUMBA_CACHE_DIR']\n"
        "found = {'empty': float(not os.listdir(cache)), 'marked': float(os.path.exists(cache + '/marker'))}\n"
        "open(cache + '/marker', 'w').close()\n"
        "import pipeline.model.robot\n"
        "found['gp7'] = float(sys.argv[1] == 'gp7')\n"
        "print(json.dumps(found))\n"))
    assert first_call_seconds() == {"cold": {"empty": 1.0, "marked": 0.0, "gp7": 1.0},
                                    "warm": {"empty": 0.0, "marked": 1.0, "gp7": 1.0}}
    assert list(tmp_path.iterdir()) == []


def test_a_failing_first_call_process_is_an_error(monkeypatch):
    monkeypatch.setattr(kinematics_bench, "FIRST_CALL_SCRIPT", "import sys; sys.exit('no compiler here')")
    with pytest.raises(RuntimeError, match="exited with status 1: no compiler here"):
        first_call_seconds()


@pytest.mark.slow
def test_first_calls_cold_then_warm():
    """Real fresh processes: the cold one compiles every kernel it uses, the warm one loads them from the cache;
    each step is measured (how much faster the warm one is belongs to the benchmark's report, not to a test
    that must pass on a busy machine)."""
    first_call = first_call_seconds()
    steps = ["import", "load", "fk", "jacobian", "ik analytic", "ik jacobian"]
    assert list(first_call) == ["cold", "warm"]
    for seconds in first_call.values():
        assert list(seconds) == steps and all(value > 0 for value in seconds.values())


def test_a_wrong_peer_is_refused(rng):
    robot = load_robot("gp7")
    drake = drake_implementation(robot)
    shifted = Implementation("shifted", lambda q: drake.fk(q) + 1e-6, drake.jacobian)
    with pytest.raises(RuntimeError, match="shifted disagrees with ours on gp7"):
        verify_implementation(robot, shifted, robot.random_configurations(rng, 3))


@pytest.mark.parametrize("peer", ["roboticstoolbox", "pinocchio"])
def test_peers_agree_with_ours_on_every_robot(peer, rng):
    pytest.importorskip(peer)
    build = rtb_implementation if peer == "roboticstoolbox" else pinocchio_implementation
    robots = [load_robot(name) for name in preset_names()] + _mixed_robots()
    for robot in robots:
        impl = build(robot)
        errors = verify_implementation(robot, impl, robot.random_configurations(rng, VERIFY_CONFIGURATIONS))
        assert max(errors.values()) < 1e-12, (robot.name, errors)
        if impl.fk_batch is not None:
            assert impl.fk_batch(robot.random_configurations(rng, 5)).shape == (5, 4, 4)
        assert np.shape(impl.jacobian(np.zeros(robot.dof))) == (6, robot.dof)
