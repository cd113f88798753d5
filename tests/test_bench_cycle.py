"""The cycle-time benchmark: its program generator, its peer pipeline and the CLI."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.bench.cycle import CELLS, LINE_MM, SHELF_CUBBIES, ZONE_MM, draw_document, parsed_job


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
        if cell == "gp7_wall_cell":             # the wall is at y -15..15: pick y > 0, place y < 0, vertical lines
            assert pick[1] > 15 and place[1] < -15
            assert np.allclose((pick - above_pick)[:2], 0) and np.allclose((place - above_place)[:2], 0)
        else:                                   # one target in each cubby, the lines along +x
            cubbies = [next(k for k, box in enumerate(SHELF_CUBBIES) if box[2][0] <= p[2] <= box[2][1])
                       for p in (pick, place)]
            assert sorted(cubbies) == [0, 1]
            assert (pick - above_pick)[0] > 0 and np.allclose((pick - above_pick)[1:], 0)
