"""Collision-free joint paths, found fast and short for the tool, the same in any process.

``plan_joint_path(model, q_start, q_goal)`` tries, in order:

1. the straight joint-space edge, when it is free;
2. the detours a programmer would teach (``DetourSearch``: via points moved up, back out along the tool
   or towards the base; the flange straight out along the tool, across and in; a change of IK branch
   out in the open), best first by the time along them, at most MAX_DETOUR_CHECKS of them checked;
3. the cell's lazy roadmap (``pipeline.cell.roadmap``: made once per cell and process, its edges checked
   when a query needs them and remembered; from the ends or from their exits, straight back along the tool,
   within ROADMAP_SHARE of the time budget), its route shortcut (``shortcut_path``) and smoothed by time
   (``smoothed_path``: partial shortcuts kept when the path gets quicker), unless a detour is quicker;
4. a search by an OMPL geometric planner (RRTConnect unless named; from the ends' longest exits where both
   have one: the narrow ways out of fixtures are then behind it) in the joint box (``planning_box``:
   a continuous joint searches half a turn beyond its start and goal values), then OMPL's
   ``PathSimplifier`` (vertex reduction, then rope shortcutting at ROPE_STEP) and ``smoothed_path``, its
   generator seeded per plan (``seeded``).

A path found by 2-4 carries the vertices of the C2 spline a program times through it (``smooth_waypoints``): a
detour's brought in (``Detour.lowered``), then any path's thinned where the spline gets quicker
(``thinned_spline``, by ``spline_time``), the spline keeping the planning margins.

Every state and every edge is checked with obstacles kept PLANNING_MARGIN_M farther than the clearance and
links SELF_PLANNING_MARGIN_M apart (the edges from a start or goal closer than that keep the clearance
alone), at the configurations Drake's padded checker visits on an edge (steps fine enough that no point dips
by the margin between them, so the smooth path the timing draws through the vertices keeps the clearance
the certificate then proves): by the compiled broad phase first (``pipeline.cell.broad_phase``, conservative:
it clears only what Drake's checker clears and calls colliding only what it finds colliding), by Drake's
checker for the configurations it cannot settle; the path returned is then judged by Drake's checker alone,
edge by edge. With a tilt limit
(``pipeline.cell.tilt``) every state and edge step keeps the tool level too (the roadmap is then skipped: its
verdicts hold for the unconstrained robot). Steps 1-3 are deterministic; the search is too when it ends
within its budget.
"""

from __future__ import annotations

import dataclasses
import functools
import heapq
import time
from dataclasses import dataclass

import numpy as np

from ..errors import CollisionError, ConfigurationError, PlanningError
from ..files.choices import DEFAULT_PLANNER, PLAN_TIME_BUDGET_S, PLANNERS
from ..model.ik.analytic import nearest_analytic
from ..model.ik.jacobian import nudged_position
from ..timing.compiled_spline import trial_spline
from .broad_phase import FREE, HIT, MAYBE
from .roadmap import roadmap_of

#: Extra distance to obstacles (beyond the clearance) and between links kept while planning [m]. Links: 4 mm,
#: under the 5.0 mm the IRB 1600's link 4 capsule keeps from the demo cells' gripper at most configurations (with
#: 5 mm that pair's verdict was the round-off of Drake's distance, and no bound can clear it).
PLANNING_MARGIN_M = 0.01
SELF_PLANNING_MARGIN_M = 0.004
#: The step of OMPL's rope shortcutting [rad]: 1 (its default) shortens the demo cell's planned paths to
#: 0.55 of the raw length in 56 ms median, 3 to 0.74 in 27 ms, vertex reduction alone to 0.87 in 11 ms
#: (30 seeded pairs per demo cell, GP7, this machine kind).
ROPE_STEP = 3.0
#: The offsets of the detours tried before a search (``DetourSearch``) [m], finer close in; a found detour
#: is then brought in by bisection (``Detour.lowered``), so a coarse step costs no lift.
DETOUR_OFFSETS_M = (0.05, 0.1, 0.15, 0.2, 0.3, 0.45, 0.6)
#: Bisections that bring a found detour in while its spline stays free.
LOWER_ROUNDS = 3
#: A straight detour's flange poses at most this far apart [m]; the most a joint may turn between two [rad]
#: (more is a change of IK branch).
STRAIGHT_STEP_M = 0.1
MAX_STEP_TURN_RAD = 0.5
#: How far an end's exits from a fixture go (straight back along the tool), while they are free [m].
EXIT_OFFSETS_M = (0.1, 0.2, 0.3, 0.45, 0.6)
#: The share of a plan's time budget the roadmap may take before the search (from the ends' longest exits) [1].
ROADMAP_SHARE = 0.5
#: Detours checked (best first) before the roadmap takes over; then the next ones checked while they are
#: quicker than the roadmap's route (by ``path_time``).
MAX_DETOUR_CHECKS = 40
MAX_QUICKER_CHECKS = 20
#: Detours whose estimated times agree to this many decimals [s] are a tie, won by the first way tried
#: (up and back coincide for a tool pointing down: their times differ only by the CPU's round-off).
TIME_DECIMALS = 6
#: The tilt kept below a move's limit while planning [rad] (the timed spline departs from the edges).
TILT_PLANNING_MARGIN_RAD = np.radians(2.0)
#: Configurations along a detour's spline are checked this far apart [rad] (the program checks the spline it
#: times again, and the certificate proves its clearance); the tilt along an edge TILT_STEP_RAD apart [rad].
CURVE_STEP_RAD = 0.03
#: An edge's configurations are checked every EDGE_STRIDE-th first, then the rest.
EDGE_STRIDE = 8
TILT_STEP_RAD = 0.01
#: Partial shortcuts tried on a roadmap's or a search's path, and the least time one must save to be kept [s].
SMOOTH_ROUNDS = 40
SMOOTH_GAIN_S = 1e-3
#: Points of a spline at which ``spline_time`` finds the path speed.
SPLINE_TIME_SAMPLES = 150
#: A via nudged from the joint values between the ends (``_nudged``): steps, tolerance [m], damping [m].
NUDGE_ITERATIONS = 30
NUDGE_TOLERANCE_M = 1e-4
NUDGE_DAMPING = 0.01


@dataclass(frozen=True, eq=False)
class PlannedPath:
    """A collision-free joint path: ``waypoints`` (k, dof) from start to goal [rad or m], every edge free;
    ``planner`` ("direct" when the straight edge was free, "detour" for ``DetourSearch``'s, "roadmap"); ``plan_time_s``
    (search) and ``simplify_time_s``; joint-space path lengths (Euclidean) ``length_before`` and
    ``length_after`` simplification [rad]; ``smooth_waypoints``: the vertices of the C2 spline a program times
    (a detour's brought closer in, ``Detour.lowered``; any path's thinned, ``thinned_spline``), along which the
    spline (not only the edges) keeps the planning margins (None: none)."""

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
    steps fine enough that a checked straight edge keeps the clearance between its steps), and with a
    ``tilt`` limit (``pipeline.cell.tilt.TiltLimit``, or None) the tool level within it less
    TILT_PLANNING_MARGIN_RAD (or within the more tilted end's tilt, when larger) at every state and edge
    step. An end (start or goal) that keeps the clearance but not the margins is still a valid state, and
    the edges from it are checked against the clearance alone: the rest of the path keeps the margins.

    Each configuration goes to the compiled broad phase first (``CollisionModel.broad_phase``: certainly free,
    certainly colliding, or maybe), and only those it cannot settle to Drake's checker, so every verdict is the
    one Drake's checker gives at the configurations it would check itself (an edge's: those of its
    ``CheckEdgeCollisionFree``). Edge verdicts are remembered (a detour's offsets share edges). ``judge`` checks
    a returned path with Drake alone."""

    def __init__(self, model, ends: tuple[np.ndarray, ...], tilt=None):
        self.model, self.tilt = model, tilt
        if tilt is not None:
            self.tilt_bound = max(tilt.max_rad - TILT_PLANNING_MARGIN_RAD, float(tilt.angles(model.robot, ends).max()))
        self.padded = model.padded_checker(PLANNING_MARGIN_M, SELF_PLANNING_MARGIN_M)
        self.broad = model.broad_phase(PLANNING_MARGIN_M, SELF_PLANNING_MARGIN_M)
        self.tight = [end for end in ends if not self._free(self.broad, self.padded, end[None])]
        self._edges: dict[tuple, bool] = {}

    def _is_tight(self, q: np.ndarray) -> bool:
        return any(np.array_equal(q, end) for end in self.tight)

    def _level(self, Q: np.ndarray) -> bool:
        return self.tilt is None or bool(np.all(self.tilt.angles(self.model.robot, Q) <= self.tilt_bound))

    @staticmethod
    def _free(broad, checker, Q: np.ndarray) -> bool:
        """Every configuration of Q (k, dof) free for ``checker``: the broad phase's verdicts (none a certain
        hit), then Drake's checks of those it cannot settle (in order; the first that collides ends it)."""
        verdicts = broad.verdicts(Q)
        if (verdicts == HIT).any():
            return False
        return all(checker.CheckConfigCollisionFree(q) for q in Q[verdicts == MAYBE])

    def _checkers(self, q_a: np.ndarray, q_b: np.ndarray):
        """(broad phase, Drake checker) of an edge: the plain ones from or to a tight end, else the padded."""
        if self._is_tight(q_a) or self._is_tight(q_b):
            return self.model.broad_phase(), self.model.checker
        return self.broad, self.padded

    def state(self, q: np.ndarray) -> bool:
        return (self._free(self.broad, self.padded, q[None]) or self._is_tight(q)) and self._level(q[None])

    def states(self, Q: np.ndarray) -> bool:
        """Every configuration of Q (k, dof) valid (an end of the query may be tight)."""
        tight = np.zeros(len(Q), dtype=bool)
        for end in self.tight:
            tight |= (Q == end).all(axis=1)
        return self._level(Q) and self._free(self.broad, self.padded, Q[~tight])

    def valid(self, Q: np.ndarray) -> np.ndarray:
        """Per configuration of Q (k, dof), whether it keeps the planning margins (bool (k,))."""
        verdicts = self.broad.verdicts(Q)
        free, maybe = verdicts == FREE, verdicts == MAYBE
        free[maybe] = [bool(self.padded.CheckConfigCollisionFree(q)) for q in Q[maybe]]
        return free

    def _edge(self, q_a: np.ndarray, q_b: np.ndarray) -> bool:
        """The configurations Drake's edge check visits free (the broad phase's verdicts, every EDGE_STRIDE-th
        first: a blocked edge shows there; Drake's checks of those it cannot settle) and the tool level at
        TILT_STEP_RAD steps."""
        broad, checker = self._checkers(q_a, q_b)
        maybe = broad.edge_maybes(q_a, q_b, stride=EDGE_STRIDE)
        if maybe is None or not all(checker.CheckConfigCollisionFree(q) for q in maybe):
            return False
        if self.tilt is None:
            return True
        steps = np.linspace(0.0, 1.0, int(np.ceil(float(np.linalg.norm(q_b - q_a)) / TILT_STEP_RAD)) + 1)
        return self._level(q_a + steps[:, None] * (q_b - q_a))

    def edge(self, q_a: np.ndarray, q_b: np.ndarray) -> bool:
        """The straight edge free (remembered)."""
        key = (q_a.tobytes(), q_b.tobytes())
        if key not in self._edges:
            self._edges[key] = self._edge(q_a, q_b)
        return self._edges[key]

    def polyline(self, vertices: np.ndarray) -> bool:
        """Every edge of the polyline free, the longest (the likeliest to collide) first."""
        edges = sorted(zip(vertices[:-1], vertices[1:]), key=lambda e: -float(np.linalg.norm(e[1] - e[0])))
        return all(self.edge(a, b) for a, b in edges)

    def judge(self, vertices: np.ndarray) -> None:
        """Drake's own edge checks (``CheckEdgesCollisionFree`` with the cell's clearance, the edges in parallel,
        no broad phase) of every edge of a returned path; PlanningError naming the first edge that fails (the
        broad phase would have passed a collision)."""
        edges = list(zip(vertices[:-1], vertices[1:]))
        for k, free in enumerate(self.model.checker.CheckEdgesCollisionFree(edges)):
            if not free:
                q_a, q_b = edges[k]
                raise PlanningError(f"Drake's checker refuses edge {k} of the planned path from {np.round(q_a, 4)} "
                                    f"to {np.round(q_b, 4)}, which the broad phase passed: please report it")


def _check_endpoint(model, q: np.ndarray, which: str) -> None:
    if not model.is_free(q):
        raise CollisionError(f"the {which} configuration is not collision-free: {model.why_not_free(q)}")


def plan_joint_path(model, q_start, q_goal, planner: str = DEFAULT_PLANNER, time_budget: float = PLAN_TIME_BUDGET_S,
                    seed: int = 0, tilt=None) -> PlannedPath:
    """A collision-free joint path from ``q_start`` to ``q_goal`` in ``model`` (see the module
    docstring); CollisionError when an end is not free, PlanningError when the planner finds nothing
    within ``time_budget`` [s]. ``seed``: OMPL's seed for this plan (``seeded``), so the same ends give
    the same path in any process; ``tilt``: a ``pipeline.cell.tilt.TiltLimit`` the path keeps (None: none).
    The path found is judged by Drake's checker alone before it is returned (``_Checks.judge``)."""
    if planner not in PLANNERS:
        raise ConfigurationError(f"unknown planner {planner!r}; choose one of {', '.join(PLANNERS)}")
    if not np.isfinite(time_budget) or time_budget <= 0.0:
        raise ConfigurationError(f"time_budget must be > 0 s, got {time_budget}")
    q_start, q_goal = (model.robot.as_configuration(q) for q in (q_start, q_goal))
    _check_endpoint(model, q_start, "start")
    _check_endpoint(model, q_goal, "goal")
    for q, which in ((q_start, "start"), (q_goal, "goal")):
        if tilt is not None and not tilt.keeps(model.robot, q):
            tilted = float(np.degrees(tilt.angles(model.robot, q)[0]))
            raise PlanningError(f"the {which} configuration tilts the tool {tilted:.1f} deg from the vertical, beyond "
                                f"the limit of {np.degrees(tilt.max_rad):g} deg")
    checks = _Checks(model, (q_start, q_goal), tilt)
    plan = _planned(model, checks, q_start, q_goal, planner, time_budget, seed, tilt)
    checks.judge(plan.waypoints)
    return plan


def _planned(model, checks: _Checks, q_start, q_goal, planner: str, time_budget: float, seed: int,
             tilt) -> PlannedPath:
    """The stages of ``plan_joint_path`` in order (see the module docstring), its path not yet judged."""
    if checks.edge(q_start, q_goal):
        straight = np.array([q_start, q_goal])
        length = path_length(straight)
        return PlannedPath(straight, "direct", 0.0, 0.0, length, length)
    began = time.perf_counter()
    detours = DetourSearch(model, checks, q_start, q_goal)
    detour = detours.next(MAX_DETOUR_CHECKS)
    if detour is not None:
        return _detour_plan(detour, began)
    exits = functools.cache(lambda: (_exits(model.robot, checks, q_start), _exits(model.robot, checks, q_goal)))
    route = _roadmap_route(model, checks, q_start, q_goal, exits, tilt, began + ROADMAP_SHARE * time_budget)
    if route is not None:
        search_time = time.perf_counter() - began
        shortcut = smoothed_path(checks, model.robot.limits, shortcut_path(checks, route), seed)
        quicker = detours.next(MAX_QUICKER_CHECKS, path_time(model.robot.limits, shortcut))
        if quicker is not None:
            return _detour_plan(quicker, began)
        smooth = _spline_vertices(model.robot, checks, shortcut)
        return PlannedPath(shortcut, "roadmap", search_time, time.perf_counter() - began - search_time,
                           path_length(route), path_length(shortcut), smooth)
    budget_left = max(time_budget - (time.perf_counter() - began), 0.01)
    outs, backs = exits()
    if not (outs and backs):
        found = _search(model, checks, q_start, q_goal, planner, budget_left, seed)
    else:
        out, back = outs[-1], backs[-1]                           # the longest ways out of the fixtures
        found = _search(model, checks, out[-1], back[-1], planner, budget_left, seed)
        vertices = np.vstack([out[:-1], found.waypoints, back[::-1][1:]])
        found = dataclasses.replace(found, waypoints=vertices, length_before=found.length_before + path_length(out)
                                    + path_length(back), length_after=path_length(vertices))
    return dataclasses.replace(found, smooth_waypoints=_spline_vertices(model.robot, checks, found.waypoints))


def _spline_vertices(robot, checks: _Checks, vertices: np.ndarray) -> np.ndarray | None:
    """The vertices of a route or a search's path (k, dof) for the spline a program times through them,
    ``thinned_spline``; None when the spline through them all does not keep the margins (or there is no inner
    vertex)."""
    if len(vertices) < 3 or not _curve_is_free(robot, checks, vertices):
        return None
    return thinned_spline(robot, checks, vertices)


def _detour_plan(detour: tuple, began: float) -> PlannedPath:
    """The PlannedPath of a detour (``DetourSearch.next``'s vertices, smooth vertices), searched since
    ``began`` [s]."""
    vertices, smooth = detour
    length = path_length(vertices)
    return PlannedPath(vertices, "detour", time.perf_counter() - began, 0.0, length, length, smooth)


def _roadmap_route(model, checks: _Checks, q_start, q_goal, exits, tilt, deadline: float) -> np.ndarray | None:
    """A route through the cell's roadmap (``pipeline.cell.roadmap``; none with a tilt limit): from the ends
    themselves, else from their exits (``exits()``: the ``_exits`` of each, made only when needed: an end deep in
    a fixture has no roadmap node in view), the shortest first, each end's longest where the other has longer
    ones."""
    roadmap = None if tilt is not None else roadmap_of(model, checks.valid)
    if roadmap is None:
        return None
    route = roadmap.path(q_start, q_goal, checks, deadline)
    if route is not None:
        return route
    outs, backs = exits()
    for k in range(max(len(outs), len(backs)) if outs and backs else 0):
        out, back = outs[min(k, len(outs) - 1)], backs[min(k, len(backs) - 1)]
        middle = roadmap.path(out[-1], back[-1], checks, deadline)
        if middle is not None:
            return np.vstack([out[:-1], middle, back[::-1][1:]])
    return None


def _exits(robot, checks: _Checks, q: np.ndarray) -> list[np.ndarray]:
    """The ways out of a fixture from q, shortest first: the flange straight back along the tool by each of
    EXIT_OFFSETS_M while the path is free, through poses STRAIGHT_STEP_M apart (k, dof), q first, its
    orientation kept (``_via``) or, where the arm cannot keep it (a joint at its limit), let free
    (``_nudged``); each ends where the planning margins hold (the edge from a tight q keeps the clearance alone:
    a search or a roadmap edge cannot start where they do not)."""
    X, exits = robot.fk(q), []
    for offset in EXIT_OFFSETS_M:
        count = int(np.ceil(offset / STRAIGHT_STEP_M))
        poses = interpolated_poses(X, _moved(X, -offset * X[:3, 2]), np.arange(1, count + 1) / count)
        chains = (_chained(robot, poses, q, solve) for solve in (_via, _nudged))
        way = next((np.array([q, *chain]) for chain in chains
                    if chain is not None and checks.polyline(np.array([q, *chain]))), None)
        if way is None:
            break
        if checks.state(way[-1]):
            exits.append(way)
    return exits


def _chained(robot, poses, q: np.ndarray, solve) -> list | None:
    """Joint values at each of ``poses`` (flange), each solved by ``solve(robot, pose, seed)`` from the one
    before, the first from q (q itself not included); None when one is out of reach or a joint turns more
    than MAX_STEP_TURN_RAD between two (a change of IK branch)."""
    chain = [q]
    for X in poses:
        q_next = solve(robot, X, chain[-1])
        if q_next is None or np.abs(q_next - chain[-1]).max() > MAX_STEP_TURN_RAD:
            return None
        chain.append(q_next)
    return chain[1:]


def smoothed_path(checks: _Checks, limits, vertices: np.ndarray, seed: int = 0) -> np.ndarray:
    """``vertices`` (k, dof) made quicker by partial shortcuts (Geraerts and Overmars, "Creating high-quality
    paths for motion planning", IJRR 2007; Hauser and Ng-Thow-Hing, ICRA 2010, by time): SMOOTH_ROUNDS times, two
    points drawn along the path (by joint-space length, from a generator seeded with ``seed``: the same path in
    any process) are joined by a straight edge, kept when the three new edges are free and the path gets
    quicker (``path_time``) by at least SMOOTH_GAIN_S."""
    rng = np.random.default_rng(seed)
    path, best = vertices, path_time(limits, vertices)
    for _ in range(SMOOTH_ROUNDS):
        lengths = np.linalg.norm(np.diff(path, axis=0), axis=1)
        ends = np.concatenate([[0.0], np.cumsum(lengths)])
        a, b = np.sort(rng.uniform(0.0, ends[-1], 2))
        i, j = (min(int(np.searchsorted(ends, x, side="right")) - 1, len(lengths) - 1) for x in (a, b))
        if i == j:
            continue
        q_a = path[i] + (a - ends[i]) / lengths[i] * (path[i + 1] - path[i])
        q_b = path[j] + (b - ends[j]) / lengths[j] * (path[j + 1] - path[j])
        candidate = np.vstack([path[:i + 1], q_a, q_b, path[j + 1:]])
        quicker = path_time(limits, candidate)
        if quicker < best - SMOOTH_GAIN_S and checks.polyline(np.array([path[i], q_a, q_b, path[j + 1]])):
            path, best = candidate, quicker
    return path


def shortcut_path(checks: _Checks, vertices: np.ndarray) -> np.ndarray:
    """``vertices`` with every vertex skipped that a free straight edge can skip: from each kept vertex,
    on to the farthest one it reaches by a free edge (deterministic, unlike OMPL's random shortcuts)."""
    kept = [0]
    while kept[-1] < len(vertices) - 1:
        i = kept[-1]
        kept.append(next(j for j in range(len(vertices) - 1, i, -1)
                         if j == i + 1 or checks.edge(vertices[i], vertices[j])))
    return vertices[kept]


class DetourSearch:
    """The detours around the obstacles between two ends, checked quickest first (``next``). Three
    directions, up (world z), back (against the tools' z axes: out of a fixture the tool points into) and
    inward (towards the base's axis), and three shapes: one via point (the flange midway between the ends,
    its orientation halfway) and two (each end moved: out, across, in), each via solved two ways (the pose
    by IK nearest the joint values it lies between, ``_via``; its position alone nudged from those joint
    values, ``_nudged``); and the flange straight out, across and in through poses STRAIGHT_STEP_M apart.
    Where the ends are on different IK branches, also vias that change branch at an end's moved pose (up
    or back). Offsets grow through DETOUR_OFFSETS_M; every way is queued at its first offset whose vias are
    free, by ``path_time``; the quickest is checked, and when an edge is blocked, its way is queued again
    at its next offset. Deterministic: the same ends give the same detours in any process."""

    def __init__(self, model, checks: "_Checks", q_start: np.ndarray, q_goal: np.ndarray):
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
        ways += [Detour(robot, checks, (q_start, q_goal), [X_a, X_b], [q_start, q_goal], along, _via,
                        STRAIGHT_STEP_M) for along in directions]
        if _branch_changes(robot, X_a, q_start, q_goal):
            ways += [Detour(robot, checks, (q_start, q_goal), poses, seeds,
                            [along[0] if X is X_a else along[1] for X in poses], _via)
                     for along in directions[:2]
                     for poses, seeds in (([X_a, X_a, X_b], [q_start, q_goal, q_goal]),
                                          ([X_a, X_b, X_b], [q_start, q_start, q_goal]))]
        self.robot, self.limits, self.checks, self.ways = robot, robot.limits, checks, ways
        self.offsets = np.array(DETOUR_OFFSETS_M)
        # entries (estimate, way, offset index, vertices or None): None until the entry is the quickest
        # queued (its estimate then the one it inherited, no more than its own: farther out takes longer)
        self.queue: list[tuple[float, int, int, np.ndarray | None]] = [(0.0, k, 0, None) for k in range(len(ways))]

    def next(self, max_checks: int, quicker_than: float = np.inf):
        """The first free detour among the next ``max_checks`` checked, while their estimates
        (``path_time``) stay below ``quicker_than`` [s] (the queue goes on from where the last call left
        it): (its vertices; and the vertices brought as close in as the spline through them keeps the
        margins, ``Detour.lowered``, None when even the first spline does not), or None."""
        queue, checked = self.queue, 0
        while queue and checked < max_checks and queue[0][0] < quicker_than:
            estimate, k, i, vertices = heapq.heappop(queue)
            if vertices is None:
                vertices = self.ways[k].vertices(self.offsets[i])
                if vertices is None:
                    if i + 1 < len(self.offsets):
                        heapq.heappush(queue, (estimate, k, i + 1, None))
                else:
                    heapq.heappush(queue, (round(path_time(self.limits, vertices), TIME_DECIMALS), k, i, vertices))
                continue
            checked += 1
            if self.checks.polyline(vertices):
                smooth = self.ways[k].lowered(self.offsets[i], vertices)
                return vertices, None if smooth is None else thinned_spline(self.robot, self.checks, smooth)
            if i + 1 < len(self.offsets):
                heapq.heappush(queue, (estimate, k, i + 1, None))
        return None


@dataclass(frozen=True, eq=False)
class Detour:
    """One way of detouring: vias at ``poses`` (flange poses) moved along ``along`` (a unit vector per
    pose) by an offset, solved by ``solve(robot, pose, seed)`` from ``seeds``, between ``ends``; with a
    ``step`` [m] the flange goes straight (and turns evenly) from each end or via to the next, through
    poses at most ``step`` apart, each solved by ``_via`` from the one before (None: the vias alone,
    joined by straight joint-space edges)."""

    robot: object
    checks: object
    ends: tuple
    poses: list
    seeds: list
    along: list
    solve: object
    step: float | None = None

    def vertices(self, offset: float) -> np.ndarray | None:
        """[start, vias..., goal] at ``offset`` [m], its edges unchecked (None: a via out of reach or not
        free; on a straight way also a joint turning more than MAX_STEP_TURN_RAD between two of its poses)."""
        moved = [_moved(X, offset * way) for X, way in zip(self.poses, self.along)]
        if self.step is not None:
            return self._straight(moved)
        vias = [self.solve(self.robot, X, seed) for X, seed in zip(moved, self.seeds)]
        if any(v is None for v in vias) or not all(self.checks.state(v) for v in vias):
            return None
        return np.array([self.ends[0], *vias, self.ends[1]])

    def _straight(self, moved: list) -> np.ndarray | None:
        keys = [self.robot.fk(self.ends[0]), *moved, self.robot.fk(self.ends[1])]
        vertices = [self.ends[0]]
        for k, (X_a, X_b) in enumerate(zip(keys[:-1], keys[1:])):
            count = max(1, int(np.ceil(np.linalg.norm(X_b[:3, 3] - X_a[:3, 3]) / self.step)))
            last = k == len(keys) - 2
            poses = interpolated_poses(X_a, X_b, np.arange(1, count + 1) / count)
            chain = _chained(self.robot, poses[:-1] if last else poses, vertices[-1], _via)
            if chain is None:
                return None
            vertices += chain
            if not last and not self.checks.state(vertices[-1]):         # a via
                return None
        if np.abs(self.ends[1] - vertices[-1]).max() > MAX_STEP_TURN_RAD:
            return None
        return np.array(vertices + [self.ends[1]])

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


def path_time(limits, vertices: np.ndarray) -> float:
    """An estimate of the time along a joint polyline (k, dof) followed without stopping at its vertices
    (the spline through them) [s]: its length in time at each edge's slowest joint's top speed, from rest
    to rest with the slowest joint's time to reach top speed (bang-bang below it)."""
    cruise = float((np.abs(np.diff(vertices, axis=0)) / limits.qd_max).max(axis=1).sum())
    if limits.qdd_max is None:
        return cruise
    rise = float((limits.qd_max / limits.qdd_max).max())
    return cruise + rise if cruise >= rise else 2.0 * np.sqrt(cruise * rise)


def polyline_time(limits, vertices: np.ndarray) -> float:
    """An estimate of the time along a joint polyline (k, dof) [s]: each edge from rest to rest at the
    slowest joint's speed and acceleration limits (a blend at a vertex saves some of it)."""
    steps = np.abs(np.diff(vertices, axis=0))
    qd, qdd = limits.qd_max, limits.qdd_max
    if qdd is None:
        return float((steps / qd).max(axis=1).sum())
    times = np.where(steps < qd**2 / qdd, 2.0 * np.sqrt(steps / qdd), steps / qd + qd / qdd)
    return float(times.max(axis=1).sum())


def spline_time(limits, vertices: np.ndarray) -> float:
    """An estimate of the time-optimal duration of the C2 spline through ``vertices`` (k, dof) from rest to rest
    (the path a program times through a planned move's vertices) [s]; inf when the spline leaves the limits:
    ``TrialSpline.time`` on SPLINE_TIME_SAMPLES points, within -7 % / +4 % of toppra's duration on the same
    limits (5th-95th percentile, 55 splines of the GP7 bookshelf's planned paths)."""
    spline = trial_spline(vertices, limits.q_min, limits.q_max)
    return np.inf if spline is None else spline.time(limits, SPLINE_TIME_SAMPLES)


def thinned_spline(robot, checks, vertices: np.ndarray) -> np.ndarray:
    """``vertices`` (k, dof) with each inner vertex dropped, in one pass from the start, when the spline through
    the rest is quicker (``spline_time``, by at least SMOOTH_GAIN_S) and keeps the margins (``_spline_is_free``):
    a detour's or a route's vertices close together at a corner (a straight retreat, then across) bend the
    spline sharply there; fewer of them swing it through in one curve."""
    limits = robot.limits
    best, k = spline_time(limits, vertices), 1
    while k < len(vertices) - 1:
        candidate = np.delete(vertices, k, axis=0)
        spline = trial_spline(candidate, limits.q_min, limits.q_max)
        quicker = np.inf if spline is None else spline.time(limits, SPLINE_TIME_SAMPLES)
        if quicker < best - SMOOTH_GAIN_S and _spline_is_free(checks, spline):
            vertices, best = candidate, quicker
        else:
            k += 1
    return vertices


def _curve_is_free(robot, checks, vertices: np.ndarray) -> bool:
    """The C2 spline through ``vertices`` (what a program times through a planned move's vertices,
    ``pipeline.program.stretch``) stays inside the limits and keeps the planning margins (``_spline_is_free``)."""
    spline = trial_spline(vertices, robot.limits.q_min, robot.limits.q_max)
    return spline is not None and _spline_is_free(checks, spline)


def _spline_is_free(checks, spline) -> bool:
    """The planning margins kept at the spline's (``TrialSpline``) configurations CURVE_STEP_RAD apart."""
    s = np.linspace(0.0, 1.0, max(3, int(np.ceil(spline.length / CURVE_STEP_RAD)) + 1))
    return checks.states(spline(s))


def _branch_changes(robot, X: np.ndarray, q_a: np.ndarray, q_b: np.ndarray) -> bool:
    """Whether the IK solutions of X nearest q_a and nearest q_b differ (q_a and q_b are on different
    branches, e.g. of the wrist): then detours that change branch out in the open are tried too."""
    a, b = _via(robot, X, q_a), _via(robot, X, q_b)
    return a is not None and b is not None and float(np.abs(a - b).max()) > MAX_STEP_TURN_RAD


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-9)


def interpolated_poses(X_a: np.ndarray, X_b: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """(n, 4, 4) the poses ``fractions`` (n,) of the way from X_a to X_b: position linear, orientation
    turned evenly about the axis of the relative rotation (slerp, by Rodrigues' formula)."""
    fractions = np.asarray(fractions, dtype=float)
    R_a, R_ab = X_a[:3, :3], X_a[:3, :3].T @ X_b[:3, :3]
    angle = float(np.arccos(np.clip((np.trace(R_ab) - 1.0) / 2.0, -1.0, 1.0)))
    X = np.tile(np.eye(4), (len(fractions), 1, 1))
    X[:, :3, 3] = (1.0 - fractions)[:, None] * X_a[:3, 3] + fractions[:, None] * X_b[:3, 3]
    if angle < 1e-9:
        X[:, :3, :3] = R_a
        return X
    if angle > np.pi - 1e-6:                   # half a turn: (R + I) / 2 = axis axis^T
        M = (R_ab + np.eye(3)) / 2.0
        i = int(np.argmax(np.diag(M)))
        axis = M[:, i] / np.sqrt(M[i, i])
    else:
        axis = np.array([R_ab[2, 1] - R_ab[1, 2], R_ab[0, 2] - R_ab[2, 0], R_ab[1, 0] - R_ab[0, 1]])
        axis /= 2.0 * np.sin(angle)
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    theta = (fractions * angle)[:, None, None]
    X[:, :3, :3] = R_a @ (np.eye(3) + np.sin(theta) * K + (1.0 - np.cos(theta)) * (K @ K))
    return X


def interpolated_pose(X_a: np.ndarray, X_b: np.ndarray, f: float) -> np.ndarray:
    """The pose a fraction ``f`` of the way from X_a to X_b (position linear, orientation slerp)."""
    return interpolated_poses(X_a, X_b, np.array([f]))[0]


def _moved(X: np.ndarray, offset: np.ndarray) -> np.ndarray:
    moved = X.copy()
    moved[:3, 3] += offset
    return moved


def _nudged(robot, X: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    """Joint values near ``seed`` whose flange is at X's position, its orientation free (damped least
    squares on the position alone, NUDGE_ITERATIONS steps; None when it does not get within
    NUDGE_TOLERANCE_M or leaves the limits): a via that keeps the wrist as it is between the ends."""
    return nudged_position(robot, X[:3, 3], seed, NUDGE_ITERATIONS, NUDGE_TOLERANCE_M, NUDGE_DAMPING)


def _via(robot, X: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    """The IK solution of X nearest ``seed`` (None: out of reach): the closed form alone where the arm
    has one (an unreachable via costs it 20 us, the numeric fallback 5 ms), else the numeric methods."""
    fits, q = nearest_analytic(robot, X, seed)
    if fits:
        return q
    result = robot.ik(X, q_seed=seed)
    if not result.success:
        return None
    if not result.solutions:
        return result.q
    Q = np.array([s.q for s in result.solutions])
    return Q[int(np.argmin(((Q - seed) ** 2).sum(axis=1)))]


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


def seeded(seed: int) -> None:
    """OMPL's generator of seeds set to ``seed`` (+ 1: OMPL refuses 0), so that every generator made from
    here on (the planner's, its sampler's, the simplifier's) draws the same numbers in any process and
    after any earlier plan. OMPL logs an error when its generator has already been used (that its
    sampling is then not reproducible): not so when every plan seeds it first, so the log is silenced
    for that call."""
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(int(seed) + 1)
    ou.setLogLevel(ou.LOG_WARN)


def _search(model, checks: _Checks, q_start, q_goal, planner_name, time_budget, seed) -> PlannedPath:
    from ompl import base as ob, geometric as og, util as ou

    seeded(seed)
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
    simplified = path_vertices(path, values)
    simplified[0], simplified[-1] = q_start, q_goal
    simplified = smoothed_path(checks, model.robot.limits, simplified, seed)
    simplify_time = time.perf_counter() - began
    return PlannedPath(simplified, planner_name, plan_time, simplify_time, path_length(raw), path_length(simplified))
