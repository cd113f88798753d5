"""IK benchmark: our methods beside Robotics Toolbox ``ik_LM``, raw Drake IK and two compiled closed
forms (OPW, EAIK), in the same run.

Per robot, the targets are the FK poses of seeded random in-limit configurations and the seeds are
independent random in-limit configurations. Every method and peer gets the same (target, seed)
pairs; on each target they take turns (the order rotated from target to target) so that drift of a
shared machine's speed hits all of them alike. The Drake rows (``OWN_PASS``) take their turns in a
second pass over the same targets: between milliseconds of Drake, a microsecond call finds cold
caches and would be timed several times slower than in a loop of its own.

Two success rates per row: *reported* (what the method or peer says) and *strict*, judged here by
our own FK whatever the method says: position error <= 1e-6 m, rotation error <= 1e-6 rad and
every joint inside its limits. Times are wall clock per solve call (``time.perf_counter_ns``),
failed calls included, in µs: the Python call, building the problem where the library needs one,
restarts, and our verification for our methods.

Peers (optional ``bench`` extra for Robotics Toolbox and py-opw-kinematics; imported lazily,
reported unavailable when missing or when their model of the robot does not match ours):

* Robotics Toolbox ``ETS.ik_LM`` (compiled C++, Chan's damping), on the ETS of the ``DHRobot``
  built from the spec with our joint limits, ``ilimit=30``, ``joint_limits=True``, and
  ``tol = RTB_TOLERANCE``: it stops when ``E = e.e / 2 < tol`` for its 6-vector error ``e``
  (position, angle-axis), so 5e-13 is the largest tolerance that implies our strict test (its
  default 1e-6 allows ~1.4e-3 of error). ``slimit=1`` (one search from the seed) and ``slimit=100``
  (up to 99 random restarts, drawn by its own unseeded C++ generator).
* Drake ``InverseKinematics`` as a user would write it: position constraint (equality) and
  orientation constraint (theta_bound 0) on the end frame, joint limits, SNOPT (else IPOPT) with
  default options, the seed as the initial guess, one solve, its own ``is_success()``.
* py-opw-kinematics (Rust rs-opw-kinematics) on arms of the OPW geometry: parameters derived from
  the spec (``opw_parameters``) and its FK checked against ours to ``VERIFY_TOLERANCE`` before use.
* EAIK (C++, subproblem decomposition) on arms it has a decomposition for: joint axes H and offsets
  P read off our joint frames at q = 0 (``HPRobot``'s parametrisation, with our end frame's rotation
  at q = 0 as its ``R6T``), its FK checked against ours likewise.

The two closed forms are timed on their compiled all-branch call alone (OPW ``inverse`` without a
seed, EAIK ``calculate_IK``), both in our joint values. Reading their answer is not timed: EAIK's
exact (not least-squares) branches, each joint shifted by 2 pi into its limits where it can be, then
the in-limit solution nearest the seed (none: reported failure). Ours pays for all of that (and for
verifying every branch by FK).

Per robot, besides the rows: the closed form's family (``spherical wrist``, ``three parallel axes``:
the UR family) and how often the target's own configuration is among its branches (modulo 2 pi: a
branch is listed once when its 2 pi variants are many), seeded as timed, not timed.

Goals (issue 15), ratios of median (or p95) times in the same run: on ``GOAL_ROBOT`` (GP7) our
closed form single call <= 0.2x ``RTB_100`` and <= 2x ``OPW``, and one ``ik_batch`` call <= 10 µs
per target; on every robot of the run damped least squares (``jacobian``) <= 1.0x ``RTB_100``
median, p95 <= 3x ``RTB_100``'s p95, strict success >= 99.9 %. Goals (issue 25) on every UR-family
robot of the run (the UR5 of tests/data, in the default robots when the checkout has it): our closed
form single call <= 2x the median of the spherical-wrist robots' closed-form medians and <= 0.5x
``RTB_100`` median, strict success 100 %, the original configuration among the branches on 100 % of
the targets. A goal whose row did not run is reported as not measured (and not passed).

Array layouts (issue 39), on ``GOAL_ROBOT`` when the closed form runs: single calls on arrays of the layouts a
caller brings against the same calls on C-ordered copies, in turns on the same targets (``layout_rows``): IK
(``robot.ik(X)``, the closed form's single-call path) on Fortran-ordered poses (Drake's ``GetAsMatrix4()``), FK
and the Jacobian on strided joint vectors (rows of a Fortran-ordered array). Goals: each median time at most
``LAYOUT_GOAL_RATIO`` x the C-ordered call's, with the same answers bit for bit.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import ConfigurationError
from ..files.branch_names import SPHERICAL_WRIST, THREE_PARALLEL
from ..files.poses import make_pose, rpy_to_rotation
from ..model.ik import METHODS as IK_METHODS
from ..model.ik.analytic import analytic_solver_for
from ..model.ik.result import TWO_PI, is_strict, make_target, pose_errors, within_limits, wrap_into_limits
from ..model.robot import Robot, load_robot
from ..outputs.versions import version_table
from ..progress import Progress
from .goals import Goal, GoalReport, goal_lines

METHODS = ("analytic", "jacobian", "drake")
#: A UR5 (UR's DH table and limits, tests/data): the UR family's closed form, in a checkout only.
UR5_FILE = Path(__file__).resolve().parents[2] / "tests" / "data" / "ur5.yaml"
ROBOTS = ("gp7", "lrmate200id", "irb1600", "arm6") + ((str(UR5_FILE),) if UR5_FILE.is_file() else ())

RTB_1 = "RTB ik_LM (C++), 1 search"
RTB_100 = "RTB ik_LM (C++), up to 100 searches"
DRAKE_RAW = "Drake IK, SNOPT defaults, 1 solve"
OPW = "OPW closed form (py-opw-kinematics, Rust)"
EAIK = "EAIK closed form (C++)"
NUMERIC_PEERS = (RTB_1, RTB_100, DRAKE_RAW)
CLOSED_FORM_PEERS = (OPW, EAIK)
PEERS = NUMERIC_PEERS + CLOSED_FORM_PEERS
ANALYTIC_BATCH = "ours: analytic, all targets in one ik_batch call (time / target)"

RTB_TOLERANCE = 5e-13       # E = |e|^2 / 2 < 5e-13  =>  |e| < 1e-6: position and angle both strict
RTB_ITERATIONS = 30         # ilimit: iterations per search (its default)
WARMUP_TARGETS = 3          # solved by everyone before timing (imports, caches); not counted
VERIFY_CONFIGURATIONS = 10
VERIFY_TOLERANCE = 1e-9

GOAL_ROBOT = "gp7"
ANALYTIC_RTB_GOAL_RATIO = 0.2     # ours: analytic median / RTB_100 median
ANALYTIC_OPW_GOAL_RATIO = 2.0     # ours: analytic median / OPW median
ANALYTIC_BATCH_GOAL_US = 10.0     # one ik_batch call, time per target [µs]
DLS_MEDIAN_GOAL_RATIO = 1.0       # ours: jacobian median / RTB_100 median
DLS_P95_GOAL_RATIO = 3.0          # ours: jacobian p95 / RTB_100 p95
DLS_STRICT_GOAL_PCT = 99.9        # ours: jacobian strict success [%]
UR_SPHERICAL_GOAL_RATIO = 2.0     # UR family: ours analytic median / the spherical-wrist robots' median
UR_RTB_GOAL_RATIO = 0.5           # UR family: ours analytic median / RTB_100 median
UR_STRICT_GOAL_PCT = 100.0        # UR family: ours analytic strict success [%], and the original found [%]
#: Two joint vectors this close modulo 2 pi [rad] are one configuration.
SAME_CONFIGURATION = 1e-6
LAYOUT_GOAL_RATIO = 1.2           # a call on a Fortran-ordered or strided array / the same call C-ordered, median


def ours_name(method: str) -> str:
    return f"ours: {method}"


#: Timed in a pass of their own, after the others: a Drake solve (milliseconds, megabytes) evicts the
#: caches that the microsecond calls after it would pay to refill (2-4x their time on a shared machine).
OWN_PASS = (ours_name("drake"), DRAKE_RAW)


@dataclass(frozen=True)
class IkRow:
    """One method or peer on one robot. Times [µs] per solve call, failed calls included.

    ``reported``: successes the method/peer reported; ``strict``: answers that passed our FK check;
    ``reported_not_strict``: reported successes that failed it; ``errors``: calls that raised
    (counted as failures; ``first_error`` says what happened).
    """

    name: str
    ours: bool
    targets: int
    reported: int
    strict: int
    reported_not_strict: int
    errors: int
    reported_pct: float
    strict_pct: float
    median_us: float
    p95_us: float
    first_error: str = ""


@dataclass(frozen=True)
class IkRobotReport:
    """All rows of one robot, ours first. ``ratio[ours][peer]``: ours median / peer median time
    (above 1: ours takes longer); ``fastest_peer``: the numeric peer with the smallest median time.
    ``unavailable``: methods or peers that could not run, with the reason. ``family``: the closed
    form's (``configurations.SPHERICAL_WRIST``, ``THREE_PARALLEL``; "" for none); ``original_found_pct``:
    targets whose own configuration is among the closed form's solutions [%] (None: not run)."""

    robot_name: str
    convention: str
    dof: int
    rows: tuple[IkRow, ...]
    ratio: dict[str, dict[str, float]]
    fastest_peer: str
    unavailable: dict[str, str]
    family: str = ""
    original_found_pct: float | None = None

    def format_lines(self) -> list[str]:
        """The robot's table, its time ratios, what could not run and the calls that raised."""
        family = f", closed form: {self.family}" if self.family else ""
        lines = [f"{self.robot_name} ({self.convention} DH, {self.dof} dof{family})", *_table(self.rows)]
        if self.original_found_pct is not None:
            lines.append(f"  the target's own configuration among the closed form's branches: "
                         f"{self.original_found_pct:.1f} % of the targets")
        medians = {row.name: row.median_us for row in self.rows}
        for name, ratios in self.ratio.items():
            analytic = name.startswith(ours_name("analytic"))
            closed_forms = [peer for peer in CLOSED_FORM_PEERS if analytic and peer in ratios]
            shown = [f"{ratios[self.fastest_peer]:.3g}x {self.fastest_peer} (fastest numeric peer, "
                     f"{medians[self.fastest_peer]:.3g} µs)"] if self.fastest_peer else []
            shown += [f"{ratios[peer]:.3g}x {peer} ({medians[peer]:.3g} µs)" for peer in closed_forms]
            if shown:
                lines.append(f"  {name} median: " + ", ".join(shown))
        lines += [f"  unavailable: {name}: {why}" for name, why in self.unavailable.items()]
        lines += [f"  {row.name}: {row.errors} call(s) raised, first: {row.first_error}"
                  for row in self.rows if row.errors]
        return lines


@dataclass(frozen=True)
class LayoutRow:
    """One single call (``call``) on ``targets`` inputs as C-ordered arrays and as arrays of another ``layout``:
    the median time per call of each [µs], their ratio (other / C), and whether every answer was the same
    bit for bit."""

    robot_name: str
    call: str
    layout: str
    targets: int
    c_us: float
    other_us: float
    ratio: float
    identical: bool


@dataclass(frozen=True)
class IkBenchReport(GoalReport):
    """Result of one IK benchmark run: one IkRobotReport per robot, the array layouts' rows (``layout_rows``),
    the goals over them."""

    targets: int
    seed: int
    methods: tuple[str, ...]
    robots: tuple[IkRobotReport, ...]
    goals: tuple[Goal, ...]
    versions: dict[str, str]
    layouts: tuple[LayoutRow, ...] = ()

    def format_table(self) -> str:
        """One table per robot (method | reported % | strict % | median µs | p95 µs), ratios, goals."""
        lines = [
            f"IK benchmark: {self.targets} targets per robot (FK of seeded random in-limit configurations), "
            f"random in-limit seeds, seed {self.seed}",
            "strict = position <= 1e-6 m, rotation <= 1e-6 rad, joints in limits, judged by our FK; "
            "times per solve call, failures included; closed-form peers: their compiled call only",
        ]
        for robot in self.robots:
            lines += ["", *robot.format_lines()]
        if self.layouts:
            lines += ["", (f"array layouts ({self.layouts[0].robot_name}, {self.layouts[0].targets} calls each, in "
                           "turns with the C-ordered call; median µs)")]
            lines += [f"  {row.call} on a {row.layout}: {row.other_us:.2f} µs, C-ordered {row.c_us:.2f} µs: "
                      f"{row.ratio:.3g}x, answers {'identical' if row.identical else 'DIFFERENT'}"
                      for row in self.layouts]
        lines += goal_lines("Goals (issues 15, 25, 39):", self.goals, self.versions)
        return "\n".join(lines)


def _table(rows: tuple[IkRow, ...]) -> list[str]:
    head = ("method", "reported %", "strict %", "reported, not strict", "median µs", "p95 µs")
    body = [(r.name, f"{r.reported_pct:.1f}", f"{r.strict_pct:.1f}", str(r.reported_not_strict),
             f"{r.median_us:.0f}", f"{r.p95_us:.0f}") for r in rows]
    widths = [max(len(row[c]) for row in (head, *body)) for c in range(len(head))]
    return ["  " + "  ".join(v.ljust(w) if c == 0 else v.rjust(w) for c, (v, w) in enumerate(zip(row, widths)))
            for row in (head, *body)]


# -- solvers under test ---------------------------------------------------------------------------
#: (X_target, q_seed) -> (reported success, q)
Solve = Callable[[np.ndarray, np.ndarray], tuple[bool, np.ndarray]]


def _as_answered(answer: tuple[bool, np.ndarray], q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
    return answer


@dataclass(frozen=True)
class Solver:
    """A method or peer under test: ``solve(X_target, q_seed)`` is timed and returns its answer;
    ``read(answer, q_seed)``, not timed, turns that into (reported success, q) (default: it is one)."""

    name: str
    solve: Callable[[np.ndarray, np.ndarray], object]
    read: Callable[[object, np.ndarray], tuple[bool, np.ndarray]] = _as_answered


def ours_solver(robot: Robot, method: str) -> Solve:
    """Our ``solve_ik`` through the dispatcher, full pose targets."""
    from ..model.ik import solve_ik, with_drake_model

    options = with_drake_model(robot, method, {})          # one Drake model, built outside the timing

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        result = solve_ik(robot, X, q_seed=q_seed, method=method, **options)
        return result.success, result.q

    return solve


def _fk_error(robot: Robot, fk: Callable[[np.ndarray], np.ndarray]) -> float:
    """Largest difference of ``fk(q)`` (4, 4) to our FK [m] over ``VERIFY_CONFIGURATIONS`` random
    configurations (NaN when either has one)."""
    Q = robot.random_configurations(np.random.default_rng(0), VERIFY_CONFIGURATIONS)
    return float(np.max([np.abs(np.asarray(fk(q)) - robot.fk(q)).max() for q in Q]))


def build_rtb_ets(robot: Robot):
    """The ETS of the Robotics Toolbox ``DHRobot`` built from the spec, with our joint limits.

    Checked against our FK before use. Raises ImportError when roboticstoolbox is not installed.
    """
    import roboticstoolbox as rtb
    from spatialmath import SE3

    from .kinematics import _rtb_link

    spec = robot.spec
    links = [_rtb_link(rtb, joint, spec.convention == "modified") for joint in spec.joints]
    for link, low, high in zip(links, robot.limits.q_min, robot.limits.q_max):
        link.qlim = [low, high]
    arm = rtb.DHRobot(links, base=SE3(spec.X_BaseD0, check=False), tool=SE3(spec.X_DnE, check=False),
                      name=spec.name)
    ets = arm.ets()
    error = _fk_error(robot, ets.eval)
    limits_error = float(np.abs(np.asarray(ets.qlim) - np.vstack([robot.limits.q_min, robot.limits.q_max])).max())
    if error > VERIFY_TOLERANCE or limits_error > VERIFY_TOLERANCE:
        raise RuntimeError(f"Robotics Toolbox model of {robot.name} disagrees with ours: FK {error:.3g} m, "
                           f"joint limits {limits_error:.3g}")
    return ets


def rtb_solver(ets, searches: int) -> Solve:
    """``ets.ik_LM`` from the seed, up to ``searches`` searches (its own reported success)."""

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        solution = ets.ik_LM(X, q0=q_seed, ilimit=RTB_ITERATIONS, slimit=searches, tol=RTB_TOLERANCE,
                             joint_limits=True)
        return bool(solution.success), np.asarray(solution.q, dtype=float)

    return solve


def drake_raw_solver(robot: Robot) -> Solve:
    """Drake InverseKinematics as a user writes it: position + orientation, default options, one solve."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.inverse_kinematics import InverseKinematics
    from pydrake.solvers import IpoptSolver, SnoptSolver

    from ..model.chain.drake_model import build_drake_robot

    drake = build_drake_robot(robot.spec)
    plant, B, E = drake.plant, drake.base_frame, drake.end_frame
    solver = SnoptSolver()
    if not solver.available():
        solver = IpoptSolver()

    def solve(X: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        ik = InverseKinematics(plant, with_joint_limits=True)
        p = X[:3, 3]
        ik.AddPositionConstraint(E, np.zeros(3), B, p, p)
        ik.AddOrientationConstraint(B, RotationMatrix(X[:3, :3]), E, RotationMatrix(), 0.0)
        result = solver.Solve(ik.prog(), q_seed, None)
        return result.is_success(), np.asarray(result.GetSolution(ik.q()), dtype=float)

    return solve


# -- closed-form peers ----------------------------------------------------------------------------
def _require_fk_match(robot: Robot, library: str, fk: Callable[[np.ndarray], np.ndarray]) -> None:
    """ValueError unless ``library``'s ``fk`` matches ours to ``VERIFY_TOLERANCE``: its model is not this robot."""
    error = _fk_error(robot, fk)
    if not error <= VERIFY_TOLERANCE:
        raise ValueError(f"{library}'s model of {robot.name} disagrees with our FK by {error:.3g} m "
                         f"(tolerance {VERIFY_TOLERANCE:g})")


def _axes_at_zero(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At q = 0: the joint axes (dof, 3) (a positive q turns about +axis), a point on each (dof, 3) [m]
    and X_BE (4, 4). Raises ValueError for a prismatic joint (both closed forms take revolute joints)."""
    if not robot.revolute_mask.all():
        raise ValueError(f"{robot.name} has a prismatic joint")
    frames, X_E0 = robot.joint_frames(np.zeros(robot.dof))
    sign = np.array([joint.sign for joint in robot.spec.joints], dtype=float)
    return frames[:, :3, 2] * sign[:, None], frames[:, :3, 3], X_E0


def _meeting_point(p1: np.ndarray, w1: np.ndarray, p2: np.ndarray, w2: np.ndarray) -> np.ndarray:
    """Midpoint of the common perpendicular of the lines p1 + t w1 and p2 + t w2 [m]."""
    n = np.cross(w1, w2)
    if np.linalg.norm(n) < VERIFY_TOLERANCE:
        raise ValueError("axes 4 and 5 are parallel")
    d = p2 - p1
    return (p1 + (np.cross(d, w2) @ n) / (n @ n) * w1 + p2 + (np.cross(d, w1) @ n) / (n @ n) * w2) / 2.0


def opw_parameters(robot: Robot) -> tuple[dict, np.ndarray]:
    """py-opw-kinematics' ``KinematicModel`` arguments of a 6R arm (``a1``, ``a2``, ``b``, ``c1``,
    ``c2``, ``c3``, ``c4`` [m], ``offsets`` [rad], ``flip_axes``) and X_BO (4, 4), OPW's base frame
    in ours, read off our joint axes at q = 0.

    OPW's arm at theta = 0 stands up: base z along axis 1, axes 2 and 3 along y, J2 at (a1, *, c1),
    J3 c2 above J2, the forearm (axis 4) along z, the wrist centre at (a1 + a2, b, c1 + c2 + c3),
    axis 5 along y, axis 6 and the end frame's z along z, its origin c4 beyond the wrist centre.
    Joint i turns by theta_i = s_i q_i - offsets_i (s_i = -1 where ``flip_axes``; the library applies
    this itself). Where either sign of an axis fits, the choice keeps OPW's x on the side of our x
    (axis 2), c3 >= 0 (axis 4), |theta_4| <= 90 deg at q = 0 (axis 5) and c4 >= 0 (axis 6).
    theta_6 = 0 at q = 0: the end frame's turn about axis 6 is left to the tool transform. This reads
    numbers off the arm; whether it has the OPW geometry at all is for the FK check (``OpwPeer.of``).
    Raises ValueError for no 6R arm.
    """
    if robot.dof != 6:
        raise ValueError(f"{robot.name} has {robot.dof} joints, not 6")
    u, p, X_E0 = _axes_at_zero(robot)
    z = u[0]
    flip2 = float(np.cross(u[1], z)[0]) < 0.0
    y = -u[1] if flip2 else u[1]
    R_BO = np.column_stack([np.cross(y, z), y, z])
    origin = p[0] - (p[0] @ z) * z                                    # on axis 1, nearest our base origin
    wrist = _meeting_point(p[3], u[3], p[4], u[4])
    j2, j3, c, e = (np.array([p[1], p[2], wrist, X_E0[:3, 3]]) - origin) @ R_BO  # in OPW's base frame
    a = u @ R_BO
    theta2 = math.atan2(j3[0] - j2[0], j3[2] - j2[2])                   # J3 - J2 = c2 (sin, 0, cos)(theta2)
    flip4 = float(a[3] @ (c - j3)) < 0.0
    forearm = -a[3] if flip4 else a[3]
    phi = math.atan2(forearm[0], forearm[2])                            # theta2 + theta3
    R_forearm = rpy_to_rotation(0.0, phi, 0.0)
    axis5 = a[4] @ R_forearm                                            # +-Rz(theta4) y
    flip5 = float(axis5[1]) < 0.0
    axis5 = -axis5 if flip5 else axis5
    theta4 = math.atan2(-axis5[0], axis5[1])
    flip6 = float(a[5] @ (e - c)) < 0.0
    axis6 = -a[5] if flip6 else a[5]
    axis6_in_wrist = axis6 @ R_forearm @ rpy_to_rotation(0.0, 0.0, theta4)  # Ry(theta5) z
    theta5 = math.atan2(axis6_in_wrist[0], axis6_in_wrist[2])
    theta = (0.0, theta2, phi - theta2, theta4, theta5, 0.0)
    parameters = {
        "a1": float(j2[0]), "a2": float((c - j3) @ R_forearm[:, 0]), "b": float(c[1]), "c1": float(j2[2]),
        "c2": math.hypot(j3[0] - j2[0], j3[2] - j2[2]), "c3": float((c - j3) @ forearm), "c4": float((e - c) @ axis6),
        "offsets": tuple(-angle for angle in theta),
        "flip_axes": (False, flip2, float(a[2, 1]) < 0.0, flip4, flip5, flip6),
    }
    return parameters, make_pose(R_BO, origin)


@dataclass(frozen=True, eq=False)
class OpwPeer:
    """py-opw-kinematics' model of a robot, FK checked against ours: X_BE(q) = X_BO @ opw(q) @ X_TE [m].

    ``model`` is its compiled ``_internal.Robot`` in radians (the public ``Robot`` wraps it in scipy
    transforms); it takes and returns our joint values, applying ``offsets`` and ``flip_axes`` itself.
    ``X_BO`` and its inverse ``X_OB`` are None when OPW's base frame is ours (to 1e-15). X_TE, our
    end frame in OPW's, goes in as its ``ee_transform`` ``tool``: that takes an (R, p) as the pose
    (R, R p) (py-opw-kinematics 1.3.0: the offset taken along the turned axes), so ``tool`` is
    (R_TE, R_TE^T p_TE). The FK check would catch a version that reads it otherwise.
    """

    model: object
    parameters: dict
    X_BO: np.ndarray | None
    X_OB: np.ndarray | None
    tool: np.ndarray

    @classmethod
    def of(cls, robot: Robot) -> "OpwPeer":
        """The model of ``robot``; ImportError without the package, ValueError when it does not fit."""
        from py_opw_kinematics import KinematicModel
        from py_opw_kinematics._internal import Robot as OpwRobot

        parameters, X_BO = opw_parameters(robot)
        model = OpwRobot(KinematicModel(**parameters), False)
        X_TE = np.linalg.inv(X_BO @ np.asarray(model.forward((0.0,) * 6, None))) @ robot.fk(np.zeros(6))
        tool = make_pose(X_TE[:3, :3], X_TE[:3, :3].T @ X_TE[:3, 3])
        if np.allclose(X_BO, np.eye(4), rtol=0.0, atol=1e-15):
            peer = cls(model, parameters, None, None, tool)
        else:
            peer = cls(model, parameters, X_BO, np.linalg.inv(X_BO), tool)
        _require_fk_match(robot, "py-opw-kinematics", peer.fk)
        return peer

    def fk(self, q: np.ndarray) -> np.ndarray:
        """X_BE (4, 4) [m] by OPW's FK."""
        X = np.asarray(self.model.forward(tuple(q), self.tool))
        return X if self.X_BO is None else self.X_BO @ X

    def solve(self, X: np.ndarray, q_seed: np.ndarray) -> list:
        """Every branch for X_BE (4, 4), our joint values: the compiled call (no seed: unsorted)."""
        return self.model.inverse(X if self.X_OB is None else self.X_OB @ X, None, self.tool)


def build_eaik(robot: Robot):
    """EAIK's model of ``robot`` (``eaik.pybindings.EAIK.Robot``, what ``HPRobot`` wraps), FK checked.

    H: the joint axes at q = 0 (dof, 3); P (dof + 1, 3) [m]: base origin -> a point on axis 1 -> ...
    -> a point on the last axis -> the end-frame origin; R6T: our end frame's rotation at q = 0
    (``HPRobot`` fixes it to the identity). Raises ImportError without the package, ValueError when
    EAIK knows no decomposition for the arm or its FK disagrees with ours.
    """
    from eaik.pybindings.EAIK import Robot as EaikRobot

    H, points, X_E0 = _axes_at_zero(robot)
    P = np.diff(np.vstack([np.zeros(3), points, X_E0[:3, 3]]), axis=0)
    model = EaikRobot(H.T, P.T, X_E0[:3, :3], [], True)
    if not model.has_known_decomposition():
        raise ValueError(f"EAIK knows no decomposition for {robot.name} ({model.get_kinematic_family()})")
    _require_fk_match(robot, "EAIK", model.fwdkin)
    return model


def closed_form_answer(robot: Robot, Q: np.ndarray, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
    """(reported, q) from a closed form's solutions Q (n, dof), our joint values [rad]: each joint
    shifted by 2 pi into its limits where it can be (nearest the seed), then the in-limit solution
    nearest the seed. None inside: (False, the nearest); no solution: (False, NaN)."""
    limits = robot.limits
    Q = np.reshape(Q, (-1, robot.dof))
    if len(Q) == 0:
        return False, np.full(robot.dof, np.nan)
    Q = np.array([wrap_into_limits(q, robot.revolute_mask, limits.q_min, limits.q_max, q_seed) for q in Q])
    order = np.argsort(np.linalg.norm(Q - q_seed, axis=1))
    inside = [k for k in order if within_limits(Q[k], limits.q_min, limits.q_max)]
    return (True, Q[inside[0]]) if inside else (False, Q[order[0]])


def opw_solver(robot: Robot) -> Solver:
    """The OPW peer: its compiled all-branch IK timed, our reading of the branches not."""
    peer = OpwPeer.of(robot)

    def read(answer: list, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        return closed_form_answer(robot, np.asarray(answer, dtype=float), q_seed)

    return Solver(OPW, peer.solve, read)


def eaik_solver(robot: Robot) -> Solver:
    """The EAIK peer: its compiled all-branch IK timed, our reading of the exact (not least-squares)
    branches not."""
    model = build_eaik(robot)

    def solve(X: np.ndarray, q_seed: np.ndarray):
        return model.calculate_IK(X)

    def read(answer, q_seed: np.ndarray) -> tuple[bool, np.ndarray]:
        return closed_form_answer(robot, answer.Q[~np.asarray(answer.is_LS, dtype=bool)], q_seed)

    return Solver(EAIK, solve, read)


def _peer_solvers(robot: Robot) -> tuple[list[Solver], dict[str, str]]:
    solvers, unavailable = [], {}
    try:
        ets = build_rtb_ets(robot)
    except ImportError as exc:
        for name in (RTB_1, RTB_100):
            unavailable[name] = f"{exc} (install the 'bench' extra)"
    else:
        solvers += [Solver(RTB_1, rtb_solver(ets, 1)), Solver(RTB_100, rtb_solver(ets, 100))]
    try:
        solvers.append(Solver(DRAKE_RAW, drake_raw_solver(robot)))
    except ImportError as exc:
        unavailable[DRAKE_RAW] = str(exc)
    for name, build in ((OPW, opw_solver), (EAIK, eaik_solver)):
        try:
            solvers.append(build(robot))
        except (ImportError, ValueError) as exc:
            unavailable[name] = f"{type(exc).__name__}: {exc}"
    return solvers, unavailable


# -- the benchmark --------------------------------------------------------------------------------
def _strict(robot: Robot, q: np.ndarray, target) -> bool:
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.dof,) or not np.isfinite(q).all():
        return False
    return is_strict(*pose_errors(robot.fk(q), target)) and within_limits(q, robot.limits.q_min, robot.limits.q_max)


def _usable(solver: Solver, robot: Robot, Q_warmup: np.ndarray, seeds: np.ndarray) -> str:
    """"" when ``solver`` runs on the warm-up targets, else why not (NotImplementedError, ImportError...)."""
    try:
        for q_target, q_seed in zip(Q_warmup, seeds):
            solver.read(solver.solve(robot.fk(q_target), q_seed), q_seed)
    except (NotImplementedError, ImportError) as exc:
        return f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 - a method that cannot run on this robot is reported, not fatal
        return f"raised on a warm-up target: {type(exc).__name__}: {exc}"
    return ""


def _solve_target(robot, solvers, group, t, q_target, q_seed, times, reported, strict, errors, first_error) -> None:
    """The solvers of ``group`` (indices) on target t, interleaved in an order rotated per target;
    fills their column t of the arrays."""
    clock = time.perf_counter_ns
    X = robot.fk(q_target)
    target = make_target(X)
    for k in np.roll(group, -t):
        solver = solvers[k]
        start = clock()
        try:
            answer = solver.solve(X, q_seed)
        except Exception as exc:  # noqa: BLE001 - counted as a failure and reported
            times[k, t] = clock() - start
            errors[k] += 1
            first_error[k] = first_error[k] or f"{type(exc).__name__}: {exc}"
            continue
        times[k, t] = clock() - start
        reported[k, t], q = solver.read(answer, q_seed)
        strict[k, t] = _strict(robot, q, target)


def benchmark_robot(robot: Robot, targets: int, seed: int, methods: tuple[str, ...]) -> IkRobotReport:
    """Run every available method and peer on ``targets`` seeded targets of one robot."""
    rng = np.random.default_rng(seed)
    Q_target = robot.random_configurations(rng, targets)
    Q_seed = robot.random_configurations(rng, targets)
    Q_warmup = robot.random_configurations(rng, 2 * WARMUP_TARGETS)

    candidates = [Solver(ours_name(m), ours_solver(robot, m)) for m in methods]
    peers, unavailable = _peer_solvers(robot)
    solvers: list[Solver] = []
    for solver in candidates + peers:
        why = _usable(solver, robot, Q_warmup[:WARMUP_TARGETS], Q_warmup[WARMUP_TARGETS:])
        if why:
            unavailable[solver.name] = why
        else:
            solvers.append(solver)

    count = len(solvers)
    times = np.zeros((count, targets))
    reported = np.zeros((count, targets), dtype=bool)
    strict = np.zeros((count, targets), dtype=bool)
    errors = [0] * count
    first_error = [""] * count
    groups = [group for group in ([k for k, solver in enumerate(solvers) if (solver.name in OWN_PASS) == own]
                                  for own in (False, True)) if group]
    with Progress(targets * len(groups), f"bench ik {robot.name}") as tick:
        for group in groups:
            for t in range(targets):
                _solve_target(robot, solvers, group, t, Q_target[t], Q_seed[t], times, reported, strict, errors,
                              first_error)
                tick()

    rows = []
    for k, solver in enumerate(solvers):
        n_reported, n_strict = int(reported[k].sum()), int(strict[k].sum())
        rows.append(IkRow(
            name=solver.name, ours=solver.name.startswith("ours: "), targets=targets, reported=n_reported,
            strict=n_strict, reported_not_strict=int((reported[k] & ~strict[k]).sum()), errors=errors[k],
            reported_pct=100.0 * n_reported / targets, strict_pct=100.0 * n_strict / targets,
            median_us=float(np.median(times[k])) / 1e3, p95_us=float(np.percentile(times[k], 95)) / 1e3,
            first_error=first_error[k],
        ))
    found = None
    if "analytic" in methods and ours_name("analytic") not in unavailable:
        rows.append(analytic_batch_row(robot, Q_target, Q_seed))
        found = original_found_pct(robot, Q_target, Q_seed)
    ours_rows = [r for r in rows if r.ours]
    peer_rows = [r for r in rows if not r.ours]
    numeric_rows = [r for r in peer_rows if r.name in NUMERIC_PEERS]
    fastest = min(numeric_rows, key=lambda r: r.median_us).name if numeric_rows else ""
    ratio = {o.name: {p.name: o.median_us / p.median_us for p in peer_rows} for o in ours_rows}
    solver = analytic_solver_for(robot)
    return IkRobotReport(robot_name=robot.name, convention=robot.spec.convention, dof=robot.dof,
                         rows=tuple(rows), ratio=ratio, fastest_peer=fastest, unavailable=unavailable,
                         family=solver.family if solver.applicable else "", original_found_pct=found)


def original_found_pct(robot: Robot, Q_target: np.ndarray, Q_seed: np.ndarray) -> float:
    """How many targets (the FK of Q_target (N, dof)) have their own configuration among the closed
    form's solutions (seeded with Q_seed), comparing modulo 2 pi [%]."""
    results = robot.ik_batch(robot.fk_batch(Q_target), Q_seed, method="analytic")
    found = 0
    for q, result in zip(Q_target, results):
        Q = np.array([s.q for s in result.solutions]).reshape(-1, robot.dof)
        difference = (Q - q + math.pi) % TWO_PI - math.pi
        found += bool(len(Q)) and bool((np.abs(difference).max(axis=1) <= SAME_CONFIGURATION).any())
    return 100.0 * found / len(Q_target)


def analytic_batch_row(robot: Robot, Q_target: np.ndarray, Q_seed: np.ndarray) -> IkRow:
    """The closed form solving all targets in one ``ik_batch`` call (best of 3 runs), ``ANALYTIC_BATCH``.

    Its median and p95 are both the run time divided by the number of targets: a batch has no
    per-target times.
    """
    X = robot.fk_batch(Q_target)
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter_ns()
        results = robot.ik_batch(X, Q_seed, method="analytic")
        best = min(best, time.perf_counter_ns() - start)
    per_target_us = best / len(X) / 1e3
    reported = np.array([r.success for r in results])
    strict = np.array([_strict(robot, r.q, make_target(x)) for r, x in zip(results, X)])
    n = len(X)
    return IkRow(name=ANALYTIC_BATCH, ours=True, targets=n,
                 reported=int(reported.sum()), strict=int(strict.sum()),
                 reported_not_strict=int((reported & ~strict).sum()), errors=0,
                 reported_pct=100.0 * reported.mean(), strict_pct=100.0 * strict.mean(),
                 median_us=per_target_us, p95_us=per_target_us)


# -- goals ----------------------------------------------------------------------------------------
def _row(robot: IkRobotReport, name: str) -> IkRow | None:
    return next((row for row in robot.rows if row.name == name), None)


def _not_measured(robot: IkRobotReport, names: tuple[str, ...]) -> str:
    """"" when every named row ran on ``robot``, else why the first missing one did not."""
    missing = [name for name in names if _row(robot, name) is None]
    if not missing:
        return ""
    return f"; not measured, {missing[0]}: {robot.unavailable.get(missing[0], 'not run')}"


def _ratio_goal(robot: IkRobotReport, ours: str, peer: str, statistic: str, bound: float) -> Goal:
    """Goal: ours / peer of a time ``statistic`` (``median_us`` or ``p95_us``) <= bound on ``robot``."""
    rows = _row(robot, ours), _row(robot, peer)
    value = None if None in rows else getattr(rows[0], statistic) / getattr(rows[1], statistic)
    return Goal(f"{robot.robot_name}: {ours} / {peer}, {statistic.removesuffix('_us')} time [x]", value,
                f"<= {bound:g}{_not_measured(robot, (ours, peer))}", value is not None and value <= bound)


def _closed_form_goals(robot: IkRobotReport | None) -> tuple[Goal, ...]:
    """The closed form's goals on the goal robot (one unmeasured goal when it is not in the run)."""
    if robot is None:
        return (Goal(f"{GOAL_ROBOT}: closed-form goals", None, f"not measured: {GOAL_ROBOT} is not in this run",
                     False),)
    analytic = ours_name("analytic")
    batch = _row(robot, ANALYTIC_BATCH)
    per_target = None if batch is None else batch.median_us
    return (
        _ratio_goal(robot, analytic, RTB_100, "median_us", ANALYTIC_RTB_GOAL_RATIO),
        _ratio_goal(robot, analytic, OPW, "median_us", ANALYTIC_OPW_GOAL_RATIO),
        Goal(f"{robot.robot_name}: {ANALYTIC_BATCH} [µs]", per_target,
             f"<= {ANALYTIC_BATCH_GOAL_US:g}{_not_measured(robot, (ANALYTIC_BATCH,))}",
             per_target is not None and per_target <= ANALYTIC_BATCH_GOAL_US),
    )


def _dls_goals(robot: IkRobotReport) -> tuple[Goal, ...]:
    """Damped least squares' goals on one robot: median and p95 time against ``RTB_100``, strict success."""
    dls = ours_name("jacobian")
    row = _row(robot, dls)
    strict = None if row is None else row.strict_pct
    return (
        _ratio_goal(robot, dls, RTB_100, "median_us", DLS_MEDIAN_GOAL_RATIO),
        _ratio_goal(robot, dls, RTB_100, "p95_us", DLS_P95_GOAL_RATIO),
        Goal(f"{robot.robot_name}: {dls} strict success [%]", strict,
             f">= {DLS_STRICT_GOAL_PCT:g}{_not_measured(robot, (dls,))}",
             strict is not None and strict >= DLS_STRICT_GOAL_PCT),
    )


def _ur_goals(robot: IkRobotReport, spherical: list[IkRobotReport]) -> tuple[Goal, ...]:
    """The UR family's goals on one robot of it, against the ``spherical`` wrist robots of the run."""
    analytic = ours_name("analytic")
    row = _row(robot, analytic)
    medians = [other.median_us for other in (_row(s, analytic) for s in spherical) if other is not None]
    reference = float(np.median(medians)) if medians else None
    value = None if row is None or reference is None else row.median_us / reference
    why = _not_measured(robot, (analytic,)) or (f"; their median {reference:.3g} µs" if medians else
                                                "; not measured: no spherical-wrist robot with "
                                                f"{analytic} in this run")
    strict = None if row is None else row.strict_pct
    name = robot.robot_name
    return (
        Goal(f"{name}: {analytic} / the spherical-wrist robots' (the median of theirs), median time [x]", value,
             f"<= {UR_SPHERICAL_GOAL_RATIO:g}{why}",
             value is not None and value <= UR_SPHERICAL_GOAL_RATIO),
        _ratio_goal(robot, analytic, RTB_100, "median_us", UR_RTB_GOAL_RATIO),
        Goal(f"{name}: {analytic} strict success [%]", strict, f">= {UR_STRICT_GOAL_PCT:g}"
             f"{_not_measured(robot, (analytic,))}", strict is not None and strict >= UR_STRICT_GOAL_PCT),
        Goal(f"{name}: the original configuration among the closed form's branches [%]", robot.original_found_pct,
             f">= {UR_STRICT_GOAL_PCT:g}{_not_measured(robot, (analytic,))}",
             robot.original_found_pct is not None and robot.original_found_pct >= UR_STRICT_GOAL_PCT),
    )


def _same_answer(first, second) -> bool:
    """Whether two answers (arrays, or IkResults: q, errors and every solution) are the same bit for bit."""
    if isinstance(first, np.ndarray):
        return np.array_equal(first, second)
    return (np.array_equal(first.q, second.q) and (first.position_error, first.rotation_error) ==
            (second.position_error, second.rotation_error) and len(first.solutions) == len(second.solutions) and
            all(np.array_equal(a.q, b.q) for a, b in zip(first.solutions, second.solutions)))


def layout_rows(robot: Robot, Q: np.ndarray) -> tuple[LayoutRow, ...]:
    """Single calls on the layouts a caller brings, beside the same calls C-ordered: ``robot.ik`` on the FK poses
    of Q (N, dof) Fortran-ordered, ``robot.fk`` and ``robot.jacobian`` on the rows of Q strided (rows of a
    Fortran-ordered copy). Each call is timed alone, the two layouts in turns (which goes first alternates), after
    WARMUP_TARGETS calls of each."""
    poses = robot.fk_batch(Q)
    Q_strided = np.asfortranarray(Q)
    calls = (("robot.ik(X)", "Fortran-ordered pose", robot.ik,
              [np.ascontiguousarray(X) for X in poses], [np.asfortranarray(X) for X in poses]),
             ("robot.fk(q)", "strided joint vector", robot.fk, list(np.ascontiguousarray(Q)), list(Q_strided)),
             ("robot.jacobian(q)", "strided joint vector", robot.jacobian, list(np.ascontiguousarray(Q)),
              list(Q_strided)))
    clock = time.perf_counter_ns
    rows = []
    for name, layout, call, c_order, other in calls:
        for argument in c_order[:WARMUP_TARGETS] + other[:WARMUP_TARGETS]:
            call(argument)
        times, identical = np.zeros((2, len(Q))), True
        for n in range(len(Q)):
            answers = [None, None]
            for k in ((0, 1) if n % 2 == 0 else (1, 0)):
                argument = (c_order, other)[k][n]
                start = clock()
                answers[k] = call(argument)
                times[k, n] = clock() - start
            identical &= _same_answer(*answers)
        c_us, other_us = (float(np.median(row)) / 1e3 for row in times)
        rows.append(LayoutRow(robot.name, name, layout, len(Q), c_us, other_us, other_us / c_us, bool(identical)))
    return tuple(rows)


def layout_goals(rows: tuple[LayoutRow, ...]) -> tuple[Goal, ...]:
    """Each layout row's time ratio <= LAYOUT_GOAL_RATIO, its answers identical to the C-ordered call's."""
    return tuple(Goal(f"{row.robot_name}: {row.call} on a {row.layout} / C-ordered, median time [x]", row.ratio,
                      f"<= {LAYOUT_GOAL_RATIO:g}, the same answers" + ("" if row.identical else ": they differ"),
                      row.identical and row.ratio <= LAYOUT_GOAL_RATIO) for row in rows)


def evaluate_goals(robots: tuple[IkRobotReport, ...]) -> tuple[Goal, ...]:
    """The closed form's goals on ``GOAL_ROBOT``, the UR family's on each of its robots, then damped least
    squares' on every robot of the run."""
    goal_robot = next((robot for robot in robots if robot.robot_name == GOAL_ROBOT), None)
    spherical = [robot for robot in robots if robot.family == SPHERICAL_WRIST]
    return (*_closed_form_goals(goal_robot),
            *(goal for robot in robots if robot.family == THREE_PARALLEL for goal in _ur_goals(robot, spherical)),
            *(goal for robot in robots for goal in _dls_goals(robot)))


def run_ik_benchmark(robots=ROBOTS, targets: int = 1000, seed: int = 0, methods=METHODS) -> IkBenchReport:
    """Our IK methods beside Robotics Toolbox ``ik_LM``, raw Drake IK and the OPW and EAIK closed forms
    on each robot, same targets, and the goals.

    ``robots``: preset names or robot files; ``targets``: per robot; ``seed``: of the targets and
    seeds (each robot draws from its own generator seeded with it); ``methods``: ours, through
    ``pipeline.model.ik.solve_ik`` (one that raises NotImplementedError or ImportError is reported unavailable).
    """
    if targets < 1:
        raise ConfigurationError(f"targets must be >= 1, got {targets}")
    if isinstance(robots, str):
        robots = (robots,)
    methods = tuple(methods)
    unknown = [m for m in methods if m not in IK_METHODS]
    if unknown:
        raise ConfigurationError(f"unknown IK method(s) {', '.join(unknown)}; choose from {', '.join(IK_METHODS)}")
    reports = tuple(benchmark_robot(load_robot(name), targets, seed, methods) for name in robots)
    layouts = ()
    if "analytic" in methods and any(report.robot_name == GOAL_ROBOT for report in reports):
        robot = load_robot(GOAL_ROBOT)
        layouts = layout_rows(robot, robot.random_configurations(np.random.default_rng(seed), targets))
    versions = version_table("numpy", "numba", "drake", "roboticstoolbox-python", "py-opw-kinematics", "eaik")
    return IkBenchReport(targets=targets, seed=seed, methods=methods, robots=reports,
                         goals=evaluate_goals(reports) + layout_goals(layouts), versions=versions, layouts=layouts)
