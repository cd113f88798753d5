"""``time_program(program, scene=None) -> Profile``: every stretch timed as one path, joined at its stops,
certified once.

Each stretch (``StretchPath``) is timed by the program's method (``pipeline.timing.time_path``) with
the robot's limits, the job's safety TCP limit everywhere and the moves' own speeds on their parts
(``LimitSchedule``), and starts and ends at rest; the stretches are joined one after the other and the
whole profile is certified once (``pipeline.timing.profile.certify``: joint limits, the schedule, and in a
cell the clearance). When the clearance fails inside a blend, that blend is narrowed and its stretch
timed again (at most MAX_REFINEMENTS times); a failure elsewhere is a ClearanceError with the job time.
``ruckig`` (waypoint to waypoint, off the path) times each stretch through its targets and planned
vertices. When the robot's limits bound joint torques, each stretch's torques (Drake's inverse dynamics) are those
with what the flange carries on it (the tool's load and the parts held: ``Program.load_after``), and a rest holds
the torque with the load after its waypoint's actions (a grip or a release happens at rest).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..cell.clear_motion import ClearanceError
from ..cell.tilt import certify_tilt
from ..errors import TimingError
from ..files.choices import DEFAULT_MAX_SAMPLES
from ..timing import time_path
from ..timing.profile import Profile, TcpSamples, TimingDetails, certify
from ..timing.schedule import LimitSchedule, joined_schedules
from ..timing.tcp import TcpMotion
from .model import Program
from .stretch import StretchPath

#: How long a stop between two stretches lasts in the joined schedule [s] (far below any sample time).
STOP_INSTANT_S = 1e-9
#: Blends narrowed (one per round) to bring the profile within the clearance before giving up.
MAX_REFINEMENTS = 8


@dataclass(frozen=True)
class ProgramDetails(TimingDetails):
    """What timing a program did: per stretch its waypoints ``first``..``last``, ``duration_s``, its
    back end's ``timing`` details and the blends narrowed for the limits or the clearance; ``passages_s``:
    the time [s] at which the motion passes (or comes to rest at) each waypoint; ``rests_s``: per waypoint how long
    the motion rests there for its actions' waits [s] (it leaves at passage + rest); ``tilt``: the tilt certificate
    of the planned moves (``pipeline.cell.tilt.TiltReport.to_dict``; None without a tilt limit); ``loads_s``: what the
    flange carries from ``from_s`` [s] on (``load`` its name, None: nothing given, and ``mass_kg``), one entry per
    stretch and rest; a sample at a piece's first time belongs to the piece before it (its torques are that one's)."""

    stretches: tuple[dict, ...]
    passages_s: tuple[float, ...]
    rests_s: tuple[float, ...] = ()
    tilt: dict | None = None
    loads_s: tuple[dict, ...] = ()


class CarriedLoads:
    """The inverse dynamics of a program's robot with what its flange carries after each waypoint
    (``Program.load_after``), or nothing to compute when the limits bound no torque. The payload body sits on the
    flange, not on the job's TCP (``program.robot``'s end frame): a load's centre of mass and inertia are in the
    flange frame."""

    def __init__(self, program: Program):
        self.program = program
        self.drake = None
        if program.limits.tau_max is not None:
            from ..model.chain.drake_model import build_drake_robot

            self.drake = build_drake_robot(program.flange_spec)

    def after(self, k: int):
        """What ``pipeline.timing.time_path`` takes as ``drake`` for motion leaving waypoint ``k`` (None: no
        torques)."""
        return None if self.drake is None else self.drake.carrying(self.program.load_after(k))

    def held_torque(self, q: np.ndarray, k: int) -> np.ndarray | None:
        """(dof,) the torque [N m or N] that holds the robot at rest at ``q`` once waypoint ``k``'s actions have run
        (None: no torques)."""
        if self.drake is None:
            return None
        zero = np.zeros_like(q)
        return self.drake.inverse_dynamics(q, zero, zero, self.program.load_after(k))[0]


def time_program(program: Program, scene=None, max_samples: int = DEFAULT_MAX_SAMPLES) -> Profile:
    """The certified profile of ``program`` (see the module docstring); TimingError when the joined
    profile fails its certificate, ClearanceError (with the job time) when it comes too close."""
    paths = [None if program.timing == "ruckig" else StretchPath(program, first, last, scene)
             for first, last in program.stretches()]
    loads = CarriedLoads(program)
    profiles = [_time_stretch(program, path, k, max_samples, loads) for k, path in enumerate(paths)]
    for _ in range(MAX_REFINEMENTS + 1):
        joined = _joined(program, paths, profiles, loads)
        certificate = certify(joined, scene=scene)
        clearance = certificate.clearance
        if clearance is None or clearance.passed:
            break
        k, blend = _blend_at(paths, profiles, _stretch_starts(program, profiles), clearance.failed_at_s)
        if blend is None:
            hint = "" if program.plan == "collision_free" else " (plan: collision_free plans joint moves around obstacles)"
            first, last = program.stretches()[k]
            raise ClearanceError(clearance, joined, hint, first, last)
        paths[k].narrow(blend)
        paths[k].rebuild()
        profiles[k] = _time_stretch(program, paths[k], k, max_samples, loads)
    else:
        raise ClearanceError(clearance, joined, "", *program.stretches()[k])
    if not certificate.passed:
        raise TimingError(f"{program.timing} profile failed certification: {certificate}")
    return dataclasses.replace(_tilt_certified(program, joined), certificate=certificate)


def _tilt_certified(program: Program, profile: Profile) -> Profile:
    """``profile`` with its planned moves' tilt certificate in its details (``pipeline.cell.tilt``), as it is
    without a tilt limit; TimingError when the tool leaves the limit."""
    if program.tilt is None:
        return profile
    passages = profile.details.passages_s
    spans = [(passages[m.end - 1], passages[m.end]) for m in program.moves if m.planned is not None]
    report = certify_tilt(program.robot, program.tilt, profile, spans)
    if not report.passed:
        raise TimingError(f"the profile does not keep the tool level on its planned moves: {report}")
    return dataclasses.replace(profile, details=dataclasses.replace(profile.details, tilt=report.to_dict()))


def _time_stretch(program: Program, path: StretchPath | None, k: int, max_samples: int,
                  loads: CarriedLoads) -> Profile:
    """Stretch k timed from rest to rest (uncertified), with what the flange carries on it; a TimingError of a robot
    whose torques are limited names the moves and the load."""
    first, last = program.stretches()[k]
    try:
        return _timed_stretch(program, path, first, last, max_samples, loads)
    except TimingError as error:
        load = program.load_after(first)
        if type(error) is not TimingError or load is None or program.limits.tau_max is None:
            raise
        raise TimingError(f"the moves from waypoint {first} to {last} carrying {load.name} ({load.mass:g} kg): "
                          f"{error}") from error


def _timed_stretch(program: Program, path: StretchPath | None, first: int, last: int, max_samples: int,
                   loads: CarriedLoads) -> Profile:
    """The stretch from waypoint ``first`` to ``last`` timed from rest to rest (``_time_stretch``)."""
    common = {"method": program.timing, "speed_scale": program.speed_scale, "limits": program.limits,
              "dt": program.dt, "max_samples": max_samples, "drake": loads.after(first)}
    if path is None:
        vertices = [program.targets[first]]
        for move in program.moves[first: last]:
            vertices += list(move.planned.waypoints[1:]) if move.planned is not None else [move.target]
        return time_path(program.robot, np.array(vertices), **common)
    tcp = TcpMotion(program.robot) if program.has_tcp_limits else None
    return time_path(program.robot, path.path, tcp=tcp, schedule=path.schedule, **common)


def _joined(program: Program, paths: list, profiles: list[Profile], loads: CarriedLoads) -> Profile:
    """The stretches' profiles one after the other, each stop held for its actions' waits (``rest_profile``), with
    their schedules, the passage times, the rests and the load each stretch carries."""
    starts = _stretch_starts(program, profiles)
    passages, stretches, pieces, carried = [], [], [], []
    if program.rest_at(0) > 0.0:
        pieces.append(rest_profile(profiles[0], 0, program.rest_at(0), program.dt,
                                   loads.held_torque(profiles[0].q[0], 0)))
        carried.append(program.load_after(0))
    for path, profile, offset, (first, last) in zip(paths, profiles, starts, program.stretches()):
        if path is None:
            times = [offset + t for t in _ruckig_passages(program, first, last, profile)]
        else:
            times = (offset + _passage_times(path, profile)).tolist()
        passages += times
        stretches.append({"first": first, "last": last, "duration_s": profile.duration,
                          "timing": profile.details.to_dict() if profile.details else None,
                          "blends_narrowed": 0 if path is None else sum(b.narrowed for b in path.blends)})
        pieces.append(profile)
        carried.append(program.load_after(first))
        if program.rest_at(last) > 0.0:
            pieces.append(rest_profile(profile, -1, program.rest_at(last), program.dt,
                                       loads.held_torque(profile.q[-1], last)))
            carried.append(program.load_after(last))
    starts_s = np.cumsum([0.0] + [p.duration for p in pieces[:-1]])
    loads_s = tuple({"from_s": float(t), "load": None if load is None else load.name,
                     "mass_kg": 0.0 if load is None else load.mass} for t, load in zip(starts_s, carried))
    joined = join_profiles(pieces, ProgramDetails(tuple(stretches), (0.0, *passages), program.rests, loads_s=loads_s))
    schedule = stopped_schedules(pieces)
    return joined if schedule is None else dataclasses.replace(joined, schedule=schedule)


def _stretch_starts(program: Program, profiles: list[Profile]) -> np.ndarray:
    """When each stretch begins in the joined profile [s]: after the stretches before it and the rests at
    their stops (and waypoint 0's)."""
    rests = [program.rest_at(first) for first, _ in program.stretches()]
    return np.cumsum([rests[0]] + [p.duration + rest for p, rest in zip(profiles[:-1], rests[1:])])


def rest_profile(profile: Profile, sample: int, duration: float, dt: float, tau: np.ndarray | None = None) -> Profile:
    """The robot at rest for ``duration`` [s] where ``profile`` is at its ``sample`` (0 or -1: a stop), sampled
    about every ``dt`` [s], under the limits the profile has there; ``tau`` (dof,) [N m or N] the torque holding it
    (None: the profile's at that sample)."""
    n = max(2, int(np.ceil(duration / dt)) + 1)
    t = np.linspace(0.0, duration, n)

    def held(array):
        return None if array is None else np.repeat(array[sample][None, :], n, axis=0)

    zeros = np.zeros((n, profile.dof))
    tcp = None if profile.tcp is None else TcpSamples(held(profile.tcp.position), np.zeros(n), np.zeros(n))
    schedule = None
    if profile.schedule is not None:
        index = 0 if sample == 0 else len(profile.schedule.bounds) - 2
        schedule = LimitSchedule(np.array([0.0, duration]), *(values[index: index + 1] for values in (
            profile.schedule.joint_speed, profile.schedule.tcp_speed, profile.schedule.tcp_accel)))
    torque = held(profile.tau) if tau is None else np.repeat(tau[None, :], n, axis=0)
    return dataclasses.replace(profile, t=t, q=held(profile.q), qd=zeros, qdd=zeros, qddd=zeros.copy(), tau=torque,
                               tcp=tcp, schedule=schedule, details=None, certificate=None)


def stopped_schedules(profiles: list[Profile]) -> LimitSchedule | None:
    """The schedules of profiles joined one after the other at rest, each after the first beginning with the stop
    under the limits the one before ends with (``_after_stop``); None when one has no schedule."""
    if any(p.schedule is None for p in profiles):
        return None
    offsets = np.cumsum([0.0] + [p.duration for p in profiles[:-1]])
    schedules = [profiles[0].schedule] + [_after_stop(p.schedule, before.schedule)
                                          for before, p in zip(profiles[:-1], profiles[1:])]
    return joined_schedules([s.shifted(o) for s, o in zip(schedules, offsets)])


def _after_stop(schedule: LimitSchedule, before: LimitSchedule) -> LimitSchedule:
    """``schedule`` of a stretch that begins at a stop, with the stop itself (its first STOP_INSTANT_S)
    under the limits the stretch ``before`` ends with: the joined profile keeps the earlier stretch's
    sample at the stop (its deceleration into it), which is judged by the limits it was timed with."""
    last = [values[-1:] for values in (before.joint_speed, before.tcp_speed, before.tcp_accel)]
    bounds = np.concatenate([[0.0, STOP_INSTANT_S], np.maximum(schedule.bounds[1:], 2.0 * STOP_INSTANT_S)])
    return LimitSchedule(bounds, *(np.concatenate([end, values]) for end, values in
                                   zip(last, (schedule.joint_speed, schedule.tcp_speed, schedule.tcp_accel))))


def _passage_times(path: StretchPath, profile: Profile) -> np.ndarray:
    """When the stretch's profile passes its path's ``passages`` [s] (each s between the times of the schedule
    bounds around it): at a bound (every waypoint a joint run or a track passes) its time, else (the middle of
    a zone's blend) the sample there nearest the path's configuration."""
    s = np.asarray(path.passages, dtype=float)
    bounds = path.schedule.bounds
    k = np.clip(np.searchsorted(bounds, s, side="right") - 1, 0, len(bounds) - 2)
    t0, t1 = profile.schedule.bounds[k], profile.schedule.bounds[k + 1]
    times = np.where(s <= bounds[k], t0, t1)
    between = np.flatnonzero((s > bounds[k]) & (s < bounds[k + 1]))
    if between.size:
        lo, hi = np.searchsorted(profile.t, t0[between], side="left"), np.searchsorted(profile.t, t1[between], "right")
        for j, q, a, b in zip(between, path.path(s[between]), lo, hi):
            nearest = a + np.argmin(np.linalg.norm(profile.q[a:b] - q, axis=1)) if b > a else None
            times[j] = (t0[j] + t1[j]) / 2.0 if nearest is None else profile.t[nearest]
    return times


def _ruckig_passages(program: Program, first: int, last: int, profile: Profile) -> list[float]:
    """When a stretch timed waypoint to waypoint (ruckig) reaches each of its waypoints [s]: the sums of
    its segments' durations up to each move's end (the stretch's end for all when they do not match)."""
    edges = [1 if m.planned is None else len(m.planned.waypoints) - 1 for m in program.moves[first: last]]
    durations = getattr(profile.details, "segment_durations_s", ())
    if len(durations) != sum(edges):
        return [profile.duration] * (last - first)
    return [float(t) for t in np.cumsum(durations)[np.cumsum(edges) - 1]]


def _blend_at(paths: list, profiles: list[Profile], offsets: np.ndarray, t: float | None):
    """(stretch index, the blend whose configurations come nearest the profile's at job time ``t``, or
    None when the nearest part of the path is not a blend); ``offsets``: when each stretch begins [s]."""
    k = int(np.clip(np.searchsorted(offsets, t if t is not None else 0.0, side="right") - 1, 0, len(profiles) - 1))
    path, profile = paths[k], profiles[k]
    if path is None or t is None:
        return k, None
    q = np.array([np.interp(t - offsets[k], profile.t, column) for column in profile.q.T])
    s = np.linspace(0.0, 1.0, 4001)
    nearest = s[int(np.argmin(np.linalg.norm(path.path(s) - q, axis=1)))] * path.total
    for kind, i, u0, u1 in path.pieces:
        if kind == "blend" and u0 <= nearest <= u1:
            return k, path.blends[i]
    return k, None


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
