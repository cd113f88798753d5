"""Reachability maps in this process (``pipeline.scale.reach``, ``grid``, ``result``, ``figures``): the grid
and the orientations asked for, the wrist centre, manipulability against ``compute_singularity``, voxels
recomputed one target at a time, a cell's obstacles, the numeric path, the files, bad input, and the
IRB 1600's datasheet reach. The maps on Dask workers (equal to these, a worker killed) are in
tests/scale/test_scale.py."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest

from pipeline.cell.cell_file import load_cell
from pipeline.errors import ConfigurationError, OutputError, RobotNotFoundError, ScaleInputError
from pipeline.files.atomic import OWNER_MARKER
from pipeline.model.chain.singularity import compute_singularity
from pipeline.model.robot import load_robot
from pipeline.scale import reachability_map
from pipeline.scale.grid import CONE_AXIS, reach_grid, tool_orientations, wrist_centre_robot
from pipeline.scale.reach import branch_count, manipulability_batch, penetrates
from pipeline.scale.result import FILES

from ..conftest import DATA_DIR
from .test_scale import CELL

#: The IRB 1600-6/1.2 datasheet's reach, and its wrist centre stretched out from axis 1: a1 + a2 + d4
#: (models/SOURCES.md) [m].
IRB1600_DATASHEET_REACH_M = 1.2
IRB1600_STRETCHED_M = 0.150 + 0.475 + 0.600


@pytest.fixture(scope="module")
def irb_map():
    """The IRB 1600's flange map, coarse: 150 mm voxels, 6 orientations."""
    return reachability_map("irb1600", step=0.15, orientations=6, seed=3)


# -- what is asked --------------------------------------------------------------------------------------
def test_the_grid_covers_the_reach_bound_and_keeps_its_centres_off_the_base_axis():
    robot = load_robot("gp7")
    grid = reach_grid(robot, 0.1)
    for axis in grid.axes:                                  # every point of the ball lies in a voxel
        assert axis[0] - 0.05 <= -robot.spec.reach_bound and axis[-1] + 0.05 >= robot.spec.reach_bound
        np.testing.assert_allclose(np.diff(axis), 0.1)
    centres = grid.centres(np.arange(np.prod(grid.shape)))
    assert np.linalg.norm(centres[:, :2], axis=1).min() == pytest.approx(0.05 * math.sqrt(2))
    assert np.any(centres[:, 2] == 0.0)
    inside = grid.within(0.35)
    assert np.all(np.linalg.norm(grid.centres(inside), axis=1) <= 0.35)
    assert len(inside) == sum(1 for i in range(-4, 4) for j in range(-4, 4) for k in range(-3, 4)
                              if (0.1 * i + 0.05) ** 2 + (0.1 * j + 0.05) ** 2 + (0.1 * k) ** 2 <= 0.35 ** 2)


def test_orientations_are_rotations_and_a_cone_keeps_the_tool_axis_inside_it():
    R = tool_orientations(50, None, 1, seed=1)
    assert R.shape == (50, 1, 3, 3)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    np.testing.assert_array_equal(R, tool_orientations(50, None, 1, seed=1))
    cone = tool_orientations(40, 25.0, 8, seed=2)
    assert cone.shape == (40, 8, 3, 3) and np.allclose(np.linalg.det(cone), 1.0)
    angles = np.degrees(np.arccos(np.clip(cone[..., :, 2] @ CONE_AXIS, -1, 1)))
    assert angles.max() <= 25.0 + 1e-9 and angles.max() > 15.0
    np.testing.assert_allclose(cone[:, :, :, 2], cone[:, :1, :, 2].repeat(8, axis=1), atol=1e-12)   # rolls: same axis
    x = cone[:, :, :, 0]
    turns = np.degrees(np.arccos(np.clip(np.einsum("nrk,nrk->nr", x[:, 1:], x[:, :-1]), -1, 1)))
    np.testing.assert_allclose(turns, 45.0, atol=1e-6)


def test_the_wrist_centre_does_not_move_with_the_wrist_joints():
    robot = load_robot("irb1600")
    wrist = wrist_centre_robot(robot)
    rng = np.random.default_rng(0)
    for q in robot.random_configurations(rng, 5):
        other = q.copy()
        other[3:] = robot.random_configurations(rng, 1)[0, 3:]
        np.testing.assert_allclose(wrist.fk(q)[:3, 3], wrist.fk(other)[:3, 3], atol=1e-12)
    # At q = 0 the IRB 1600's wrist centre is d6 = 65 mm behind the flange, along the flange's z.
    X = robot.fk(np.zeros(6))
    np.testing.assert_allclose(wrist.fk(np.zeros(6))[:3, 3], X[:3, 3] - 0.065 * X[:3, 2], atol=1e-12)
    with pytest.raises(ConfigurationError, match="no wrist centre"):
        wrist_centre_robot(load_robot("arm5"))


@pytest.mark.parametrize("name", ["gp7", "arm5"])
def test_batch_manipulability_is_compute_singularitys(name):
    robot = load_robot(name)
    Q = robot.random_configurations(np.random.default_rng(4), 30)
    expected = [compute_singularity(robot.jacobian(q)).manipulability for q in Q]
    np.testing.assert_allclose(manipulability_batch(robot, Q), expected, rtol=1e-12, atol=1e-15)


def test_a_configuration_that_penetrates_is_never_free_and_most_that_are_not_free_penetrate():
    from pipeline.cell.collision import CollisionModel

    cell = load_cell(CELL)
    model = CollisionModel(cell.load_robot(), cell)
    Q = model.robot.random_configurations(np.random.default_rng(6), 400)
    fast = np.array([penetrates(model, q) for q in Q])
    free = np.array([model.is_free(q) for q in Q])
    assert not np.any(fast & free)
    assert np.count_nonzero(fast) > 0.8 * np.count_nonzero(~free)


def test_branches_count_labels_once_and_unlabelled_solutions_each():
    from pipeline.model.ik.result import Solution

    q = np.zeros(6)
    assert branch_count([Solution(q, 0, 0, "a"), Solution(q, 0, 0, "a"), Solution(q, 0, 0, "b")]) == 2
    assert branch_count([Solution(q, 0, 0), Solution(q, 0, 0)]) == 2 and branch_count(()) == 0


# -- the map --------------------------------------------------------------------------------------------
def test_sampled_voxels_recomputed_one_target_at_a_time_agree(irb_map):
    """The batch, the chunks and the assembly against plain ``robot.ik`` per target and
    ``compute_singularity`` per solution, on voxels reached and not."""
    robot = irb_map.robot
    rng = np.random.default_rng(5)
    reached, missed = np.flatnonzero(irb_map.fraction > 0), np.flatnonzero(irb_map.fraction == 0)
    within = missed[np.linalg.norm(irb_map.grid.centres(missed), axis=1) <= robot.spec.reach_bound]
    for flat in [*rng.choice(reached, 12, replace=False), *rng.choice(within, 4, replace=False)]:
        centre = irb_map.grid.centres(np.array([flat]))[0]
        hits, branches, best = 0, 0, 0.0
        for R in irb_map.rotations:
            X = np.eye(4)
            X[:3, :3], X[:3, 3] = R, centre
            result = robot.ik(X, method="analytic")
            hits += result.success
            branches = max(branches, len({s.branch for s in result.solutions}))
            best = max([best, *(compute_singularity(robot.jacobian(s.q)).manipulability for s in result.solutions)])
        assert irb_map.fraction.flat[flat] == hits / len(irb_map.rotations)
        assert irb_map.branches.flat[flat] == branches
        assert irb_map.manipulability.flat[flat] == pytest.approx(best, rel=1e-12, abs=1e-15)


def test_the_map_has_its_figures_of_merit(irb_map):
    summary = irb_map.summary()
    assert irb_map.fraction.shape == irb_map.grid.shape == irb_map.branches.shape
    assert 0.0 <= irb_map.fraction.min() and irb_map.fraction.max() == 1.0
    assert irb_map.branches.max() == 8 and summary["branches_max"] == 8       # every closed-form branch somewhere
    assert summary["orientations"] == 6 and summary["ik_method"] == "analytic" and summary["target_kind"] == "pose"
    volumes = list(summary["volume_m3"].values())
    assert volumes == sorted(volumes, reverse=True) and volumes[0] > 1.0
    assert volumes[0] == pytest.approx(np.count_nonzero(irb_map.fraction) * 0.15 ** 3)
    # The flange reaches a1 + a2 + d4 + d6 from axis 1 at most (stretched, pointing out).
    assert IRB1600_STRETCHED_M - 0.15 * math.sqrt(3) < irb_map.reach_m <= IRB1600_STRETCHED_M + 0.065
    assert irb_map.reach_m <= irb_map.reach_from_base_origin_m and irb_map.poses > 0


@pytest.mark.slow
def test_in_a_cell_voxels_inside_obstacles_are_never_reached():
    cell = load_cell(CELL)
    free = reachability_map(cell.load_robot(), step=0.15, orientations=2, tool_axis_cone=20)
    in_cell = reachability_map(cell, step=0.15, orientations=2, tool_axis_cone=20)
    assert in_cell.summary()["cell"] == "gp7_wall_cell"
    centres = in_cell.grid.centres(np.arange(in_cell.fraction.size))
    X_BW = np.linalg.inv(cell.X_WB)
    inside = np.zeros(len(centres), dtype=bool)
    for shape in cell.objects:
        local = (np.linalg.inv(X_BW @ shape.X) @ np.column_stack([centres, np.ones(len(centres))]).T).T[:, :3]
        inside |= np.all(np.abs(local) <= np.array(shape.size) / 2.0, axis=1)
    assert np.count_nonzero(free.fraction.ravel()[inside]) > 0        # the robot alone reaches into the table...
    assert np.count_nonzero(in_cell.fraction.ravel()[inside]) == 0    # ...not in the cell
    assert np.all(in_cell.fraction <= free.fraction) and in_cell.volume_m3() < free.volume_m3()


def test_a_five_axis_arm_is_mapped_by_its_tool_axis_with_numeric_ik_the_same_whatever_the_chunks():
    first = reachability_map("arm5", step=0.3, orientations=3, tool_axis_cone=45, seed=1)
    again = reachability_map("arm5", step=0.3, orientations=3, tool_axis_cone=45, seed=1, chunk_poses=7)
    assert first.method == "jacobian" and first.kind == "position+axis" and first.rolls == 1
    assert again.chunks > first.chunks
    for name in ("fraction", "manipulability", "branches"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
    assert first.volume_m3() > 0 and first.branches.max() == 1      # one numeric answer per target


@pytest.mark.slow
def test_save_writes_the_arrays_with_units_the_figures_and_the_summary(tmp_path, irb_map):
    out = tmp_path / "map"
    paths = irb_map.save(out)
    assert sorted(p.name for p in out.iterdir()) == sorted([OWNER_MARKER, *FILES.values()])
    assert all(p.is_file() for p in paths)
    with np.load(out / FILES["npz"]) as data:
        np.testing.assert_array_equal(data["fraction"], irb_map.fraction)
        np.testing.assert_array_equal(data["branches"], irb_map.branches)
        np.testing.assert_array_equal(data["x"], irb_map.grid.axes[0])
        assert float(data["step"]) == 0.15 and data["rotations"].shape == (6, 3, 3)
        units = json.loads(str(data["units"]))
        assert units["x"] == "m" and units["fraction"] == "1" and units["manipulability"] == "m^3"
        assert json.loads(str(data["summary"]))["reach_m"] == irb_map.reach_m
    assert (out / FILES["png"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / FILES["html"]).read_text()
    assert "<html" in html.lower() and len(html) > 100_000
    summary = json.loads((out / FILES["json"]).read_text())
    assert summary["robot"] == "irb1600" and summary["reach_m"] == irb_map.reach_m and summary["step_m"] == 0.15
    (tmp_path / "foreign").mkdir()
    (tmp_path / "foreign" / "notes.txt").write_text("mine")
    with pytest.raises(OutputError):
        irb_map.save(tmp_path / "foreign")


@pytest.mark.parametrize("kwargs, field, value", [
    ({"step": 0}, "step", 0), ({"step": -0.01}, "step", -0.01), ({"step": math.nan}, "step", math.nan),
    ({"step": "25"}, "step", "25"), ({"orientations": 0}, "orientations", 0),
    ({"tool_axis_cone": 0}, "tool_axis_cone", 0), ({"tool_axis_cone": 181}, "tool_axis_cone", 181),
    ({"seed": -1}, "seed", -1), ({"point": "elbow"}, "point", "elbow"), ({"chunk_poses": 0}, "chunk_poses", 0),
    ({"step": 1e-4}, "step", 1e-4),                       # 34,000^3 voxels
])
def test_bad_map_arguments_are_typed_errors_naming_the_field_and_value(kwargs, field, value):
    with pytest.raises(ScaleInputError) as info:
        reachability_map("gp7", **kwargs)
    assert info.value.field == field and repr(value)[:6] in str(info.value)
    assert str(info.value).startswith(f"{field}: ")


def test_an_unknown_robot_is_a_typed_error_naming_it():
    with pytest.raises(RobotNotFoundError, match="nope"):
        reachability_map("nope")


def test_the_wrist_of_an_arm_without_one_is_a_typed_error():
    with pytest.raises(ConfigurationError, match="arm5.*no wrist centre"):
        reachability_map("arm5", point="wrist")


def test_a_ur_arm_is_mapped_by_its_compiled_closed_form():
    """The UR5 of tests/data (the UR family's closed form, one solution per branch): every branch somewhere,
    voxels recomputed one target at a time agree, and nothing beyond the stretched arm (|a2| + |a3| + d5
    from axis 1 in its plane, with d4 + d6 across it)."""
    ur_map = reachability_map(DATA_DIR / "ur5.yaml", step=0.15, orientations=6, seed=3)
    summary = ur_map.summary()
    assert summary["ik_method"] == "analytic" and ur_map.branches.max() == 8
    robot = ur_map.robot
    for flat in np.random.default_rng(6).choice(np.flatnonzero(ur_map.fraction > 0), 6, replace=False):
        results = []
        for R in ur_map.rotations:
            X = np.eye(4)
            X[:3, :3], X[:3, 3] = R, ur_map.grid.centres(np.array([flat]))[0]
            results.append(robot.ik(X, method="analytic"))
        assert ur_map.fraction.flat[flat] == np.mean([r.success for r in results])
        assert ur_map.branches.flat[flat] == max(len({s.branch for s in r.solutions}) for r in results)
    assert ur_map.reach_m <= math.hypot(0.425 + 0.39225 + 0.09465, 0.10915 + 0.0823)


# -- the IRB 1600's datasheet reach ---------------------------------------------------------------------
def check_datasheet_reach(reach_map) -> None:
    """ABB gives the IRB 1600-6/1.2's reach as "1.2 m", at the wrist centre (axis 5), from axis 1: its
    own dimensions put the stretched wrist centre at a1 + a2 + d4 = 1.225 m, which it rounds to 1.2 m.
    The map's reach (the largest distance of a reachable wrist-centre voxel centre from axis 1) is never
    beyond 1.225 m, falls short of it by less than a voxel diagonal, and rounds to the datasheet's 1.2 m."""
    reach = reach_map.reach_m
    assert reach_map.point == "wrist"
    assert IRB1600_STRETCHED_M - reach_map.step * math.sqrt(3) <= reach <= IRB1600_STRETCHED_M + 1e-9, reach
    assert round(reach, 1) == IRB1600_DATASHEET_REACH_M


@pytest.mark.slow
def test_the_irb1600_reaches_its_datasheet_reach_coarse_map():
    reach_map = reachability_map("irb1600", step=0.1, orientations=4, point="wrist")
    check_datasheet_reach(reach_map)
    assert abs(reach_map.reach_m - IRB1600_DATASHEET_REACH_M) <= 0.02 * IRB1600_DATASHEET_REACH_M


@pytest.mark.slow
def test_the_irb1600_reaches_its_datasheet_reach_25_mm_map():
    from pipeline.scale import dask_client

    with dask_client(workers=2) as client:
        # the wrist centre's position is set by joints 1-3: one orientation a voxel finds the reach to
        # 0.13 mm (1.22487 m) with a quarter of the IK targets of four (270 s on 2 shared cores)
        reach_map = reachability_map("irb1600", step=0.025, orientations=1, point="wrist", client=client)
    check_datasheet_reach(reach_map)
    assert IRB1600_STRETCHED_M - reach_map.reach_m < 1e-3          # 25 mm voxels find it to a millimetre
    deviation = 100 * (reach_map.reach_m / IRB1600_DATASHEET_REACH_M - 1)
    print(f"IRB 1600 wrist-centre reach, 25 mm map: {reach_map.reach_m:.5f} m, {deviation:+.3f} % of the datasheet's "
          "1.2 m", file=sys.stderr)


# -- fuzz finding 8 of issue 22: the work of a map is bounded, not only its voxels --------------------------
@pytest.mark.parametrize("kwargs, field, problem", [
    ({"orientations": 1_000_000_000}, "orientations", "in [1, 10,000]"),     # was a MemoryError at 29.8 GiB
    ({"orientations": 200_000}, "orientations", "in [1, 10,000]"),           # ran past 60 s
    ({"orientations": 10_000}, "step x orientations", "more than 1,000,000,000"),
    ({"step": 0.01, "orientations": 100}, "step x orientations", "23,485,544 voxels x 100 orientations"),
    ({"chunk_poses": 10**9}, "chunk_poses", "in [1, 1,000,000]"),
])
def test_a_map_of_too_much_work_is_refused_before_any_is_done(kwargs, field, problem):
    """Finding 8: the bound covered voxels, not voxels x orientations. The product (IK targets) is
    bounded by MAX_POSES and counted without building the grid's arrays, so a refusal is immediate."""
    with pytest.raises(ScaleInputError) as info:
        reachability_map("irb1600", **kwargs)
    assert info.value.field == field and problem in str(info.value)


def test_the_targets_are_counted_exactly_without_the_grids_arrays():
    from pipeline.scale.grid import MAX_POSES
    from pipeline.scale.reach import plan_map

    for name, step in (("irb1600", 0.05), ("arm5", 0.037), ("gp7", 0.1)):
        robot = load_robot(name)
        grid = reach_grid(robot, step)
        assert grid.count_within(robot.spec.reach_bound) == len(grid.within(robot.spec.reach_bound))
    plan = plan_map("irb1600", step=0.025, orientations=16)
    assert plan.poses == 24_053_504 and plan.poses * 40 < MAX_POSES       # the default map fits 40 times over


def test_worker_processes_are_bounded_per_core():
    """A LocalCluster of a million processes would fork the machine to death: refused at once."""
    from pipeline.scale import dask_client
    from pipeline.scale.cluster import max_local_workers

    with pytest.raises(ScaleInputError, match=rf"--workers: must be a whole number in \[1, {max_local_workers()}\]"):
        with dask_client(workers=10**6):
            pass
