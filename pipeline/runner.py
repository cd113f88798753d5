"""``run_job(job, out_dir)``: the one path from a job to certified output files.

Steps: the output folder is checked first (``staged_output``: nothing is computed for a folder that
cannot be written), then IK for pose waypoints (each seeded with the previous solution), the joint
path, timing and its certification (by ``retime``: a profile that fails is an error, never an
output), then every requested output (profile CSV/NPZ, JSON report, profile plot, the 3-D views: a
standalone Meshcat HTML animation and a PNG drawing of the arm, and the profile as a ROS 2
JointTrajectory message in YAML or JSON for a controller) written into a staging folder that replaces
the output folder whole. Used by the CLI (``python -m pipeline run``), the tests and the
notebooks.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .controller_formats import write_json_trajectory, write_ros2_yaml
from .cell_motion import ClearanceError, collision_free_ik, time_joint_moves
from .choices import DEFAULT_MAX_DURATION_S
from .errors import CollisionError, ConfigurationError, PlanningError, ProfileSizeError, TimingError
from .ik import with_drake_model
from .ik.branches import branch_change_reason, choose_solution, configuration_labels
from .io import staged_output, write_json, write_profile_csv, write_profile_npz
from .jobs import Job, JointWaypoint, PoseWaypoint, load_job
from .profile import QUANTITIES, LimitReport, Profile, certify, limits_summary
from .timing import DEFAULT_MAX_SAMPLES, retime
from .versions import installed_version

log = logging.getLogger(__name__)

#: Output kind -> file name inside the output directory.
FILE_NAMES = {"csv": "profile.csv", "npz": "profile.npz", "json": "report.json", "png": "profile.png",
              "html": "view.html", "arm_png": "arm.png", "ros2_yaml": "trajectory.ros2.yaml",
              "json_trajectory": "trajectory.json", "tcp_png": "tcp.png"}
VERSIONED_PACKAGES = ("dh-pipeline", "drake", "toppra", "ruckig", "copp-py", "numpy", "scipy")


@dataclass(frozen=True, eq=False)
class WaypointIk:
    """How one waypoint became joint values: ``q`` [rad or m]; for a pose, the IK method that solved
    it, its errors [m, rad], the number of in-limit solutions it chose from, the target kind and the
    components matched, the configuration asked for, the branch kept and whether that is a change from
    the previous pose waypoint's (None for joint waypoints)."""

    q: np.ndarray
    method: str | None = None
    position_error: float | None = None
    rotation_error: float | None = None
    solutions: int | None = None
    target: str | None = None
    matched: tuple[str, ...] | None = None
    config: dict | None = None
    branch: str | None = None
    branch_changed: bool | None = None

    def to_dict(self) -> dict:
        return {"q": self.q.tolist(), "given_as": "joints" if self.method is None else "pose",
                "ik_method": self.method, "position_error_m": self.position_error,
                "rotation_error_rad": self.rotation_error, "solutions": self.solutions, "target": self.target,
                "matched": None if self.matched is None else list(self.matched), "config": self.config,
                "branch": self.branch or None, "branch_changed": self.branch_changed}


@dataclass(frozen=True, eq=False)
class JobOutcome:
    """What a job produced: the certified ``profile``, the ``files`` written and the ``report`` (the
    JSON report's content)."""

    job: Job
    profile: Profile
    files: tuple[Path, ...]
    report: dict

    @property
    def limit_report(self) -> LimitReport:
        """The profile's certificate (peak/limit ratios), from ``retime``."""
        return self.profile.certificate

    def summary(self) -> str:
        """A few lines: robot, method, duration, peak/limit ratios, files."""
        scale = self.job.speed_scale
        lines = [f"job {self.job.name}: robot {self.job.robot.name}, {len(self.job.waypoints)} waypoints, "
                 f"timing {self.profile.method}, speed scale {scale:g}",
                 f"duration {self.profile.duration:.4f} s, {len(self.profile.t)} samples every {self.job.dt:g} s",
                 f"peak/limit, limits x speed scale {scale:g}: {_ratios(self.limit_report)} "
                 f"({'PASS' if self.limit_report.passed else 'FAIL'})"]
        if scale != 1.0:
            own = certify(self.profile, self.job.robot.limits)
            lines.append(f"peak/limit, the robot's own limits: {_ratios(own)}")
        if self.limit_report.clearance is not None:
            lines.append(f"cell {self.job.cell.name}: {self.limit_report.clearance}")
        lines += [f"planned {plan['planner']}: {plan['plan_time_s'] * 1e3:.1f} ms search, "
                  f"{plan['simplify_time_s'] * 1e3:.1f} ms shortcutting, path {plan['path_length_before_rad']:.2f} -> "
                  f"{plan['path_length_after_rad']:.2f} rad" for plan in (self.report.get("cell") or {}).get(
                      "planned_moves", []) if plan["planner"] != "direct"]
        lines += [f"wrote {path}" for path in self.files]
        return "\n".join(lines)


def _ratios(report: LimitReport) -> str:
    return ", ".join(f"{name} {report.max_ratio(name):.4f}" for name in QUANTITIES if name in report.ratios)


def solve_waypoints(job: Job, scene=None) -> list[WaypointIk]:
    """Joint values for every waypoint, in order. A pose is solved by ``robot.ik`` seeded with the
    previous waypoint's joint values (the first: ``job.start`` or the middle of the limits, 0 for a
    continuous joint), and of its in-limit solutions one is kept by the rule of ``pipeline.ik.branches``
    (of the configuration the waypoint names, the one nearest the previous joint values; a joint
    waypoint's own configuration counts as the previous branch). A JobFileError names the waypoint when
    a pose is unreachable, has no solution of the configuration asked for, or changes branch from the
    previous pose waypoint (naming both branches and the joint that forces it) unless the job allows
    branch changes. With ``scene`` (a CollisionModel) a joint waypoint that collides is an error naming
    the pair, and IK answers that collide are skipped (``cell_motion``)."""
    robot = job.robot
    previous = job.start if job.start is not None else robot.limits.q_middle
    previous_branch = ""
    options = with_drake_model(robot, job.ik, {}) if job.has_poses else {}
    solved = []
    for k, waypoint in enumerate(job.waypoints):
        field = ("waypoints", k)
        if isinstance(waypoint, JointWaypoint):
            if scene is not None and not scene.is_free(waypoint.q):
                raise job.error(field, f"is not collision-free: {scene.why_not_free(waypoint.q)}")
            solved.append(WaypointIk(waypoint.q))
            previous, previous_branch = waypoint.q, configuration_labels(robot, waypoint.q[None])[0]
            continue
        if scene is None:
            result = robot.ik(waypoint.X_BE, q_seed=previous, method=job.ik, target_kind=waypoint.target, **options)
        else:
            result, collides = collision_free_ik(robot, scene, waypoint.X_BE, previous, job.ik, waypoint.target,
                                                 options, np.random.default_rng(k))
            if result is None:
                raise job.error(field, collides)
        if not result.success:
            raise job.error(field, f"pose is unreachable with IK method {job.ik!r} ({result.method}, "
                               f"target {waypoint.target}): {result.reason}")
        choice = choose_solution(robot, result, previous, previous_branch, waypoint.config)
        if choice.q is None:
            raise job.error((*field, "config"), choice.reason)
        if choice.changed and not job.allow_branch_change:
            raise job.error(field, f"the IK branch changes from '{choice.previous}' to '{choice.branch}': "
                               f"{branch_change_reason(robot, choice, waypoint.X_BE, previous)}. Name the configuration "
                               "(config:), add waypoints, or allow the change (allow_branch_change: true)")
        if choice.changed:
            log.warning("%s: branch changes from %s to %s (allowed)", job.location(field), choice.previous,
                        choice.branch)
        solved.append(WaypointIk(choice.q, result.method, result.position_error, result.rotation_error,
                                 choice.solutions, waypoint.target, result.matched, waypoint.config, choice.branch,
                                 choice.changed))
        previous, previous_branch = choice.q, choice.branch
    return solved


def duration_lower_bound(job: Job, solved_q: list[np.ndarray]) -> tuple[float, float, float]:
    """(bound, tcp, joints) [s]: a lower bound of the job's duration from its moves before timing, and
    the parts of it the TCP's and the joints' speed limits set. Per move, the TCP travels at least the
    straight distance between its waypoints (through the via point of a circular move, less the zones at
    either end) at most ``tcp_speed_max``; a joint move turns each joint at least the difference of its
    solved values at most ``qd_max``; both x ``speed_scale``."""
    positions = job.robot.fk_batch(np.array(solved_q))[:, :3, 3]
    zones = [w.zone if isinstance(w, PoseWaypoint) else 0.0 for w in job.waypoints]
    tcp_speed = None if job.tcp_speed_max is None else job.tcp_speed_max * job.speed_scale
    qd_max = job.robot.limits.qd_max * job.speed_scale
    bound = tcp_total = joint_total = 0.0
    for k in range(1, len(solved_q)):
        waypoint = job.waypoints[k]
        tool_move = isinstance(waypoint, PoseWaypoint) and waypoint.is_tool_move
        via = [waypoint.via] if tool_move and waypoint.via is not None else []
        stops = np.array([positions[k - 1], *via, positions[k]])
        distance = max(float(np.linalg.norm(np.diff(stops, axis=0), axis=1).sum()) - zones[k - 1] - zones[k], 0.0)
        tcp = 0.0 if tcp_speed is None else distance / tcp_speed
        joints = 0.0 if tool_move else float(np.max(np.abs(solved_q[k] - solved_q[k - 1]) / qd_max))
        bound, tcp_total, joint_total = bound + max(tcp, joints), tcp_total + tcp, joint_total + joints
    return bound, tcp_total, joint_total


def check_duration(job: Job, solved_q: list[np.ndarray], max_samples: int, max_duration_s: float) -> None:
    """Refuse, before timing, a job whose duration is bounded from below (``duration_lower_bound``) by
    more samples of ``dt`` than ``max_samples`` (ProfileSizeError, as timing would, but at once) or by
    more than ``max_duration_s`` [s] (a JobFileError); both name the field that sets the bound
    (tcp_speed_max, or speed_scale for the joints' speeds)."""
    from .timing.toppra_backend import check_sample_count

    bound, tcp, joints = duration_lower_bound(job, solved_q)
    if job.tcp_speed_max is not None and tcp >= joints:
        field, speed = "tcp_speed_max", job.tcp_speed_max * job.speed_scale
        why = (f"its TCP travels at least {tcp * speed * 1e3:.4g} mm at {speed * 1e3:.4g} mm/s (tcp_speed_max x "
               "speed_scale). Is tcp_speed_max in the job's length_unit per second?")
    else:
        field, why = "speed_scale", f"its joint moves take {joints:.4g} s at the robot's qd_max x speed_scale"
    try:
        check_sample_count(bound, job.dt, max_samples)
    except ProfileSizeError as exc:
        raise ProfileSizeError(f"{job.source}: {exc} (at least, found before timing: {job.location((field,))}: "
                               f"{why})") from None
    if bound > max_duration_s:
        raise job.error((field,), f"the job would last at least {bound:.4g} s, longer than {max_duration_s:g} s "
                        f"(run --max-duration raises the limit): {why}")


def package_versions() -> dict[str, str | None]:
    """Installed versions of this package and its numerical dependencies (None when absent)."""
    return {name: installed_version(name) for name in VERSIONED_PACKAGES}


def build_report(job: Job, waypoints: list[WaypointIk], profile: Profile, plans: list | None = None) -> dict:
    """The JSON report: inputs and their hash, methods (``path`` null for ruckig, which times waypoint
    to waypoint), duration, the limits (values and peak/limit ratios, against the limits the profile was
    timed against and against the robot's own, with the speed scale), timing details; in a cell, the
    cell, the clearance certificate and the planned moves (planner, times, path lengths)."""
    certificate = profile.certificate
    cell = None if job.cell is None else {
        "name": job.cell.name, "file": job.cell.source, "plan": job.plan,
        "clearance": None if certificate is None or certificate.clearance is None else certificate.clearance.to_dict(),
        "planned_moves": [plan.to_dict() for plan in plans or []]}
    return {
        "job": job.name,
        "job_file": job.source,
        "description": job.description,
        "robot": {"name": job.robot.name, "file": job.robot.spec.source, "joints": list(job.robot.joint_names)},
        "inputs_sha256": job.inputs_sha256,
        "method": {"ik": job.ik, "timing": job.timing, "path": job.path},
        "speed_scale": job.speed_scale,
        "dt_s": job.dt,
        "duration_s": profile.duration,
        "samples": int(len(profile.t)),
        "waypoints": [w.to_dict() for w in waypoints],
        "limits": limits_summary(profile),
        "timing_details": profile.details.to_dict(),
        "cell": cell,
        "versions": package_versions(),
    }


def _title(job: Job, profile: Profile) -> str:
    return f"{job.robot.name}: {job.name}, {profile.method}, speed scale {job.speed_scale:g}, {profile.duration:.3f} s"


def run_job(job: Job, out_dir: str | Path, max_samples: int = DEFAULT_MAX_SAMPLES,
            max_duration_s: float = DEFAULT_MAX_DURATION_S) -> JobOutcome:
    """Run a validated job and write its outputs into ``out_dir``, which is replaced whole on success
    and left as it was on any failure (``staged_output``; checked before any work). A profile of more
    than ``max_samples`` samples is refused (ProfileSizeError) before it is made, and a job whose moves
    take more than ``max_duration_s`` [s] or ``max_samples`` samples at their speed limits before any
    timing (``check_duration``)."""
    with staged_output(out_dir) as staging:
        scene = collision_model(job)
        waypoints = solve_waypoints(job, scene)
        check_duration(job, [w.q for w in waypoints], max_samples, max_duration_s)
        profile, plans = _timed(job, waypoints, max_samples, scene)
        report = build_report(job, waypoints, profile, plans)
        writers = _writers(job, profile, report)
        for kind in job.outputs:
            writers[kind](staging / FILE_NAMES[kind])
    files = tuple(Path(out_dir) / FILE_NAMES[kind] for kind in job.outputs)
    log.info("job %s: %s, %.4f s; wrote %d file(s) to %s", job.name, profile.method, profile.duration,
             len(files), out_dir)
    return JobOutcome(job, profile, files, report)


def collision_model(job: Job):
    """The job's CollisionModel (its cell's robot, as the robot file gives it, and the cell), or None
    for a job without a cell."""
    if job.cell is None:
        return None
    from .collision import CollisionModel   # Drake's checker only for jobs in a cell

    return CollisionModel(job.cell.load_robot(), job.cell)


def _timed(job: Job, waypoints: list[WaypointIk], max_samples: int, scene=None) -> tuple[Profile, list]:
    """The certified profile through the solved waypoints (in pieces when the job has tool moves or TCP
    limits, ``pipeline.motion``; in a cell, planned and certified clear, ``pipeline.cell_motion``) and the
    planned paths; timing and collision errors name the job file, tool-move errors the waypoint and its line,
    clearance failures the line of the waypoint the move goes to (``move_at``) and the job's time."""
    try:
        if job.has_tool_moves or job.tcp_speed_max is not None or job.tcp_accel_max is not None:
            from .motion import time_tool_job
            from .tool_moves import ToolMoveError

            try:
                return time_tool_job(job, [w.q for w in waypoints], max_samples, scene)
            except ToolMoveError as exc:
                raise job.error(("waypoints", exc.move), str(exc)) from exc
        Q = np.array([w.q for w in waypoints])

        def timed(vertices: np.ndarray) -> Profile:
            return retime(job.robot, vertices, method=job.timing, speed_scale=job.speed_scale, dt=job.dt,
                          shape=job.path, max_samples=max_samples)

        if scene is None:
            return timed(Q), []
        profile, plans, _, _ = time_joint_moves(scene, Q, timed, job.plan, job.planner, job.plan_time_budget)
        return profile, plans
    except ClearanceError as exc:
        k = move_at(exc.profile, [w.q for w in waypoints], exc.first, exc.last, exc.report.failed_at_s)
        raise CollisionError(f"{job.location(('waypoints', k))}: on the move to this waypoint (t in job time), "
                             f"{exc}") from exc
    except (TimingError, ConfigurationError, CollisionError, PlanningError) as exc:
        raise type(exc)(f"{job.source}: {exc}") from exc


def move_at(profile: Profile, solved_q: list[np.ndarray], first: int, last: int | None, t: float | None) -> int:
    """The waypoint the motion is moving to at time ``t`` [s] (None: the last) of ``profile``, which
    runs through the solved waypoints ``first`` .. ``last`` (None: the last) in order: each is reached at
    the sample nearest its joint values after the previous one's."""
    last = len(solved_q) - 1 if last is None else last
    start = 0
    for k in range(first + 1, last + 1):
        start += int(np.argmin(np.linalg.norm(profile.q[start:] - solved_q[k], axis=1)))
        if t is not None and profile.t[start] >= t:
            return k
    return last


def _writers(job: Job, profile: Profile, report: dict) -> dict:
    """Output kind -> function writing that output at the path it is given."""
    revolute = [j.is_revolute for j in job.robot.spec.joints]
    return {
        "csv": lambda path: write_profile_csv(path, profile, revolute),
        "npz": lambda path: write_profile_npz(path, profile),
        "json": lambda path: write_json(path, report),
        "png": lambda path: _plot(path, job, profile, revolute),
        "html": lambda path: _view_html(path, job, profile),
        "arm_png": lambda path: _plot_arm(path, job, profile),
        "tcp_png": lambda path: _plot_tcp(path, job, profile),
        "ros2_yaml": lambda path: write_ros2_yaml(path, profile),
        "json_trajectory": lambda path: write_json_trajectory(path, profile),
    }


def _plot(path: Path, job: Job, profile: Profile, revolute: list[bool]) -> None:
    from .plots import plot_profile   # matplotlib only when a plot is asked for

    plot_profile(path, profile, revolute, _title(job, profile))


def _plot_tcp(path: Path, job: Job, profile: Profile) -> None:
    from .plots import plot_tcp

    plot_tcp(path, profile, _title(job, profile))


def _view_html(path: Path, job: Job, profile: Profile) -> None:
    from .views import profile_html   # Drake's Meshcat only when a view is asked for

    Path(path).write_text(profile_html(job.robot, profile, cell=job.cell, tool=job.tool), encoding="utf-8")


def _plot_arm(path: Path, job: Job, profile: Profile) -> None:
    from .views import plot_arm_motion

    plot_arm_motion(path, job.robot, profile, _title(job, profile), job.cell)


def run_job_file(path: str | Path, out_dir: str | Path, max_samples: int = DEFAULT_MAX_SAMPLES,
                 max_duration_s: float = DEFAULT_MAX_DURATION_S) -> JobOutcome:
    """Load a job file and run it: ``run_job(load_job(path), out_dir, max_samples, max_duration_s)``."""
    return run_job(load_job(path), out_dir, max_samples, max_duration_s)
