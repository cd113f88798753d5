"""Kinematics benchmark: our DH model (``robot.fk``, ``robot.jacobian`` and their batches) against Drake,
Robotics Toolbox and Pinocchio, and the time of our first calls in a fresh process.

Every peer is built generically from the robot's ``RobotSpec`` (never hand-coded per robot) and is
checked against our FK and Jacobian before it is timed: a benchmark of a wrong model is worthless.
Robotics Toolbox and Pinocchio come from the optional ``bench`` extra; they are imported lazily and
reported as unavailable when missing.

Times are wall-clock microseconds from ``time.perf_counter_ns``. A single-call time is the median
over distinct random in-limit configurations, each call timed on its own (so it includes about
0.05 µs of clock overhead and the Python call into the library). A batch time is the best of
``BATCH_REPEATS`` runs over the whole batch, divided by the batch size. Implementations take turns
(in chunks of configurations, and run by run for batches) so that drift of a shared or throttled
machine's speed biases no ratio.

First calls: our kernels are compiled by Numba on their first call and cached on disk. A fresh
Python process (``FIRST_CALL_SCRIPT``) imports the pipeline, loads ``FIRST_CALL_ROBOT`` and times its
first ``fk``, ``jacobian``, ``ik(method="analytic")`` and ``ik(method="jacobian")`` calls [s]. It runs
twice with ``NUMBA_CACHE_DIR`` set to one new temporary directory: the first run compiles into the
empty cache (cold), the second loads what the first cached (warm). The directory is removed after.

Goals (issue 15, ratios in the same run): FK and Jacobian single calls at most ``SINGLE_CALL_GOAL_RATIO``
= 1.0x Pinocchio's; not measured (so not passed) when Pinocchio is unavailable.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import ConfigurationError
from ..model.chain.drake_model import (
    END_FRAME,
    PLACEHOLDER_MASS_KG,
    PLACEHOLDER_RADIUS_M,
    build_drake_robot,
    joint_split,
)
from ..model.robot import Robot, load_robot
from ..outputs.versions import version_table
from .goals import Goal, GoalReport, goal_lines

OURS = "ours"
DRAKE = "Drake"
RTB = "Robotics Toolbox (C++ ETS)"
PINOCCHIO = "Pinocchio"

VERIFY_CONFIGURATIONS = 20
VERIFY_TOLERANCE = 1e-9
WARMUP_CALLS = 50
TIMING_ROUNDS = 5
BATCH_REPEATS = 3
SINGLE_CALL_GOAL_RATIO = 1.0    # ours / Pinocchio, FK and Jacobian single calls
FIRST_CALL_ROBOT = "gp7"
FIRST_CALL_TIMEOUT_S = 900

#: Rx(pi): conjugating a +z joint motion by it gives the same motion about/along -z.
_FLIP_Z = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class Implementation:
    """One kinematics implementation of a robot, as callables.

    ``fk(q)``: X_BE (4, 4) [m]; ``jacobian(q)``: (6, dof), rows [v; w] in the base frame at the
    end-frame origin; ``q`` (dof,) [rad or m]. ``fk_batch(Q)`` / ``jacobian_batch(Q)`` take Q
    (N, dof) and return (N, 4, 4) / (N, 6, dof), or are None when the library has no batch API.
    """

    name: str
    fk: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    fk_batch: Callable[[np.ndarray], np.ndarray] | None = None
    jacobian_batch: Callable[[np.ndarray], np.ndarray] | None = None


@dataclass(frozen=True)
class TimingRow:
    """Times of one implementation [µs]: single calls per call, batches per configuration (None: no batch API)."""

    name: str
    fk_single_us: float
    jacobian_single_us: float
    fk_batch_us: float | None
    jacobian_batch_us: float | None


@dataclass(frozen=True)
class KinematicsBenchReport(GoalReport):
    """Result of one benchmark run.

    ``rows``: ours first, then each available peer. ``ratio[peer]``: time ratios ours / peer
    (above 1 means ours takes longer) with keys ``fk_single``, ``jacobian_single`` (single calls)
    and ``fk_per_config``, ``jacobian_per_config`` (ours batched vs the peer's fastest time per
    configuration: its batch API where it has one, else its single call). ``max_error[peer]``: the
    largest FK [m] and Jacobian element differences to ours found by the check before timing.
    ``unavailable``: peers that could not be imported, with the reason. ``first_call``: for the
    ``cold`` and the ``warm`` run of a fresh process, the seconds of each of its steps (import,
    load, fk, jacobian, ik analytic, ik jacobian); None when not measured. ``goals``: the
    single-call ratios to Pinocchio.
    """

    robot_name: str
    convention: str
    dof: int
    batch: int
    single_calls: int
    seed: int
    rows: tuple[TimingRow, ...]
    ratio: dict[str, dict[str, float]]
    max_error: dict[str, dict[str, float]]
    versions: dict[str, str]
    unavailable: dict[str, str]
    first_call: dict[str, dict[str, float]] | None
    goals: tuple[Goal, ...]

    def format_table(self) -> str:
        """A plain-text table of the times, one line of ratios per peer, the first calls, then the goals."""
        head = ("implementation", "FK single [µs/call]", "Jacobian single [µs/call]",
                "FK batch [µs/config]", "Jacobian batch [µs/config]")
        body = [(r.name, *(_format_us(t) for t in (r.fk_single_us, r.jacobian_single_us,
                                                   r.fk_batch_us, r.jacobian_batch_us))) for r in self.rows]
        widths = [max(len(row[c]) for row in (head, *body)) for c in range(len(head))]
        table = ["  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(row, widths)))
                 for row in (head, *body)]
        lines = [
            f"Kinematics benchmark: {self.robot_name} ({self.convention} DH, {self.dof} dof); single calls: "
            f"median of {self.single_calls} configurations; batch: {self.batch} configurations, "
            f"best of {BATCH_REPEATS}",
            *table,
            "n/a: no batch API. Every peer matched our FK and Jacobian to "
            f"{VERIFY_TOLERANCE:g} on {VERIFY_CONFIGURATIONS} configurations before timing.",
            "Time ratios (above 1x: ours takes longer):",
            *(self._ratio_line(peer, r) for peer, r in self.ratio.items()),
        ]
        lines += [f"unavailable: {peer}: {why}" for peer, why in self.unavailable.items()]
        lines += _first_call_lines(self.first_call)
        lines += goal_lines("Goals:", self.goals, self.versions)
        return "\n".join(lines)

    @staticmethod
    def _ratio_line(peer: str, r: dict[str, float]) -> str:
        return (f"  ours / {peer}: FK {r['fk_single']:.3g}x, Jacobian {r['jacobian_single']:.3g}x per single "
                f"call; ours batched vs its fastest per configuration: FK {r['fk_per_config']:.3g}x, "
                f"Jacobian {r['jacobian_per_config']:.3g}x")


def _first_call_lines(first_call: dict[str, dict[str, float]] | None) -> list[str]:
    """The first-call report: one line per run, the seconds of each step and their total."""
    if first_call is None:
        return ["First calls in a fresh process: not measured"]
    lines = [f"First calls in a fresh process ({FIRST_CALL_ROBOT}) [s], NUMBA_CACHE_DIR a new temporary directory:"]
    for run, label in (("cold", "cold (empty cache: compiles)"), ("warm", "warm (second run: cached)")):
        steps = first_call[run]
        lines.append(f"  {label}: " + ", ".join(f"{step} {seconds:.3g}" for step, seconds in steps.items())
                     + f"; total {sum(steps.values()):.3g}")
    return lines


def _format_us(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f}"


# -- implementations ------------------------------------------------------------------------------
def ours_implementation(robot: Robot) -> Implementation:
    """Our DH model as a user calls it (``robot.fk``, ``robot.jacobian``), with its batch API."""
    return Implementation(OURS, robot.fk, robot.jacobian, robot.fk_batch, robot.jacobian_batch)


def drake_implementation(robot: Robot) -> Implementation:
    """Drake's MultibodyPlant built from the spec (SetPositions + CalcRelativeTransform / Jacobian)."""
    drake = build_drake_robot(robot.spec)
    return Implementation(DRAKE, drake.fk, drake.jacobian)


def _rtb_link(rtb, joint, modified: bool):
    """One Robotics Toolbox DH link; ``flip`` negates the joint variable (our sign = -1)."""
    flip = joint.sign < 0
    if joint.is_revolute:
        cls = rtb.RevoluteMDH if modified else rtb.RevoluteDH
        return cls(d=joint.d, a=joint.a, alpha=joint.alpha, offset=joint.theta_offset, flip=flip)
    cls = rtb.PrismaticMDH if modified else rtb.PrismaticDH
    return cls(theta=joint.theta_offset, a=joint.a, alpha=joint.alpha, offset=joint.d, flip=flip)


def rtb_implementation(robot: Robot) -> Implementation:
    """Robotics Toolbox ``DHRobot`` -> ETS, timed through its compiled C++ kinematics.

    The public ``ETS.eval`` / ``ETS.jacob0`` spend most of a call normalising arguments in Python
    (about 5x the C++ time for a 6-dof arm); we call the compiled functions they dispatch to, so
    the row measures the C++ kinematics. ``ETS_fkine`` also takes a (N, dof) batch. Its ``jacob0``
    rows are [v; w] in the base frame, like ours. Raises ImportError when it is not installed.
    """
    import roboticstoolbox as rtb
    from roboticstoolbox._fknm_c import ETS_fkine, ETS_jacob0
    from spatialmath import SE3

    spec = robot.spec
    links = [_rtb_link(rtb, joint, spec.convention == "modified") for joint in spec.joints]
    arm = rtb.DHRobot(links, base=SE3(spec.X_BaseD0, check=False), tool=SE3(spec.X_DnE, check=False),
                      name=spec.name)
    ets = arm.ets()
    handle = ets._fknm  # C++ handle into memory owned by ``ets``: the closures keep ``ets`` alive.
    if handle is None:
        raise ImportError("roboticstoolbox has no compiled ETS handle for this robot")

    def fk(q: np.ndarray, _owner=ets) -> np.ndarray:
        return ETS_fkine(handle, q, None, None, True)

    def jacobian(q: np.ndarray, _owner=ets) -> np.ndarray:
        return ETS_jacob0(handle, q, None)

    return Implementation(RTB, fk, jacobian, fk_batch=fk)


def _pin_se3(pin, X: np.ndarray):
    return pin.SE3(X[:3, :3].copy(), X[:3, 3].copy())


def build_pinocchio_model(robot: Robot):
    """A ``pin.Model`` of the spec whose world frame is our base frame, and its end frame's id.

    Joint i is a z joint placed at ``post_{i-1} * pre_i`` (``joint_split``), with the base transform
    in the first placement and the tool in the end frame. A joint with sign -1 keeps the fast z
    joint type: its frame is turned by Rx(pi), which turns +z motion into -z motion.
    Raises ImportError when Pinocchio is not installed.
    """
    import pinocchio as pin

    spec = robot.spec
    model = pin.Model()
    model.name = spec.name
    parent, placement = 0, spec.X_BaseD0
    for joint in spec.joints:
        pre, post = joint_split(joint, spec.convention)
        flip = _FLIP_Z if joint.sign < 0 else np.eye(4)
        joint_model = pin.JointModelRZ() if joint.is_revolute else pin.JointModelPZ()
        parent = model.addJoint(parent, joint_model, _pin_se3(pin, placement @ pre.GetAsMatrix4() @ flip),
                                joint.name)
        # Kinematics never depends on the inertia: the Drake model's placeholder sphere.
        model.appendBodyToJoint(parent, pin.Inertia.FromSphere(PLACEHOLDER_MASS_KG, PLACEHOLDER_RADIUS_M),
                                pin.SE3.Identity())
        placement = flip.T @ post.GetAsMatrix4()
    end = pin.Frame(END_FRAME, parent, _pin_se3(pin, placement @ spec.X_DnE), pin.FrameType.OP_FRAME)
    return model, model.addFrame(end)


def pinocchio_implementation(robot: Robot) -> Implementation:
    """Pinocchio: forwardKinematics + updateFramePlacement, computeFrameJacobian (LOCAL_WORLD_ALIGNED, [v; w])."""
    import pinocchio as pin

    model, frame_id = build_pinocchio_model(robot)
    data = model.createData()
    forward, placement, frame_jacobian = pin.forwardKinematics, pin.updateFramePlacement, pin.computeFrameJacobian
    aligned = pin.LOCAL_WORLD_ALIGNED

    def fk(q: np.ndarray) -> np.ndarray:
        forward(model, data, q)
        return placement(model, data, frame_id).homogeneous

    def jacobian(q: np.ndarray) -> np.ndarray:
        return frame_jacobian(model, data, q, frame_id, aligned)

    return Implementation(PINOCCHIO, fk, jacobian)


_OPTIONAL_PEERS = ((RTB, rtb_implementation, "roboticstoolbox-python"), (PINOCCHIO, pinocchio_implementation, "pin"))


# -- correctness ----------------------------------------------------------------------------------
def _max_error(got, want: np.ndarray) -> float:
    got = np.asarray(got)
    return float(np.abs(got - want).max()) if got.shape == want.shape else float("inf")


def verify_implementation(robot: Robot, impl: Implementation, Q: np.ndarray) -> dict[str, float]:
    """Largest FK [m] and Jacobian differences of ``impl`` to ours on Q (N, dof), batch APIs included.

    Raises RuntimeError when either exceeds ``VERIFY_TOLERANCE``: that peer models another robot.
    """
    fk_error = max(_max_error(impl.fk(q), robot.fk(q)) for q in Q)
    jacobian_error = max(_max_error(impl.jacobian(q), robot.jacobian(q)) for q in Q)
    if impl.fk_batch is not None:
        fk_error = max(fk_error, _max_error(impl.fk_batch(Q), robot.fk_batch(Q)))
    if impl.jacobian_batch is not None:
        jacobian_error = max(jacobian_error, _max_error(impl.jacobian_batch(Q), robot.jacobian_batch(Q)))
    if max(fk_error, jacobian_error) > VERIFY_TOLERANCE:
        raise RuntimeError(
            f"{impl.name} disagrees with ours on {robot.name}: max FK error {fk_error:.3g} m, max Jacobian "
            f"error {jacobian_error:.3g} (tolerance {VERIFY_TOLERANCE:g}); a benchmark of a wrong model is "
            "worthless, so it is not timed"
        )
    return {"fk": fk_error, "jacobian": jacobian_error}


# -- timing ---------------------------------------------------------------------------------------
def single_call_medians_us(fns: list[Callable[[np.ndarray], object]], Q: np.ndarray) -> list[float]:
    """Median time of each ``fn(q)`` over the rows of Q, each call timed alone [µs].

    After ``WARMUP_CALLS`` warm-up calls each, Q is split into ``TIMING_ROUNDS`` chunks and every fn
    runs through a chunk in turn, so a slow drift of the machine's speed hits all of them alike.
    """
    for fn in fns:
        for q in Q[:WARMUP_CALLS]:
            fn(q)
    clock = time.perf_counter_ns
    elapsed: list[list[int]] = [[] for _ in fns]
    for chunk in np.array_split(Q, min(TIMING_ROUNDS, len(Q))):
        for fn, times in zip(fns, elapsed):
            for q in chunk:
                start = clock()
                fn(q)
                times.append(clock() - start)
    return [float(np.median(times)) / 1e3 for times in elapsed]


def batch_per_config_us(fns: list[Callable[[np.ndarray], object]], Q: np.ndarray) -> list[float]:
    """Best of ``BATCH_REPEATS`` runs of each ``fn(Q)`` divided by len(Q) [µs], the fns taking turns."""
    for fn in fns:
        fn(Q[:WARMUP_CALLS])
    best = [float("inf")] * len(fns)
    for _ in range(BATCH_REPEATS):
        for k, fn in enumerate(fns):
            start = time.perf_counter_ns()
            fn(Q)
            best[k] = min(best[k], time.perf_counter_ns() - start)
    return [ns / len(Q) / 1e3 for ns in best]


def _batch_or_none(fns: list[Callable | None], Q: np.ndarray) -> list[float | None]:
    """``batch_per_config_us`` of the batch APIs that exist [µs], None in place of the missing ones."""
    present = [fn for fn in fns if fn is not None]
    times = iter(batch_per_config_us(present, Q))
    return [None if fn is None else next(times) for fn in fns]


def time_implementations(impls: list[Implementation], Q_single: np.ndarray, Q_batch: np.ndarray) -> list[TimingRow]:
    """Single-call medians over Q_single and batch times per configuration over Q_batch [µs], one row each."""
    fk_single = single_call_medians_us([impl.fk for impl in impls], Q_single)
    jacobian_single = single_call_medians_us([impl.jacobian for impl in impls], Q_single)
    fk_batch = _batch_or_none([impl.fk_batch for impl in impls], Q_batch)
    jacobian_batch = _batch_or_none([impl.jacobian_batch for impl in impls], Q_batch)
    return [TimingRow(*row) for row in zip([impl.name for impl in impls], fk_single, jacobian_single,
                                           fk_batch, jacobian_batch)]


def _fastest(single: float, batch: float | None) -> float:
    return single if batch is None else min(single, batch)


def time_ratios(ours: TimingRow, peer: TimingRow) -> dict[str, float]:
    """Time ratios ours / peer (see ``KinematicsBenchReport``); above 1 means ours takes longer."""
    return {
        "fk_single": ours.fk_single_us / peer.fk_single_us,
        "jacobian_single": ours.jacobian_single_us / peer.jacobian_single_us,
        "fk_per_config": ours.fk_batch_us / _fastest(peer.fk_single_us, peer.fk_batch_us),
        "jacobian_per_config": ours.jacobian_batch_us / _fastest(peer.jacobian_single_us, peer.jacobian_batch_us),
    }


# -- first calls ---------------------------------------------------------------------------------
#: ``python -c FIRST_CALL_SCRIPT ROBOT``: prints the seconds of each step as one JSON object.
FIRST_CALL_SCRIPT = """\
import json, sys, time

seconds = {}


def step(name, call):
    start = time.perf_counter()
    value = call()
    seconds[name] = time.perf_counter() - start
    return value


load_robot = step("import", lambda: __import__("pipeline.model.robot", fromlist=["load_robot"]).load_robot)
robot = step("load", lambda: load_robot(sys.argv[1]))
import numpy as np
q, q_seed = robot.random_configurations(np.random.default_rng(0), 2)
X = step("fk", lambda: robot.fk(q))
step("jacobian", lambda: robot.jacobian(q))
step("ik analytic", lambda: robot.ik(X, q_seed, method="analytic"))
step("ik jacobian", lambda: robot.ik(X, q_seed, method="jacobian"))
print(json.dumps(seconds))
"""

#: The folder holding the ``pipeline`` package: the fresh process imports this very copy.
_SOURCE_ROOT = str(Path(__file__).resolve().parents[2])


def first_call_seconds() -> dict[str, dict[str, float]]:
    """Seconds of each step of ``FIRST_CALL_SCRIPT`` in a fresh process, run twice on one new, empty
    Numba cache directory (removed after): ``cold`` compiles into it, ``warm`` loads what it cached.

    Raises RuntimeError when the process fails.
    """
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        path = os.pathsep.join(filter(None, [_SOURCE_ROOT, os.environ.get("PYTHONPATH")]))
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONDONTWRITEBYTECODE": "1", "PYTHONPATH": path}
        return {run: _first_calls(env) for run in ("cold", "warm")}


def _first_calls(env: dict[str, str]) -> dict[str, float]:
    done = subprocess.run([sys.executable, "-c", FIRST_CALL_SCRIPT, FIRST_CALL_ROBOT], env=env, capture_output=True,
                          text=True, timeout=FIRST_CALL_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"the first-call process exited with status {done.returncode}: "
                           f"{done.stderr.strip()[-2000:]}")
    return json.loads(done.stdout.splitlines()[-1])


# -- goals ----------------------------------------------------------------------------------------
def kinematics_goals(ratio: dict[str, dict[str, float]], unavailable: dict[str, str]) -> tuple[Goal, ...]:
    """FK and Jacobian single calls, ours / Pinocchio <= ``SINGLE_CALL_GOAL_RATIO``; without a
    Pinocchio row both are not measured (value None, not passed)."""
    peer = ratio.get(PINOCCHIO)
    bound = f"<= {SINGLE_CALL_GOAL_RATIO:g}"
    if peer is None:
        bound += f"; not measured, {PINOCCHIO} unavailable: {unavailable.get(PINOCCHIO, 'not run')}"
    goals = []
    for label, key in (("FK", "fk_single"), ("Jacobian", "jacobian_single")):
        value = None if peer is None else peer[key]
        goals.append(Goal(f"{label} single call, ours / {PINOCCHIO} [x]", value, bound,
                          value is not None and value <= SINGLE_CALL_GOAL_RATIO))
    return tuple(goals)


# -- the benchmark --------------------------------------------------------------------------------
def run_kinematics_benchmark(robot_name: str = "gp7", batch: int = 100_000, single_calls: int = 2000,
                             seed: int = 0, first_calls: bool = True) -> KinematicsBenchReport:
    """Verify, then time, FK and Jacobian of ours, Drake, Robotics Toolbox and Pinocchio on one robot;
    time our first calls in a fresh process (cold and warm cache).

    ``robot_name``: a preset name or robot file; ``batch``: configurations per batch run;
    ``single_calls``: configurations timed one call at a time; ``seed``: of the random configurations;
    ``first_calls``: False skips the two fresh processes (the cold one compiles for up to minutes).
    """
    if batch < 1 or single_calls < 1:
        raise ConfigurationError(f"batch and single_calls must be >= 1, got {batch} and {single_calls}")
    robot = load_robot(robot_name)
    rng = np.random.default_rng(seed)
    Q_verify = robot.random_configurations(rng, VERIFY_CONFIGURATIONS)
    Q_single = robot.random_configurations(rng, single_calls)
    Q_batch = robot.random_configurations(rng, batch)
    versions = version_table("numpy", "numba", "drake")
    implementations, unavailable = [ours_implementation(robot), drake_implementation(robot)], {}
    for name, build, distribution in _OPTIONAL_PEERS:
        try:
            implementations.append(build(robot))
        except ImportError as exc:
            unavailable[name] = f"{exc} (install the 'bench' extra)"
        else:
            versions.update(version_table(distribution))
    max_error = {impl.name: verify_implementation(robot, impl, Q_verify) for impl in implementations[1:]}
    rows = time_implementations(implementations, Q_single, Q_batch)
    ratio = {peer.name: time_ratios(rows[0], peer) for peer in rows[1:]}
    return KinematicsBenchReport(
        robot_name=robot.name,
        convention=robot.spec.convention,
        dof=robot.dof,
        batch=batch,
        single_calls=single_calls,
        seed=seed,
        rows=tuple(rows),
        ratio=ratio,
        max_error=max_error,
        versions=versions,
        unavailable=unavailable,
        first_call=first_call_seconds() if first_calls else None,
        goals=kinematics_goals(ratio, unavailable),
    )
