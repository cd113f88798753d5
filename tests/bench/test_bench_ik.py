"""The IK benchmark: report structure, strict judging, JSON, the table (a tiny run); the closed-form
peers (OPW, EAIK) built from the spec; the goals."""

from __future__ import annotations

import dataclasses
import json
import math
import sys

import numpy as np
import pytest

from pipeline.bench.ik import (
    ANALYTIC_BATCH,
    CLOSED_FORM_PEERS,
    DRAKE_RAW,
    EAIK,
    NUMERIC_PEERS,
    OPW,
    PEERS,
    ROBOTS,
    RTB_1,
    RTB_100,
    UR5_FILE,
    IkRobotReport,
    IkRow,
    OpwPeer,
    build_eaik,
    closed_form_answer,
    evaluate_goals,
    ours_name,
    layout_goals,
    layout_rows,
    run_ik_benchmark,
)
from pipeline.errors import ConfigurationError
from pipeline.files.branch_names import SPHERICAL_WRIST, THREE_PARALLEL
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.ik.result import within_limits
from pipeline.model.robot import Robot, load_robot

TARGETS = 5
OPW_ARMS = ("gp7", "irb1600", "lrmate200id", "arm6", "gp7 tilted, with a tool")


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
    numeric = [row for row in peers if row.name in NUMERIC_PEERS]
    assert robot.fastest_peer == min(numeric, key=lambda r: r.median_us).name
    assert set(robot.ratio) == {ours.name} and set(robot.ratio[ours.name]) == {r.name for r in peers}
    if RTB_100 in names:
        rtb = next(row for row in robot.rows if row.name == RTB_100)
        assert rtb.reported_not_strict == 0     # its tolerance implies our strict test
        assert RTB_1 in names
    for row in peers:
        if row.name in CLOSED_FORM_PEERS:       # every target is reachable: a closed form solves all
            assert row.strict == row.reported == TARGETS, row


def test_json_and_table(report):
    data = json.loads(json.dumps(report.to_dict()))
    assert data["robots"][0]["rows"][0]["name"] == ours_name("drake")
    assert data["passed"] is False and len(data["goals"]) == len(report.goals)
    table = report.format_table()
    assert "strict" in table and "gp7" in table and "median" in table
    assert "(fastest numeric peer, " in table and "Goals (issues 15, 25, 39):" in table


def test_goals_without_our_rows_are_not_measured(report):
    """Only ours: drake ran: every goal is reported, none measured, none passed."""
    assert len(report.goals) == 6
    for goal in report.goals:
        assert goal.value is None and not goal.passed and "not measured" in goal.bound
    assert f"not measured, {ours_name('jacobian')}: not run" in report.format_table()


def test_unknown_method_is_a_configuration_error():
    with pytest.raises(ConfigurationError, match="unknown IK method"):
        run_ik_benchmark(robots=("gp7",), targets=1, methods=("nope",))


def test_unavailable_method_is_reported(monkeypatch):
    import pipeline.model.ik as ik

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


# -- a small run of the methods the goals are about -----------------------------------------------
def test_small_run_has_every_goal_measured():
    pytest.importorskip("roboticstoolbox")
    pytest.importorskip("py_opw_kinematics")
    report = run_ik_benchmark(robots=("gp7",), targets=4, seed=2, methods=("analytic", "jacobian"))
    (robot,) = report.robots
    rows = {row.name: row for row in robot.rows}
    assert {ours_name("analytic"), ours_name("jacobian"), ANALYTIC_BATCH, RTB_100, OPW, EAIK} <= set(rows)
    assert rows[ANALYTIC_BATCH].ours and rows[ANALYTIC_BATCH].targets == 4
    assert [goal.name.split(": ", 1)[0] for goal in report.goals] == ["gp7"] * 9       # 3 of them array layouts
    for goal in report.goals:
        assert goal.value is not None and goal.value > 0 and "not measured" not in goal.bound, goal
    analytic_vs_opw = rows[ours_name("analytic")].median_us / rows[OPW].median_us
    assert any(goal.value == pytest.approx(analytic_vs_opw) for goal in report.goals)
    assert any(goal.value == rows[ANALYTIC_BATCH].median_us for goal in report.goals)
    table = report.format_table()
    assert f"x {OPW} (" in table and f"x {EAIK} (" in table
    assert table.count("PASS  ") + table.count("FAIL  ") == 9
    assert report.passed == all(goal.passed for goal in report.goals)


def test_array_layouts_are_timed_beside_the_c_ordered_calls_with_the_same_answers():
    """IK on Fortran-ordered poses, FK and the Jacobian on strided joint vectors: a row each, in the report of a
    run with the closed form on the GP7, with a goal each."""
    report = run_ik_benchmark(robots=("gp7",), targets=4, seed=2, methods=("analytic",))
    calls = [row.call for row in report.layouts]
    assert calls == ["robot.ik(X)", "robot.fk(q)", "robot.jacobian(q)"]
    for row in report.layouts:
        assert row.identical and row.targets == 4 and row.ratio == row.other_us / row.c_us
    layout = [goal for goal in report.goals if "C-ordered" in goal.name]
    assert [goal.value for goal in layout] == [row.ratio for row in report.layouts]
    assert "array layouts (gp7, 4 calls each" in report.format_table()
    assert run_ik_benchmark(robots=("gp7",), targets=2, seed=2, methods=("drake",)).layouts == ()


def test_a_different_answer_fails_the_layout_goal_whatever_the_time():
    (row, *_) = layout_rows(load_robot("gp7"), load_robot("gp7").random_configurations(np.random.default_rng(1), 3))
    (goal,) = layout_goals((dataclasses.replace(row, ratio=0.5, identical=False),))
    assert not goal.passed and "they differ" in goal.bound


# -- goals, on rows made up here --------------------------------------------------------------------
def _row(name: str, median_us: float, p95_us: float, strict_pct: float = 100.0) -> IkRow:
    return IkRow(name=name, ours=name.startswith("ours: "), targets=1000, reported=1000, strict=int(10 * strict_pct),
                 reported_not_strict=0, errors=0, reported_pct=100.0, strict_pct=strict_pct, median_us=median_us,
                 p95_us=p95_us)


def _robot(name: str, *rows: IkRow, unavailable=None, family: str = "", found: float | None = None) -> IkRobotReport:
    return IkRobotReport(robot_name=name, convention="standard", dof=6, rows=rows, ratio={}, fastest_peer=RTB_100,
                         unavailable=unavailable or {}, family=family, original_found_pct=found)


def test_goals_verdicts():
    gp7 = _robot("gp7", _row(ours_name("analytic"), 10.0, 20.0), _row(ours_name("jacobian"), 100.0, 700.0, 99.95),
                 _row(ANALYTIC_BATCH, 4.0, 4.0), _row(RTB_100, 100.0, 200.0), _row(OPW, 4.0, 6.0))
    arm6 = _robot("arm6", _row(ours_name("jacobian"), 90.0, 100.0, 99.8), _row(RTB_100, 100.0, 200.0))
    goals = {goal.name: goal for goal in evaluate_goals((gp7, arm6))}
    analytic, dls = ours_name("analytic"), ours_name("jacobian")
    expected = {
        f"gp7: {analytic} / {RTB_100}, median time [x]": (0.1, True),
        f"gp7: {analytic} / {OPW}, median time [x]": (2.5, False),
        f"gp7: {ANALYTIC_BATCH} [µs]": (4.0, True),
        f"gp7: {dls} / {RTB_100}, median time [x]": (1.0, True),
        f"gp7: {dls} / {RTB_100}, p95 time [x]": (3.5, False),
        f"gp7: {dls} strict success [%]": (99.95, True),
        f"arm6: {dls} / {RTB_100}, median time [x]": (0.9, True),
        f"arm6: {dls} / {RTB_100}, p95 time [x]": (0.5, True),
        f"arm6: {dls} strict success [%]": (99.8, False),
    }
    assert list(goals) == list(expected)
    for name, (value, passed) in expected.items():
        assert goals[name].value == pytest.approx(value) and goals[name].passed is passed, name


def test_ur_family_goals_verdicts():
    """The UR family's goals: against the spherical-wrist robots' median of medians and RTB_100, strict
    success and the original configuration found, on each UR-family robot alone."""
    analytic = ours_name("analytic")
    gp7 = _robot("gp7", _row(analytic, 10.0, 20.0), _row(RTB_100, 100.0, 200.0), family=SPHERICAL_WRIST)
    irb = _robot("irb1600", _row(analytic, 14.0, 20.0), family=SPHERICAL_WRIST)
    lrmate = _robot("lrmate200id", _row(analytic, 20.0, 20.0), family=SPHERICAL_WRIST)
    ur5 = _robot("ur5", _row(analytic, 21.0, 40.0, 99.9), _row(RTB_100, 50.0, 90.0), family=THREE_PARALLEL,
                 found=100.0)
    goals = {goal.name: goal for goal in evaluate_goals((gp7, irb, lrmate, ur5)) if goal.name.startswith("ur5")
             and "jacobian" not in goal.name}
    expected = {
        f"ur5: {analytic} / the spherical-wrist robots' (the median of theirs), median time [x]": (1.5, True),
        f"ur5: {analytic} / {RTB_100}, median time [x]": (0.42, True),
        f"ur5: {analytic} strict success [%]": (99.9, False),
        "ur5: the original configuration among the closed form's branches [%]": (100.0, True),
    }
    assert list(goals) == list(expected)
    for name, (value, passed) in expected.items():
        assert goals[name].value == pytest.approx(value) and goals[name].passed is passed, name
    alone = evaluate_goals((ur5,))[1]
    assert alone.value is None and not alone.passed and "no spherical-wrist robot" in alone.bound


def test_a_small_run_of_the_ur5_reports_its_family_and_the_original_configuration():
    assert str(UR5_FILE) in ROBOTS
    report = run_ik_benchmark(robots=("gp7", str(UR5_FILE)), targets=4, seed=2, methods=("analytic",))
    gp7, ur5 = report.robots
    assert (gp7.family, ur5.family) == (SPHERICAL_WRIST, THREE_PARALLEL)
    assert ur5.original_found_pct == 100.0 and gp7.original_found_pct == 100.0
    goals = {goal.name: goal for goal in report.goals if goal.name.startswith("ur5")}
    assert goals[f"ur5: {ours_name('analytic')} strict success [%]"].passed
    assert goals["ur5: the original configuration among the closed form's branches [%]"].passed
    assert "closed form: three parallel axes" in report.format_table()


def test_goals_with_a_missing_peer_or_robot_are_not_measured():
    gp7 = _robot("gp7", _row(ours_name("analytic"), 10.0, 20.0), _row(RTB_100, 100.0, 200.0),
                 unavailable={OPW: "ImportError: No module named 'py_opw_kinematics'"})
    goals = evaluate_goals((gp7,))
    opw = next(goal for goal in goals if OPW in goal.name)
    assert opw.value is None and not opw.passed
    assert opw.bound == f"<= 2; not measured, {OPW}: ImportError: No module named 'py_opw_kinematics'"
    (missing, *_) = evaluate_goals((_robot("arm6", _row(RTB_100, 100.0, 200.0)),))
    assert missing.value is None and not missing.passed and "gp7 is not in this run" in missing.bound


# -- the closed-form peers ------------------------------------------------------------------------
def _arm(name: str) -> Robot:
    """A preset, or the GP7 on a tilted, shifted base with a tool off its flange axis."""
    if name != "gp7 tilted, with a tool":
        return load_robot(name)
    spec = load_robot("gp7").spec
    return Robot(dataclasses.replace(spec, name="gp7_tilted", X_BaseD0=rpy_position_to_pose([0.3, -0.2, 0.5],
                                                                                              [0.1, -0.2, 0.3]),
                                     X_DnE=spec.X_DnE @ rpy_position_to_pose([0.0, 0.4, 0.2], [0.05, 0.0, 0.12])))


def _non_opw_arm() -> Robot:
    """GP7 with a 50 mm offset along axis 5: its wrist axes no longer meet."""
    spec = load_robot("gp7").spec
    joints = list(spec.joints)
    joints[4] = dataclasses.replace(joints[4], d=0.05)
    return Robot(dataclasses.replace(spec, name="gp7_offset_wrist", joints=tuple(joints)))


@pytest.mark.parametrize("name", OPW_ARMS)
def test_opw_parameters_reproduce_our_fk(name, rng):
    pytest.importorskip("py_opw_kinematics")
    robot = _arm(name)
    peer = OpwPeer.of(robot)
    for q in robot.random_configurations(rng, 10):
        assert np.abs(peer.fk(q) - robot.fk(q)).max() < 1e-12
        solutions = np.asarray(peer.solve(robot.fk(q), q))          # our joint values
        assert solutions.shape[1:] == (6,) and 1 <= len(solutions) <= 8
        wrapped = np.angle(np.exp(1j * (solutions - q)))              # differences modulo 2 pi
        assert np.abs(wrapped).max(axis=1).min() < 1e-9               # q is one of the branches
        for solution in solutions:
            assert np.abs(robot.fk(solution) - robot.fk(q)).max() < 1e-9


def test_opw_parameters_of_the_gp7():
    """The GP7's DH magnitudes (models/gp7.yaml) as OPW lengths [m]; J3's -90 deg between the two zeros."""
    pytest.importorskip("py_opw_kinematics")
    peer = OpwPeer.of(load_robot("gp7"))
    lengths = {key: peer.parameters[key] for key in ("a1", "a2", "b", "c1", "c2", "c3", "c4")}
    assert lengths == pytest.approx({"a1": 0.04, "a2": -0.04, "b": 0.0, "c1": 0.33, "c2": 0.445, "c3": 0.44,
                                     "c4": 0.08}, abs=1e-12)
    assert peer.parameters["offsets"] == pytest.approx((0.0, 0.0, -math.pi / 2, 0.0, 0.0, 0.0), abs=1e-12)
    assert peer.parameters["flip_axes"] == (False, False, True, True, True, True)
    assert peer.X_BO is None and peer.X_OB is None                      # OPW's base frame is ours


def test_a_robot_the_closed_forms_do_not_fit_is_refused():
    pytest.importorskip("py_opw_kinematics")
    with pytest.raises(ValueError, match="arm5 has 5 joints, not 6"):
        OpwPeer.of(load_robot("arm5"))
    with pytest.raises(ValueError, match="py-opw-kinematics's model of gp7_offset_wrist disagrees with our FK"):
        OpwPeer.of(_non_opw_arm())


@pytest.mark.parametrize("name", OPW_ARMS)
def test_eaik_model_reproduces_our_fk(name, rng):
    robot = _arm(name)
    model = build_eaik(robot)
    for q in robot.random_configurations(rng, 10):
        assert np.abs(model.fwdkin(q) - robot.fk(q)).max() < 1e-12
        answer = model.calculate_IK(robot.fk(q))
        assert closed_form_answer(robot, answer.Q[~np.asarray(answer.is_LS)], q)[0]


def test_closed_form_answer_shifts_into_the_limits_and_takes_the_nearest():
    robot = load_robot("gp7")                                   # axis 4 (R): +-190 deg
    seed = np.radians([0.0, 10.0, 10.0, 185.0, 10.0, 0.0])
    near = np.radians([0.0, 10.0, 10.0, -180.0, 10.0, 0.0])    # 180 deg as -180: shifted by 2 pi
    far = np.radians([90.0, 10.0, 10.0, 0.0, 10.0, 0.0])
    outside = np.radians([0.0, 150.0, 10.0, 0.0, 10.0, 0.0])   # axis 2 beyond 145 deg
    reported, q = closed_form_answer(robot, np.array([far, near, outside]), seed)
    assert reported and q == pytest.approx(np.radians([0.0, 10.0, 10.0, 180.0, 10.0, 0.0]))
    reported, q = closed_form_answer(robot, outside, seed)
    assert not reported and q == pytest.approx(outside)
    assert not within_limits(q, robot.limits.q_min, robot.limits.q_max)
    reported, q = closed_form_answer(robot, np.empty((0, 6)), seed)
    assert not reported and np.isnan(q).all()


def test_missing_closed_form_peers_are_reported_not_fatal(monkeypatch):
    monkeypatch.setitem(sys.modules, "py_opw_kinematics", None)
    monkeypatch.setitem(sys.modules, "eaik.pybindings.EAIK", None)
    report = run_ik_benchmark(robots=("gp7",), targets=1, seed=0, methods=("analytic",))
    robot = report.robots[0]
    assert "py_opw_kinematics" in robot.unavailable[OPW] and "eaik" in robot.unavailable[EAIK]
    assert not {OPW, EAIK} & {row.name for row in robot.rows}
    opw_goal = next(goal for goal in report.goals if OPW in goal.name)
    assert opw_goal.value is None and not opw_goal.passed
