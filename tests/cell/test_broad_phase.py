"""The compiled broad phase: its link capsules are Drake's, its distances lower bounds, and it never calls free
a configuration or an edge Drake's checker (with the same paddings) finds colliding, nor a hit one it finds free."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit
from scipy.spatial.transform import Rotation

from pipeline.bench.broad_phase import CHECKERS
from pipeline.bench.plan_sets import cell_model
from pipeline.cell import broad_phase as bp
from pipeline.cell.cell_file import Shape, cell_names, load_cell
from pipeline.cell.collision import CollisionModel

#: A cell with every obstacle kind and a tool box beside the gripper cylinder (mm, deg).
ALL_KINDS_CELL = """\
name: all_kinds
length_unit: mm
angle_unit: deg
robot: gp7
clearance: 10
objects:
  - {name: table, box: [800, 1200, 40], xyz: [650, 0, -20], rpy: [0, 0, 10]}
  - {name: post, cylinder: [50, 900], xyz: [400, 300, 450], rpy: [20, 0, 0]}
  - {name: disc, cylinder: [200, 30], xyz: [500, -300, 300]}
  - {name: ball, sphere: 60, xyz: [300, -400, 200]}
  - {name: rail, capsule: [20, 500], xyz: [300, 0, 700], quaternion: [0.7071068, 0.7071068, 0, 0]}
tool_shapes:
  - {name: gripper, cylinder: [35, 120], xyz: [0, 0, 60]}
  - {name: camera, box: [40, 60, 90], xyz: [0, 70, 30], rpy: [0, 0, 30]}
"""


@pytest.fixture(scope="module")
def shelf():
    return cell_model("gp7_bookshelf")


@pytest.fixture(scope="module")
def irb():
    return cell_model("irb1600_box")


def _all_kinds(folder, robot: str = "gp7") -> CollisionModel:
    """``robot`` in the cell of every obstacle kind (ALL_KINDS_CELL, written into ``folder``)."""
    path = folder / "all_kinds.yaml"
    path.write_text(ALL_KINDS_CELL.replace("robot: gp7", f"robot: {robot}"))
    cell = load_cell(path)
    return CollisionModel(cell.load_robot(), cell)


@pytest.fixture(scope="module")
def arm5(tmp_path_factory):
    """The five-axis arm in the cell of every obstacle kind, with a tool box and cylinder."""
    return _all_kinds(tmp_path_factory.mktemp("arm5"), "arm5")


def _drake_free(checker, Q) -> np.ndarray:
    return np.array([checker.CheckConfigCollisionFree(q) for q in Q])


def _compare(model, count: int, seed: int) -> dict[str, tuple[int, float, int, float]]:
    """Per checker of the benchmark: (false frees, fraction of Drake's free configurations called free, false
    hits, fraction of Drake's colliding configurations called a hit)."""
    Q = model.robot.random_configurations(np.random.default_rng(seed), count)
    out = {}
    for name, (extra_m, self_m) in CHECKERS.items():
        broad = model.broad_phase(extra_m, self_m)
        verdicts, drake = broad.verdicts(Q), _drake_free(broad.checker, Q)
        ours, hit = verdicts == bp.FREE, verdicts == bp.HIT
        out[name] = (int((ours & ~drake).sum()), float((ours & drake).sum() / max(drake.sum(), 1)),
                     int((hit & drake).sum()), float((hit & ~drake).sum() / max((~drake).sum(), 1)))
        assert np.array_equal(broad.free(Q), ours)
    return out


@pytest.mark.parametrize("which", ["shelf", "irb"])
def test_the_capsules_are_drakes_in_the_world(which, request):
    model = request.getfixturevalue(which)
    broad = model.broad_phase()
    Q = model.robot.random_configurations(np.random.default_rng(1), 10)
    segments = broad.segments(Q) @ model.cell.X_WB[:3, :3].T + model.cell.X_WB[:3, 3]
    context = model.diagram.CreateDefaultContext()
    plant_context = model.plant.GetMyContextFromRoot(context)
    checked = 0
    for q, ours in zip(Q, segments):
        model.plant.SetPositions(plant_context, q)
        query = model.plant.get_geometry_query_input_port().Eval(plant_context)
        inspector = query.inspector()
        ids = {inspector.GetName(g).split("::")[-1]: g for g in inspector.GetAllGeometryIds()}
        for k, name in enumerate(broad.names):
            if not name.startswith("capsule"):
                continue
            shape = inspector.GetShape(ids[name])
            half = shape.length() / 2.0 if hasattr(shape, "length") else 0.0
            X = query.GetPoseInWorld(ids[name])
            np.testing.assert_allclose(ours[k], [X.multiply([0, 0, -half]), X.multiply([0, 0, half])], atol=1e-9)
            checked += 1
    assert checked >= 10 * 6


@njit
def _distances(segments, boxes, halves):
    """Per row: (segment-segment squared distance of segments[k] and segments[k + 1], segment-box squared
    distance of segments[k] and the box of half sides halves[k])."""
    out = np.empty((segments.shape[0] - 1, 2))
    breaks = np.empty(8)
    for k in range(segments.shape[0] - 1):
        out[k, 0] = bp._segment_segment_sq(segments, k, segments, k + 1)
        out[k, 1] = bp._segment_box_sq(segments[k, :3], segments[k, 3:] - segments[k, :3], halves[k], breaks)
    return out


def test_the_distances_are_exact_within_sampling():
    rng = np.random.default_rng(2)
    segments = rng.normal(size=(150, 6)) * 0.3
    segments[::7, 3:] = segments[::7, :3]                                # points among them
    segments[1::9, 3:] = segments[1::9, :3] + (segments[2::9, 3:] - segments[2::9, :3])[:len(segments[1::9])]  # parallels
    halves = rng.uniform(0.01, 0.3, size=(150, 3))
    ours = np.sqrt(_distances(segments, None, halves))
    t = np.linspace(0.0, 1.0, 101)[:, None]
    for k in range(len(segments) - 1):
        a = segments[k, :3] + t * (segments[k, 3:] - segments[k, :3])
        b = segments[k + 1, :3] + t * (segments[k + 1, 3:] - segments[k + 1, :3])
        sampled = np.linalg.norm(a[:, None] - b[None], axis=2).min()
        assert ours[k, 0] <= sampled + 1e-12 and ours[k, 0] >= sampled - 0.01
        to_box = np.linalg.norm(np.maximum(np.abs(a) - halves[k], 0.0), axis=1).min()
        assert ours[k, 1] <= to_box + 1e-12 and ours[k, 1] >= to_box - 0.01


def _random_shape(rng, kind: str) -> Shape:
    sizes = {"box": 3, "sphere": 1, "capsule": 2, "cylinder": 2}[kind]
    X = np.eye(4)
    X[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    X[:3, 3] = rng.normal(scale=0.25, size=3)
    return Shape(kind, kind, tuple(rng.uniform(0.02, 0.3, size=sizes)), X)


def _points_in(shape: Shape, rng, count: int) -> np.ndarray:
    """``count`` points on the surface of ``shape`` (in the frame its pose is given in)."""
    u = rng.normal(size=(count, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    size = np.asarray(shape.size)
    if shape.kind == "box":
        local = rng.uniform(-0.5, 0.5, size=(count, 3)) * size
        face = rng.integers(3, size=count)
        local[np.arange(count), face] = np.sign(u[:, 0]) * size[face] / 2.0
    elif shape.kind == "sphere":
        local = u * size[0]
    else:
        z = rng.uniform(-0.5, 0.5, size=count) * size[1]
        across = u[:, :2] / np.linalg.norm(u[:, :2], axis=1, keepdims=True)
        if shape.kind == "capsule":
            local = np.column_stack([across * size[0], z])
            local[:count // 2] = u[:count // 2] * size[0] + [0.0, 0.0, size[1] / 2.0]
        else:
            radial = np.sqrt(rng.uniform(size=count))[:, None] * np.where(rng.uniform(size=(count, 1)) < 0.5, 1.0, 0.0)
            radial[radial == 0.0] = 1.0
            local = np.column_stack([across * size[0] * radial, z])
            ends = rng.uniform(size=count) < 0.5
            local[ends, 2] = np.sign(local[ends, 2]) * size[1] / 2.0
    return local @ shape.X[:3, :3].T + shape.X[:3, 3]


@njit
def _separations(a, b):
    return np.array([bp._separation(a, k, b, k) for k in range(a.shape[0])])


def test_the_separating_axes_bound_the_distance_between_two_shapes():
    """``_separation`` (a tool box or cylinder by an obstacle) never exceeds the distance between two shapes of
    any kinds (sampled on their surfaces), and is the gap itself where a cylinder's flat end faces a box."""
    rng = np.random.default_rng(16)
    kinds = ("box", "sphere", "capsule", "cylinder")
    shapes = [(_random_shape(rng, a), _random_shape(rng, b)) for a in kinds for b in kinds for _ in range(4)]
    rows = [np.array([bp._obstacle_row(shape, np.eye(4)) for shape in column]) for column in zip(*shapes)]
    ours = _separations(*rows)
    for (a, b), bound in zip(shapes, ours):
        sampled = np.linalg.norm(_points_in(a, rng, 700)[:, None] - _points_in(b, rng, 700)[None], axis=2).min()
        assert bound <= sampled + 1e-12
    assert (ours > 0.0).sum() > 16                                         # not a bound that never clears
    cylinder, box = Shape("end", "cylinder", (0.04, 0.2), np.eye(4)), Shape("floor", "box", (1.0, 1.0, 0.1), np.eye(4))
    box.X[:3, 3] = [0.3, -0.2, -0.1 - 0.05 - 0.013]                       # 13 mm below the flat end, off its axis
    gap = _separations(*(np.array([bp._obstacle_row(shape, np.eye(4))]) for shape in (cylinder, box)))[0]
    assert gap == pytest.approx(0.013, abs=1e-12)


@njit
def _shape_upper_bounds(tools, boxes):
    return np.array([bp._shape_box_upper(tools, k, boxes, k) for k in range(tools.shape[0])])


def test_a_tool_shape_is_no_farther_from_a_box_than_its_points_say():
    """``_shape_box_upper`` (a tool box or cylinder by a box obstacle: a certain hit below it) is a distance from
    points of the shape: never below the separating axes' lower bound nor the sampled distance less the samples'
    spacing, and the distance itself where a tilted cylinder's rim comes nearest a face."""
    rng = np.random.default_rng(19)
    pairs = [(_random_shape(rng, kind), _random_shape(rng, "box")) for kind in ("box", "cylinder") for _ in range(16)]
    tools, boxes = (np.array([bp._obstacle_row(shape, np.eye(4)) for shape in column]) for column in zip(*pairs))
    ours, lower = _shape_upper_bounds(tools, boxes), _separations(tools, boxes)
    for (tool, box), upper, bound in zip(pairs, ours, lower):
        sampled = np.linalg.norm(_points_in(tool, rng, 800)[:, None] - _points_in(box, rng, 800)[None], axis=2).min()
        assert upper >= bound - 1e-12 and upper >= sampled - 0.03
    tilt = np.radians(20.0)
    cylinder = Shape("gripper", "cylinder", (0.035, 0.12), np.eye(4))
    cylinder.X[:3, :3] = Rotation.from_rotvec([tilt, 0.0, 0.0]).as_matrix()
    lowest = -0.06 * np.cos(tilt) - 0.035 * np.sin(tilt)                   # the rim's lowest point
    floor = Shape("floor", "box", (1.0, 1.0, 0.02), np.eye(4))
    floor.X[:3, 3] = [0.1, 0.05, lowest - 0.005 - 0.01]
    rows = [np.array([bp._obstacle_row(shape, np.eye(4))]) for shape in (cylinder, floor)]
    assert _shape_upper_bounds(*rows)[0] == pytest.approx(0.005, abs=1e-9)


@njit
def _upper_bounds(segments, shapes):
    local, breaks = np.empty((5, 6)), np.empty(8)
    return np.array([bp._segment_shape_upper(segments, k, shapes, k, local, breaks) for k in range(len(shapes))])


def test_the_upper_bound_of_a_segment_to_a_tool_shape_is_the_distance():
    """``_segment_shape_upper`` (a link capsule's core by a tool box or cylinder: a certain hit below it) is at least
    the distance, and within sampling of it (the segment sampled, each point's distance exact)."""
    rng = np.random.default_rng(17)
    shapes = [_random_shape(rng, kind) for kind in ("box", "cylinder") for _ in range(40)]
    rows = np.array([bp._obstacle_row(shape, np.eye(4)) for shape in shapes])
    segments = np.zeros((len(shapes), 9))
    segments[:, :6] = rng.normal(scale=0.3, size=(len(shapes), 6))
    ours = _upper_bounds(segments, rows)
    t = np.linspace(0.0, 1.0, 20001)[:, None]
    for k, shape in enumerate(shapes):
        points = (segments[k, :3] + t * (segments[k, 3:6] - segments[k, :3]) - shape.X[:3, 3]) @ shape.X[:3, :3]
        size = np.asarray(shape.size)
        if shape.kind == "box":
            outside = np.maximum(np.abs(points) - size / 2.0, 0.0)
        else:
            outside = np.column_stack([np.maximum(np.hypot(points[:, 0], points[:, 1]) - size[0], 0.0),
                                       np.maximum(np.abs(points[:, 2]) - size[1] / 2.0, 0.0)])
        sampled = np.linalg.norm(outside, axis=1).min()
        lower = sampled - np.linalg.norm(segments[k, 3:6] - segments[k, :3]) / 20000
        assert lower - 1e-12 <= ours[k] <= sampled + 1e-8                # the search brackets to 4e-9 of |d|


def test_never_free_where_drake_collides_nor_a_hit_where_it_is_free(shelf, irb):
    shelf_result, irb_result = _compare(shelf, 2000, 3), _compare(irb, 2000, 4)
    results = [*shelf_result.values(), *irb_result.values()]
    assert all(false_free == 0 and false_hit == 0 for false_free, _, false_hit, _ in results)
    assert shelf_result["plain"][1] > 0.9 and shelf_result["planner"][1] > 0.9 and irb_result["plain"][1] > 0.9
    assert all(hits > 0.2 for _, _, _, hits in results)


def test_the_irb1600_wrist_keeps_more_than_the_planner_self_margin_from_the_gripper(irb):
    # Link 4's capsule ends at the wrist centre (radius 60 mm), the gripper's flat face is 65 mm beyond it on the
    # flange axis at every configuration: 5 mm. The planner keeps links SELF_PLANNING_MARGIN_M = 4 mm apart (with
    # 5 mm Drake's verdict on that pair was its round-off, and the broad phase could clear no configuration).
    clearance = irb.clearance(np.zeros(6))
    assert clearance.self_pair == ("link4", "tool") and clearance.self == pytest.approx(0.005, abs=1e-6)
    extra_m, self_m = CHECKERS["planner"]
    assert self_m + 5 * bp.DRAKE_TOLERANCE_M < 0.005
    Q = irb.robot.random_configurations(np.random.default_rng(5), 200)
    drake = np.array([irb.padded_checker(extra_m, self_m).CheckConfigCollisionFree(q) for q in Q])
    assert irb.broad_phase(extra_m, self_m).free(Q[drake]).mean() > 0.9


def test_an_edge_called_free_is_free_for_drake(shelf):
    extra_m, self_m = CHECKERS["planner"]
    broad = shelf.broad_phase(extra_m, self_m)
    rng = np.random.default_rng(6)
    A = shelf.robot.random_configurations(rng, 150)
    B = A + rng.normal(scale=0.15, size=A.shape)
    ours = broad.edges_free(A, B)
    drake = np.array([broad.checker.CheckEdgeCollisionFree(a, b) for a, b in zip(A, B)])
    assert not (ours & ~drake).any()
    assert ours.sum() > 0.8 * drake.sum() > 0
    assert broad.edge_free(A[0], B[0]) == ours[0]
    assert broad.edges_free(A[:20], B[:20], step=0.5).sum() >= ours[:20].sum()   # fewer steps: never stricter


def _edge_configurations(broad, a, b, stride):
    """The configurations Drake's CheckEdgeCollisionFree checks on a -> b at the broad phase's step, every
    ``stride``-th first (as ``edge_maybes_into`` visits them)."""
    n = int(max(1.0, np.ceil(np.linalg.norm(b - a) / broad.step)))
    order = [i for i in range(n + 1) if i % stride == 0] + [i for i in range(n + 1) if i % stride]
    return np.array([b if i == 0 else a * (1.0 - (i - 1) / n) + b * ((i - 1) / n) for i in order])


@pytest.mark.parametrize("which", ["shelf", "irb", "arm5"])
def test_an_edges_verdicts_are_those_of_its_configurations_one_by_one(which, request):
    """The edge kernel tests a pair only where its slack elsewhere on the edge, less its drift, does not clear it:
    its answer is still the per-configuration verdicts (None at a hit, else the maybes in order)."""
    model = request.getfixturevalue(which)
    rng = np.random.default_rng(11)
    for broad in (model.broad_phase(*CHECKERS["planner"]), model.broad_phase()):
        Q = model.robot.random_configurations(rng, 1000)
        verdicts = broad.verdicts(Q)
        free, maybe = Q[verdicts == bp.FREE], Q[verdicts == bp.MAYBE][:20]
        near = np.clip(free[:40] + rng.normal(scale=0.3, size=free[:40].shape), model.robot.limits.q_min,
                       model.robot.limits.q_max)
        by_maybe = np.clip(maybe + rng.normal(scale=0.05, size=maybe.shape), model.robot.limits.q_min,
                           model.robot.limits.q_max)
        outcomes = set()
        for a, b in [*zip(free[40:80], free[80:120]), *zip(free[:40], near), *zip(maybe, by_maybe)]:
            for stride in (1, 8):
                configurations = _edge_configurations(broad, a, b, stride)
                verdicts = broad.verdicts(configurations)
                ours = broad.edge_maybes(a, b, stride=stride)
                if (verdicts == bp.HIT).any():
                    assert ours is None
                    outcomes.add("hit")
                else:
                    np.testing.assert_array_equal(ours, configurations[verdicts == bp.MAYBE])
                    outcomes.add("maybe" if len(ours) else "free")
        assert outcomes == {"hit", "free", "maybe"}


def test_the_drift_rates_bound_how_fast_each_pairs_distances_change(irb):
    """``_rates`` bound how far a pair's primitives move relative to each other per unit of each joint: the core
    segments' ends of an obstacle pair move no farther, a link pair's ends change their distances no more."""
    broad = irb.broad_phase(*CHECKERS["planner"])
    rng = np.random.default_rng(12)
    A = irb.robot.random_configurations(rng, 300)
    B = A + rng.normal(scale=0.5, size=A.shape)
    ends_a, ends_b = broad.segments(A), broad.segments(B)
    tightest = np.inf
    for k, (kind, i, j) in enumerate(broad._pairs):
        allowed = np.abs(B - A) @ broad._rates[k] + 1e-12
        if kind == bp.ENV:
            moved = np.linalg.norm(ends_b[:, i] - ends_a[:, i], axis=2).max(axis=1)
        else:
            gaps_a = np.linalg.norm(ends_a[:, i, :, None] - ends_a[:, j, None], axis=3)
            gaps_b = np.linalg.norm(ends_b[:, i, :, None] - ends_b[:, j, None], axis=3)
            moved = np.abs(gaps_b - gaps_a).reshape(len(A), -1).max(axis=1)
        assert (moved <= allowed).all(), (kind, i, j)
        tightest = min(tightest, float(np.median(allowed / np.maximum(moved, 1e-9))))
    assert tightest < 3.0                                  # and not loose beyond use for every pair


def _band_configurations(model, inner, outer, count: int, seed: int) -> np.ndarray:
    """Configurations on random edges where Drake's checker with the paddings ``outer`` (extra, self [m])
    collides and the one with ``inner`` does not."""
    rng = np.random.default_rng(seed)
    tight, wide = (model.broad_phase(*margins).checker for margins in (inner, outer))
    A, B = (model.robot.random_configurations(rng, count) for _ in range(2))
    Q = (A[:, None] + np.linspace(0.0, 1.0, 60)[None, :, None] * (B - A)[:, None]).reshape(-1, A.shape[1])
    return np.array([q for q in Q if tight.CheckConfigCollisionFree(q) and not wide.CheckConfigCollisionFree(q)])


@pytest.mark.parametrize("which, least_hits", [("shelf", 0.2), ("arm5", 0.2), ("irb", 0.0)])
def test_a_hit_within_the_padding_is_drakes_too(which, least_hits, request):
    """Within the planner's padding (its checker collides, the plain one is free) the broad phase calls hits
    (PADDED_HIT_DEPTH_M inside the padding; the IRB 1600's band is mostly its wrist by the gripper, whose
    cylinder is only bounded), and none in the 10 mm beyond it (where the planner's checker is free)."""
    model = request.getfixturevalue(which)
    planner = CHECKERS["planner"]
    broad = model.broad_phase(*planner)
    within = _band_configurations(model, CHECKERS["plain"], planner, 40, 14)
    beyond = _band_configurations(model, planner, (2.0 * planner[0], 2.0 * planner[1]), 40, 15)
    assert len(within) > 20 and len(beyond) > 20
    assert (broad.verdicts(beyond) != bp.HIT).all()
    assert (broad.verdicts(within) == bp.HIT).mean() >= least_hits


def test_every_obstacle_kind_and_a_tool_box(tmp_path):
    model = _all_kinds(tmp_path)
    broad = model.broad_phase()
    assert broad.names.count("camera") == len(bp.TOOL_SHORTENING) and len(broad._boxes) == 2
    result = _compare(model, 2000, 7)
    assert all(false_free == 0 and false_hit == 0 for false_free, _, false_hit, _ in result.values())
    assert all(found > 0.8 and hits > 0.2 for _, found, _, hits in result.values())


def test_the_capsule_inside_a_tool_box_or_cylinder_is_inside_it(tmp_path):
    """Points all over the inscribed capsule (core and radius) lie in the shape: an overlap of it is one of the
    shape's, and the broad phase calls such a configuration a hit (the tool's hits: most of the planner's
    blocked edges end there rather than with Drake)."""
    model = _all_kinds(tmp_path)
    rng = np.random.default_rng(13)
    for shape in model.tool_shapes:
        p, r, radius = bp.inscribed_capsule(shape)
        points = p + rng.uniform(size=(5000, 1)) * (r - p)
        direction = rng.normal(size=(5000, 3))
        points += direction / np.linalg.norm(direction, axis=1, keepdims=True) * radius * rng.uniform(size=(5000, 1))
        local = (points - shape.X[:3, 3]) @ shape.X[:3, :3]
        if shape.kind == "box":
            assert (np.abs(local) <= np.asarray(shape.size) / 2.0 + 1e-12).all()
        else:
            assert (np.hypot(local[:, 0], local[:, 1]) <= shape.size[0] + 1e-12).all()
            assert (np.abs(local[:, 2]) <= shape.size[1] / 2.0 + 1e-12).all()
        assert radius > 0.0
    broad = model.broad_phase()
    inscribed = broad._prims[broad._prims[:, bp.ALTERNATIVES] > 1, bp.INSCRIBED].astype(int)
    assert [broad.names[k] for k in inscribed] == ["gripper (inscribed)", "camera (inscribed)"]


def test_bad_configurations_are_refused(shelf):
    broad = shelf.broad_phase()
    with pytest.raises(ValueError):
        broad.free(np.zeros((3, 5)))
    with pytest.raises(ValueError):
        broad.free(np.full((1, 6), np.nan))
    with pytest.raises(ValueError):
        broad.edges_free(np.zeros((1, 6)), np.zeros((1, 6)), step=0.0)
    assert shelf.broad_phase() is broad


@pytest.mark.slow
@pytest.mark.parametrize("name", cell_names())
def test_never_free_where_drake_collides_in_every_demo_cell(name):
    result = _compare(cell_model(name), 20_000, 8)
    assert all(false_free == 0 and false_hit == 0 for false_free, _, false_hit, _ in result.values()), result
    assert result["plain"][1] > 0.9, result


def test_read_only_and_strided_configurations_enter_the_compiled_kernels(shelf):
    broad = shelf.broad_phase()
    Q = shelf.robot.random_configurations(np.random.default_rng(8), 4)
    frozen = Q.copy()
    frozen.flags.writeable = False
    assert (broad._batch(frozen).flags.writeable, broad._batch(Q.T.copy().T).flags.c_contiguous) == (True, True)
    np.testing.assert_array_equal(broad.free(frozen), broad.free(Q))
