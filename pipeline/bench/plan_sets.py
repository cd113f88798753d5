"""Problem sets for the planning benchmark that need a search: start/goal configurations reaching into fixtures.

Each set is a cell (``models/cells/<cell>.yaml``) and targets for the tool centre point T (the cells' gripper:
X_FT = 120 mm along the flange z), each solved by the closed-form IK (every branch), kept only when a
collision-free solution exists (``CollisionModel.is_free``: the cell's clearance) with the shoulder in front and
the elbow up (ARM_CONFIGURATION: without it 8 of the GP7's 100 bookshelf targets reached in over its back), and
then taken on the free such solution nearest the set's reference configuration (joint-space Euclidean
distance), so the arm keeps its configuration from target to target as a programmer's would.

* ``cubbies`` (``gp7_shelf_cell``, the demo shelf): six fixed targets in the middle of its cubbies (z 300 and
  600 mm, y -250, 0, 250 mm), TCP at x = 650 mm (100 mm inside the front face), tool pointing in (+x, the
  flange's orientation at q = 0); every ordered pair is a query (30), ``count`` and ``seed`` are not used.
  The reference is q = 0 (the arm facing the shelf, tool pointing in).
* MotionBenchMaker-style scenes (KavrakiLab/motion_bench_maker, BSD-3; the notice is in each cell file), for
  the GP7 (``gp7_*``) and, 1.3x larger, the IRB 1600-6/1.2 (``irb1600_*``): ``table_clutter`` (a table with
  seven objects; targets between them, TCP 20-60 mm above the top, tool down, tilted up to 20 deg), ``box``
  (an open box of two compartments on a table; targets in each and on the table beside it, TCP 20-100 mm above
  the bottom or the top, tool down, tilted up to 15 deg), ``bookshelf`` (three levels, the lower two split by a
  divider; targets inside them, tool pointing in, turned up to 15 deg about the vertical and rolled up to
  30 deg about its axis). Targets are drawn in the scene's regions, visited in a fixed cyclic order whose
  neighbours differ (table quadrant to another across the clutter; box compartment, table, other compartment;
  shelf level to another level), from ``np.random.default_rng((seed, k))`` with k the set's place in
  SET_NAMES; a draw is repeated in its region until it is kept (at most MAX_DRAWS_PER_TARGET times). Query i
  goes from kept target i to kept target i + 1 (``count`` queries from ``count + 1`` targets). The tool-down
  reference is q = 0 with the wrist bent so the tool points down (GP7 q5 = -90 deg, IRB 1600 q5 = +90 deg).
* Our own scenes (not after MotionBenchMaker: cells a user would bring), drawn the same way, for both robots:
  ``rack`` (a parts rack of 3 x 3 slots 180 mm wide and high, turned -45 deg about the vertical so its front
  is not square to the robot, two stored parts at the back; targets 40-120 mm inside each slot, tool pointing
  in, turned up to 10 deg about the vertical and rolled up to 30 deg; each slot after one of another row and
  column), ``machine_door`` (machine tending: an enclosure in front with a door opening 500 x 450 mm, a chuck
  facing the door inside, a table outside to the left; targets in front of the chuck, tool pointing in
  through the door, and on the table, tool down, tilted up to 15 deg: chuck, table, chuck, other half of the
  table) and ``tote`` (bin picking from three totes 180 mm deep, on a table in front, on a stand to the left,
  on a pallet to the front right; targets 20-60 mm above each bottom, tool down, tilted up to 10 deg: tote to
  tote). A region may name its own reference (the door's table: down) and a heading: its box is in the cell
  frame turned by it about the vertical (the turned rack's slots, the totes) and its reference configuration
  has joint 1 turned by it (the arm faces the region; the tool "in" points along the heading).

The regions are given at the GP7's scale [mm] and multiplied by the robot's SCALE, as the cells are (every
length of an ``irb1600_`` cell but the gripper's is 1.3 times its ``gp7_`` twin's).
"""

from __future__ import annotations

import importlib.resources
import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..cell.cell_file import load_cell
from ..cell.collision import SELF_CLEARANCE_M, CollisionModel
from ..cell.tool import rigid_inverse
from ..errors import ConfigurationError, PipelineError
from ..files.branch_names import matches
from ..files.poses import make_pose

#: The arm configuration every target is taken on (the references'; the wrist may flip or not).
ARM_CONFIGURATION = {"shoulder": "front", "elbow": "up"}
#: The cells' gripper: the TCP 120 mm along the flange z [m].
X_FT = make_pose(np.eye(3), [0.0, 0.0, 0.120])
#: How far beyond the cell's clearance every target keeps from the obstacles [m].
TARGET_MARGIN_M = 0.001
#: Draws of one target's region before the set is given up.
MAX_DRAWS_PER_TARGET = 500
#: Each robot's scene scale (the cells' sizes relative to the GP7's) [1].
SCALE = {"gp7": 1.0, "irb1600": 1.3}
#: Each robot's reference configurations [rad]: "in" (the tool along +x of the cell, q = 0) and "down".
REFERENCES = {"gp7": {"in": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), "down": (0.0, 0.0, 0.0, 0.0, -math.pi / 2, 0.0)},
              "irb1600": {"in": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0), "down": (0.0, 0.0, 0.0, 0.0, math.pi / 2, 0.0)}}


@dataclass(frozen=True)
class Query:
    """One planning problem: ``start`` and ``goal`` (dof,) [rad] (in limits, collision-free in the cell), their
    TCP poses in the cell frame ``X_start``, ``X_goal`` (4, 4) [m], and the regions they were drawn in."""

    index: int
    start: np.ndarray
    goal: np.ndarray
    X_start: np.ndarray
    X_goal: np.ndarray
    start_region: str = ""
    goal_region: str = ""


@dataclass(frozen=True)
class ProblemSet:
    """A named set of queries in ``cell`` (a demo cell's name) for a tool ``X_FT`` (4, 4) [m]; ``seed`` (None:
    not drawn); ``draws``: per region (name, targets kept, draws made)."""

    name: str
    cell: str
    X_FT: np.ndarray
    queries: list[Query]
    seed: int | None = None
    draws: tuple[tuple[str, int, int], ...] = ()


@dataclass(frozen=True)
class Region:
    """Where targets are drawn: the TCP position uniform in the box ``lo``..``hi`` (GP7 scale [mm]) of the cell
    frame turned by ``heading_deg`` about the vertical; the orientation is the region's reference (``reference``
    "in" | "down", "" for the scene's, taken with joint 1 turned by ``heading_deg``: the arm faces the region)
    turned by up to ``roll_deg`` about the tool axis, tilted by up to ``tilt_deg`` about a random horizontal
    axis and turned by up to ``yaw_deg`` about the vertical [deg]."""

    name: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    tilt_deg: float = 0.0
    yaw_deg: float = 0.0
    roll_deg: float = 0.0
    reference: str = ""
    heading_deg: float = 0.0


@dataclass(frozen=True)
class Scene:
    """A drawn set's layout (its cell is ``<robot>_<scene>``): the reference of its regions ("in" | "down"; a
    region may name its own) and the regions in the order they are visited."""

    reference: str
    regions: tuple[Region, ...]


def _table_regions() -> tuple[Region, ...]:
    """The table's quadrants (top at z = 250 mm), front-left, back-right, front-right, back-left; TCP 20-60 mm
    above the top."""
    front, back, left, right = (380, 600), (640, 880), (30, 470), (-470, -30)
    return tuple(Region(name, (x[0], y[0], 270), (x[1], y[1], 310), tilt_deg=20, yaw_deg=90)
                 for name, x, y in (("front_left", front, left), ("back_right", back, right),
                                    ("front_right", front, right), ("back_left", back, left)))


def _box_regions() -> tuple[Region, ...]:
    """The box's compartments (bottom at z = 215 mm) and the table beside it (top at 200 mm); TCP 20-100 mm up."""
    return (Region("box_a", (415, 15, 235), (745, 225, 315), tilt_deg=15, yaw_deg=90),
            Region("table", (400, -450, 220), (760, -60, 300), tilt_deg=15, yaw_deg=90),
            Region("box_b", (415, 235, 235), (745, 445, 315), tilt_deg=15, yaw_deg=90))


def _shelf_regions() -> tuple[Region, ...]:
    """The shelf's levels (z 130-380, 400-650, 670-950 mm; the lower two split at y = 0), each level after
    another one; TCP 60-220 mm inside the front face (x = 540 mm), within 40 mm of the level's middle height."""
    def level(name, z, y):
        return Region(name, (600, y[0], z - 40), (760, y[1], z + 40), yaw_deg=15, roll_deg=30)

    left, right, wide = (60, 430), (-430, -60), (-430, 430)
    return (level("low_left", 255, left), level("middle_right", 525, right), level("high", 810, wide),
            level("low_right", 255, right), level("middle_left", 525, left), level("high", 810, wide))


def _rack_regions() -> tuple[Region, ...]:
    """The rack's nine slots (in the rack's frame, the cell frame turned -45 deg: front face at x' = 560 mm,
    rows z 380-560, 580-760, 780-960 mm, columns y' 360-540, 160-340, -40-140 mm), each after a slot of another
    row and another column; TCP 40-120 mm inside the front face, within 40 mm of the slot's middle."""
    rows, columns = (("low", 470), ("middle", 670), ("high", 870)), (("left", 450), ("middle", 250), ("right", 50))

    def slot(row, column):
        (level, z), (side, y) = rows[row], columns[column]
        return Region(f"{level}_{side}", (600, y - 40, z - 40), (680, y + 40, z + 40), yaw_deg=10, roll_deg=30,
                      heading_deg=-45)

    return tuple(slot(k % 3, (k + k // 3) % 3) for k in range(9))


def _door_regions() -> tuple[Region, ...]:
    """The chuck inside the machine (its face at x = 800 mm, centre z = 700 mm; TCP 20-70 mm in front of it, tool
    pointing in through the door) and the two halves of the table outside to the left (top at z = 400 mm; in
    the cell frame turned 90 deg, TCP 400-700 mm out, 20-80 mm above the top, tool down), in turn."""
    def table(name, y):
        return Region(name, (400, y[0], 420), (700, y[1], 480), tilt_deg=15, yaw_deg=90, reference="down",
                      heading_deg=90)

    chuck = Region("chuck", (730, -50, 650), (780, 50, 750), yaw_deg=10, roll_deg=30)
    return chuck, table("table_back", (40, 300)), chuck, table("table_front", (-300, -40))


def _tote_regions() -> tuple[Region, ...]:
    """The three totes' insides (each in the cell frame turned to face it: the table's in front, bottom at
    z = 315 mm; the stand's turned 90 deg, 465 mm; the pallet's turned -60 deg, 135 mm), 60 mm from the walls,
    TCP 20-60 mm above the bottom, in turn."""
    def tote(name, x, bottom, heading):
        return Region(name, (x[0] + 60, -90, bottom + 20), (x[1] - 60, 90, bottom + 60), tilt_deg=10, yaw_deg=90,
                      heading_deg=heading)

    return (tote("tote_table", (420, 820), 315, 0), tote("tote_stand", (320, 720), 465, 90),
            tote("tote_pallet", (460, 860), 135, -60))


#: The MotionBenchMaker-style scenes.
MBM_SCENES = {"table_clutter": Scene("down", _table_regions()), "box": Scene("down", _box_regions()),
              "bookshelf": Scene("in", _shelf_regions())}
#: Our own scenes (unseen-style cells a user would bring).
OWN_SCENES = {"rack": Scene("in", _rack_regions()), "machine_door": Scene("in", _door_regions()),
              "tote": Scene("down", _tote_regions())}
SCENES = {**MBM_SCENES, **OWN_SCENES}
#: The sets (each drawn set's seed stream is its place here: new sets go last).
SET_NAMES: tuple[str, ...] = ("cubbies", *(f"{robot}_{scene}" for scenes in (MBM_SCENES, OWN_SCENES)
                                           for robot in SCALE for scene in scenes))
#: The cubby targets' TCP positions (gp7_shelf_cell) [m]: levels z 300, 600 mm, y -250, 0, 250 mm, x 650 mm.
CUBBY_POSITIONS = tuple((0.650, y, z) for z in (0.300, 0.600) for y in (-0.250, 0.0, 0.250))


def _split(name: str) -> tuple[str, Scene]:
    """(robot, scene) of a drawn set's name; PipelineError for an unknown name."""
    robot, _, scene = name.partition("_")
    if name not in SET_NAMES or name == "cubbies":
        raise PipelineError(f"unknown problem set {name!r}; the sets: {', '.join(SET_NAMES)}")
    return robot, SCENES[scene]


def set_cell(name: str) -> str:
    """The name of the demo cell a set is posed in (a drawn set's cell has the set's name)."""
    if name == "cubbies":
        return "gp7_shelf_cell"
    _split(name)
    return name


def cell_file(name: str) -> Path:
    """A demo cell installed with the package (the checkout's models/cells/)."""
    return Path(str(importlib.resources.files("pipeline.models") / "cells" / f"{name}.yaml"))


def cell_model(name: str) -> CollisionModel:
    """The CollisionModel of a demo cell (its robot preset, obstacles, tool shapes and clearance)."""
    cell = load_cell(cell_file(name))
    return CollisionModel(cell.load_robot(), cell)


def set_model(name: str) -> CollisionModel:
    """The CollisionModel of the set's cell."""
    return cell_model(set_cell(name))


# -- targets ----------------------------------------------------------------------------------------
def tcp_pose(model, q: np.ndarray) -> np.ndarray:
    """The TCP pose X_WT (4, 4) [m] of configuration q in the cell frame: X_WB @ X_BF(q) @ X_FT."""
    return model.cell.X_WB @ model.robot.fk(q) @ X_FT


def solve_target(model, X_WT: np.ndarray, q_ref: np.ndarray) -> np.ndarray | None:
    """The collision-free IK solution in ARM_CONFIGURATION (of every closed-form branch) of the TCP pose X_WT
    (4, 4) [m] nearest q_ref (dof,) [rad], TARGET_MARGIN_M beyond the cell's clearance (a motion from a
    target right at the clearance cannot be certified: the motion may stray a fraction of a millimetre
    between samples); None when none is (or IK fails)."""
    X_BF = rigid_inverse(model.cell.X_WB) @ X_WT @ rigid_inverse(X_FT)
    result = model.robot.ik(X_BF)
    candidates = [s.q for s in result.solutions if matches(s.branch, ARM_CONFIGURATION)] if result.success else []
    roomy = model.padded_checker(TARGET_MARGIN_M, SELF_CLEARANCE_M)
    free = [q for q in candidates if roomy.CheckConfigCollisionFree(q)]
    if not free:
        return None
    return min(free, key=lambda q: float(np.linalg.norm(q - q_ref)))


def region_reference(name: str, model, region: Region) -> tuple[np.ndarray, np.ndarray]:
    """The reference configuration q_ref (dof,) [rad] of a drawn set's region (its reference with joint 1
    turned by the region's heading) and its TCP orientation R_ref (3, 3)."""
    robot, scene = _split(name)
    q_ref = np.array(REFERENCES[robot][region.reference or scene.reference])
    q_ref[0] += math.radians(region.heading_deg)
    return q_ref, tcp_pose(model, q_ref)[:3, :3]


def draw_pose(region: Region, scale: float, R_ref: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A TCP pose (4, 4) [m] in ``region`` (see Region) at ``scale``, around the reference orientation R_ref."""
    p = 1e-3 * scale * (np.array(region.lo) + (np.array(region.hi) - np.array(region.lo)) * rng.random(3))
    roll, tilt, yaw = np.radians([region.roll_deg, region.tilt_deg, region.yaw_deg]) * rng.uniform(-1, 1, 3)
    heading = rng.uniform(0.0, 2.0 * math.pi)
    tilt_axis = np.array([math.cos(heading), math.sin(heading), 0.0])
    turn = Rotation.from_rotvec([0.0, 0.0, yaw]) * Rotation.from_rotvec(abs(tilt) * tilt_axis)    # in the cell frame
    p_cell = Rotation.from_rotvec([0.0, 0.0, math.radians(region.heading_deg)]).apply(p)
    return make_pose(turn.as_matrix() @ R_ref @ Rotation.from_rotvec([0.0, 0.0, roll]).as_matrix(), p_cell)


def _draw_targets(name: str, model, count: int, seed: int) -> tuple[list[tuple[str, np.ndarray]],
                                                                   tuple[tuple[str, int, int], ...]]:
    """``count`` kept targets [(region name, q)] of a drawn set, and the per-region (name, kept, draws)."""
    robot, scene = _split(name)
    references = {region: region_reference(name, model, region) for region in scene.regions}
    rng = np.random.default_rng((seed, SET_NAMES.index(name)))
    kept, tally = [], {region.name: [0, 0] for region in scene.regions}
    for region in itertools.islice(itertools.cycle(scene.regions), count):
        q_ref, R_ref = references[region]
        for _ in range(MAX_DRAWS_PER_TARGET):
            tally[region.name][1] += 1
            q = solve_target(model, draw_pose(region, SCALE[robot], R_ref, rng), q_ref)
            if q is not None:
                kept.append((region.name, q))
                tally[region.name][0] += 1
                break
        else:
            raise PipelineError(f"problem set {name}: no collision-free target in region {region.name} after "
                                f"{MAX_DRAWS_PER_TARGET} draws (cell {set_cell(name)})")
    return kept, tuple((region, kept_, draws) for region, (kept_, draws) in tally.items())


def _query(model, index: int, a: tuple[str, np.ndarray], b: tuple[str, np.ndarray]) -> Query:
    return Query(index, a[1], b[1], tcp_pose(model, a[1]), tcp_pose(model, b[1]), a[0], b[0])


def _cubbies(model) -> ProblemSet:
    """The cubby set (see the module docstring): every ordered pair of the six targets."""
    q_ref = np.zeros(model.robot.dof)
    R_in = tcp_pose(model, q_ref)[:3, :3]
    targets = []
    for k, p in enumerate(CUBBY_POSITIONS):
        q = solve_target(model, make_pose(R_in, p), q_ref)
        if q is None:
            raise PipelineError(f"problem set cubbies: no collision-free IK solution for target {k} at "
                                f"{np.round(np.array(p) * 1e3).tolist()} mm in gp7_shelf_cell")
        targets.append((f"cubby_{k}", q))
    pairs = itertools.permutations(targets, 2)
    return ProblemSet("cubbies", "gp7_shelf_cell", X_FT, [_query(model, i, a, b) for i, (a, b) in enumerate(pairs)],
                      None, tuple((name, 1, 1) for name, _ in targets))


def problem_set(name: str, model, count: int = 100, seed: int = 0) -> ProblemSet:
    """The problem set ``name`` (one of SET_NAMES) in ``model`` (the CollisionModel of its cell: ``set_model``):
    ``count`` queries drawn from ``seed`` (the cubbies: their 30 fixed queries). Deterministic."""
    if model.cell is None or model.cell.name != set_cell(name):
        raise PipelineError(f"problem set {name} is posed in cell {set_cell(name)}, the model given is in "
                            f"{None if model.cell is None else model.cell.name}")
    if name == "cubbies":
        return _cubbies(model)
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ConfigurationError(f"problem set {name}: count must be an integer >= 1, got {count!r}")
    targets, draws = _draw_targets(name, model, count + 1, seed)
    queries = [_query(model, i, a, b) for i, (a, b) in enumerate(zip(targets[:-1], targets[1:]))]
    return ProblemSet(name, set_cell(name), X_FT, queries, seed, draws)


def search_fraction(model, problems: ProblemSet) -> float:
    """The fraction of the set's queries whose straight joint-space edge is not free (they need a search) [1]."""
    return float(np.mean([not model.edge_is_free(q.start, q.goal) for q in problems.queries]))
