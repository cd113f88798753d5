"""Problem sets of the planning benchmark (pipeline.bench.plan_sets): their cells, determinism, the starts and
goals (in limits, free, on the reference arm configuration, TCP poses from FK), the cubbies' fixed targets and
that most drawn queries need a search."""

from __future__ import annotations

import importlib.resources
import itertools

import numpy as np
import pytest

from pipeline.bench.plan_sets import (
    ARM_CONFIGURATION,
    CUBBY_POSITIONS,
    MBM_SCENES,
    OWN_SCENES,
    SCALE,
    SCENES,
    SET_NAMES,
    X_FT,
    problem_set,
    search_fraction,
    set_cell,
    set_model,
)
from pipeline.cell.cell_file import cell_names, load_cell
from pipeline.errors import ConfigurationError, PipelineError
from pipeline.files.branch_names import matches
from pipeline.model.chain.kinematics import DhKinematics
from pipeline.model.ik.branches import configuration_labels

#: Queries drawn per set in these tests (the benchmark draws 100).
COUNT = 10
DRAWN = tuple(name for name in SET_NAMES if name != "cubbies")


def _quick(names) -> list:
    """``names`` for parametrize, the IRB 1600 twins of our own scenes (their GP7 sets test the same code) in the
    slow run only: make test stays under 5 minutes."""
    return [pytest.param(name, marks=pytest.mark.slow)
            if name.startswith("irb1600_") and name.split("_", 1)[1] in OWN_SCENES else name for name in names]


NEW_CELLS = tuple(f"{robot}_{scene}" for robot in ("gp7", "irb1600") for scene in SCENES)
#: How far a TCP pose may be from the oracle's FK [m or rotation-matrix entries]: round-off of two FK codes.
FK_TOLERANCE = 1e-9
#: The cubbies' tool axis is +x within this [1].
AXIS_TOLERANCE = 1e-6


@pytest.fixture(scope="module")
def sets():
    """Each set's model and problem set (COUNT queries, seed 0), built on first use."""
    cache = {}

    def get(name: str):
        if name not in cache:
            model = set_model(name)
            cache[name] = (model, problem_set(name, model, count=COUNT, seed=0))
        return cache[name]
    return get


@pytest.mark.parametrize("cell", NEW_CELLS)
def test_the_scene_cells_are_installed_and_load(cell):
    resource = importlib.resources.files("pipeline.models") / "cells" / f"{cell}.yaml"
    assert resource.is_file() and cell in cell_names()
    loaded = load_cell(cell)
    assert loaded.name == cell and str(loaded.robot) == cell.split("_")[0]
    assert loaded.clearance == pytest.approx(0.010) and len(loaded.objects) < 30
    assert [(s.name, s.kind, s.size) for s in loaded.tool_shapes] == [("gripper", "cylinder", (0.035, 0.120))]
    assert "floor" in [s.name for s in loaded.objects]
    text = resource.read_text()
    if cell.split("_", 1)[1] in MBM_SCENES:
        assert "Copyright (c) 2021, Rice University" in text and "BSD 3-Clause" in text
    else:
        assert text.startswith("# Our own planning scene (not after a MotionBenchMaker scene)")
        assert "Rice University" not in text


def test_set_names_and_cells():
    assert SET_NAMES[0] == "cubbies" and set(DRAWN) == set(NEW_CELLS)
    assert set_cell("cubbies") == "gp7_shelf_cell" and set_cell("gp7_box") == "gp7_box"
    with pytest.raises(PipelineError, match="unknown problem set 'gp7_boxes'"):
        set_cell("gp7_boxes")


def test_a_model_of_another_cell_is_refused(sets):
    model, _ = sets("gp7_box")
    with pytest.raises(PipelineError, match="posed in cell gp7_bookshelf, the model given is in gp7_box"):
        problem_set("gp7_bookshelf", model, count=2)


@pytest.mark.parametrize("name", _quick(SET_NAMES))
def test_every_set_repeats_with_its_seed(sets, name):
    model, problems = sets(name)
    again = problem_set(name, model, count=COUNT, seed=0)
    for field in ("start", "goal", "X_start", "X_goal"):
        np.testing.assert_array_equal([getattr(q, field) for q in problems.queries],
                                      [getattr(q, field) for q in again.queries])
    if name != "cubbies":
        other = problem_set(name, model, count=COUNT, seed=1)
        assert not np.array_equal([q.start for q in other.queries], [q.start for q in problems.queries])


@pytest.mark.parametrize("name", _quick(SET_NAMES))
def test_starts_and_goals_are_free_in_limits_and_their_tcp_poses_match_fk(sets, name):
    model, problems = sets(name)
    oracle = DhKinematics(model.robot.spec)
    lo, hi = model.robot.limits.q_min, model.robot.limits.q_max
    assert problems.cell == model.cell.name == set_cell(name)
    np.testing.assert_array_equal(problems.X_FT, X_FT)
    for query in problems.queries:
        for q, X in ((query.start, query.X_start), (query.goal, query.X_goal)):
            assert q.shape == (model.robot.dof,) and np.all(lo <= q) and np.all(q <= hi)
            assert model.is_free(q)
            np.testing.assert_allclose(X, model.cell.X_WB @ oracle.fk(q) @ X_FT, atol=FK_TOLERANCE)
    Q = np.array([q for query in problems.queries for q in (query.start, query.goal)])
    assert all(matches(label, ARM_CONFIGURATION) for label in configuration_labels(model.robot, Q))


def test_the_cubbies_are_every_ordered_pair_of_six_targets_tool_pointing_in(sets):
    _, problems = sets("cubbies")
    assert len(problems.queries) == 30
    starts = {tuple(q.start) for q in problems.queries}
    assert len(starts) == 6
    assert {(tuple(q.start), tuple(q.goal)) for q in problems.queries} == set(itertools.permutations(starts, 2))
    for query in problems.queries:
        for X in (query.X_start, query.X_goal):
            np.testing.assert_allclose(X[:3, 2], [1.0, 0.0, 0.0], atol=AXIS_TOLERANCE)
    positions = {tuple(np.round(q.X_start[:3, 3], 6)) for q in problems.queries}
    assert positions == {tuple(np.round(p, 6)) for p in CUBBY_POSITIONS}


@pytest.mark.parametrize("name", _quick(DRAWN))
def test_drawn_queries_chain_targets_of_different_regions(sets, name):
    _, problems = sets(name)
    assert [q.index for q in problems.queries] == list(range(COUNT))
    for a, b in zip(problems.queries[:-1], problems.queries[1:]):
        np.testing.assert_array_equal(a.goal, b.start)
    assert all(q.start_region != q.goal_region for q in problems.queries)
    assert sum(kept for _, kept, _ in problems.draws) == COUNT + 1


def _regions(name: str) -> tuple:
    """A drawn set's scene and its regions by name."""
    scene = SCENES[name.split("_", 1)[1]]
    return scene, {region.name: region for region in scene.regions}


@pytest.mark.parametrize("name", _quick(DRAWN))
def test_the_tool_points_down_or_in_as_the_region_says(sets, name):
    _, problems = sets(name)
    scene, regions = _regions(name)
    for query in problems.queries:
        for label, X in ((query.start_region, query.X_start), (query.goal_region, query.X_goal)):
            region, axis = regions[label], X[:3, 2]
            if (region.reference or scene.reference) == "down":
                assert axis[2] <= -np.cos(np.radians(region.tilt_deg)) + AXIS_TOLERANCE
            else:           # horizontal, into the fixture: along the region's heading, turned up to its yaw
                heading, yaw = np.radians([region.heading_deg, region.yaw_deg])
                assert region.tilt_deg == 0 and abs(axis[2]) <= AXIS_TOLERANCE
                assert axis @ [np.cos(heading), np.sin(heading), 0.0] >= np.cos(yaw) - AXIS_TOLERANCE


@pytest.mark.parametrize("name", _quick(DRAWN))
def test_the_targets_are_in_their_regions(sets, name):
    _, problems = sets(name)
    _, regions = _regions(name)
    scale = SCALE[name.split("_", 1)[0]]
    for query in problems.queries:
        for label, X in ((query.start_region, query.X_start), (query.goal_region, query.X_goal)):
            region = regions[label]
            c, s = np.cos(np.radians(region.heading_deg)), np.sin(np.radians(region.heading_deg))
            x, y, z = X[:3, 3] * 1e3 / scale
            p = np.array([c * x + s * y, -s * x + c * y, z])        # in the region's frame (turned by its heading)
            assert np.all(np.array(region.lo) - 1e-6 <= p) and np.all(p <= np.array(region.hi) + 1e-6)


def test_the_new_scenes_face_their_fixtures():
    """The rack's slots and the totes are drawn in frames turned toward them, the door's table to the left."""
    assert {region.heading_deg for region in SCENES["rack"].regions} == {-45.0}
    assert len({(region.lo[1], region.lo[2]) for region in SCENES["rack"].regions}) == 9
    assert [region.heading_deg for region in SCENES["tote"].regions] == [0.0, 90.0, -60.0]
    door = SCENES["machine_door"].regions
    assert [(region.name, region.reference or "in", region.heading_deg) for region in door] == [
        ("chuck", "in", 0.0), ("table_back", "down", 90.0), ("chuck", "in", 0.0), ("table_front", "down", 90.0)]


@pytest.mark.parametrize("name", _quick(DRAWN))
def test_most_drawn_queries_need_a_search(sets, name):
    model, problems = sets(name)
    assert search_fraction(model, problems) > 0.5


def test_a_bad_count_is_refused(sets):
    model, _ = sets("gp7_box")
    with pytest.raises(ConfigurationError, match="problem set gp7_box: count must be an integer >= 1, got 0"):
        problem_set("gp7_box", model, count=0)
