"""Cycle-time benchmark: our programs' cycle times beside their lower bound and beside a peer pipeline.

Problem set, per demo cell (``gp7_wall_cell``: a wall across a table between the pick, y > 0, and the
place, y < 0; ``gp7_shelf_cell``: a shelf of three boards at z 150, 450 and 750 mm, x 550..850 mm),
``programs`` seeded pick-and-place programs drawn by ``draw_document`` from one generator seeded with
``seed`` (``np.random.default_rng``): a pick target on one side of the obstacle, a place target on the
other (wall cell: pick y > 0, place y < 0, the tool pointing down, ``rpy [180, 0, yaw]``, the approach
and retreat vertical; shelf cell: the two targets in two different cubbies, the lower and the upper, so
a board is between them, the tool pointing into the shelf (+x, tilted down by SHELF_TILT_DEG), the
approach and retreat along x), each
with its own approach length of LINE_MM (100-200 mm). The program, in TCP poses of a 120 mm tool:

    0 above the pick                                  (the start)
    1 pick            linear                          stop
    2 above the pick  linear (the retreat)            zone
    3 above the place joint  (planned)                zone
    4 place           linear                          stop
    5 above the place linear (the retreat)            zone
    6 above the pick  joint  (planned)                stop (the end)

``plan: collision_free``, ``allow_branch_change: true`` (in the shelf, the two cubbies want different wrist
branches; a joint move may change it, a tool move cannot); ``tcp_speed_max`` drawn from TCP_SPEED_MM_S (every tool move's speed),
``tcp_accel_max`` TCP_ACCEL_MM_S2; each zone drawn from ZONE_MM and at most half the line it rounds into
or out of. A draw is kept when our compiler accepts it (``compile_job``: every pose reachable with a
collision-free answer, every tool move's IK samples free, every joint move planned); otherwise the whole
program is drawn again, at most MAX_DRAWS times per program. The report says how many were drawn.

Beside them, the demo cell jobs (DEMO_JOBS, in the cells measured).

Two contestants on every program, both certified by our judge (``pipeline.profile.certify``: the joint
limits on every sample, the columns against each other, the clearance over the whole motion):

* ours: ``compile_job`` then ``time_program`` (zones at the junctions, planned moves without interior
  stops), its certified profile; cycle = its duration, beside ``lower_bound(program)``;
* the peer, a pipeline as people build it by hand (MPlib's ``TOPP``, MoveIt's default pipeline): the same
  solved targets (``program.targets``) and the same IK samples of each tool move (``move.samples``).
  Each joint move: ``plan_joint_path(scene, q_a, q_b, "RRTConnect")`` (OMPL RRTConnect + simplification
  on Drake's checker), then toppra itself through the vertices (``toppra.SplineInterpolator`` over
  ``linspace(0, 1, n)``, ``JointVelocityConstraint`` x the move's speed fraction and
  ``JointAccelerationConstraint`` from the robot's limits, ``TOPPRA`` with its default grid and
  ``ParametrizeConstAccel``, ``compute_trajectory(0, 0)``: rest to rest). Each tool move: the same toppra
  along a spline through its IK samples, then slowed uniformly until the TCP speed and acceleration on
  its samples are within the move's speed and the job's TCP acceleration (MoveIt's velocity and
  acceleration scaling). It stops at every junction (no zones); the pieces are joined at rest and
  sampled at the job's ``dt``, jerk by finite differences (jerk is not limited). Its TCP limits hold on
  its tool moves only (a ``LimitSchedule``), as ours.

Figures per cell: programs, draws; ours certified %, median and max cycle / bound; the peer certified %
and median cycle / bound (over the programs it produced a profile for, certified or not); ours / peer:
our median cycle over the peer's; the largest ``time_stretch`` in our profiles' timing details.

Goals (issue 23): over each cell's random programs our median cycle / bound <= 1.6 and max <= 2.0, 100 %
certified; our median cycle below the peer's on every cell; ``time_stretch`` <= 1.01 everywhere.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import PipelineError
from ..planning import plan_joint_path
from ..profile import Profile, scale_limits
from ..robot_spec import Limits
from ..schedule import LimitSchedule
from ..tcp import TcpMotion
from ..timing.toppra_backend import sample_times

#: The demo cells and the demo cell jobs (trajectories/jobs/) measured beside them.
CELLS = ("gp7_wall_cell", "gp7_shelf_cell")
DEMO_JOBS = {"gp7_cell_pick_place": "gp7_wall_cell"}
#: Draws of a whole program before one is given up [1].
MAX_DRAWS = 50
#: The programs' tool [mm, deg], TCP speed range [mm/s], TCP acceleration [mm/s^2], approach and retreat
#: length range [mm], zone range [mm] (each at most half its line), the IK seed of the first pose [deg].
TOOL = {"xyz": [0, 0, 120], "rpy": [0, 0, 0]}
TCP_SPEED_MM_S = (250.0, 1000.0)
TCP_ACCEL_MM_S2 = 2500.0
LINE_MM = (100.0, 200.0)
ZONE_MM = (30.0, 75.0)
START_DEG = [0, 0, 0, 0, -90, 0]
#: Where the targets are drawn: the TCP position box [mm] per side (x, y, z ranges) and the tool's spin about
#: its axis [deg]. Wall cell: the table top is at z 100, the wall at y -15..15 up to z 550. Shelf cell:
#: the cubbies between the boards, z 160..440 and 460..740, x 550..850, y -410..410.
WALL_SIDES = {"pick": ((450.0, 750.0), (150.0, 450.0), (140.0, 260.0)),
              "place": ((450.0, 750.0), (-450.0, -150.0), (140.0, 260.0))}
SHELF_CUBBIES = (((590.0, 700.0), (-300.0, 300.0), (260.0, 340.0)),
                 ((590.0, 700.0), (-300.0, 300.0), (560.0, 640.0)))
SPIN_DEG = (-30.0, 30.0)
#: In the shelf the tool points into it (+x) tilted down by this much [deg] (level, its wrist would be
#: near the wrist singularity, J4 and J6 aligned, at the upper cubby's height).
SHELF_TILT_DEG = (5.0, 20.0)
#: The peer's planning budget per joint move [s] (MoveIt's default planning time is 5 s, MPlib's 1 s);
#: its rounds of uniform slow-down of a tool move; what its profiles are called.
PEER_PLAN_BUDGET_S = 2.0
STRETCH_ROUNDS = 5
PEER_METHOD = "peer: OMPL RRTConnect + simplify, toppra (MPlib's TOPP), stops at every junction"


# -- the programs -----------------------------------------------------------------------------------
def _uniform(rng: np.random.Generator, low_high: tuple[float, float]) -> float:
    """One draw in [low, high), rounded to 0.1 (the job file's precision)."""
    return round(float(rng.uniform(*low_high)), 1)


def _point(rng: np.random.Generator, box) -> list[float]:
    return [_uniform(rng, axis) for axis in box]


def _tool_rpy(pitch_deg: float, spin_deg: float) -> list[float]:
    """rpy [deg] of the tool turned by ``pitch`` about y from pointing down (0: down, rpy [180, 0, spin];
    90 + tilt: into the shelf (+x) and ``tilt`` down), then by ``spin`` about its own axis."""
    from ..poses import rotation_to_rpy, rpy_to_rotation

    if pitch_deg == 0.0:
        return [180.0, 0.0, spin_deg]
    R = rpy_to_rotation(0.0, math.radians(pitch_deg), 0.0) @ rpy_to_rotation(0.0, 0.0, math.radians(spin_deg))
    return [round(math.degrees(a), 6) for a in rotation_to_rpy(R)]


def _station(rng: np.random.Generator, box, direction: np.ndarray, pitch_deg: float) -> tuple[list, list, list, float]:
    """A target drawn in ``box`` [mm], the point ``direction`` x its approach length before it, the tool's
    rpy [deg] (``_tool_rpy``, a spin drawn in SPIN_DEG) and the approach length [mm]."""
    target = _point(rng, box)
    length = _uniform(rng, LINE_MM)
    above = [round(float(t - length * d), 1) for t, d in zip(target, direction)]
    line = float(np.linalg.norm(np.subtract(target, above)))          # after rounding
    return target, above, _tool_rpy(pitch_deg, _uniform(rng, SPIN_DEG)), line


def _stations(cell: str, rng: np.random.Generator) -> tuple[tuple, tuple]:
    """(pick, place) stations of one program in ``cell`` (see ``_station``)."""
    if cell == "gp7_wall_cell":
        down = np.array([0.0, 0.0, -1.0])
        return (_station(rng, WALL_SIDES["pick"], down, 0.0), _station(rng, WALL_SIDES["place"], down, 0.0))
    if cell == "gp7_shelf_cell":
        into = np.array([1.0, 0.0, 0.0])
        order = rng.permutation(2)
        return tuple(_station(rng, SHELF_CUBBIES[k], into, 90.0 + _uniform(rng, SHELF_TILT_DEG)) for k in order)
    raise ValueError(f"bench cycle draws programs in {', '.join(CELLS)}, not in {cell!r}")


def _zone(rng: np.random.Generator, line_mm: float) -> float:
    """A zone drawn in ZONE_MM, at most half the line [mm] (rounded down to 0.1 mm)."""
    return min(_uniform(rng, ZONE_MM), math.floor(5.0 * line_mm - 1e-6) / 10.0)


def draw_document(cell: str, rng: np.random.Generator) -> dict:
    """One pick-and-place job document in ``cell`` (see the module docstring) [mm, deg]."""
    (pick, above_pick, rpy_pick, d_pick), (place, above_place, rpy_place, d_place) = _stations(cell, rng)
    speed = round(float(rng.uniform(*TCP_SPEED_MM_S)), -1)
    zones = [_zone(rng, d_pick), _zone(rng, d_place), _zone(rng, d_place)]
    return {
        "description": f"bench cycle: a pick and place in {cell}",
        "cell": cell, "length_unit": "mm", "angle_unit": "deg", "tool": TOOL,
        "tcp_speed_max": speed, "tcp_accel_max": TCP_ACCEL_MM_S2, "start": START_DEG, "plan": "collision_free",
        "allow_branch_change": True,                    # a joint move may change the wrist (the two cubbies)
        "waypoints": [
            {"xyz": above_pick, "rpy": rpy_pick},
            {"xyz": pick, "rpy": rpy_pick, "move": "linear"},
            {"xyz": above_pick, "rpy": rpy_pick, "move": "linear", "zone": zones[0]},
            {"xyz": above_place, "rpy": rpy_place, "move": "joint", "zone": zones[1]},
            {"xyz": place, "rpy": rpy_place, "move": "linear"},
            {"xyz": above_place, "rpy": rpy_place, "move": "linear", "zone": zones[2]},
            {"xyz": above_pick, "rpy": rpy_pick, "move": "joint"},
        ],
    }


def parsed_job(document: dict, name: str):
    """The job of a drawn document (``parse_job``; the cell named by its name)."""
    from ..jobs import parse_job

    return parse_job(document, source=f"<bench cycle {name}>", name=name)


# -- the peer ---------------------------------------------------------------------------------------
class PeerError(PipelineError):
    """The peer pipeline produced no profile (a planner or toppra failure), with why."""


def _toppra_trajectory(vertices: np.ndarray, limits: Limits, speed_fraction: float):
    """toppra as MPlib's ``TOPP`` calls it: a cubic spline through ``vertices`` (k, dof) over
    ``linspace(0, 1, k)``, joint velocity limits x ``speed_fraction`` and acceleration limits, the default
    grid, ``ParametrizeConstAccel``, from rest to rest. PeerError when toppra finds none."""
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    path = toppra.SplineInterpolator(np.linspace(0.0, 1.0, len(vertices)), vertices)
    qd, qdd = limits.qd_max * speed_fraction, limits.qdd_max
    instance = algo.TOPPRA([constraint.JointVelocityConstraint(np.column_stack([-qd, qd])),
                            constraint.JointAccelerationConstraint(np.column_stack([-qdd, qdd]))],
                           path, parametrizer="ParametrizeConstAccel")
    trajectory = instance.compute_trajectory(0.0, 0.0)
    if trajectory is None:
        raise PeerError(f"toppra found no parameterisation through {len(vertices)} vertices")
    return trajectory


def _sampled(trajectory, stretch: float, dt: float) -> tuple[np.ndarray, ...]:
    """(t, q, qd, qdd) of toppra's trajectory slowed uniformly by ``stretch`` [1], every ``dt`` [s] and at
    its end."""
    t = sample_times(trajectory.duration * stretch, dt)
    tau = np.minimum(t / stretch, trajectory.duration)
    return t, trajectory(tau), trajectory(tau, 1) / stretch, trajectory(tau, 2) / stretch**2


def _tcp_stretch(tcp: TcpMotion, trajectory, speed: float, accel: float | None, dt: float) -> float:
    """The uniform slow-down [1] after which the TCP's speed and acceleration on the samples are within
    ``speed`` [m/s] and ``accel`` [m/s^2] (None: not limited): scaled by the peak ratios (speed ~ 1/c,
    acceleration ~ 1/c^2) until the samples the judge sees pass, at most STRETCH_ROUNDS times."""
    stretch = 1.0
    for _ in range(STRETCH_ROUNDS):
        _, q, qd, qdd = _sampled(trajectory, stretch, dt)
        motion = tcp.samples(q, qd, qdd)
        ratio = max(motion.speed.max() / speed, math.sqrt(motion.accel.max() / accel) if accel else 0.0)
        if ratio <= 1.0:
            break
        stretch *= ratio
    return stretch


def _through(q_a: np.ndarray, samples: np.ndarray, q_b: np.ndarray) -> np.ndarray:
    """The joint points of a tool move from ``q_a`` through its IK samples to ``q_b``, each once."""
    inner = [q for q in samples if not (np.allclose(q, q_a, atol=1e-9) or np.allclose(q, q_b, atol=1e-9))]
    return np.array([q_a, *inner, q_b])


@dataclass(frozen=True)
class PeerPiece:
    """One move of the peer from rest to rest: its samples (t from 0 [s], q, qd, qdd), the limits on it
    (``joint_speed`` fraction, TCP ``tcp_speed`` [m/s] and ``tcp_accel`` [m/s^2], inf: none), its planned
    vertices (joint moves) and the uniform slow-down it took (tool moves) [1]."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    joint_speed: float
    tcp_speed: float
    tcp_accel: float
    vertices: int
    stretch: float


def peer_piece(program, scene, k: int, limits: Limits, tcp: TcpMotion, budget: float) -> PeerPiece:
    """Move k of ``program`` the peer's way (see the module docstring), with ``limits`` (the program's
    after its speed scale); PeerError, or the planner's PipelineError, when it makes none."""
    move, q_a, q_b = program.moves[k], program.targets[k], program.targets[k + 1]
    scale = program.speed_scale
    if move.kind == "joint":
        vertices = (np.array([q_a, q_b]) if scene is None
                    else plan_joint_path(scene, q_a, q_b, "RRTConnect", budget).waypoints)
        t, q, qd, qdd = _sampled(_toppra_trajectory(vertices, limits, move.speed), 1.0, program.dt)
        return PeerPiece(t, q, qd, qdd, move.speed, np.inf, np.inf, len(vertices), 1.0)
    points = _through(q_a, move.samples, q_b)
    trajectory = _toppra_trajectory(points, limits, 1.0)
    speed = move.speed * scale
    accel = None if program.tcp_accel_max is None else program.tcp_accel_max * scale**2
    stretch = _tcp_stretch(tcp, trajectory, speed, accel, program.dt)
    t, q, qd, qdd = _sampled(trajectory, stretch, program.dt)
    return PeerPiece(t, q, qd, qdd, 1.0, speed, np.inf if accel is None else accel, len(points), stretch)


def joined_at_rest(pieces: list[PeerPiece]) -> tuple[np.ndarray, ...]:
    """(t, q, qd, qdd) of the pieces one after the other, each junction sample once, and the times the
    pieces begin and end (m + 1,) [s]."""
    bounds = np.concatenate([[0.0], np.cumsum([piece.t[-1] for piece in pieces])])
    keep = [slice(None)] + [slice(1, None)] * (len(pieces) - 1)
    t = np.concatenate([piece.t[s] + start for piece, s, start in zip(pieces, keep, bounds)])
    q, qd, qdd = (np.vstack([getattr(piece, name)[s] for piece, s in zip(pieces, keep)])
                  for name in ("q", "qd", "qdd"))
    return t, q, qd, qdd, bounds


def peer_profile(program, scene=None, budget: float = PEER_PLAN_BUDGET_S) -> Profile:
    """The peer's profile of ``program`` (see the module docstring), not yet judged: the program's limits
    after its speed scale, jerk not limited (``qddd`` by finite differences), the TCP's motion at every
    sample and the limits of each move as a ``LimitSchedule`` over t. PeerError (or the planner's
    PipelineError) when a move has none."""
    robot = program.robot
    limits = dataclasses.replace(scale_limits(program.limits, program.speed_scale), qddd_max=None)
    tcp = TcpMotion(robot)
    pieces = [peer_piece(program, scene, k, limits, tcp, budget) for k in range(len(program.moves))]
    t, q, qd, qdd, bounds = joined_at_rest(pieces)
    schedule = LimitSchedule(bounds, *(np.array([getattr(p, name) for p in pieces])
                                       for name in ("joint_speed", "tcp_speed", "tcp_accel")))
    return Profile(t, q, qd, qdd, np.gradient(qdd, t, axis=0), PEER_METHOD, limits, tuple(robot.joint_names),
                   speed_scale=program.speed_scale, unscaled_limits=program.limits, tcp=tcp.samples(q, qd, qdd),
                   schedule=schedule)
