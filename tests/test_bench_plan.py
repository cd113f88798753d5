"""The planning benchmark on a few pairs: its problem set, its independent check and its report."""

from __future__ import annotations

import numpy as np

from pipeline.bench.plan import cell_file, problem_set, run_plan_benchmark, verify
from pipeline.cell import load_cell
from pipeline.collision import CollisionModel


def test_problem_pairs_are_free_and_repeat_with_the_seed():
    cell = load_cell(cell_file("gp7_shelf_cell"))
    model = CollisionModel(cell.load_robot(), cell)
    pairs = problem_set(model, 4, np.random.default_rng(3))
    again = problem_set(model, 4, np.random.default_rng(3))
    assert len(pairs) == 4 and all(model.is_free(q) for pair in pairs for q in pair)
    np.testing.assert_array_equal(np.array(pairs), np.array(again))


def test_the_independent_check_finds_a_path_through_the_wall():
    cell = load_cell(cell_file("gp7_wall_cell"))
    model = CollisionModel(cell.load_robot(), cell)
    pick, place = np.radians([[30, 20, 10, 0, -60, 0], [-30, 20, 10, 0, -60, 0]])
    free, distance = verify(model, np.array([pick, place]))
    assert not free and distance < model.clearance_m


def test_the_report_has_every_figure_and_goal():
    report = run_plan_benchmark(cells=("gp7_wall_cell",), pairs=3, seed=1)
    (cell,) = report.cells
    assert cell.pairs == 3 and cell.feasible + cell.unproven == 3 and 0 <= cell.search_pairs <= 3
    assert cell.ours_success is None or 0.0 <= cell.ours_success <= 1.0
    text = report.format_table()
    assert "gp7_wall_cell" in text and "whole job" in text and len(report.goals) == 5
    assert text.count("PASS") + text.count("FAIL") == 5
    assert report.to_dict()["cells"][0]["cell"] == "gp7_wall_cell"
