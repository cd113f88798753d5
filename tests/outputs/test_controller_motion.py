"""The model of what a controller does with a written program (``pipeline.outputs.controllers.controller_motion``,
issue 36): its path, its cycle time as written and its certificate.

* Written with an exact stop at every target, the demo cell job (``gp7_cell_pick_place``: planned moves over a
  wall, tool moves, zones of 75 mm) runs stop and go: the modelled path passes exactly through every target, the
  motion rests there, it keeps the clearance, and it takes at least as long as the certified profile.
* Zones make it shorter, and a corner stays inside its zone: every sample of a corner between two joint moves that
  is off the two written segments has its TCP within the zone of the corner's target.
* The certificate fails where it must: a zone too large next to the wall (joint moves hugging the wall top, certified at
  20 mm, cut their corners to within the 10 mm clearance with zones of 80 mm; 20 mm zones keep it), and a planned move
  written as a sparse sampling of its certified path (one joint target in its middle), whose straight joint segments
  cut the corner into the wall.
* Tool moves joined by zones (``gp7_pick_place``) are rounded on the tool path, as certified: the time as written is
  the certified one, move by move. A joint-space corner (KUKA C_PTP) lies in the triangle of its cuts and target.
"""

from __future__ import annotations

import dataclasses
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pipeline.outputs.controllers.controller_motion import (
    WrittenMove,
    controller_path,
    point_to_polyline,
    smoothstep,
    written_moves,
    written_program_certificate,
)
from pipeline.program.job import load_job
from pipeline.runner import collision_model, timed_program

DEMO_JOBS = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"

WALL_HUG = """\
description: joint moves up beside the wall, across 20 mm above its top, and down; no zones
cell: gp7_wall_cell
length_unit: mm
angle_unit: deg
tool: {xyz: [0, 0, 120], rpy: [0, 0, 0]}
start: [0, 0, 0, 0, -90, 0]
waypoints:
  - {xyz: [550, 70, 400], rpy: [180, 0, 0]}
  - {xyz: [550, 70, 570], rpy: [180, 0, 0], move: joint}
  - {xyz: [550, -70, 570], rpy: [180, 0, 0], move: joint}
  - {xyz: [550, -70, 400], rpy: [180, 0, 0], move: joint}
timing: toppra
dt: 0.004
"""


@cache
def _timed(path: str):
    job = load_job(path)
    scene = collision_model(job)
    program, _, profile = timed_program(job)
    return program, profile, scene


def cell_job():
    return _timed(str(DEMO_JOBS / "gp7_cell_pick_place.yaml"))


def _is_program_target(program, written: WrittenMove) -> bool:
    return bool(np.allclose(written.target, program.moves[written.source - 1].target))


def _with_vertex_zones(program, moves, vertex_zone: float) -> list[WrittenMove]:
    """``moves`` with a zone at every planner vertex and the program's own zone where it does not stop."""
    out = []
    for w in moves:
        move = program.moves[w.source - 1]
        if not _is_program_target(program, w):
            zone = vertex_zone
        else:
            zone = 0.0 if w.source in program.stops else move.zone
        out.append(dataclasses.replace(w, zone_m=zone))
    return out


def test_exact_stops_everywhere_run_stop_and_go_through_every_target():
    program, profile, scene = cell_job()
    moves = written_moves(program, exact_stops=True)
    path, timing, certificate = written_program_certificate(program, moves, profile, scene)
    assert path.stops == list(range(len(moves)))
    assert len(path.stretches) == len(moves)
    for k, move in enumerate(moves):
        # the path passes exactly through the target, and the motion rests there
        assert np.min(np.linalg.norm(path.q - move.target, axis=1)) <= 1e-9
        i = int(np.argmin(np.abs(timing.profile.t - timing.passages_s[k])))
        assert abs(timing.profile.t[i] - timing.passages_s[k]) <= 1e-9
        assert np.linalg.norm(timing.profile.q[i] - move.target) <= 1e-6
        assert np.abs(timing.profile.qd[i]).max() <= 1e-6
    assert path.max_deviation_rad == 0.0
    assert certificate.passed, certificate.limits
    assert certificate.min_clearance_m >= scene.clearance_m
    assert timing.duration_s >= profile.duration
    assert np.all(timing.move_durations_s > 0.0)
    assert timing.move_durations_s.sum() == pytest.approx(timing.duration_s)


@pytest.mark.slow
def test_zones_make_it_shorter_and_a_corner_stays_in_its_zone():
    program, profile, scene = cell_job()
    stop_and_go = written_program_certificate(program, written_moves(program, exact_stops=True), profile, scene)[1]
    zone = 0.05
    moves = _with_vertex_zones(program, written_moves(program), zone)
    path, timing, certificate = written_program_certificate(program, moves, profile, scene)
    assert certificate.passed, certificate.limits
    assert timing.duration_s < stop_and_go.duration_s - 0.3
    assert path.stops == [k for k, w in enumerate(moves) if w.zone_m == 0.0]
    robot = program.robot
    corners = 0
    for k, w in enumerate(moves[:-1]):
        nxt = moves[k + 1]
        if not (w.zone_m > 0.0 and w.kind == nxt.kind == "joint"):
            continue
        corners += 1
        q_from = moves[k - 1].target if k else program.waypoints[0].q
        ours = path.q[(path.move_of == k) | (path.move_of == k + 1)]
        on_segments = np.minimum(point_to_polyline(ours, np.array([q_from, w.target])),
                                 point_to_polyline(ours, np.array([w.target, nxt.target])))
        near = np.linalg.norm(ours - w.target, axis=1) < 0.5 * min(np.linalg.norm(w.target - q_from),
                                                                     np.linalg.norm(nxt.target - w.target))
        off = ours[(on_segments > 1e-9) & near]        # the corner at this target (not those at its neighbours)
        assert len(off) > 10
        tcp = robot.fk_batch(off)[:, :3, 3]
        assert np.linalg.norm(tcp - robot.fk(w.target)[:3, 3], axis=1).max() <= zone + 1e-6
        assert path.moves[k].corner_tcp_m <= zone + 1e-6
        assert 0.0 < path.moves[k].deviation_rad <= path.moves[k].hull_bound_rad + 1e-12
    assert corners == 2                      # the vertex over the wall, out and back
    # every corner of the program's own zones too: the TCP within the zone of its target
    for move in path.moves:
        if move.move.zone_m > 0.0:
            assert move.corner_tcp_m <= move.move.zone_m + 1e-6


def test_a_zone_too_large_near_the_wall_fails_the_certificate(tmp_path):
    job_file = tmp_path / "wall_hug.yaml"
    job_file.write_text(WALL_HUG)
    program, profile, scene = _timed(str(job_file))
    exact = written_moves(program)
    assert [w.zone_m for w in exact] == [0.0, 0.0, 0.0]
    _, timing, certificate = written_program_certificate(program, exact, profile, scene)
    assert certificate.passed and certificate.min_clearance_m >= 0.015
    assert certificate.max_deviation_rad <= 1e-4
    small = [dataclasses.replace(w, zone_m=0.02) for w in exact[:-1]] + [exact[-1]]
    _, small_timing, certificate = written_program_certificate(program, small, profile, scene)
    assert certificate.passed and small_timing.duration_s < timing.duration_s
    large = [dataclasses.replace(w, zone_m=0.08) for w in exact[:-1]] + [exact[-1]]
    _, _, certificate = written_program_certificate(program, large, profile, scene)
    assert not certificate.passed
    assert not certificate.limits.clearance.passed
    assert certificate.min_clearance_m < scene.clearance_m
    assert "wall" in str(certificate.limits.clearance)


def test_a_sparse_sampling_of_a_planned_move_cuts_into_the_wall():
    program, profile, scene = cell_job()
    passages = profile.details.passages_s
    as_written = written_moves(program)
    _, _, certificate = written_program_certificate(program, as_written, profile, scene)
    assert certificate.passed                # the planner's own vertices, exact stops: its edges are clear
    sparse = []
    for w in as_written:
        move = program.moves[w.source - 1]
        if move.planned is None:
            sparse.append(w)
        elif _is_program_target(program, w):    # one joint target in the middle of the certified path, then the end
            t = (passages[move.end - 1] + passages[move.end]) / 2.0
            middle = np.array([np.interp(t, profile.t, column) for column in profile.q.T])
            sparse += [WrittenMove("joint", middle, move.speed, source=move.end), w]
    assert len(sparse) == len(as_written)
    _, _, certificate = written_program_certificate(program, sparse, profile, scene)
    assert not certificate.passed
    assert not certificate.limits.clearance.passed
    assert certificate.min_clearance_m < scene.clearance_m
    # its joint targets lie on the certified path, its segments do not
    assert certificate.max_deviation_rad > 0.05


def test_a_joint_corner_is_a_convex_combination_inside_the_hull():
    """Two straight joint moves with a joint-space zone (KUKA C_PTP): the corner leaves and joins them where every
    axis is within the zone of the target, tangentially, within the triangle of the two cuts and the target."""
    program, _, _ = cell_job()
    robot = program.robot
    q0 = np.zeros(6)
    q1 = np.radians([30.0, 10.0, 5.0, 0.0, -40.0, 0.0])
    q2 = np.radians([60.0, 0.0, 20.0, 10.0, -60.0, 0.0])
    moves = [WrittenMove("joint", q1, 1.0, zone_axis_rad=np.radians(5.0)), WrittenMove("joint", q2, 1.0)]
    path = controller_path(robot, q0, moves)
    first = path.moves[0]
    assert path.stops == [1] and len(path.stretches) == 1
    assert np.abs((1.0 - first.cut_out) * (q1 - q0)).max() == pytest.approx(np.radians(5.0), rel=1e-3)
    assert np.abs(first.cut_in * (q2 - q1)).max() == pytest.approx(np.radians(5.0), rel=1e-3)
    a, b = q0 + first.cut_out * (q1 - q0), q1 + first.cut_in * (q2 - q1)
    # inside the triangle (a, q1, b): barycentric coordinates of every sample in [0, 1]
    off = np.minimum(point_to_polyline(path.q, np.array([q0, q1])), point_to_polyline(path.q, np.array([q1, q2])))
    corner = path.q[off > 1e-12]
    assert len(corner) > 10
    basis = np.stack([a - q1, b - q1], axis=1)
    coefficients, *_ = np.linalg.lstsq(basis, (corner - q1).T, rcond=None)
    residual = np.linalg.norm(basis @ coefficients - (corner - q1).T, axis=0)
    assert residual.max() <= 1e-9
    assert coefficients.min() >= -1e-9 and coefficients.sum(axis=0).max() <= 1.0 + 1e-9
    assert 0.0 < first.deviation_rad <= first.hull_bound_rad
    tau = np.linspace(0.0, 1.0, 11)
    assert smoothstep(tau)[[0, -1]].tolist() == [0.0, 1.0]
    assert np.all(np.diff(smoothstep(tau)) > 0.0)


@pytest.mark.slow
def test_tool_moves_joined_by_zones_are_rounded_on_the_tool_path_as_certified():
    """gp7_pick_place (lines and an arc joined by 60 mm zones, no planned moves): written with its zones, the
    modelled path rounds the corners between tool moves on the tool path, as the certified profile does, and its
    time as written is the certified one, move by move; each corner's TCP stays within its zone."""
    program, profile, scene = _timed(str(DEMO_JOBS / "gp7_pick_place.yaml"))
    moves = written_moves(program)
    assert any(w.zone_m > 0.0 for w in moves)
    path, timing, certificate = written_program_certificate(program, moves, profile, scene)
    assert certificate.passed, certificate.limits
    assert timing.duration_s == pytest.approx(profile.duration, rel=2e-3)
    assert np.allclose(timing.move_durations_s, np.diff(profile.details.passages_s), atol=5e-3)
    assert certificate.max_deviation_rad <= 1e-3
    for move in path.moves:
        if move.move.zone_m > 0.0:
            assert move.corner_tcp_m <= move.move.zone_m + 1e-9
    exact = written_program_certificate(program, written_moves(program, exact_stops=True), profile, scene)[1]
    assert exact.duration_s > timing.duration_s
