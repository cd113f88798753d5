"""Collision-free joint paths: OMPL's sampling planners with Drake's checker as their validity checker.

``plan_joint_path(model, q_start, q_goal)``: the straight joint-space edge when it is free, else the
quickest free detour around the obstacles (``detour_path``: a via point or two moved up, back out
along the tool or towards the base, the motion a programmer would teach, found without randomness),
else a search by an OMPL geometric planner (RRTConnect unless named) in the joint box (``planning_box``: a
continuous joint searches half a turn beyond its start and goal values), each state checked by
Drake's checker and each edge by Drake's parallel edge check, then OMPL's ``PathSimplifier`` on the
result (vertex reduction, then rope shortcutting at ROPE_STEP). While planning, obstacles are kept
PLANNING_MARGIN_M farther than the clearance and links SELF_PLANNING_MARGIN_M apart (the edges from a
start or goal closer than that keep the clearance alone), with edge steps fine enough that no point
dips by the margin between them, so the smooth path the timing draws through the vertices keeps the
clearance the certificate then proves.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .choices import DEFAULT_PLANNER, PLAN_TIME_BUDGET_S, PLANNERS
from .errors import CollisionError, ConfigurationError, PlanningError
from .path import PathError, make_path

#: Extra distance to obstacles (beyond the clearance) and between links kept while planning [m].
PLANNING_MARGIN_M = 0.01
SELF_PLANNING_MARGIN_M = 0.005
#: The step of OMPL's rope shortcutting [rad]: 1 (its default) shortens the demo cell's planned paths to
#: 0.55 of the raw length in 56 ms median, 3 to 0.74 in 27 ms, vertex reduction alone to 0.87 in 11 ms
#: (30 seeded pairs per demo cell, GP7, this machine kind).
ROPE_STEP = 3.0
#: Offset steps and the largest offset of the detours tried before a search (``detour_path``) [m]; a found
#: detour is then brought in by bisection (``Detour.lowered``), so a coarse step costs no lift.
DETOUR_STEP_M = 0.1
MAX_DETOUR_M = 0.6
#: Offset steps the detour search goes on after the first way found a free one; bisections that bring
#: a found detour in while its spline stays free.
DETOUR_SPREAD = 3
LOWER_ROUNDS = 5
#: Detours whose estimated times agree to this many decimals [s] are a tie, won by the first way tried
#: (up and back coincide for a tool pointing down: their times differ only by the CPU's round-off).
TIME_DECIMALS = 6
#: Configurations along a detour's spline are checked this far apart [rad].
CURVE_STEP_RAD = 0.01
#: A via nudged from the joint values between the ends (``_nudged``): steps, tolerance [m], damping [m].
NUDGE_ITERATIONS = 30
NUDGE_TOLERANCE_M = 1e-4
NUDGE_DAMPING = 0.01
#: OMPL's random generator takes one seed per process (before its first sample).
_seeded: list[int] = []


@dataclass(frozen=True, eq=False)
class PlannedPath:
    """A collision-free joint path: ``waypoints`` (k, dof) from start to goal [rad or m], every edge free;
    ``planner`` ("direct" when the straight edge was free, "detour" for ``detour_path``'s); ``plan_time_s``
    (search) and ``simplify_time_s``; joint-space path lengths (Euclidean) ``length_before`` and
    ``length_after`` simplification [rad]; ``smooth_waypoints``: a detour's vertices brought closer in,
    through which the C2 spline (not the edges) keeps the planning margins (None: none)."""

    waypoints: np.ndarray
    planner: str
    plan_time_s: float
    simplify_time_s: float
    length_before: float
    length_after: float
    smooth_waypoints: np.ndarray | None = None

    def to_dict(self) -> dict:
        return {"planner": self.planner, "plan_time_s": self.plan_time_s, "simplify_time_s": self.simplify_time_s,
                "path_length_before_rad": self.length_before, "path_length_after_rad": self.length_after,
                "vertices": len(self.waypoints)}


def path_length(waypoints: np.ndarray) -> float:
    """Euclidean joint-space length of a polyline (k, dof) [rad]."""
    return float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum())


class _Checks:
    """State and edge checks with the planning margins (``CollisionModel.padded_checker``: its edge
    steps fine enough that a checked straight edge keeps the clearance between its steps). An end
    (start or goal) that keeps the clearance but not the margins is still a valid state, and the edges
    from it are checked against the clearance alone: the rest of the path keeps the margins."""

    def __init__(self, model, ends: tuple[np.ndarray, ...]):
        self.model = model
        self.padded = model.padded_checker(PLANNING_MARGIN_M, SELF_PLANNING_MARGIN_M)
        self.tight = [end for end in ends if not self.padded.CheckConfigCollisionFree(end)]

    def _is_tight(self, q: np.ndarray) -> bool:
        return any(np.array_equal(q, end) for end in self.tight)

    def state(self, q: np.ndarray) -> bool:
        return bool(self.padded.CheckConfigCollisionFree(q)) or self._is_tight(q)

    def edge(self, q_a: np.ndarray, q_b: np.ndarray) -> bool:
        if self._is_tight(q_a) or self._is_tight(q_b):
            return self.model.edge_is_free(q_a, q_b)
        return bool(self.padded.CheckEdgeCollisionFreeParallel(q_a, q_b))


def _check_endpoint(model, q: np.ndarray, which: str) -> None:
    if not model.is_free(q):
        raise CollisionError(f"the {which} configuration is not collision-free: {model.why_not_free(q)}")


def plan_joint_path(model, q_start, q_goal, planner: str = DEFAULT_PLANNER, time_budget: float = PLAN_TIME_BUDGET_S,
                    seed: int = 0) -> PlannedPath:
    """A collision-free joint path from ``q_start`` to ``q_goal`` in ``model`` (see the module
    docstring); CollisionError when an end is not free, PlanningError when the planner finds nothing
    within ``time_budget`` [s]. ``seed``: OMPL's seed, taken once per process (its generator cannot be
    re-seeded), so a job's plan repeats run to run."""
    if planner not in PLANNERS:
        raise ConfigurationError(f"unknown planner {planner!r}; choose one of {', '.join(PLANNERS)}")
    if not np.isfinite(time_budget) or time_budget <= 0.0:
        raise ConfigurationError(f"time_budget must be > 0 s, got {time_budget}")
    q_start, q_goal = (model.robot.as_configuration(q) for q in (q_start, q_goal))
    _check_endpoint(model, q_start, "start")
    _check_endpoint(model, q_goal, "goal")
    checks = _Checks(model, (q_start, q_goal))
    if checks.edge(q_start, q_goal):
        straight = np.array([q_start, q_goal])
        length = path_length(straight)
        return PlannedPath(straight, "direct", 0.0, 0.0, length, length)
    began = time.perf_counter()
    detour = detour_path(model, checks, q_start, q_goal)
    if detour is not None:
        vertices, smooth = detour
        length = path_length(vertices)
        return PlannedPath(vertices, "detour", time.perf_counter() - began, 0.0, length, length, smooth)
    return _search(model, checks, q_start, q_goal, planner, time_budget, seed)


def detour_path(model, checks: "_Checks", q_start: np.ndarray, q_goal: np.ndarray):
    """The quickest of the shortest free detours around the obstacles, or None. Three directions, up
    (world z), back (against the tools' z axes: out of a fixture the tool points into) and inward
    (towards the base's axis), two shapes each: one via point (the flange midway between the ends,
    its orientation halfway) and two (each end moved: out, across, in); each via solved two ways (the
    pose by IK nearest the joint values it lies between, ``_via``; its position alone nudged from those
    joint values, ``_nudged``). Offsets grow by DETOUR_STEP_M up to MAX_DETOUR_M; each way keeps its
    first offset whose vias and edges are free, and the search ends DETOUR_SPREAD steps after the first
    way found one. Of these, the quickest by ``polyline_time``: (its vertices, every edge free; the
    vertices brought as close in as the spline through them keeps the margins, ``Detour.lowered``: the
    spline bulges beyond the edges a detour bends outwards; None when even the first spline does not),
    or None. Deterministic: the same ends give the same path in any process."""
    robot = model.robot
    X_a, X_b = robot.fk(q_start), robot.fk(q_goal)
    middle = interpolated_pose(X_a, X_b, 0.5)
    inward = -middle[:3, 3] * np.array([1.0, 1.0, 0.0])
    directions = ([np.array([0.0, 0.0, 1.0])] * 2, [-X_a[:3, 2], -X_b[:3, 2]], [_unit(inward)] * 2)
    ways = [Detour(robot, checks, (q_start, q_goal), poses, seeds, along, solve)
            for along in directions
            for poses, seeds, along in (([middle], [(q_start + q_goal) / 2.0], [_unit(along[0] + along[1])]),
                                        ([X_a, X_b], [q_start, q_goal], along))
            for solve in (_via, _nudged)]
    found: list[tuple[Detour, float, np.ndarray]] = []
    for offset in np.arange(DETOUR_STEP_M, MAX_DETOUR_M + DETOUR_STEP_M / 2.0, DETOUR_STEP_M):
        for way in [w for w in ways if all(w is not f[0] for f in found)]:
            vertices = way.vertices(offset)
            if vertices is not None and all(checks.edge(a, b) for a, b in zip(vertices[:-1], vertices[1:])):
                found.append((way, offset, vertices))
        if found and offset >= found[0][1] + DETOUR_SPREAD * DETOUR_STEP_M - 1e-12:
            break
    if not found:
        return None
    way, offset, vertices = min(found, key=lambda f: round(polyline_time(robot.limits, f[2]), TIME_DECIMALS))
    return vertices, way.lowered(offset, vertices)


@dataclass(frozen=True, eq=False)
class Detour:
    """One way of detouring: vias at ``poses`` (flange poses) moved along ``along`` (a unit vector per
    pose) by an offset, solved by ``solve(robot, pose, seed)`` from ``seeds``, between ``ends``."""

    robot: object
    checks: object
    ends: tuple
    poses: list
    seeds: list
    along: list
    solve: object

    def vertices(self, offset: float) -> np.ndarray | None:
        """[start, vias..., goal] at ``offset`` [m] (None: a via out of reach or not free)."""
        vias = [self.solve(self.robot, _moved(X, offset * way), seed)
                for X, way, seed in zip(self.poses, self.along, self.seeds)]
        if any(v is None for v in vias) or not all(self.checks.state(v) for v in vias):
            return None
        return np.array([self.ends[0], *vias, self.ends[1]])

    def lowered(self, offset: float, vertices: np.ndarray) -> np.ndarray | None:
        """The vertices at the smallest offset below ``offset`` through which the spline keeps the
        margins, found by LOWER_ROUNDS bisections of [0, offset] (None when even the spline through
        ``vertices`` does not)."""
        if not _curve_is_free(self.robot, self.checks, vertices):
            return None
        low, high, best = 0.0, offset, vertices
        for _ in range(LOWER_ROUNDS):
            middle = (low + high) / 2.0
            candidate = self.vertices(middle)
            if candidate is not None and _curve_is_free(self.robot, self.checks, candidate):
                high, best = middle, candidate
            else:
                low = middle
        return best


def polyline_time(limits, vertices: np.ndarray) -> float:
    """An estimate of the time along a joint polyline (k, dof) [s]: each edge from rest to rest at the
    slowest joint's speed and acceleration limits (a blend at a vertex saves some of it)."""
    steps = np.abs(np.diff(vertices, axis=0))
    qd, qdd = limits.qd_max, limits.qdd_max
    if qdd is None:
        return float((steps / qd).max(axis=1).sum())
    times = np.where(steps < qd**2 / qdd, 2.0 * np.sqrt(steps / qdd), steps / qd + qd / qdd)
    return float(times.max(axis=1).sum())


def _curve_is_free(robot, checks, vertices: np.ndarray) -> bool:
    """The C2 spline through ``vertices`` (what a program times through a planned move's vertices,
    ``pipeline.program.stretch``) stays inside the limits and keeps the planning margins at
    configurations CURVE_STEP_RAD apart."""
    try:
        curve = make_path(vertices, robot.limits.q_min, robot.limits.q_max, "spline")
    except PathError:
        return False
    s = np.linspace(0.0, 1.0, max(3, int(np.ceil(curve.length / CURVE_STEP_RAD)) + 1))
    return all(checks.state(q) for q in curve(s))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-9)


def interpolated_pose(X_a: np.ndarray, X_b: np.ndarray, f: float) -> np.ndarray:
    """The pose a fraction ``f`` of the way from X_a to X_b (position linear, orientation slerp)."""
    from scipy.spatial.transform import Rotation, Slerp

    X = np.eye(4)
    X[:3, :3] = Slerp([0.0, 1.0], Rotation.from_matrix([X_a[:3, :3], X_b[:3, :3]]))(f).as_matrix()
    X[:3, 3] = (1.0 - f) * X_a[:3, 3] + f * X_b[:3, 3]
    return X


def _moved(X: np.ndarray, offset: np.ndarray) -> np.ndarray:
    moved = X.copy()
    moved[:3, 3] += offset
    return moved


def _nudged(robot, X: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    """Joint values near ``seed`` whose flange is at X's position, its orientation free (damped least
    squares on the position alone, NUDGE_ITERATIONS steps; None when it does not get within
    NUDGE_TOLERANCE_M or leaves the limits): a via that keeps the wrist as it is between the ends."""
    q, target, limits = seed.copy(), X[:3, 3], robot.limits
    for _ in range(NUDGE_ITERATIONS):
        error = target - robot.fk(q)[:3, 3]
        if np.linalg.norm(error) < NUDGE_TOLERANCE_M:
            return q if np.all((q >= limits.q_min) & (q <= limits.q_max)) else None
        J = robot.jacobian(q)[:3]
        q = q + J.T @ np.linalg.solve(J @ J.T + NUDGE_DAMPING**2 * np.eye(3), error)
    return None


def _via(robot, X: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    """The IK solution of X nearest ``seed`` (None: out of reach)."""
    result = robot.ik(X, q_seed=seed)
    if not result.success:
        return None
    return min((s.q for s in result.solutions), key=lambda q: float(np.linalg.norm(q - seed)), default=result.q)


def planning_box(limits, q_start: np.ndarray, q_goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (dof,) of the joint box a planner searches [rad or m]: the joint limits, and for a
    continuous joint (no limits; OMPL needs finite bounds) the window from half a turn below the lower
    of its start and goal values to half a turn above the higher: at least a turn wide, so every angle
    of the joint is in it, and a path may swing past either end by up to half a turn."""
    low = np.where(limits.continuous, np.minimum(q_start, q_goal) - np.pi, limits.q_min)
    high = np.where(limits.continuous, np.maximum(q_start, q_goal) + np.pi, limits.q_max)
    return low, high


def joint_space(robot, q_start, q_goal):
    """OMPL's view of the robot's joint box: (RealVectorStateSpace bounded by ``planning_box``, a function
    state -> joint values (dof,), the start and goal states)."""
    from ompl import base as ob

    dof = robot.dof
    low, high = planning_box(robot.limits, np.asarray(q_start, dtype=float), np.asarray(q_goal, dtype=float))
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for j in range(dof):
        bounds.setLow(j, float(low[j]))
        bounds.setHigh(j, float(high[j]))
    space.setBounds(bounds)
    start, goal = space.allocState(), space.allocState()
    for j in range(dof):
        start[j], goal[j] = float(q_start[j]), float(q_goal[j])

    def values(state) -> np.ndarray:
        return np.array([state[j] for j in range(dof)])

    return space, values, start, goal


def path_vertices(path, values) -> np.ndarray:
    """The states of an OMPL ``PathGeometric`` as joint values (k, dof), by ``values`` (``joint_space``)."""
    return np.array([values(path.getState(k)) for k in range(path.getStateCount())])


def _search(model, checks: _Checks, q_start, q_goal, planner_name, time_budget, seed) -> PlannedPath:
    from ompl import base as ob, geometric as og, util as ou

    ou.setLogLevel(ou.LOG_WARN)
    if not _seeded:
        ou.RNG.setSeed(int(seed) + 1)           # OMPL refuses 0
        _seeded.append(seed)
    space, values, start, goal = joint_space(model.robot, q_start, q_goal)
    info = ob.SpaceInformation(space)

    def valid(state) -> bool:
        return checks.state(values(state))

    class DrakeEdges(ob.MotionValidator):
        def checkMotion(self, s1, s2, *rest):
            return bool(checks.edge(values(s1), values(s2)))

    info.setStateValidityChecker(valid)
    validator = DrakeEdges(info)
    info.setMotionValidator(validator)
    info.setup()
    problem = ob.ProblemDefinition(info)
    problem.setStartAndGoalStates(start, goal)
    search = getattr(og, planner_name)(info)
    search.setProblemDefinition(problem)
    search.setup()
    began = time.perf_counter()
    status = search.solve(float(time_budget))
    plan_time = time.perf_counter() - began
    if not problem.hasExactSolution():
        raise PlanningError(f"{planner_name} found no collision-free path in {plan_time:.3f} s (budget "
                            f"{time_budget:g} s; {status})")
    path = problem.getSolutionPath()
    raw = path_vertices(path, values)
    began = time.perf_counter()
    simplifier = og.PathSimplifier(info)
    simplifier.reduceVertices(path)
    simplifier.ropeShortcutPath(path, ROPE_STEP)
    simplify_time = time.perf_counter() - began
    simplified = path_vertices(path, values)
    simplified[0], simplified[-1] = q_start, q_goal
    return PlannedPath(simplified, planner_name, plan_time, simplify_time, path_length(raw), path_length(simplified))
