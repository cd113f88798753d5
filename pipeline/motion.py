"""A job's motion when it has tool moves: pieces timed from rest to rest, joined into one profile.

The waypoints split into pieces: a run of joint moves is one joint path through its waypoints (as a
job without tool moves is); a run of tool moves (linear, circular) is one tool path up to each stop
(a waypoint without a zone). Each piece starts where the previous one ended (the joint values the
tool path's IK reached), is timed by the job's method with the joint limits and the TCP's limits
(which hold for joint moves too: the TCP never goes faster than ``tcp_speed_max`` anywhere in the
job), and the pieces are joined at rest; the joined profile is certified as a whole.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .cell_motion import ClearanceError, check_samples, time_joint_moves
from .jobs import Job, PoseWaypoint
from .profile import Profile, TcpSamples, TimingDetails, certify
from .tcp import TcpMotion
from .timing import retime
from .tool_moves import ToolMoveError, joint_path_along
from .tool_path import ToolMove, ToolPath


@dataclass(frozen=True)
class Piece:
    """Waypoints ``first`` .. ``last`` (indices; the piece starts at ``first``): joint or tool moves."""

    kind: str
    first: int
    last: int


@dataclass(frozen=True)
class MotionDetails(TimingDetails):
    """What timing a job of several pieces did: per piece, its ``kind``, waypoints ``first``..``last``,
    ``duration_s``, its back end's ``timing`` details, and for tool pieces the track ``length_m``, the IK
    ``samples``, the largest deviation from the ideal track between them (``max_position_error_m``,
    ``max_rotation_error_rad``) and the lowest TCP speed the joint speed limits allow on it
    (``slowest_allowed_tcp_speed_m_s``: below the TCP limit, the move slows down there)."""

    pieces: tuple[dict, ...]


def pieces_of(job: Job) -> list[Piece]:
    """The job's waypoints in pieces (see the module docstring)."""
    kinds = ["tool" if isinstance(w, PoseWaypoint) and w.is_tool_move else "joint" for w in job.waypoints]
    pieces, first = [], 0
    for k in range(1, len(kinds)):
        stop = kinds[k] == "tool" and job.waypoints[k].zone <= 0.0
        if k + 1 == len(kinds) or kinds[k + 1] != kinds[k] or stop:
            pieces.append(Piece(kinds[k], first, k))
            first = k
    return pieces


def time_tool_job(job: Job, solved_q: list[np.ndarray], max_samples: int, scene=None) -> tuple[Profile, list]:
    """The certified profile of a job with tool moves, from the waypoints' solved joint values, and the
    planned paths of its joint pieces. With ``scene`` (a CollisionModel) joint pieces are timed by
    ``cell_motion.time_clear`` (planned first with ``plan: collision_free``), tool pieces' IK samples are
    checked (ToolMoveError naming the move, the sample and the pair) and the joined profile carries its
    clearance certificate; a ClearanceError gives the job's time and the waypoints of the piece it is in."""
    robot = job.robot
    limits = dataclasses.replace(robot.limits, tcp_speed_max=job.tcp_speed_max, tcp_accel_max=job.tcp_accel_max)
    tcp = TcpMotion(robot)
    timing = {"method": job.timing, "speed_scale": job.speed_scale, "dt": job.dt, "max_samples": max_samples,
              "limits": limits, "tcp": tcp}
    q_start, profiles, reports, plans = solved_q[0], [], [], []
    for piece in pieces_of(job):
        if piece.kind == "joint":
            waypoints = np.array([q_start, *solved_q[piece.first + 1: piece.last + 1]])
            try:
                profile, report = _time_joint_piece(job, scene, waypoints, timing, plans,
                                                    sum(p.duration for p in profiles))
            except ClearanceError as exc:
                exc.first, exc.last = piece.first, piece.last
                raise
        else:
            moves = [ToolMove(w.move, w.X_BE, w.via, w.zone if k < piece.last else 0.0)
                     for k, w in enumerate(job.waypoints[piece.first + 1: piece.last + 1], start=piece.first + 1)]
            tool_path = ToolPath(robot.fk(q_start), moves, first_index=piece.first + 1)
            along = joint_path_along(robot, tool_path, q_start, job.tcp_speed_max * job.speed_scale,
                                     job.singularity, job.ik)
            if scene is not None:
                _check_tool_samples(robot, scene, along)
            profile = retime(robot, along.path, **timing)
            report = {"length_m": tool_path.length, "samples": len(along.sigma),
                      "max_position_error_m": along.max_position_error,
                      "max_rotation_error_rad": along.max_rotation_error,
                      "slowest_allowed_tcp_speed_m_s": along.slowest_tcp_speed}
        profiles.append(profile)
        reports.append({"kind": piece.kind, "first": piece.first, "last": piece.last, "duration_s": profile.duration,
                        **report, "timing": profile.details.to_dict() if profile.details else None})
        q_start = profile.q[-1]
    joined = join_profiles(profiles, MotionDetails(tuple(reports)))
    certificate = certify(joined, scene=scene)
    if certificate.clearance is not None and not certificate.clearance.passed:
        raise ClearanceError(certificate.clearance, joined)
    return dataclasses.replace(joined, certificate=certificate), plans


def _time_joint_piece(job: Job, scene, waypoints: np.ndarray, timing: dict, plans: list,
                      t_start: float) -> tuple[Profile, dict]:
    """A joint piece timed through its waypoints (planned and certified clear in a cell, its clearance
    in job time from ``t_start`` [s]); its report."""
    def timed(vertices: np.ndarray) -> Profile:
        return retime(job.robot, vertices, shape=job.path, **timing)

    if scene is None:
        return timed(waypoints), {}
    profile, piece_plans, vertices, added = time_joint_moves(scene, waypoints, timed, job.plan, job.planner,
                                                              job.plan_time_budget, t_start)
    plans += piece_plans
    return profile, {"vertices": vertices, "vertices_added_for_clearance": added}


def _check_tool_samples(robot, scene, along) -> None:
    """Tool moves are checked, not re-planned: the first IK sample that is not free is an error."""
    k = check_samples(scene, along.samples)
    if k is not None:
        move = int(along.tool_path.move_of(along.sigma[k])[0])
        raise ToolMoveError(move, k, robot.fk(along.samples[k]),
                            f"not collision-free: {scene.why_not_free(along.samples[k])}")


def join_profiles(profiles: list[Profile], details: TimingDetails) -> Profile:
    """Profiles that each end at rest where the next begins, one after the other (the joint sample of
    two pieces once)."""
    first = profiles[0]
    offsets = np.cumsum([0.0] + [p.duration for p in profiles[:-1]])
    keep = [slice(None)] + [slice(1, None)] * (len(profiles) - 1)

    def joined(arrays) -> np.ndarray:
        return np.concatenate([array[k] for array, k in zip(arrays, keep)])

    def stacked(name: str):
        return None if getattr(first, name) is None else joined([getattr(p, name) for p in profiles])

    tcp = None if first.tcp is None else TcpSamples(*(joined([getattr(p.tcp, field) for p in profiles])
                                                      for field in ("position", "speed", "accel")))
    t = joined([p.t + offset for p, offset in zip(profiles, offsets)])
    return Profile(t, stacked("q"), stacked("qd"), stacked("qdd"), stacked("qddd"), first.method, first.limits,
                   first.joint_names, details, tau=stacked("tau"), speed_scale=first.speed_scale,
                   unscaled_limits=first.unscaled_limits, tcp=tcp)
