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
branches; a joint move may change it, a tool move cannot); ``tcp_speed_max`` drawn from TCP_SPEED_MM_S
(every tool move's speed), ``tcp_accel_max`` TCP_ACCEL_MM_S2; each zone drawn from ZONE_MM and at most half
the line it rounds into or out of. A draw is kept when our compiler accepts it (``compile_job``: every pose
reachable with a collision-free answer, every tool move's IK samples free, every joint move planned);
otherwise the whole program is drawn again, at most MAX_DRAWS times per program. The report says how many were drawn.

Beside them, the demo cell jobs (DEMO_JOBS, in the cells measured).

Two contestants on every program, both certified by our judge (``pipeline.timing.profile.certify``: the joint
limits on every sample, the columns against each other, the clearance over the whole motion):

* ours: ``compile_job`` then ``time_program`` (zones at the junctions, planned moves without interior
  stops), its certified profile; cycle = its duration, beside ``lower_bound(program)``;
* the peer, a pipeline as people build it by hand (MPlib's ``TOPP``, MoveIt's default pipeline): the same
  solved targets (``program.targets``) and the same IK samples of each tool move (``move.samples``).
  Each joint move: ``peer_plan`` (OMPL by hand, as ``bench plan``'s peer: RRTConnect on Drake's checker,
  then ``simplifySolution``; not ``plan_joint_path``, which tries its straight edge and a lift first and
  keeps a margin beyond the clearance), then toppra itself through the vertices
  (``toppra.SplineInterpolator`` over ``linspace(0, 1, n)``, ``JointVelocityConstraint`` x the move's
  speed fraction and ``JointAccelerationConstraint`` from the robot's limits, ``TOPPRA`` with its default
  grid and ``ParametrizeConstAccel``, ``compute_trajectory(0, 0)``: rest to rest). Each tool move: the same toppra
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
import functools
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cell.planning import path_vertices, seeded
from ..errors import ConfigurationError, PipelineError
from ..files.poses import rotation_to_rpy, rpy_to_rotation
from ..files.robot_spec import Limits
from ..outputs.versions import version_table
from ..program.bound import lower_bound
from ..program.compile import compile_job
from ..program.timing import time_program
from ..program.job import load_job, parse_job
from ..progress import Progress
from ..runner import collision_model
from ..timing.profile import Profile, certify, scale_limits
from ..timing.schedule import LimitSchedule
from ..timing.tcp import TcpMotion
from ..timing.toppra_backend import sample_times
from .goals import Goal, GoalReport, fmt, goal_lines
from .plan import peer_setup

log = logging.getLogger(__name__)

#: The demo cells, and the demo cell jobs (in the checkout's trajectories/jobs/) with their cells.
CELLS = ("gp7_wall_cell", "gp7_shelf_cell", "irb1600_wall_cell")
DEMO_JOBS = {"gp7_cell_pick_place": "gp7_wall_cell"}
DEMO_JOB_DIR = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
#: The goals (issue 23): median and max cycle / bound, the largest time_stretch [1].
MEDIAN_GOAL, MAX_GOAL, STRETCH_GOAL = 1.6, 2.0, 1.01
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
#: its rounds of uniform slow-down of a tool move and their samples per dt; what its profiles are called.
PEER_PLAN_BUDGET_S = 2.0
STRETCH_ROUNDS, STRETCH_DENSITY = 5, 10
PEER_METHOD = "peer: OMPL RRTConnect + simplify, toppra (MPlib's TOPP), stops at every junction"


# -- the programs -----------------------------------------------------------------------------------
def _uniform(rng: np.random.Generator, low_high: tuple[float, float]) -> float:
    """One draw in [low, high), rounded to 0.1 (the job file's precision)."""
    return round(float(rng.uniform(*low_high)), 1)


def _point(rng: np.random.Generator, box) -> list[float]:
    return [_uniform(rng, axis) for axis in box]


def _shelf_rpy(tilt_deg: float, spin_deg: float) -> list[float]:
    """rpy [deg] of the tool pointing into the shelf (+x) tilted down by ``tilt``, turned by ``spin`` about
    its own axis (its z axis (cos tilt, 0, -sin tilt))."""
    R = rpy_to_rotation(0.0, math.radians(90.0 + tilt_deg), 0.0) @ rpy_to_rotation(0.0, 0.0, math.radians(spin_deg))
    return [round(math.degrees(a), 6) for a in rotation_to_rpy(R)]


def _station(rng: np.random.Generator, box, direction: np.ndarray, rpy: list[float]) -> tuple[list, list, list, float]:
    """A target drawn in ``box`` [mm], the point ``direction`` x its approach length (drawn in LINE_MM)
    before it, the tool's ``rpy`` [deg] and the approach length [mm]."""
    target = _point(rng, box)
    length = _uniform(rng, LINE_MM)
    above = [round(float(t - length * d), 1) for t, d in zip(target, direction)]
    line = float(np.linalg.norm(np.subtract(target, above)))          # after rounding
    return target, above, rpy, line


def _wall_stations(rng: np.random.Generator, spin_offset_deg: float = 0.0) -> tuple[tuple, tuple]:
    """(pick, place) stations of one program in the wall cell (see ``_station``), the tool pointing down
    turned by ``spin_offset_deg`` and a spin drawn in SPIN_DEG."""
    down = np.array([0.0, 0.0, -1.0])
    return tuple(_station(rng, WALL_SIDES[side], down, [180.0, 0.0, spin_offset_deg + _uniform(rng, SPIN_DEG)])
                 for side in ("pick", "place"))


def _shelf_stations(rng: np.random.Generator) -> tuple[tuple, tuple]:
    """(pick, place) stations of one program in the shelf cell, in the two cubbies in a drawn order, the
    tool into the shelf (``_shelf_rpy``: a tilt drawn in SHELF_TILT_DEG, a spin in SPIN_DEG)."""
    into = np.array([1.0, 0.0, 0.0])
    order = rng.permutation(2)
    return tuple(_station(rng, SHELF_CUBBIES[k], into, _shelf_rpy(_uniform(rng, SHELF_TILT_DEG),
                                                                   _uniform(rng, SPIN_DEG)))
                 for k in order)


#: How each demo cell draws its stations.
#: The IRB 1600's tool points down at axis 5 = +90 deg with its x axis along the base's -x: its stations are turned
#: by 180 deg (as an ABB programmer teaches them), else axis 4 or 6 sits at +-180 deg, which Yaskawa's RCONF cannot
#: tell from -180 deg.
STATIONS = {"gp7_wall_cell": _wall_stations, "gp7_shelf_cell": _shelf_stations,
            "irb1600_wall_cell": functools.partial(_wall_stations, spin_offset_deg=180.0)}
#: The IK seed of the first pose [deg] per cell (else START_DEG): the IRB 1600's wrist points down at +90 deg.
STARTS = {"irb1600_wall_cell": [0, 0, 0, 0, 90, 0]}


def _zone(rng: np.random.Generator, line_mm: float) -> float:
    """A zone drawn in ZONE_MM, at most half the line [mm] (rounded down to 0.1 mm)."""
    return min(_uniform(rng, ZONE_MM), math.floor(5.0 * line_mm - 1e-6) / 10.0)


def draw_document(cell: str, rng: np.random.Generator) -> dict:
    """One pick-and-place job document in ``cell`` (see the module docstring) [mm, deg]."""
    (pick, above_pick, rpy_pick, d_pick), (place, above_place, rpy_place, d_place) = STATIONS[cell](rng)
    speed = round(float(rng.uniform(*TCP_SPEED_MM_S)), -1)
    zones = [_zone(rng, d_pick), _zone(rng, d_place), _zone(rng, d_place)]
    return {
        "description": f"bench cycle: a pick and place in {cell}",
        "cell": cell, "length_unit": "mm", "angle_unit": "deg", "tool": TOOL,
        "tcp_speed_max": speed, "tcp_accel_max": TCP_ACCEL_MM_S2, "start": STARTS.get(cell, START_DEG),
        "plan": "collision_free",
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
    return parse_job(document, source=f"<bench cycle {name}>", name=name)


# -- the peer ---------------------------------------------------------------------------------------
class PeerError(PipelineError):
    """The peer pipeline produced no profile (a planner or toppra failure), with why."""


def peer_plan(scene, q_a: np.ndarray, q_b: np.ndarray, budget: float) -> np.ndarray:
    """OMPL set up by hand, as ``bench plan``'s peer (and MoveIt's and MPlib's default): ``SimpleSetup`` over
    the joint box, a validity callback on the scene's Drake checker (its clearance), the motion validator at
    PEER_STEP_RAD, ``RRTConnect``, ``solve(budget)``, ``simplifySolution()``: the vertices (k, dof).
    OMPL's generator is seeded per plan as ``plan_joint_path`` seeds it (``seeded``), so a run repeats.
    PeerError when it finds no exact solution within ``budget`` [s]."""
    seeded(0)
    setup, values = peer_setup(scene, q_a, q_b)
    setup.solve(budget)
    if not setup.haveExactSolutionPath():
        raise PeerError(f"RRTConnect found no exact solution in {budget:g} s")
    setup.simplifySolution()
    return path_vertices(setup.getSolutionPath(), values)


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
    """The uniform slow-down [1] after which the TCP's speed and acceleration are within ``speed`` [m/s] and
    ``accel`` [m/s^2] (None: not limited): scaled by their peak ratios (speed ~ 1/c, acceleration ~ 1/c^2)
    on samples STRETCH_DENSITY times denser than ``dt`` (a superset of the samples the judge sees) until
    they pass, at most STRETCH_ROUNDS times."""
    stretch = 1.0
    for _ in range(STRETCH_ROUNDS):
        _, q, qd, qdd = _sampled(trajectory, stretch, dt / STRETCH_DENSITY)
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
    """One move of the peer from rest to rest: its samples (t from 0 [s], q, qd, qdd) and the limits on it
    (``joint_speed`` fraction, TCP ``tcp_speed`` [m/s] and ``tcp_accel`` [m/s^2], inf: none)."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    joint_speed: float
    tcp_speed: float
    tcp_accel: float


def peer_piece(program, scene, k: int, limits: Limits, tcp: TcpMotion, budget: float) -> PeerPiece:
    """Move k of ``program`` the peer's way (see the module docstring), with ``limits`` (the program's
    after its speed scale); PeerError, or the planner's PipelineError, when it makes none."""
    move, q_a, q_b = program.moves[k], program.targets[k], program.targets[k + 1]
    scale = program.speed_scale
    if move.kind == "joint":
        vertices = np.array([q_a, q_b]) if scene is None else peer_plan(scene, q_a, q_b, budget)
        t, q, qd, qdd = _sampled(_toppra_trajectory(vertices, limits, move.speed), 1.0, program.dt)
        return PeerPiece(t, q, qd, qdd, move.speed, np.inf, np.inf)
    trajectory = _toppra_trajectory(_through(q_a, move.samples, q_b), limits, 1.0)
    speed = move.speed * scale
    accel = None if program.tcp_accel_max is None else program.tcp_accel_max * scale**2
    stretch = _tcp_stretch(tcp, trajectory, speed, accel, program.dt)
    t, q, qd, qdd = _sampled(trajectory, stretch, program.dt)
    return PeerPiece(t, q, qd, qdd, 1.0, speed, np.inf if accel is None else accel)


def joined_at_rest(pieces: list[PeerPiece]) -> tuple[np.ndarray, ...]:
    """(t, q, qd, qdd) of the pieces one after the other and the times the pieces begin and end (m + 1,)
    [s]. Two pieces meet at rest at the same q, so their junction is one sample: the one of the piece
    whose TCP limits are stricter (a tool move's, whose limits hold at its ends), else the earlier's."""
    bounds = np.concatenate([[0.0], np.cumsum([piece.t[-1] for piece in pieces])])
    keep = [np.ones(len(piece.t), dtype=bool) for piece in pieces]
    for k in range(1, len(pieces)):
        before, after = pieces[k - 1], pieces[k]
        later = (after.tcp_speed, after.tcp_accel) < (before.tcp_speed, before.tcp_accel)
        keep[k - 1 if later else k][-1 if later else 0] = False
    t = np.concatenate([piece.t[mask] + start for piece, mask, start in zip(pieces, keep, bounds)])
    q, qd, qdd = (np.vstack([getattr(piece, name)[mask] for piece, mask in zip(pieces, keep)])
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


# -- the contestants --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Outcome:
    """One contestant on one program: ``cycle_s`` (its profile's duration [s]; None: no profile),
    ``certified`` (our judge passed it), ``failure`` (what failed in a few words: the error's type, or the
    parts of the judge that failed, ``judge_failures``; "" when certified) and ``reason`` (the whole
    message), ``worst_ratio`` (the judge's largest peak/limit ratio [1]; None: no profile), ``time_stretch``
    (the largest uniform slow-down its timing details report [1]; None: none reported) and ``compute_s``
    (wall clock [s]: ours compiling (planning included) and timing, the peer planning and timing; both
    with our judge)."""

    cycle_s: float | None
    certified: bool
    failure: str
    reason: str
    worst_ratio: float | None
    time_stretch: float | None
    compute_s: float


def judge_failures(certificate) -> str:
    """The parts of our judge a profile failed, comma-separated: the worst quantity beyond its limit
    ("qdd", "tcp_speed", ...), "columns", "clearance" ("" when it passed)."""
    parts = [certificate.worst_quantity] if certificate.worst_ratio > 1.0 + certificate.tolerance else []
    if certificate.columns is not None and not certificate.columns.passed:
        parts.append("columns")
    if certificate.clearance is not None and not certificate.clearance.passed:
        parts.append("clearance")
    return ", ".join(parts)


def _failed(exc: PipelineError, began: float, stage: str = "") -> Outcome:
    """The outcome of a contestant that raised ``exc`` (in ``stage``, when named)."""
    return Outcome(None, False, stage + type(exc).__name__, f"{stage}{type(exc).__name__}: {exc}", None, None,
                   time.perf_counter() - began)


def largest_time_stretch(details) -> float | None:
    """The largest value under a key ``time_stretch`` anywhere in nested dicts and lists (None: none)."""
    if isinstance(details, dict):
        found = [largest_time_stretch(value) for key, value in details.items() if key != "time_stretch"]
        found.append(details.get("time_stretch"))
    elif isinstance(details, (list, tuple)):
        found = [largest_time_stretch(value) for value in details]
    else:
        return None
    found = [value for value in found if value is not None]
    return max(found, default=None)


def _judged(profile: Profile, certificate, began: float, time_stretch: float | None) -> Outcome:
    return Outcome(profile.duration, certificate.passed, judge_failures(certificate),
                   "" if certificate.passed else str(certificate), certificate.worst_ratio, time_stretch,
                   time.perf_counter() - began)


def run_ours(program, scene) -> Outcome:
    """``time_program`` on ``program``: its certified profile, or the error it raised."""
    began = time.perf_counter()
    try:
        profile = time_program(program, scene)
    except PipelineError as exc:
        return _failed(exc, began)
    details = profile.details.to_dict() if profile.details is not None else {}
    return _judged(profile, profile.certificate, began, largest_time_stretch(details))


def run_peer(program, scene, budget: float = PEER_PLAN_BUDGET_S) -> Outcome:
    """The peer on ``program``, judged by ``certify`` (with ``scene``: the clearance too)."""
    began = time.perf_counter()
    try:
        profile = peer_profile(program, scene, budget)
    except PipelineError as exc:
        return _failed(exc, began)
    return _judged(profile, certify(profile, scene=scene), began, None)


@dataclass(frozen=True)
class ProgramRecord:
    """One program: ``name``, its lower bound [s] (``lower_bound(program).total_s``), the TCP speed of its
    tool moves [m/s], the draws it took, both outcomes, and its ``job``: the drawn document (``parse_job``
    reads it again), or a demo job's file."""

    name: str
    bound_s: float
    tcp_speed: float
    draws: int
    ours: Outcome
    peer: Outcome
    job: dict | str

    def ratio(self, which: str) -> float | None:
        """cycle / bound of ``which`` ("ours" | "peer") [1], None without a profile."""
        cycle = getattr(self, which).cycle_s
        return None if cycle is None else cycle / self.bound_s


@dataclass(frozen=True, eq=False)
class Drawn:
    """A program of the problem set: ``name``, its ``job`` (a document, or a demo job's file), the
    ``program`` our compiler made of it, the ``draws`` it took and the compiler's wall clock on it
    (``compile_s`` [s]: IK, tool tracks, planning)."""

    name: str
    job: dict | str
    program: object
    draws: int
    compile_s: float


def measure(drawn: Drawn, scene, budget: float) -> ProgramRecord:
    """Both contestants on a program (ours first; its compute time includes the compiler's)."""
    ours = run_ours(drawn.program, scene)
    ours = dataclasses.replace(ours, compute_s=ours.compute_s + drawn.compile_s)
    peer = run_peer(drawn.program, scene, budget)
    speeds = [move.speed for move in drawn.program.moves if move.kind != "joint"]
    return ProgramRecord(drawn.name, lower_bound(drawn.program).total_s, max(speeds, default=0.0), drawn.draws,
                         ours, peer, drawn.job)


# -- the problem set --------------------------------------------------------------------------------
def drawn_programs(cell: str, count: int, rng: np.random.Generator, scene=None) -> tuple[list[Drawn], object]:
    """``count`` programs in ``cell``: each the first draw our compiler accepts, at most MAX_DRAWS draws
    (fewer programs when one was given up); the cell's CollisionModel (built from the first job: every
    drawn job has the same cell and tool)."""
    programs = []
    for k in range(count):
        name = f"{cell}_{k:02d}"
        for draws in range(1, MAX_DRAWS + 1):
            document = draw_document(cell, rng)
            job = parsed_job(document, name)
            scene = scene or collision_model(job)
            began = time.perf_counter()
            try:
                program = compile_job(job, scene)
                programs.append(Drawn(name, document, program, draws, time.perf_counter() - began))
                break
            except PipelineError as exc:
                log.info("%s draw %d refused: %s", name, draws, exc)
    return programs, scene


def measure_demo(name: str, budget: float) -> ProgramRecord:
    """A demo cell job (trajectories/jobs/NAME.yaml) compiled and measured like a drawn program."""
    path = DEMO_JOB_DIR / f"{name}.yaml"
    job = load_job(path)
    scene = collision_model(job)
    began = time.perf_counter()
    try:
        program = compile_job(job, scene)
    except PipelineError as exc:
        failed = _failed(exc, began, "compile_job: ")
        return ProgramRecord(name, math.nan, job.tcp_speed_max or 0.0, 1, failed, failed, str(path))
    return measure(Drawn(name, str(path), program, 1, time.perf_counter() - began), scene, budget)


# -- figures ----------------------------------------------------------------------------------------
def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


def _fraction(flags: list[bool]) -> float | None:
    return float(np.mean(flags)) if flags else None


def _tally(outcomes: list[Outcome]) -> dict[str, int]:
    """How often each failure occurred among the outcomes, most frequent first."""
    counts: dict[str, int] = {}
    for outcome in outcomes:
        if not outcome.certified:
            counts[outcome.failure] = counts.get(outcome.failure, 0) + 1
    return dict(sorted(counts.items(), key=lambda item: -item[1]))


@dataclass
class CellReport:
    """One cell's random programs: how many were asked for, made and drawn; ours certified (fraction),
    its median and max cycle / bound; the peer's certified fraction and median cycle / bound (over the
    programs it made a profile for); ``ours_over_peer``: our median cycle over the peer's and
    ``ours_faster``: on how many programs ours was the faster (both over the programs both made a profile
    for, ``compared``); our largest ``time_stretch``; the peer's largest peak/limit ratio;
    each side's median compute time [s] (``Outcome.compute_s``); each side's failures tallied; and every
    program's record."""

    cell: str
    asked: int
    programs: int
    draws: int
    ours_certified: float | None
    ours_median: float | None
    ours_max: float | None
    peer_certified: float | None
    peer_median: float | None
    ours_over_peer: float | None
    ours_faster: int
    compared: int
    time_stretch_max: float | None
    peer_worst_ratio: float | None
    ours_compute_s: float | None
    peer_compute_s: float | None
    ours_failures: dict[str, int]
    peer_failures: dict[str, int]
    records: list[ProgramRecord] = field(repr=False)


def cell_report(cell: str, asked: int, records: list[ProgramRecord]) -> CellReport:
    ours = [r.ratio("ours") for r in records if r.ours.cycle_s is not None]
    peer = [r.ratio("peer") for r in records if r.peer.cycle_s is not None]
    both = [r for r in records if r.ours.cycle_s is not None and r.peer.cycle_s is not None]
    ours_over_peer = (_median([r.ours.cycle_s for r in both]) / _median([r.peer.cycle_s for r in both])
                      if both else None)
    stretches = [r.ours.time_stretch for r in records if r.ours.time_stretch is not None]
    return CellReport(cell, asked, len(records), sum(r.draws for r in records),
                      _fraction([r.ours.certified for r in records]), _median(ours), max(ours, default=None),
                      _fraction([r.peer.certified for r in records]), _median(peer), ours_over_peer,
                      sum(r.ours.cycle_s < r.peer.cycle_s for r in both), len(both),
                      max(stretches, default=None),
                      max((r.peer.worst_ratio for r in records if r.peer.worst_ratio is not None), default=None),
                      _median([r.ours.compute_s for r in records]), _median([r.peer.compute_s for r in records]),
                      _tally([r.ours for r in records]),
                      _tally([r.peer for r in records]), records)


# -- the report -------------------------------------------------------------------------------------
def _percent(fraction: float | None) -> str:
    return fmt(None if fraction is None else 100.0 * fraction, ".0f") + " %"


def _aligned(head: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    widths = [max(len(row[i]) for row in (head, *rows)) for i in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *rows)]


def _cell_row(c: CellReport) -> tuple[str, ...]:
    return (c.cell, f"{c.programs}/{c.asked} ({c.draws})", _percent(c.ours_certified),
            f"{fmt(c.ours_median, '.3f')} / {fmt(c.ours_max, '.3f')}", _percent(c.peer_certified),
            fmt(c.peer_median, ".3f"), f"{fmt(c.ours_over_peer, '.3f')} ({c.ours_faster}/{c.compared})",
            fmt(c.time_stretch_max, ".4f"))


def _outcome_text(outcome: Outcome, bound_s: float) -> str:
    if outcome.cycle_s is None:
        return f"no profile ({outcome.failure})"
    verdict = "certified" if outcome.certified else f"not certified: {outcome.failure}"
    return f"{outcome.cycle_s:.3f} s = {outcome.cycle_s / bound_s:.3f} x bound, {verdict}"


def _demo_line(record: ProgramRecord) -> str:
    ours, peer = (_outcome_text(outcome, record.bound_s) for outcome in (record.ours, record.peer))
    return (f"  {record.name}: bound {record.bound_s:.3f} s; ours {ours} (time_stretch "
            f"{fmt(record.ours.time_stretch, '.4f')}); peer {peer}")


@dataclass
class CycleBenchReport(GoalReport):
    programs: int
    seed: int
    cells: list[CellReport]
    demos: list[ProgramRecord]
    goals: list[Goal]
    versions: dict

    def format_table(self) -> str:
        """The cells' table, the demo jobs, the failures, then the goals."""
        lines = [
            f"Cycle-time benchmark: {self.programs} seeded pick-and-place programs per cell (seed {self.seed}), "
            "cycle / lower bound (lower_bound(program).total_s)",
            "ours: compile_job + time_program (zones at the junctions); peer: the same targets and tool-move IK "
            "samples, RRTConnect + simplify, toppra through the vertices (MPlib's TOPP), tool moves slowed "
            "uniformly to their TCP limits, a stop at every junction; both judged by certify (limits, clearance)",
            "programs: made / asked (draws); cycle / bound: median / max over the programs with a profile; ours / "
            "peer: median cycle over median cycle (programs where ours is faster / programs compared)",
            "",
        ]
        head = ("cell", "programs", "ours cert.", "ours cycle/bound", "peer cert.", "peer cycle/bound",
                "ours/peer", "time_stretch")
        lines += _aligned(head, [_cell_row(c) for c in self.cells])
        for c in self.cells:
            for who, tally in (("ours", c.ours_failures), ("peer", c.peer_failures)):
                if tally:
                    lines.append(f"  {c.cell} {who} not certified: "
                                 + ", ".join(f"{kind or '?'} x{count}" for kind, count in tally.items()))
            lines.append(f"  {c.cell}: the peer's largest peak/limit ratio {fmt(c.peer_worst_ratio, '.6f')}; compute"
                         f" time, median: ours {fmt(c.ours_compute_s, '.2f')} s, peer {fmt(c.peer_compute_s, '.2f')} s")
        if self.demos:
            lines += ["", "Demo cell jobs:"]
            lines += [_demo_line(record) for record in self.demos]
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)


def cycle_goals(cells: list[CellReport], demos: list[ProgramRecord]) -> list[Goal]:
    """The goals of issue 23 (see the module docstring), per cell, and the demo jobs' time_stretch."""
    goals = []
    for c in cells:
        goals += [
            Goal(f"{c.cell}: ours certified [1]", c.ours_certified, "= 1", c.ours_certified == 1.0),
            Goal(f"{c.cell}: ours median cycle / bound", c.ours_median, f"<= {MEDIAN_GOAL:g}",
                 c.ours_median is not None and c.ours_median <= MEDIAN_GOAL),
            Goal(f"{c.cell}: ours max cycle / bound", c.ours_max, f"<= {MAX_GOAL:g}",
                 c.ours_max is not None and c.ours_max <= MAX_GOAL),
            Goal(f"{c.cell}: ours median cycle / the peer's", c.ours_over_peer, "< 1",
                 c.ours_over_peer is not None and c.ours_over_peer < 1.0),
        ]
    stretches = [r.ours.time_stretch for c in cells for r in c.records] + [r.ours.time_stretch for r in demos]
    found = [s for s in stretches if s is not None]
    goals.append(Goal("ours: largest time_stretch (programs and demo jobs)", max(found, default=None),
                      f"<= {STRETCH_GOAL:g}", all(s <= STRETCH_GOAL for s in found)))
    return goals


def run_cycle_benchmark(cells=CELLS, programs: int = 20, seed: int = 0,
                        budget: float = PEER_PLAN_BUDGET_S) -> CycleBenchReport:
    """The benchmark (see the module docstring): ``programs`` per cell, the demo jobs of the cells measured;
    ``budget`` [s]: the peer's planning time per joint move."""
    unknown = [cell for cell in cells if cell not in CELLS]
    if unknown:
        raise ConfigurationError(f"bench cycle draws programs in {', '.join(CELLS)}, not in {', '.join(unknown)}")
    reports = []
    for cell in cells:
        drawn, scene = drawn_programs(cell, programs, np.random.default_rng(seed))
        records = []
        with Progress(len(drawn), f"bench cycle {cell}") as tick:
            for program in drawn:
                records.append(measure(program, scene, budget))
                tick()
        reports.append(cell_report(cell, programs, records))
    demos = [measure_demo(name, budget) for name, cell in DEMO_JOBS.items() if cell in cells]
    versions = version_table("drake", "ompl", "toppra", "numpy")
    return CycleBenchReport(programs, seed, reports, demos, cycle_goals(reports, demos), versions)
