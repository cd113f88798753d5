"""Motion programs (pipeline.program, issue 23): zones between a joint move and a line, per-move speeds,
tcp_speed_max on tool moves only, the safety TCP limit everywhere, planned moves without interior stops,
certify once per job, the lower bound, StretchPath geometry, determinism, the cycle report and the stops.
Small GP7 jobs (mm, deg) without a cell unless the test is about the cell."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pipeline.cell.clear_motion
import pipeline.program.report
import pipeline.program.stretch
import pipeline.program.timing
import pipeline.runner
import pipeline.timing
import pipeline.timing.profile
from pipeline.cell.planning import PlannedPath
from pipeline.program.bound import follow_time, lower_bound, rest_to_rest_time
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job
from pipeline.program.stretch import BREAKPOINT_GAP, StretchPath
from pipeline.program.timing import time_program
from pipeline.program.tool_moves import POSITION_TOLERANCE_M
from pipeline.runner import collision_model, run_job
from pipeline.timing.tcp import TcpMotion

from .test_job_moves import gp7_job

A = {"xyz": [500, 300, 400], "rpy": [180, 0, 0]}
B = {"xyz": [500, -100, 400], "rpy": [180, 0, 0]}
C = {"xyz": [500, -100, 200], "rpy": [180, 0, 0]}
D = {"xyz": [500, -300, 200], "rpy": [180, 0, 0]}
E = {"xyz": [400, -300, 300], "rpy": [180, 0, 0]}
J0 = [0, 10, 0, 0, -60, 0]
J1 = [100, 40, 20, 30, -30, 50]
#: The wall cell's two sides: a joint move between them goes over the wall.
PICK = {"xyz": [550, 300, 400], "rpy": [180, 0, 30]}
PLACE = {"xyz": [550, -300, 400], "rpy": [180, 0, -30]}
#: Every module a run may call certify through (each imported the name itself).
CERTIFY_MODULES = (pipeline.program.timing, pipeline.timing, pipeline.timing.profile, pipeline.runner, pipeline.cell.clear_motion)


def timed(waypoints: list, **changes):
    """(program, profile) of a GP7 job (``gp7_job``, TCP accel 2500 mm/s^2 unless changed), without a cell."""
    job = parse_job(gp7_job(waypoints, **{"tcp_accel_max": 2500, **changes}), source="x.yaml")
    program = compile_job(job)
    return program, time_program(program)


def tcp_of(program, profile):
    """The TCP's samples (position [m], speed [m/s], accel [m/s^2]) computed from the profile's joints."""
    return TcpMotion(program.robot).samples(profile.q, profile.qd, profile.qdd)


def during(profile, k: int) -> np.ndarray:
    """Mask of the samples of move k (from the passage of waypoint k to that of waypoint k + 1)."""
    passages = profile.details.passages_s
    return (profile.t >= passages[k]) & (profile.t <= passages[k + 1])


def off_segment(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance [m] of each point (n, 3) from the segment start-end."""
    direction = end - start
    along = np.clip((points - start) @ direction / (direction @ direction), 0.0, 1.0)
    return np.linalg.norm(points - start - along[:, None] * direction, axis=1)


def xyz(waypoint: dict) -> np.ndarray:
    return np.array(waypoint["xyz"]) / 1e3


def counting(monkeypatch) -> list:
    """Replace certify in every module a run reaches by a wrapper recording whether each call had a scene."""
    calls = []
    for module in CERTIFY_MODULES:
        def wrapper(*args, _certify=module.certify, **kwargs):
            calls.append(kwargs.get("scene") is not None)
            return _certify(*args, **kwargs)
        monkeypatch.setattr(module, "certify", wrapper)
    return calls


# -- zones, speeds, TCP limits ---------------------------------------------------------------------------

@pytest.mark.parametrize("line_first", [False, True], ids=["joint_to_line", "line_to_joint"])
def test_a_zone_between_a_joint_move_and_a_line_keeps_the_line_and_does_not_stop(line_first):
    """Outside the zone (farther than R from the corner, on the line's side of the passage) the TCP is on the
    line within POSITION_TOLERANCE_M; near the corner it moves at > 0.1 m/s; the joints never rest in between."""
    zone = 0.04
    if line_first:   # C -> B by a line, then a joint move to A
        waypoints, line, k_line = [C, {**B, "move": "linear", "zone": zone * 1e3}, A], (C, B), 0
    else:            # A -> B by a joint move, then a line to C
        waypoints, line, k_line = [A, {**B, "zone": zone * 1e3}, {**C, "move": "linear"}], (B, C), 1
    program, profile = timed(waypoints)
    assert program.stops == (0, 2)
    tcp = tcp_of(program, profile)
    corner = xyz(B)
    to_corner = np.linalg.norm(tcp.position - corner, axis=1)
    on_line = during(profile, k_line) & (to_corner > zone)
    assert on_line.sum() >= 20
    assert off_segment(tcp.position[on_line], *map(xyz, line)).max() <= POSITION_TOLERANCE_M
    assert to_corner.min() <= zone
    assert tcp.speed[to_corner <= zone].min() > 0.1
    assert np.linalg.norm(profile.qd[1:-1], axis=1).min() > 1e-4


def test_a_joint_move_at_half_speed_is_timed_as_with_half_the_joint_speed_limits():
    """speed: 50 on a joint move == the same move without a speed on a robot whose qd_max is halved:
    the same duration and peak joint speeds within 1e-3 relative (and slower than at 100 %)."""
    half = compile_job(parse_job(gp7_job([J0, {"joints": J1, "speed": 50}], tcp_speed_max=None), source="x.yaml"))
    full = compile_job(parse_job(gp7_job([J0, J1], tcp_speed_max=None), source="x.yaml"))
    halved = dataclasses.replace(full.limits, qd_max=full.limits.qd_max / 2.0)
    at_half = time_program(half)
    on_slow_robot = time_program(dataclasses.replace(full, limits=halved))
    assert at_half.duration == pytest.approx(on_slow_robot.duration, rel=1e-3)
    np.testing.assert_allclose(np.abs(at_half.qd).max(axis=0), np.abs(on_slow_robot.qd).max(axis=0), rtol=1e-3)
    assert np.abs(at_half.qd).max(axis=0)[0] == pytest.approx(halved.qd_max[0], rel=1e-3)   # S binds
    assert time_program(full).duration < 0.9 * at_half.duration


@pytest.mark.parametrize("zone", [0, 30])
def test_each_line_meets_its_own_speed(zone):
    """A 400 mm line at 300 mm/s then a 300 mm line at 150 mm/s (a stop or a zone between them): each
    reaches 0.99 of its speed and never exceeds it (1e-6 relative)."""
    start = {"xyz": [450, 200, 300], "rpy": [180, 0, 0]}
    corner = {"xyz": [450, -200, 300], "rpy": [180, 0, 0], "move": "linear", "speed": 300, "zone": zone}
    end = {"xyz": [450, -200, 600], "rpy": [180, 0, 0], "move": "linear", "speed": 150}
    program, profile = timed([start, corner, end])
    speed = tcp_of(program, profile).speed
    for k, own in enumerate((0.3, 0.15)):
        assert program.moves[k].speed == pytest.approx(own)
        assert 0.99 * own <= speed[during(profile, k)].max() <= own * (1.0 + 1e-6)


def test_tcp_speed_max_does_not_slow_a_joint_move(caplog):
    """A job of joint moves only: tcp_speed_max 50 mm/s changes nothing (the same duration), and the TCP
    goes faster than 50 mm/s."""
    waypoints = [A, B, J0]
    program, limited = timed(waypoints, tcp_speed_max=50, tcp_accel_max=None)
    _, free = timed(waypoints, tcp_speed_max=None, tcp_accel_max=None)
    assert limited.duration == pytest.approx(free.duration, rel=1e-9)
    assert tcp_of(program, limited).speed.max() > 10 * 0.05
    assert "no longer limits anything" in caplog.text


def test_the_safety_tcp_limit_holds_everywhere():
    """tcp_speed_limit 200 mm/s on joint moves, a zone and a line at 500 mm/s: the TCP at most 0.2 m/s at every
    sample (1e-6 relative), where without it it goes faster, and the job takes longer."""
    waypoints = [A, {**B, "zone": 40}, {**C, "move": "linear"}, A]
    program, limited = timed(waypoints, tcp_speed_limit=200)
    _, free = timed(waypoints)
    assert tcp_of(program, limited).speed.max() <= 0.2 * (1.0 + 1e-6)
    assert tcp_of(program, free).speed.max() > 0.4
    assert limited.duration > 1.5 * free.duration


def test_a_line_after_a_joint_move_that_stops_is_certified():
    """A joint move to B, a stop, a line down (the commonest approach of a pick, as in gp7_pick_place): timed,
    certified, the line within the TCP acceleration after the stop."""
    program, profile = timed([A, B, {**C, "move": "linear"}])
    assert program.stops == (0, 1, 2)
    assert profile.certificate.passed
    line = profile.t > profile.details.passages_s[1]
    assert tcp_of(program, profile).accel[line].max() <= 2.5 * (1.0 + 1e-6)


def test_lines_with_a_zone_into_a_joint_move_are_timed_without_a_uniform_slow_down():
    """Two lines joined by a zone, then a zone into a joint move: no stretch slowed uniformly by more than 1 %."""
    program, profile = timed([B, {**C, "move": "linear", "zone": 30}, {**D, "move": "linear", "zone": 40}, A])
    assert [s["timing"]["time_stretch"] <= 1.01 for s in profile.details.stretches] == [True]


# -- certify once, the cycle report ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def zoned_run(tmp_path_factory):
    """(outcome, certify calls) of run_job on a job with a joint move, two lines and zones between them."""
    waypoints = [A, {**B, "zone": 40}, {**C, "move": "linear", "zone": 30}, {**D, "move": "linear"}, A]
    job = parse_job(gp7_job(waypoints, tcp_accel_max=2500), source="x.yaml")
    with pytest.MonkeyPatch.context() as monkeypatch:
        calls = counting(monkeypatch)
        outcome = run_job(job, tmp_path_factory.mktemp("zoned") / "out")
    return outcome, calls


def test_certify_is_called_once_per_job(zoned_run):
    outcome, calls = zoned_run
    assert outcome.job.speed_scale == 1.0
    assert len(calls) == 1


def test_the_cycle_report_has_every_move(zoned_run):
    """report["cycle"]: one entry per move in order, durations summing to the profile's (within dt), the lower
    bound at most the cycle, a binding limit named for every move."""
    outcome, _ = zoned_run
    cycle, profile = outcome.report["cycle"], outcome.profile
    moves = cycle["moves"]
    assert [(m["from"], m["to"]) for m in moves] == [(k, k + 1) for k in range(len(outcome.job.waypoints) - 1)]
    assert [m["kind"] for m in moves] == ["joint", "linear", "linear", "joint"]
    assert abs(sum(m["duration_s"] for m in moves) - profile.duration) <= outcome.job.dt
    assert all(m["duration_s"] > 0.0 for m in moves)
    assert cycle["cycle_s"] == pytest.approx(profile.duration)
    assert 0.0 < cycle["lower_bound_s"] <= profile.duration
    assert all(isinstance(m["binding"], str) and m["binding"].strip() for m in moves)


# -- the wall cell ---------------------------------------------------------------------------------------

def wall_job():
    """The wall cell, a joint move over the wall from the pick side to the place side, planned."""
    return parse_job({"cell": "gp7_wall_cell", "length_unit": "mm", "angle_unit": "deg",
                      "tool": {"xyz": [0, 0, 120], "rpy": [0, 0, 0]}, "start": [0, 0, 0, 0, -90, 0],
                      "plan": "collision_free", "outputs": ["json"], "waypoints": [PICK, PLACE]}, source="x.yaml")


@pytest.fixture(scope="module")
def wall_run(tmp_path_factory):
    """(outcome, certify calls: True where a scene was given) of run_job on ``wall_job``."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        calls = counting(monkeypatch)
        outcome = run_job(wall_job(), tmp_path_factory.mktemp("wall") / "out")
    return outcome, calls


def test_a_planned_move_has_no_interior_stop(wall_run):
    """The move over the wall is planned through >= 3 vertices and the joints never rest between its ends."""
    outcome, _ = wall_run
    planned = outcome.report["program"]["moves"][0]["planned"]
    assert planned is not None and len(planned["vertices_q"]) >= 3
    speed = np.linalg.norm(outcome.profile.qd, axis=1)
    assert speed[1:-1].min() > 1e-4


def test_a_cell_job_has_its_clearance_certified_once(wall_run):
    _, calls = wall_run
    assert calls.count(True) == 1


def test_a_cell_job_is_timed_the_same_twice(wall_run):
    """Compiled and timed again in the same process: the same profile, sample for sample."""
    outcome, _ = wall_run
    job = wall_job()
    scene = collision_model(job)
    profile = time_program(compile_job(job, scene), scene)
    assert np.array_equal(profile.t, outcome.profile.t) and np.array_equal(profile.q, outcome.profile.q)


# -- the lower bound -------------------------------------------------------------------------------------

def test_rest_to_rest_time_by_hand():
    """Triangular: 2 sqrt(d / a) when d < v^2 / a; trapezoidal: d / v + v / a; no acceleration limit: d / v."""
    distance = np.array([0.1, 2.0, -2.0, 0.0])
    np.testing.assert_allclose(rest_to_rest_time(distance, 1.0, 1.0), [2.0 * np.sqrt(0.1), 3.0, 3.0, 0.0])
    np.testing.assert_allclose(rest_to_rest_time(distance, np.array([2.0, 2.0, 4.0, 1.0]), None),
                               [0.05, 1.0, 0.5, 0.0])
    np.testing.assert_allclose(rest_to_rest_time(np.array([0.5, 0.5]), np.array([1.0, 0.5]), np.array([4.0, 1.0])),
                               [0.5 + 0.25, 1.0 + 0.5])


@pytest.mark.parametrize("length, from_rest, to_rest, expected", [
    (3.0, True, True, 4.0),                  # trapezoid: 1 s up and 1 s down (0.5 m each), 2 m at 1 m/s
    (0.25, True, True, 1.0),                 # triangle: 2 sqrt(0.25 / 1)
    (1.0, True, False, 1.5),                 # 1 s up over 0.5 m, then 0.5 m at 1 m/s
    (1.0, False, True, 1.5),                 # the same backwards
    (0.2, True, False, np.sqrt(0.4)),        # accelerating all along: 0.2 = a t^2 / 2
    (0.2, False, True, np.sqrt(0.4)),
    (1.0, False, False, 1.0),                # free at both ends: at the speed all along
    (0.0, True, True, 0.0),
])
def test_follow_time_by_hand(length, from_rest, to_rest, expected):
    """At most 1 m/s and 1 m/s^2 along ``length`` m."""
    assert follow_time(length, 1.0, 1.0, from_rest, to_rest) == pytest.approx(expected, rel=1e-12)
    assert follow_time(length, 2.0, None, from_rest, to_rest) == pytest.approx(length / 2.0, rel=1e-12)


def test_the_lower_bound_of_one_line_is_its_tcp_time():
    """One 150 mm line at 500 mm/s and 2500 mm/s^2 from rest to rest: 0.3 s at speed + 0.2 s of ramps = 0.5 s
    (the joints need less)."""
    top = {"xyz": [500, 300, 350], "rpy": [180, 0, 0]}
    program = compile_job(parse_job(gp7_job([top, {**top, "xyz": [500, 300, 200], "move": "linear"}],
                                            tcp_accel_max=2500), source="x.yaml"))
    bound = lower_bound(program)
    assert bound.tcp_s == pytest.approx(0.5, rel=1e-9)
    assert bound.joints_s < 0.5 and bound.total_s == pytest.approx(0.5, rel=1e-9)


def test_the_lower_bound_of_two_lines_joined_by_a_zone():
    """150 mm down, a 50 mm zone, 150 mm sideways: each line followed for 100 mm, from rest to 500 mm/s
    (0.05 m of ramp: 0.1 s, then 0.05 m at speed: 0.1 s) and back to rest: 0.3 s each, 0.6 s in all."""
    top = {"xyz": [500, 300, 350], "rpy": [180, 0, 0]}
    waypoints = [top, {**top, "xyz": [500, 300, 200], "move": "linear", "zone": 50},
                 {**top, "xyz": [500, 150, 200], "move": "linear"}]
    program = compile_job(parse_job(gp7_job(waypoints, tcp_accel_max=2500), source="x.yaml"))
    bound = lower_bound(program)
    assert program.stops == (0, 2)
    assert bound.tcp_s == pytest.approx(0.6, rel=1e-9)


@pytest.mark.parametrize("speed_scale", [1.0, 0.5])
def test_the_lower_bound_of_a_joint_move_is_its_slowest_joint(speed_scale):
    """S turns 90 deg at 375 deg/s and 1250 deg/s^2 (x speed scale, x its square): 90 < 375^2 / 1250, a
    triangle, 2 sqrt(90 / 1250) s at full speed, twice that at half."""
    program = compile_job(parse_job(gp7_job([J0, [90, 10, 0, 0, -60, 0]], tcp_speed_max=None,
                                            speed_scale=speed_scale), source="x.yaml"))
    bound = lower_bound(program)
    assert bound.total_s == pytest.approx(2.0 * np.sqrt(90.0 / 1250.0) / speed_scale, rel=1e-3)
    assert (bound.stretches[0].joint, bound.tcp_s) == (0, 0.0)


def test_the_lower_bound_counts_the_joint_waypoints_a_joint_path_passes_through():
    """Out to S = 90 deg and back through joint waypoints without zones (one stretch: the path passes the
    middle one exactly, and S turns back there, at rest): twice the 90 deg triangle, not the zero change
    from the first stop to the last; with a zone at the turn (not passed exactly) only the net change."""
    out = [90, 10, 0, 0, -60, 0]
    through = compile_job(parse_job(gp7_job([J0, out, J0], tcp_speed_max=None), source="x.yaml"))
    assert through.stops == (0, 2)
    assert lower_bound(through).total_s == pytest.approx(2.0 * 2.0 * np.sqrt(90.0 / 1250.0), rel=1e-3)
    zoned = compile_job(parse_job(gp7_job([J0, {"joints": out, "zone": 50}, J0], tcp_speed_max=None),
                                  source="x.yaml"))
    assert lower_bound(zoned).total_s == pytest.approx(0.0, abs=1e-12)


# -- StretchPath geometry, stops -------------------------------------------------------------------------

def derivative_scale(path, order: int) -> float:
    """The largest |d^order q / ds^order| over the path (sampled) [rad / 1^order]."""
    return float(np.linalg.norm(path(np.linspace(0.0, 1.0, 2001), order), axis=1).max())


@pytest.mark.parametrize("smooth, pieces", [(True, ["segment", "blend", "segment"]),
                                            (False, ["segment", "blend", "segment", "blend", "segment"])])
def test_a_stretch_path_is_smooth_at_every_piece_boundary(smooth, pieces, monkeypatch):
    """A planned joint move through an inner vertex, then a zone into a line: at every boundary of the
    StretchPath's pieces (the planned move's spline, or, where that spline is refused, its edges with a
    blend at the vertex; the zone's blend; the track) the value and the first two derivatives agree from
    both sides within 1e-6 of their scale, and each derivative is the finite difference of the one below
    it, on both sides."""
    if not smooth:
        monkeypatch.setattr(pipeline.program.stretch, "_smooth_plan", lambda planned, robot, scene, tilt: None)
    job = parse_job(gp7_job([A, {**B, "zone": 40}, {**C, "move": "linear"}], tcp_accel_max=2500), source="x.yaml")
    program = compile_job(job)
    q_a, q_b = program.targets[:2]
    vertex = (q_a + q_b) / 2.0 + np.radians([0.0, -15.0, 10.0, 0.0, 0.0, 0.0])
    planned = PlannedPath(np.array([q_a, vertex, q_b]), "test", 0.0, 0.0, 0.0, 0.0)
    moves = (dataclasses.replace(program.moves[0], planned=planned), *program.moves[1:])
    stretch = StretchPath(dataclasses.replace(program, moves=moves), 0, 2)
    assert [p[0] for p in stretch.pieces] == pieces
    path, h, step = stretch.path, 1e-9, 1e-5
    scales = [derivative_scale(path, order) for order in range(4)]
    for s in [p[2] / stretch.total for p in stretch.pieces[1:]]:
        for order in range(3):
            left, right = path(np.array([s - h, s + h]), order)
            assert np.linalg.norm(left - right) <= 1e-6 * scales[order], (s, order)
        for side in (-1.0, 1.0):   # one-sided second-order differences, inside one piece
            x = s + side * (h + np.array([0.0, step, 2.0 * step]))
            for order in range(3):
                values = path(x, order)
                difference = side * (-3.0 * values[0] + 4.0 * values[1] - values[2]) / (2.0 * step)
                assert np.linalg.norm(difference - path(x[:1], order + 1)[0]) <= 1e-4 * scales[order + 1], (s, order)


def test_the_schedule_changes_limits_at_breakpoints_of_the_path_or_apart_from_them():
    """A line into a zone into a joint move: every bound of the stretch's LimitSchedule is one of its path's
    breakpoints or more than BREAKPOINT_GAP from each (a bound a rounding error from a breakpoint makes a
    microscopic grid interval)."""
    program = compile_job(parse_job(gp7_job([C, {**B, "move": "linear", "zone": 40}, A], tcp_accel_max=2500),
                                    source="x.yaml"))
    stretch = StretchPath(program, 0, 2)
    breakpoints = stretch.path.breakpoints
    for bound in stretch.schedule.bounds:
        gaps = np.abs(breakpoints - bound)
        assert gaps.min() == 0.0 or gaps.min() > BREAKPOINT_GAP, (bound, breakpoints[np.argmin(gaps)])


def test_a_joint_run_that_turns_back_passes_its_waypoints_in_order():
    """Out to S = 90 deg and back, twice, through zone-less joint waypoints (one stretch that passes them all):
    each waypoint the run passes is a bound of the stretch's schedule and a breakpoint of its path, so its
    passage time is the timing's own there: the passages increase, and every move lasts a quarter of the
    cycle. The sample nearest each waypoint anywhere in the stretch, as before issue 39, was t = 0 for the
    return to the start (passages 0, 1.61, 0, 1.61, 2.15 s: moves of -1.61 s in the cycle report), and was
    looked for once per waypoint over the whole profile."""
    out = [90, 10, 0, 0, -60, 0]
    program, profile = timed([J0, out, J0, out, J0], tcp_speed_max=None)
    assert program.stops == (0, 4)
    stretch = StretchPath(program, 0, 4)
    inner = stretch.passages[:-1]
    assert np.isin(inner, stretch.schedule.bounds).all() and np.isin(inner, stretch.path.breakpoints).all()
    passages = np.array(profile.details.passages_s)
    np.testing.assert_allclose(np.diff(passages), profile.duration / 4.0, rtol=1e-3)
    moves = pipeline.program.report.cycle_report(program, profile)["moves"]
    np.testing.assert_allclose([m["duration_s"] for m in moves], np.diff(passages))


def test_the_stops_are_the_zoneless_waypoints_but_those_a_joint_path_passes():
    """Zones at waypoints 2 and 4 only: 1 and 5 (zone-less between two joint moves) are passed, 3 (between two
    lines) and 6 (a joint move then a line) are stops, with 0 and 7."""
    waypoints = [A, B, {**E, "zone": 30}, {**D, "move": "linear"}, {**C, "move": "linear", "zone": 20}, B, A,
                 {**E, "move": "linear"}]
    program = compile_job(parse_job(gp7_job(waypoints, tcp_accel_max=2500), source="x.yaml"))
    assert [m.zone > 0.0 for m in program.moves] == [False, True, False, True, False, False, False]
    assert program.stops == (0, 3, 6, 7)
    assert program.stretches() == [(0, 3), (3, 6), (6, 7)]
