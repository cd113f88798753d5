"""``reachability_map(robot_or_cell, ...)``: where an arm reaches, and in how many orientations.

For every voxel of ``grid.reach_grid`` inside the robot's reach bound and every tool orientation of
``grid.tool_orientations``, IK is asked for the pose (the voxel centre, the orientation) of the mapped
point (the end frame, or with ``point="wrist"`` the wrist centre). An orientation counts when IK finds
an in-limit solution (in a cell, one that Drake's checker finds collision-free with the cell's
clearance: ``CollisionModel.is_free``); a tool axis in a cone counts when any of its rolls does. Per
voxel: the fraction of the orientations that count, the best Yoshikawa manipulability of their
solutions (``sqrt(det(J J^T))``, the product of J's singular values as ``compute_singularity`` gives it)
and the most IK branches (distinct branch labels, or distinct solutions for arms without named
branches) any one orientation has.

IK: the compiled closed form (every branch, ``robot.ik_batch(..., method="analytic")``) where the arm
has one (a spherical wrist, or the UR family's three parallel axes) and the target is a full pose;
else damped least squares (``jacobian``) with NUMERIC_RESTARTS seeded restarts (a generator per voxel
and orientation, seeded with ``(seed, voxel, orientation)``), for a pose or, for arms of fewer than 6
joints and for cones, the tool axis alone (``position+axis``); a numeric answer is one branch of what
may be several. Its time budget is set so large that the restart count is what ends a search: the map
never depends on the machine's speed.

The voxels are cut into chunks of about CHUNK_POSES poses; each chunk is a pure function of its
arguments (``solve_chunk``), run in this process or on Dask (``cluster.map_chunks``), and the chunks'
results are put back in order: the map is the same, to the bit, whatever ran it and however many
workers there were.
"""

from __future__ import annotations

import hashlib
import pickle
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cell.cell_file import Cell, load_cell
from ..errors import RobotFileError, ScaleInputError
from ..files.arrays import is_whole_number
from ..files.choices import FULL_POSE, POSITION_AND_AXIS
from ..files.schema import load_document
from ..model.robot import Robot, load_robot
from .cluster import map_chunks, worker_count
from .grid import (POINTS, ROLLS, VoxelGrid, check_orientations, check_poses, check_step, reach_grid,
                   tool_orientations, wrist_centre_robot)
from .result import ReachabilityMap

#: Poses (voxels x orientations x rolls) per chunk: about a second of closed-form IK, so Dask's
#: per-task cost (a few ms, ``bench scale``) stays below 1 %.
CHUNK_POSES = 20_000
#: Most poses per chunk a caller may ask for: a chunk holds a 4x4 target per pose (128 MB at this).
MAX_CHUNK_POSES = 1_000_000
#: Orientations per voxel when none are asked for.
DEFAULT_ORIENTATIONS = 16
#: Numeric IK: random restarts after the first descent, and a time budget no search reaches [s].
NUMERIC_RESTARTS = 4
NUMERIC_TIME_BUDGET_S = 3600.0


@dataclass(frozen=True, eq=False)
class MapProblem:
    """Everything a chunk needs: ``mapped`` (the robot whose end frame is the mapped point), ``robot``
    and ``cell`` (the collision model's, None outside a cell), the orientations (count, rolls, 3, 3),
    the IK ``method`` and target ``kind``, the ``seed``, and ``token`` (a digest of it all, naming the
    models a worker builds once and keeps)."""

    mapped: Robot
    robot: Robot
    cell: Cell | None
    rotations: np.ndarray
    method: str
    kind: str
    seed: int
    token: str = ""


@dataclass(frozen=True, eq=False)
class ChunkResult:
    """Per voxel of a chunk: ``fraction`` of the orientations reached [1], best ``manipulability``
    (0 where none), most ``branches`` of one orientation."""

    fraction: np.ndarray
    manipulability: np.ndarray
    branches: np.ndarray


_MODELS: dict = {}


def _models(problem: MapProblem):
    """(the mapped robot, the CollisionModel or None) of a problem, built once per process."""
    if problem.token not in _MODELS:
        _MODELS.clear()                     # one problem at a time: a collision model is large
        model = None
        if problem.cell is not None:
            from ..cell.collision import CollisionModel

            model = CollisionModel(problem.robot, problem.cell)
        _MODELS[problem.token] = (problem.mapped, model)
    return _MODELS[problem.token]


def branch_count(solutions) -> int:
    """Distinct branch labels among IK solutions (each unlabelled solution counts on its own)."""
    return len({s.branch or k for k, s in enumerate(solutions)})


def manipulability_batch(robot, Q: np.ndarray) -> np.ndarray:
    """Yoshikawa's manipulability (N,) at configurations Q (N, dof): the product of the Jacobian's
    singular values (sqrt(det(J J^T)), or sqrt(det(J^T J)) for fewer than 6 joints), as
    ``compute_singularity`` gives it, for a whole batch at once."""
    if len(Q) == 0:
        return np.zeros(0)
    return np.prod(np.linalg.svd(robot.jacobian_batch(Q), compute_uv=False), axis=-1)


def penetrates(model, q: np.ndarray) -> bool:
    """Whether a pair that the CollisionModel's checker checks is in penetration at q: Drake's point-pair
    penetration query, which computes no distances. A configuration that penetrates is not free (the
    checker asks for distances of at least the clearance, and links apart), so it needs no signed
    distance query: those take up to a second in Drake 1.51 for an arm deep through a thin box (the
    floor), against 12 us for this."""
    context = model.checker.model_context().plant_context()
    model.plant.SetPositions(context, q)
    query = model.plant.get_geometry_query_input_port().Eval(context)
    inspector = query.inspector()
    for pair in query.ComputePointPairPenetration():
        a, b = (model.plant.GetBodyFromFrameId(inspector.GetFrameId(g)) for g in (pair.id_A, pair.id_B))
        if not model.checker.IsCollisionFilteredBetween(a, b):
            return True
    return False


def collision_free(model, solutions) -> tuple:
    """The solutions Drake's checker finds free (``CollisionModel.is_free``), as
    ``clear_motion.free_solutions`` keeps them, with two shortcuts: a solution that ``penetrates`` is not
    free, and solutions that differ by whole turns of revolute joints (the same arm: the closed form
    returns every 2 pi variant in the limits) are checked once."""
    revolute = np.array([j.is_revolute for j in model.robot.spec.joints])
    verdicts: dict = {}
    free = []
    for s in solutions:
        key = tuple(np.round(np.where(revolute, np.mod(s.q, 2.0 * np.pi), s.q), 9))
        if key not in verdicts:
            verdicts[key] = not penetrates(model, s.q) and model.is_free(s.q)
        if verdicts[key]:
            free.append(s)
    return tuple(free)


def _solve_targets(problem: MapProblem, X: np.ndarray, voxels: np.ndarray, model) -> list:
    """Per target X (n, 4, 4): its accepted solutions (in limits; free in a cell), maybe none."""
    robot = problem.mapped
    if problem.method == "analytic":
        results = robot.ik_batch(X, method="analytic", target_kind=problem.kind)
        if model is None:
            return [r.solutions if r.success else () for r in results]
        return [collision_free(model, r.solutions) if r.success else () for r in results]
    count = problem.rotations.shape[0] * problem.rotations.shape[1]
    options = {"max_restarts": NUMERIC_RESTARTS, "time_budget": NUMERIC_TIME_BUDGET_S}
    found = []
    for i, (X_target, voxel) in enumerate(zip(X, np.repeat(voxels, count))):
        rng = np.random.default_rng((problem.seed, int(voxel), i % count))
        if model is None:
            result = robot.ik(X_target, method="jacobian", target_kind=problem.kind, rng=rng, **options)
        else:
            from ..cell.clear_motion import collision_free_ik

            result, _ = collision_free_ik(robot, model, X_target, None, "jacobian", problem.kind, options, rng)
        found.append(result.solutions if result is not None and result.success else ())
    return found


def solve_chunk(problem: MapProblem, voxels: np.ndarray, centres: np.ndarray) -> ChunkResult:
    """The map at voxels (flat indices (V,)) with centres (V, 3) [m]: a pure function (a Dask task)."""
    mapped, model = _models(problem)
    count, rolls = problem.rotations.shape[:2]
    V = len(voxels)
    X = np.zeros((V, count * rolls, 4, 4))
    X[:, :, :3, :3] = problem.rotations.reshape(1, count * rolls, 3, 3)
    X[:, :, :3, 3] = centres[:, None, :]
    X[:, :, 3, 3] = 1.0
    solutions = _solve_targets(problem, X.reshape(-1, 4, 4), voxels, model)
    reached = np.array([len(s) > 0 for s in solutions]).reshape(V, count, rolls).any(axis=2)
    branches = np.array([branch_count(s) for s in solutions], dtype=np.int16).reshape(V, count * rolls).max(axis=1)
    owner = np.repeat(np.arange(V).repeat(count * rolls), [len(s) for s in solutions])
    Q = np.array([s.q for found in solutions for s in found]).reshape(-1, mapped.dof)
    best = np.zeros(V)
    np.maximum.at(best, owner, manipulability_batch(mapped, Q))
    return ChunkResult(reached.mean(axis=1), best, branches)


def load_robot_or_cell(name_or_path) -> tuple[Robot, Cell | None]:
    """(robot, cell) from a preset name, a robot file or a cell file (told apart by its ``robot`` key),
    a Robot, or a Cell; a robot name or file that does not exist is a RobotNotFoundError."""
    if isinstance(name_or_path, Robot):
        return name_or_path, None
    if isinstance(name_or_path, Cell):
        return name_or_path.load_robot(), name_or_path
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") and path.is_file():
        data = load_document(path, RobotFileError).data
        if isinstance(data, dict) and "robot" in data:
            cell = load_cell(path)
            return cell.load_robot(), cell
    return load_robot(name_or_path), None


def _token(*parts) -> str:
    return hashlib.sha256(pickle.dumps(parts)).hexdigest()[:16]


def map_problem(robot: Robot, cell: Cell | None, orientations: int | None, tool_axis_cone: float | None, seed: int,
                point: str) -> MapProblem:
    """The problem of a map (see the module docstring for the IK method and target kind)."""
    from ..model.ik import has_closed_form

    orientations = DEFAULT_ORIENTATIONS if orientations is None else orientations
    check_orientations(orientations, tool_axis_cone)
    if not is_whole_number(seed, 0):
        raise ScaleInputError("seed", "must be a whole number >= 0", seed)
    if point not in POINTS:
        raise ScaleInputError("point", f"must be one of {', '.join(POINTS)}", point)
    mapped = wrist_centre_robot(robot) if point == "wrist" else robot
    closed = mapped.dof >= 6 and has_closed_form(mapped)
    method = "analytic" if closed else "jacobian"
    kind = FULL_POSE if mapped.dof >= 6 and (closed or tool_axis_cone is None) else POSITION_AND_AXIS
    rolls = ROLLS if tool_axis_cone is not None and kind == FULL_POSE else 1
    rotations = tool_orientations(orientations, tool_axis_cone, rolls, seed)
    return MapProblem(mapped, robot, cell, rotations, method, kind, int(seed),
                      _token(mapped.spec, cell, rotations, method, kind, int(seed)))


@dataclass(frozen=True, eq=False)
class MapPlan:
    """A checked map, not computed yet: its ``problem``, ``grid``, the ``voxels`` solved (flat indices,
    those inside the reach bound), ``chunk_voxels`` per chunk, the ``point`` and ``tool_axis_cone`` asked for."""

    problem: MapProblem
    grid: VoxelGrid
    voxels: np.ndarray
    chunk_voxels: int
    point: str
    tool_axis_cone: float | None

    @property
    def poses(self) -> int:
        """IK targets: voxels x orientations x rolls."""
        return len(self.voxels) * self.problem.rotations.shape[0] * self.problem.rotations.shape[1]

    @property
    def chunk_count(self) -> int:
        return -(-len(self.voxels) // self.chunk_voxels)

    def chunks(self) -> list[tuple]:
        """The arguments of ``solve_chunk`` for every chunk, in voxel order."""
        size = self.chunk_voxels
        return [(self.problem, self.voxels[k:k + size], self.grid.centres(self.voxels[k:k + size]))
                for k in range(0, len(self.voxels), size)]

    def run(self, client=None) -> ReachabilityMap:
        """Solve every chunk (on the Dask ``client``'s workers, or in this process) and assemble the map."""
        began = time.perf_counter()
        problem, grid = self.problem, self.grid
        chunks = self.chunks()
        label = f"reach {problem.robot.name}" + (f" in {problem.cell.name}" if problem.cell is not None else "")
        results = map_chunks(solve_chunk, chunks, client, label)
        arrays = {}
        for name, dtype in (("fraction", float), ("manipulability", float), ("branches", np.int16)):
            flat = np.zeros(int(np.prod(grid.shape)), dtype=dtype)
            if results:
                flat[self.voxels] = np.concatenate([getattr(r, name) for r in results])
            arrays[name] = flat.reshape(grid.shape)
        return ReachabilityMap(
            robot=problem.robot, cell=problem.cell, point=self.point, grid=grid, rotations=problem.rotations[:, 0],
            tool_axis_cone=self.tool_axis_cone, rolls=problem.rotations.shape[1], method=problem.method,
            kind=problem.kind, seed=problem.seed, poses=self.poses, chunks=len(chunks),
            elapsed_s=time.perf_counter() - began, workers=worker_count(client), **arrays)


def plan_map(robot_or_cell, step: float = 0.025, orientations: int | None = None, tool_axis_cone: float | None = None,
             seed: int = 0, point: str = "end", chunk_poses: int = CHUNK_POSES) -> MapPlan:
    """Check a map's arguments (see ``reachability_map``; a typed error naming the first bad one) and
    plan it, before anything is computed."""
    robot, cell = load_robot_or_cell(robot_or_cell)
    check_step(step)
    if not is_whole_number(chunk_poses, 1, MAX_CHUNK_POSES):
        raise ScaleInputError("chunk_poses", f"must be a whole number in [1, {MAX_CHUNK_POSES:,}]", chunk_poses)
    problem = map_problem(robot, cell, orientations, tool_axis_cone, seed, point)
    grid = reach_grid(problem.mapped, step)
    per_voxel = problem.rotations.shape[0] * problem.rotations.shape[1]
    check_poses(grid.count_within(problem.mapped.spec.reach_bound), per_voxel, grid.step)
    return MapPlan(problem, grid, grid.within(problem.mapped.spec.reach_bound), max(1, chunk_poses // per_voxel),
                   point, tool_axis_cone)


def reachability_map(robot_or_cell, step: float = 0.025, orientations: int | None = None,
                     tool_axis_cone: float | None = None, client=None, seed: int = 0, point: str = "end",
                     chunk_poses: int = CHUNK_POSES) -> ReachabilityMap:
    """The reachability map of a robot (a Robot, preset name or robot file) or of the robot in a cell (a
    Cell or cell file): voxels ``step`` [m] apart; ``orientations`` (default DEFAULT_ORIENTATIONS) tool
    orientations per voxel over all of SO(3), or as many tool axes within ``tool_axis_cone`` [deg] of
    straight down; on the Dask ``client``'s workers, or in this process without one; ``point``: ``end``
    (the end frame) or ``wrist`` (the wrist centre). See the module docstring; the result does not
    depend on the client or ``chunk_poses`` (the poses per chunk)."""
    return plan_map(robot_or_cell, step, orientations, tool_axis_cone, seed, point, chunk_poses).run(client)
