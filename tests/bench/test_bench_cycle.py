"""The cycle-time benchmark: its program generator, its peer pipeline and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.bench.cycle import (
    CELLS,
    LINE_MM,
    SHELF_CUBBIES,
    SHELF_TILT_DEG,
    ZONE_MM,
    PeerPiece,
    draw_document,
    joined_at_rest,
    largest_time_stretch,
    parsed_job,
    peer_profile,
    run_peer,
)
from pipeline.files.poses import rpy_to_rotation


def _documents(cell: str, seed: int, count: int = 3) -> list[dict]:
    rng = np.random.default_rng(seed)
    return [draw_document(cell, rng) for _ in range(count)]


@pytest.mark.parametrize("cell", CELLS)
def test_the_programs_repeat_with_the_seed_and_parse(cell):
    documents = _documents(cell, 4)
    assert documents == _documents(cell, 4) and documents != _documents(cell, 5)
    for k, document in enumerate(documents):
        job = parsed_job(document, f"{cell}_{k}")
        assert job.cell.name == cell and len(job.waypoints) == 7
        assert [w.move for w in job.waypoints[1:]] == ["linear", "linear", "joint", "linear", "linear", "joint"]
        assert [w.zone > 0.0 for w in job.waypoints] == [False, False, True, True, False, True, False]


@pytest.mark.parametrize("cell", CELLS)
def test_the_targets_are_on_both_sides_of_the_obstacle(cell):
    for document in _documents(cell, 0, 10):
        above_pick, pick, _, above_place, place, _, back = (np.array(w["xyz"]) for w in document["waypoints"])
        assert np.array_equal(back, above_pick)
        lines = [np.linalg.norm(pick - above_pick), np.linalg.norm(place - above_place)]
        assert all(LINE_MM[0] - 0.2 <= d <= LINE_MM[1] + 0.2 for d in lines)
        zones = [w["zone"] for w in document["waypoints"] if "zone" in w]
        assert all(0.0 < z <= ZONE_MM[1] for z in zones)
        assert zones[0] <= lines[0] / 2 and max(zones[1:]) <= lines[1] / 2
        tool_axes = [rpy_to_rotation(*np.radians(document["waypoints"][k]["rpy"]))[:, 2] for k in (1, 4)]
        if cell.endswith("wall_cell"):          # the wall is at y -15..15: pick y > 0, place y < 0, vertical lines
            assert pick[1] > 15 and place[1] < -15
            assert np.allclose((pick - above_pick)[:2], 0) and np.allclose((place - above_place)[:2], 0)
            assert all(np.allclose(axis, [0, 0, -1]) for axis in tool_axes)
        else:                                   # one target in each cubby, the lines along +x, the tool into the shelf
            cubbies = [next(k for k, box in enumerate(SHELF_CUBBIES) if box[2][0] <= p[2] <= box[2][1])
                       for p in (pick, place)]
            assert sorted(cubbies) == [0, 1]
            for line in (pick - above_pick, place - above_place):
                assert line[0] > 0 and np.allclose(line[1:], 0)
            for axis in tool_axes:
                assert axis[0] >= np.cos(np.radians(SHELF_TILT_DEG[1])) - 1e-9 and abs(axis[1]) < 1e-7


SMALL = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tool": {"xyz": [0, 0, 120], "rpy": [0, 0, 0]},
         "tcp_speed_max": 400, "tcp_accel_max": 2500, "start": [0, 0, 0, 0, -90, 0],
         "waypoints": [{"xyz": [550, 300, 400], "rpy": [180, 0, 30]},
                       {"xyz": [550, 300, 250], "rpy": [180, 0, 30], "move": "linear"},
                       {"xyz": [550, -300, 400], "rpy": [180, 0, -30], "move": "joint"},
                       {"xyz": [550, -300, 250], "rpy": [180, 0, -30], "move": "linear", "speed": 250}]}


@pytest.fixture(scope="module")
def small():
    from pipeline.program.compile import compile_job

    program = compile_job(parsed_job(SMALL, "small"))
    return program, peer_profile(program)


def test_the_peer_stops_at_every_junction_and_keeps_the_tool_moves_speeds(small):
    program, profile = small
    bounds = profile.schedule.bounds
    assert len(bounds) == len(program.moves) + 1 and bounds[-1] == pytest.approx(profile.duration, abs=1e-12)
    for k, bound in enumerate(bounds):
        i = int(np.argmin(np.abs(profile.t - bound)))
        assert profile.t[i] == pytest.approx(bound, abs=1e-12)
        assert np.abs(profile.qd[i]).max() < 1e-9                                # at rest
        np.testing.assert_allclose(profile.q[i], program.targets[k], atol=1e-9)  # on the waypoint
    assert list(profile.schedule.tcp_speed) == [0.4, np.inf, 0.25]
    for k, speed in ((0, 0.4), (2, 0.25)):
        inside = (profile.t >= bounds[k]) & (profile.t <= bounds[k + 1])
        assert profile.tcp.speed[inside].max() <= speed * (1 + 1e-6)
        assert profile.tcp.accel[inside].max() <= 2.5 * (1 + 1e-6)
        assert profile.tcp.speed[inside].max() > 0.5 * speed                     # slowed, not crawling


def test_the_peer_is_judged_by_certify_with_a_reason(small):
    program, _ = small
    outcome = run_peer(program, None)
    assert outcome.cycle_s > 0.0 and outcome.worst_ratio is not None
    if outcome.certified:
        assert outcome.failure == outcome.reason == ""
    else:                                       # toppra checks its limits at its grid points only
        assert outcome.failure and outcome.reason.startswith("FAIL") and outcome.worst_ratio > 1.0


def test_a_junction_keeps_the_sample_of_the_move_with_the_tcp_limits():
    def piece(qdd: float, tcp: float) -> PeerPiece:
        t = np.array([0.0, 0.1, 0.2])
        return PeerPiece(t, np.zeros((3, 1)), np.zeros((3, 1)), np.full((3, 1), qdd), 1.0, tcp, tcp)

    t, _, _, qdd, bounds = joined_at_rest([piece(1.0, np.inf), piece(2.0, 0.5), piece(3.0, np.inf)])
    np.testing.assert_allclose(t, [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    np.testing.assert_allclose(bounds, [0.0, 0.2, 0.4, 0.6])
    assert qdd[:, 0].tolist() == [1.0, 1.0, 2.0, 2.0, 2.0, 3.0, 3.0]    # joint -> tool: the tool's; tool -> joint


def test_the_largest_time_stretch_is_found_anywhere_in_the_details():
    details = {"stretches": [{"timing": {"time_stretch": 1.002}}, {"timing": None},
                             {"timing": {"pieces": ({"time_stretch": 1.004},)}}], "time_stretch": 1.0}
    assert largest_time_stretch(details) == 1.004
    assert largest_time_stretch({"stretches": [{"timing": None}]}) is None


@pytest.mark.slow                                  # one program through the CLI, both contestants: 2-10 s
def test_the_cli_runs_the_suite_and_writes_json(tmp_path, capsys):
    out = tmp_path / "cycle.json"
    assert main(["bench", "cycle", "--programs", "1", "--cells", "gp7_shelf_cell", "--seed", "1",
                 "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    (cell,) = data["cells"]
    assert cell["cell"] == "gp7_shelf_cell" and cell["programs"] == 1 and len(cell["records"]) == 1
    record = cell["records"][0]
    assert record["bound_s"] > 0.0 and record["draws"] >= 1
    for who in ("ours", "peer"):
        outcome = record[who]
        assert outcome["certified"] or outcome["failure"]
        assert outcome["cycle_s"] is None or outcome["cycle_s"] > record["bound_s"]
    assert data["demos"] == []                     # the demo job is in the wall cell
    text = capsys.readouterr().out
    assert "gp7_shelf_cell" in text and "ours/peer" in text and text.count("  PASS  ") + text.count("  FAIL  ") == 5
