"""The planning benchmark on a few pairs: its problem set, its independent checks, its report and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.bench.plan import (
    CELLS,
    cell_model,
    dense_polyline,
    problem_set,
    run_plan_benchmark,
    subdivided,
    verify,
)

PAIRS = 3


@pytest.fixture(scope="module")
def report():
    return run_plan_benchmark(cells=("gp7_wall_cell",), pairs=PAIRS, seed=1)


def test_problem_pairs_are_free_and_repeat_with_the_seed():
    model = cell_model("gp7_shelf_cell")
    pairs = problem_set(model, 4, np.random.default_rng(3))
    again = problem_set(model, 4, np.random.default_rng(3))
    assert len(pairs) == 4 and all(model.is_free(q) for pair in pairs for q in pair)
    np.testing.assert_array_equal(np.array(pairs), np.array(again))


@pytest.mark.parametrize("name", CELLS)
def test_the_cells_leave_room_to_move(name):
    model = cell_model(name)
    assert model.is_free(np.zeros(6))
    Q = model.robot.random_configurations(np.random.default_rng(0), 200)
    assert np.mean([model.is_free(q) for q in Q]) > 0.3


def test_the_independent_check_finds_the_straight_edge_through_the_wall():
    model = cell_model("gp7_wall_cell")
    pick, place = np.radians([[30, 20, 10, 0, -60, 0], [-30, 20, 10, 0, -60, 0]])
    check = verify(model, np.array([pick, place]))
    assert not check.ok and check.obstacle_m < model.clearance_m
    assert "independent check" in check.why()


def test_dense_points_keep_the_vertices_and_the_step():
    V = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.3]])
    Q = dense_polyline(V, 0.1)
    assert np.all(np.linalg.norm(np.diff(Q, axis=0), axis=1) <= 0.1 + 1e-12)
    assert all(any(np.allclose(q, v) for q in Q) for v in V)
    S = subdivided(V, 10)
    assert len(S) == 21 and np.allclose(S[::10], V) and np.allclose(S[5], [0.5, 0.0])


def test_the_report_has_every_figure_and_goal(report):
    (cell,) = report.cells
    assert cell.pairs == PAIRS == len(cell.records) and cell.direct + cell.search == PAIRS
    assert cell.feasible + len(cell.unproven) == PAIRS
    assert [r.ours_first for r in cell.records] == [True, False, True]
    for figures in (cell.ours, cell.peer):
        assert figures.success is None or 0.0 <= figures.success <= 1.0
    assert report.job.runs == min(cell.search, 20) and report.job.certified <= report.job.runs
    text = report.format_table()
    assert "gp7_wall_cell" in text and "whole job" in text and "peer / ours" in text
    assert len(report.goals) == 5 and text.count("  PASS  ") + text.count("  FAIL  ") == 5
    assert report.to_dict()["cells"][0]["cell"] == "gp7_wall_cell"


@pytest.mark.slow                                  # the whole suite through the CLI: about 6 s
def test_the_cli_runs_the_suite_and_writes_json(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["bench", "plan", "--pairs", "1", "--seed", "2", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert [c["cell"] for c in data["cells"]] == list(CELLS) and len(data["goals"]) == 5
    assert "Goals:" in capsys.readouterr().out


def test_the_cli_refuses_no_pairs(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "plan", "--pairs", "0"])
