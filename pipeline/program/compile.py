"""``compile_job(job, scene=None) -> Program``: a validated job's waypoints solved, its tool moves tracked
and its joint moves planned, before any timing.

Steps: IK for pose waypoints (``solve_waypoints``: each seeded with the previous solution, one branch
kept by the rule of ``pipeline.model.ik.branches``, or exactly the solution a waypoint's controller
configuration names, ``pipeline.model.vendors.selection``; in a cell, answers that collide are skipped),
then the
joint path along each run of tool moves (the moves the TCP follows without stopping: tool moves joined
by zones; ``pipeline.program.tool_moves``; in a cell its IK samples are checked), then, in a cell with
``plan: collision_free``, each joint move planned around the obstacles (``pipeline.cell.planning``). A
waypoint is a stop when it has no zone, except between two joint moves of a job that does not plan
them: a joint path passes through those (the job's path shape), as it always did.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from ..cell.clear_motion import check_samples, collision_free_ik
from ..cell.planning import plan_joint_path
from ..cell.tilt import TiltLimit
from ..cell.tool import Tool
from ..errors import VendorConfigurationError
from ..files.branch_names import label_parts, matches
from ..model.ik import with_drake_model
from ..model.ik.branches import (BranchChoice, branch_change_reason, choose_solution, configuration_labels,
                                 wrist_singular)
from ..model.ik.result import MATCHED_COMPONENTS, make_target, pose_errors
from ..model.vendors.configuration import format_configuration
from ..model.vendors.selection import select_solution
from .actions import stops_motion
from .job import Job, JointWaypoint
from .model import JOINT, Move, Program, ToolTrack, WaypointSolution
from .tool_moves import ToolMoveError, joint_path_along
from .tool_path import ToolMove, ToolPath, move_length

log = logging.getLogger(__name__)

#: A zone may exceed half a neighbouring move by this much [m] (the rounding of the move's length).
ZONE_SLACK_M = 1e-9


def compile_job(job: Job, scene=None) -> Program:
    """The job as a Program (see the module docstring). ``scene``: the job's CollisionModel (None: no
    cell). Errors: JobFileError naming the waypoint (unreachable, branch change, collision),
    ToolMoveError naming the tool move and sample, PlanningError / CollisionError from the planner."""
    solved = solve_waypoints(job, scene)
    targets = [w.q for w in solved]
    job = with_capped_zones(job, targets)
    tracks = _tool_tracks(job, targets, scene)
    tilt = None if job.plan_tilt_max is None else TiltLimit(job.cell.X_WB[:3, :3], job.plan_tilt_max)
    moves = []
    for k in range(1, len(job.waypoints)):
        waypoint = job.waypoints[k]
        track = next((t for t in tracks if t.first <= k <= t.last), None)
        if track is not None and k == track.last:
            targets[k] = track.along.samples[-1]        # where the IK along the track ends
        planned = None
        if not waypoint.is_tool_move and scene is not None and job.plan == "collision_free":
            planned = plan_joint_path(scene, targets[k - 1], targets[k], job.planner, job.plan_time_budget, seed=k,
                                      tilt=tilt)
        moves.append(Move(k, waypoint.move, targets[k], job.robot.fk(targets[k]), move_speed(job, waypoint),
                          waypoint.zone if k + 1 < len(job.waypoints) else 0.0, getattr(waypoint, "via", None),
                          planned, track))
    limits = dataclasses.replace(job.robot.limits, tcp_speed_max=job.tcp_speed_limit, tcp_accel_max=None)
    return Program(job.name, job.robot, Tool.of_job(job), job.cell, limits, job.tcp_accel_max, job.speed_scale, job.timing,
                   job.path, job.dt, tuple(solved), tuple(moves), _stops(job, moves), job.plan, tilt,
                   payload=job.payload, job_name=job.name, actions=tuple(w.actions for w in job.waypoints),
                   signals=dict(job.signals), parts=dict(job.parts))


def with_capped_zones(job: Job, targets: list[np.ndarray]) -> Job:
    """The job with every zone [m] at most half of either neighbouring move's TCP length (``move_length``; a
    move of no length takes the zones on both its ends to 0), as controllers shrink a zone: the profile is
    timed, and the controller programs written, with the same zones. A warning names each zone shrunk."""
    tcp = job.robot.fk_batch(np.array(targets))[:, :3, 3]
    lengths = [move_length(tcp[k - 1], tcp[k], getattr(job.waypoints[k], "via", None))
               for k in range(1, len(targets))]
    waypoints = list(job.waypoints)
    for k in range(1, len(waypoints) - 1):
        cap = 0.5 * min(lengths[k - 1], lengths[k])
        if waypoints[k].zone > cap + ZONE_SLACK_M:
            log.warning("%s: zone %.6g mm is more than half of a neighbouring move (%.6g mm long): rounded with "
                        "%.6g mm, as a controller shrinks it", job.location(("waypoints", k, "zone")),
                        waypoints[k].zone * 1e3, 2e3 * cap, cap * 1e3)
            waypoints[k] = dataclasses.replace(waypoints[k], zone=cap)
    return dataclasses.replace(job, waypoints=tuple(waypoints))


def move_speed(job: Job, waypoint) -> float:
    """The speed of the move to ``waypoint``: its own, else the job's tcp_speed_max (a tool move, [m/s]) or 1
    (a joint move, a fraction of the joint speed limits)."""
    if waypoint.speed is not None:
        return waypoint.speed
    return job.tcp_speed_max if waypoint.is_tool_move else 1.0


def _stops(job: Job, moves: list[Move]) -> tuple[int, ...]:
    """The waypoints where the motion rests: the first, the last, every one whose actions wait or change the load,
    and every one without a zone except between two joint moves that are not planned (a joint path passes through
    those)."""
    stops = [0]
    for k in range(1, len(moves)):
        before, after = moves[k - 1], moves[k]
        passed = before.kind == JOINT and after.kind == JOINT and job.plan != "collision_free"
        if (before.zone <= 0.0 and not passed) or stops_motion(job.waypoints[k].actions):
            stops.append(k)
    return (*stops, len(moves))


def solve_waypoints(job: Job, scene=None) -> list[WaypointSolution]:
    """Joint values for every waypoint, in order. A pose is solved by ``robot.ik`` seeded with the
    previous waypoint's joint values (the first: ``job.start`` or the middle of the limits, 0 for a
    continuous joint), and of its in-limit solutions one is kept by the rule of ``pipeline.model.ik.branches``
    (of the configuration the waypoint names, the one nearest the previous joint values; a joint
    waypoint's own configuration counts as the previous branch). A JobFileError names the waypoint when
    a pose is unreachable, has no solution of the configuration asked for, or changes branch from the
    previous pose waypoint (naming both branches and the joint that forces it) unless the job allows
    branch changes. With ``scene`` (a CollisionModel) a joint waypoint that collides is an error naming
    the pair, and IK answers that collide are skipped (``clear_motion``). A pose with a controller
    configuration takes exactly the solution it names (``controller_solution``)."""
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
            solved.append(WaypointSolution(waypoint.q))
            previous, previous_branch = waypoint.q, configuration_labels(robot, waypoint.q[None])[0]
            continue
        if waypoint.controller_config is not None:
            solution = controller_solution(job, k, previous_branch, scene)
            solved.append(solution)
            previous, previous_branch = solution.q, solution.branch
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
        if choice.changed and not job.allow_branch_change and not _names_change(waypoint.config, choice):
            raise job.error(field, f"the IK branch changes from '{choice.previous}' to '{choice.branch}': "
                               f"{branch_change_reason(robot, choice, waypoint.X_BE, previous)}. Name the configuration "
                               "(config:), add waypoints, or allow the change (allow_branch_change: true)")
        if choice.changed and not _names_change(waypoint.config, choice):
            log.warning("%s: branch changes from %s to %s (allowed)", job.location(field), choice.previous,
                        choice.branch)
        singular = wrist_singular(robot, choice.q)
        if singular:
            log.info("%s: the wrist is at its singularity (axes 4 and 6 aligned): %s and %s kept nearest the "
                     "previous waypoint's", job.location(field), robot.joint_names[3], robot.joint_names[5])
        solved.append(WaypointSolution(choice.q, result.method, result.position_error, result.rotation_error,
                                       choice.solutions, waypoint.target, result.matched, waypoint.config,
                                       choice.branch, choice.changed, wrist_singular=singular))
        previous, previous_branch = choice.q, choice.branch
    return solved


def _names_change(config: dict[str, str] | None, choice: BranchChoice) -> bool:
    """Whether the configuration a waypoint names asks for the branch change ``choice`` makes: it names every
    part of the branch that changes (a program read back from a controller names each point's)."""
    before, after = label_parts(choice.previous), label_parts(choice.branch)
    return bool(config) and all(config.get(part) == value for part, value in after.items()
                                if before.get(part) != value)


def controller_solution(job: Job, k: int, previous_branch: str, scene=None) -> WaypointSolution:
    """Pose waypoint k solved as its controller configuration names it: the one in-limit closed-form
    solution and 2 pi representative ``pipeline.model.vendors.selection`` selects (whatever the job's IK
    method). A JobFileError names the waypoint's controller_config (its line and value) when no solution
    or several have it, listing the configurations the pose's solutions have; names its config when our
    configuration asked for beside it is not that solution's branch; and names the waypoint when the
    solution collides (with ``scene``) or changes branch from the previous pose waypoint's, the job
    does not allow branch changes and its config does not name the change."""
    robot, waypoint = job.robot, job.waypoints[k]
    vendor, fields = waypoint.controller_config
    field, text = ("waypoints", k, "controller_config", vendor), format_configuration(vendor, fields)
    try:
        q = select_solution(robot, waypoint.X_BE, fields, vendor)
    except VendorConfigurationError as exc:
        raise job.error(field, str(exc), text) from exc
    choice = _named_choice(robot, q, previous_branch)
    if waypoint.config and not matches(choice.branch, waypoint.config):
        named = ", ".join(f"{key} {value}" for key, value in waypoint.config.items())
        raise job.error(("waypoints", k, "config"), f"asks for {named}, but the solution of {vendor} configuration "
                        f"{text} is on the branch '{choice.branch}'", waypoint.config)
    if scene is not None and not scene.is_free(q):
        raise job.error(field, f"names a solution that is not collision-free: {scene.why_not_free(q)}", text)
    if choice.changed and not job.allow_branch_change and not _names_change(waypoint.config, choice):
        raise job.error(("waypoints", k), f"the IK branch changes from '{choice.previous}' to '{choice.branch}', "
                        f"the branch of {vendor} configuration {text}: name a configuration on '{choice.previous}', "
                        "add waypoints, or allow the change (allow_branch_change: true)")
    if choice.changed and not _names_change(waypoint.config, choice):
        log.warning("%s: branch changes from %s to %s (allowed)", job.location(("waypoints", k)), choice.previous,
                    choice.branch)
    position_error, rotation_error = pose_errors(robot.fk(q), make_target(waypoint.X_BE))
    return WaypointSolution(q, "analytic", position_error, rotation_error, 1, waypoint.target,
                            MATCHED_COMPONENTS[waypoint.target], waypoint.config, choice.branch, choice.changed,
                            (vendor, text))


def _named_choice(robot, q, previous_branch: str) -> BranchChoice:
    """The BranchChoice of the one solution q a controller configuration named."""
    branch = configuration_labels(robot, q[None])[0]
    return BranchChoice(q, branch, previous_branch, bool(previous_branch) and branch != previous_branch, 1)


def _tool_runs(job: Job) -> list[tuple[int, int]]:
    """(first, last) waypoint indices of each run of tool moves the TCP follows without stopping (tool
    moves joined by zones)."""
    runs, first = [], None
    for k, waypoint in enumerate(job.waypoints):
        if not waypoint.is_tool_move:
            continue
        first = k if first is None else first
        next_is_tool = k + 1 < len(job.waypoints) and job.waypoints[k + 1].is_tool_move
        if not (next_is_tool and waypoint.zone > 0.0):
            runs.append((first, k))
            first = None
    return runs


#: A tool move shorter than this [m] and turning less than this [rad] goes nowhere.
STILL_MOVE = 1e-9


def _check_tool_moves_go_somewhere(job: Job, X_start: np.ndarray, first: int, last: int) -> None:
    """A JobFileError naming the first tool move of the run ``first`` .. ``last`` (TCP pose ``X_start`` before it) whose
    TCP neither moves nor turns: it has no path to follow (a controller program may teach one: make it a joint move
    or leave it out)."""
    X_before = X_start
    for k in range(first, last + 1):
        X = job.waypoints[k].X_BE
        turn = np.arccos(np.clip((np.trace(X_before[:3, :3].T @ X[:3, :3]) - 1.0) / 2.0, -1.0, 1.0))
        if np.linalg.norm(X[:3, 3] - X_before[:3, 3]) < STILL_MOVE and turn < STILL_MOVE:
            raise job.error(("waypoints", k, "move"), f"a {job.waypoints[k].move} move to where the TCP already is "
                            "(the previous waypoint's pose): it has no path to follow; remove the waypoint or make it "
                            "a joint move", job.waypoints[k].move)
        X_before = X


def _tool_tracks(job: Job, targets: list[np.ndarray], scene) -> list[ToolTrack]:
    """The joint path along each run of tool moves, from the joint values where the run starts (those
    of the waypoint before it, or where the previous run's IK ended); in a cell its IK samples are
    checked (ToolMoveError naming the move, the sample and the pair)."""
    robot, tracks = job.robot, []
    for first, last in _tool_runs(job):
        q_start = targets[first - 1]
        if tracks and tracks[-1].last == first - 1:
            q_start = tracks[-1].along.samples[-1]
        waypoints = job.waypoints[first: last + 1]
        _check_tool_moves_go_somewhere(job, robot.fk(q_start), first, last)
        moves = [ToolMove(w.move, w.X_BE, w.via, w.zone if k < last else 0.0)
                 for k, w in enumerate(waypoints, start=first)]
        tool_path = ToolPath(robot.fk(q_start), moves, first_index=first)
        slowest = min(move_speed(job, w) for w in waypoints) * job.speed_scale
        along = joint_path_along(robot, tool_path, q_start, slowest, job.singularity, job.ik)
        if scene is not None:
            k = check_samples(scene, along.samples)
            if k is not None:
                move = int(tool_path.move_of(along.sigma[k])[0])
                raise ToolMoveError(move, k, robot.fk(along.samples[k]),
                                    f"not collision-free: {scene.why_not_free(along.samples[k])}")
        tracks.append(ToolTrack(first, last, along))
    return tracks
