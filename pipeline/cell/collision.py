"""The robot in its cell as Drake sees it for collision: every geometric query goes through here.

``CollisionModel(robot, cell)`` builds a ``RobotDiagram`` (``RobotDiagramBuilder``): a body ``base``
welded to the world at the cell's ``X_WB`` carrying the robot's chain (``drake_model.add_robot``),
the capsules of ``pipeline.model.chain.geometry.link_capsules`` as collision geometry on each link, the cell's
tool shapes on a body ``tool`` welded to the last link, and each obstacle as a body of its own name
welded to the world. A ``SceneGraphCollisionChecker`` over it answers "is this configuration / edge
free" (robot-obstacle distance at least the clearance, links not touching) and ``clearance(q)`` gives
the smallest distances and the closest pairs by name.

Filtered pairs, besides the adjacent links Drake filters itself: a link pair that touches at every one
of SELF_FILTER_SAMPLES seeded random configurations (their capsules share a joint, as a spherical
wrist's do: MoveIt's "always in collision"), and link 1 (and the base) against an obstacle the robot
stands on (the base origin lies on or in it). ``filtered_pairs`` lists them by name.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from pydrake.geometry import Capsule as DrakeCapsule, CollisionFilterDeclaration, GeometrySet, Sphere
from pydrake.math import RigidTransform
from pydrake.multibody.plant import CoulombFriction
from pydrake.multibody.tree import SpatialInertia
from pydrake.planning import CollisionCheckerParams, RobotCollisionType, RobotDiagramBuilder, SceneGraphCollisionChecker

from ..model.chain.drake_model import add_robot, as_rigid_transform, drake_shape, pose_between, quiet_drake_log
from ..model.chain.geometry import link_capsules, lever_arms

log = logging.getLogger(__name__)

#: Random configurations on which a link pair must touch every time to be filtered as "always".
SELF_FILTER_SAMPLES = 200
#: Distances beyond this are not computed: a robot farther from everything is "far" [m].
INFLUENCE_DISTANCE_M = 1.0
#: An obstacle whose signed distance to the robot's base origin is at most this carries the robot [m].
MOUNT_TOLERANCE_M = 1e-3
#: Self-collision: link capsules may come this close (they are envelopes already) [m].
SELF_CLEARANCE_M = 0.0
#: Drake's code of a link-link row of a clearance result (as an int: comparing the enum per row costs more).
_SELF_COLLISION = int(RobotCollisionType.kSelfCollision)
#: Drake's edge checks step at most this far in joint space (Euclidean norm) [rad] (the planner's
#: padded checker steps finer where its margin needs it: ``padded_checker``).
EDGE_STEP_RAD = 0.02


@dataclass(frozen=True)
class Clearance:
    """Distances of one configuration [m]: ``obstacle`` (smallest robot-obstacle distance, inf without
    obstacles in reach) and its ``obstacle_pair`` (robot body, obstacle), ``self`` (smallest distance
    between checked link pairs) and its ``self_pair``. Negative: penetration depth."""

    obstacle: float
    obstacle_pair: tuple[str, str] | None
    self: float
    self_pair: tuple[str, str] | None


class CollisionModel:
    """A robot (``pipeline.model.robot.Robot``, its end frame the flange F: as its file gives it) in a cell
    (``pipeline.cell.cell_file.Cell``, or None: the robot alone, self-collision only), carrying the shapes of ``tool``
    (a ``pipeline.cell.tool.Tool``, shapes posed in F; None: the cell's tool shapes)."""

    def __init__(self, robot, cell=None, tool=None):
        self.robot = robot
        self.cell = cell
        self.clearance_m = 0.0 if cell is None else cell.clearance
        builder = RobotDiagramBuilder(time_step=0.0)
        plant = self.plant = builder.plant()
        instance = plant.AddModelInstance("robot")
        base = plant.AddRigidBody("robot_base", instance, SpatialInertia.Zero())
        X_WB = np.eye(4) if cell is None else cell.X_WB
        plant.WeldFrames(plant.world_frame(), base.body_frame(), as_rigid_transform(X_WB))
        links = add_robot(plant, robot.spec, instance, base.body_frame())
        self.bodies = [base, *links]
        capsules = link_capsules(robot)
        self._add_capsules(capsules)
        tool_shapes = self.tool_shapes = tool.shapes if tool is not None else () if cell is None else cell.tool_shapes
        self.tool_reach = max((np.linalg.norm(s.X[:3, 3]) + s.bounding_radius for s in tool_shapes), default=0.0)
        if tool_shapes:
            self._add_tool(instance, tool_shapes)
        self.obstacles = self._add_obstacles(() if cell is None else cell.objects)
        plant.Finalize()
        joined = self._filter_joined(builder.scene_graph(), capsules)
        self.diagram = builder.Build()
        params = CollisionCheckerParams()
        params.model = self.diagram
        params.robot_model_instances = [instance]
        params.edge_step_size = EDGE_STEP_RAD
        params.env_collision_padding = self.clearance_m
        params.self_collision_padding = SELF_CLEARANCE_M
        with quiet_drake_log():
            self.checker = SceneGraphCollisionChecker(params)
        self.filtered_pairs = joined + self._filter_mounts(X_WB) + self._filter_always_touching()
        self._padded = {}
        self._broad = {}

    # -- geometry ---------------------------------------------------------------------------------
    def _add_capsules(self, capsules) -> None:
        """The link capsules as collision geometry (a sphere where a capsule has no length)."""
        for k, capsule in enumerate(capsules):
            shape = DrakeCapsule(capsule.radius, capsule.length) if capsule.length > 0 else Sphere(capsule.radius)
            self.plant.RegisterCollisionGeometry(self.bodies[capsule.body], pose_between(capsule.p, capsule.r),
                                                 shape, f"capsule{k}", CoulombFriction())

    def _add_tool(self, instance, tool_shapes) -> None:
        """A body ``tool`` welded to the last link at the end frame, carrying the tool shapes."""
        tool = self.plant.AddRigidBody("tool", instance, SpatialInertia.Zero())
        self.plant.WeldFrames(self.bodies[-1].body_frame(), tool.body_frame(), as_rigid_transform(self.robot.spec.X_DnE))
        for shape in tool_shapes:
            self.plant.RegisterCollisionGeometry(tool, as_rigid_transform(shape.X), drake_shape(shape), shape.name,
                                                 CoulombFriction())

    def _add_obstacles(self, objects) -> list:
        """One body per obstacle, named after it, welded to the world at its pose."""
        instance = self.plant.AddModelInstance("cell")
        bodies = []
        for shape in objects:
            body = self.plant.AddRigidBody(shape.name, instance, SpatialInertia.Zero())
            self.plant.WeldFrames(self.plant.world_frame(), body.body_frame(), as_rigid_transform(shape.X))
            self.plant.RegisterCollisionGeometry(body, RigidTransform(), drake_shape(shape), shape.name,
                                                 CoulombFriction())
            bodies.append(body)
        return bodies

    # -- filters ----------------------------------------------------------------------------------
    def _filter_joined(self, scene_graph, capsules) -> list[tuple[str, str]]:
        """Filter, in SceneGraph itself, links that meet in a joint point: links a and b > a + 1 whose
        links between have no length (a spherical wrist's 4 and 6). Their capsules overlap along one
        line at every configuration, where Drake 1.51's capsule-capsule signed distance does not return."""
        lengths = {}
        for c in capsules:
            lengths[c.body] = lengths.get(c.body, 0.0) + c.length
        filtered = []
        for a in range(1, len(self.bodies)):
            for b in range(a + 2, len(self.bodies)):
                if any(lengths.get(k, 0.0) > 0.0 for k in range(a + 1, b)):
                    break
                sets = [GeometrySet(self.plant.GetCollisionGeometriesForBody(self.bodies[k])) for k in (a, b)]
                scene_graph.collision_filter_manager().Apply(CollisionFilterDeclaration().ExcludeBetween(*sets))
                filtered.append((self.bodies[a].name(), self.bodies[b].name()))
        return filtered

    def _filter_mounts(self, X_WB: np.ndarray) -> list[tuple[str, str]]:
        """Filter the base and link 1 against obstacles the robot stands on."""
        context = self.checker.model_context().plant_context()
        query = self.plant.get_geometry_query_input_port().Eval(context)
        filtered = []
        for distance in query.ComputeSignedDistanceToPoint(X_WB[:3, 3], MOUNT_TOLERANCE_M):
            body = self.plant.GetBodyFromFrameId(query.inspector().GetFrameId(distance.id_G))
            if body in self.obstacles:
                for robot_body in self.bodies[:2]:
                    self.checker.SetCollisionFilteredBetween(robot_body, body, True)
                filtered.append(("link1", body.name()))
        return filtered

    def _filter_always_touching(self) -> list[tuple[str, str]]:
        """Filter link pairs that touch at every one of SELF_FILTER_SAMPLES random configurations."""
        Q = self.robot.random_configurations(np.random.default_rng(0), SELF_FILTER_SAMPLES)
        always = None
        for q in Q:
            result = self.checker.CalcRobotClearance(q, SELF_CLEARANCE_M)
            touching = {tuple(sorted((int(a), int(b))))
                        for a, b, kind, d in zip(result.robot_indices(), result.other_indices(),
                                                 result.collision_types(), result.distances())
                        if kind.name == "kSelfCollision" and d <= SELF_CLEARANCE_M}
            always = touching if always is None else always & touching
            if not always:
                return []
        names = []
        for a, b in sorted(always):
            body_a, body_b = self.plant.get_body(_index(a)), self.plant.get_body(_index(b))
            self.checker.SetCollisionFilteredBetween(body_a, body_b, True)
            names.append((body_a.name(), body_b.name()))
        return names

    # -- queries ----------------------------------------------------------------------------------
    @cached_property
    def lever_arms(self) -> np.ndarray:
        """Per joint, how far any point of the robot's geometry moves per unit of it [m/rad or 1]."""
        return lever_arms(self.robot, self.tool_reach)

    def clearance(self, q) -> Clearance:
        """The smallest robot-obstacle and link-link distances at q and their pairs [m] (Drake reports
        them less the checker's padding, which is added back here)."""
        result = self.checker.CalcRobotClearance(np.asarray(q, dtype=float), INFLUENCE_DISTANCE_M)
        kinds = np.array([int(kind) for kind in result.collision_types()], dtype=int) == _SELF_COLLISION
        distances = result.distances() + np.where(kinds, SELF_CLEARANCE_M, self.clearance_m)
        robots, others = result.robot_indices(), result.other_indices()
        best = {}
        for is_self in (False, True):
            rows = np.flatnonzero(kinds == is_self)
            if len(rows) == 0:
                best[is_self] = (np.inf, None)
                continue
            k = rows[np.argmin(distances[rows])]
            pair = (self.plant.get_body(_index(robots[k])).name(), self.plant.get_body(_index(others[k])).name())
            best[is_self] = (float(distances[k]), pair)
        return Clearance(*best[False], *best[True])

    def margin(self, q) -> tuple[float, Clearance]:
        """(how far q is from violating the clearance or touching links [m], negative when it does, at
        most INFLUENCE_DISTANCE_M less the clearance; the Clearance)."""
        c = self.clearance(q)
        obstacle, self_ = (min(d, INFLUENCE_DISTANCE_M) for d in (c.obstacle, c.self))
        return min(obstacle - self.clearance_m, self_ - SELF_CLEARANCE_M), c

    def is_free(self, q) -> bool:
        """q keeps the clearance to every obstacle and its links apart (Drake's padded check)."""
        return bool(self.checker.CheckConfigCollisionFree(np.asarray(q, dtype=float)))

    def edge_is_free(self, q_a, q_b) -> bool:
        """Every configuration on the straight joint-space edge, at EDGE_STEP_RAD, is free (Drake's
        parallel edge check: 2x faster than the serial one on 2 cores)."""
        return bool(self.checker.CheckEdgeCollisionFreeParallel(np.asarray(q_a, dtype=float),
                                                                np.asarray(q_b, dtype=float)))

    def padded_checker(self, extra_m: float, self_m: float):
        """A clone of the checker keeping ``extra_m`` [m] beyond the clearance to obstacles and ``self_m``
        [m] between links, its edge step small enough that no point of the robot dips more than
        ``extra_m`` below what the steps see (half a step's displacement, ``step * |lever_arms|``)."""
        key = (extra_m, self_m)
        if key not in self._padded:
            checker = self.checker.Clone()
            checker.SetPaddingAllRobotEnvironmentPairs(self.clearance_m + extra_m)
            checker.SetPaddingAllRobotRobotPairs(self_m)
            checker.set_edge_step_size(min(EDGE_STEP_RAD, 2.0 * extra_m / float(np.linalg.norm(self.lever_arms))))
            self._padded[key] = checker
        return self._padded[key]

    def broad_phase(self, extra_m: float = 0.0, self_m: float = SELF_CLEARANCE_M):
        """The compiled conservative check (``pipeline.cell.broad_phase.BroadPhase``) of the checker of
        ``padded_checker(extra_m, self_m)`` (of the plain checker for the defaults), made once per pair."""
        key = (extra_m, self_m)
        if key not in self._broad:
            from .broad_phase import BroadPhase

            plain = extra_m == 0.0 and self_m == SELF_CLEARANCE_M
            self._broad[key] = BroadPhase(self, self.checker if plain else self.padded_checker(extra_m, self_m))
        return self._broad[key]

    def why_not_free(self, q) -> str:
        """The closest pair of q and its distance, in words (for error messages)."""
        c = self.clearance(q)
        if c.self <= SELF_CLEARANCE_M and c.self_pair is not None:
            return f"links {c.self_pair[0]} and {c.self_pair[1]} touch ({c.self * 1e3:.1f} mm)"
        if c.obstacle_pair is None:
            return "no pair in reach"
        return (f"{c.obstacle_pair[0]} is {c.obstacle * 1e3:.1f} mm from {c.obstacle_pair[1]} "
                f"(clearance {self.clearance_m * 1e3:g} mm)")

    def describe(self) -> str:
        """The geometry and filters in a few lines."""
        capsules = link_capsules(self.robot)
        radii = ", ".join(f"{r * 1e3:.0f}" for r in {c.body: c.radius for c in capsules}.values())
        lines = [f"collision model of {self.robot.name}: {len(capsules)} capsules (radii {radii} mm), "
                 f"{len(self.obstacles)} obstacles, clearance {self.clearance_m * 1e3:g} mm"]
        lines += [f"  not checked: {a} - {b}" for a, b in self.filtered_pairs]
        return "\n".join(lines)


def _index(value):
    from pydrake.multibody.tree import BodyIndex

    return BodyIndex(int(value))


def compile_broad_phase() -> float:
    """Compile the broad phase's kernels Python calls (``verdicts``, ``edges_free``) into Numba's cache beside
    ``pipeline/cell/broad_phase.py``, for the GP7 alone (the types are the same in any cell), so that no first
    plan compiles them; the seconds taken."""
    import time

    from ..model.robot import load_robot

    began = time.perf_counter()
    broad = CollisionModel(load_robot("gp7")).broad_phase()
    Q = np.zeros((1, broad.dof))
    broad.free(Q)
    broad.edges_free(Q, Q)
    return time.perf_counter() - began
