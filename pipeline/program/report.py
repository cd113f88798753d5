"""The cycle-time report: per move its duration and the limit that binds it most of the time, and the
program's lower bound beside its cycle time.

A move lasts from the passage of its start waypoint to the passage of its end waypoint (at a zone, the
middle of the blend; at a stop, the stop). At each sample the binding limit is the one closest to
its bound: joint i's speed (against its move's speed fraction), joint i's acceleration, the TCP's
speed or acceleration (where limited); a move's is the one binding at most of its samples, noting
when blends of its stretch were narrowed to keep the joint limits or the clearance, and a "singularity
slow-down" when a tool move's track allows the TCP less than the move's speed.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..timing.profile import Profile, limits_at
from .bound import LowerBound, lower_bound
from .model import Program


def binding_labels(profile: Profile) -> list[str]:
    """Per sample, the name of the limit closest to its bound (the limits that apply there, ``limits_at``)."""
    limits = profile.limits
    joint_speed, tcp_speed, tcp_accel = limits_at(limits, profile.schedule, profile.t)
    columns = [np.abs(profile.qd) / (limits.qd_max * joint_speed[:, None])]
    names = [f"joint {name} speed" for name in profile.joint_names]
    if limits.qdd_max is not None:
        columns.append(np.abs(profile.qdd) / limits.qdd_max)
        names += [f"joint {name} acceleration" for name in profile.joint_names]
    if profile.tcp is not None:
        columns += [(profile.tcp.speed / tcp_speed)[:, None], (profile.tcp.accel / tcp_accel)[:, None]]
        names += ["TCP speed", "TCP acceleration"]
    ratios = np.hstack(columns)
    return [names[i] for i in np.argmax(ratios, axis=1)]


def cycle_report(program: Program, profile: Profile, bound: LowerBound | None = None) -> dict:
    """The report (JSON-ready): ``cycle_s``, ``lower_bound_s``, their ratio, the stretches' bounds, per move its
    waypoints, kind, duration [s] (from leaving its start waypoint to passing its end) and binding limit, and per
    waypoint with actions what they do, when the robot gets there and how long it rests for them (``rests_s`` the
    total) [s]."""
    bound = lower_bound(program) if bound is None else bound
    passages = list(profile.details.passages_s)
    rests = program.rests
    labels = binding_labels(profile)
    narrowed = {s["last"]: s["blends_narrowed"] for s in profile.details.stretches}
    # Each move's samples (t0 <= t <= t1) and the last waypoint of its stretch, found by bisection.
    starts = np.searchsorted(profile.t, np.add(passages[:-1], rests[:-1]), side="left")
    ends = np.searchsorted(profile.t, passages[1:], side="right")
    stops = np.asarray(program.stops)
    stretch_ends = stops[np.searchsorted(stops, np.arange(len(program.moves)), side="right")]
    moves = []
    for k, move in enumerate(program.moves):
        t0, t1 = passages[k] + rests[k], passages[k + 1]
        inside = labels[starts[k]: ends[k]]
        binding = Counter(inside).most_common(1)[0][0] if inside else "none"
        if narrowed.get(int(stretch_ends[k])):
            binding += " (blends narrowed to keep the limits or the clearance)"
        if move.track is not None and move.track.along.slowest_tcp_speed < move.speed * program.speed_scale:
            binding += " (singularity slow-down)"
        moves.append({"from": k, "to": k + 1, "kind": move.kind, "duration_s": t1 - t0, "binding": binding})
    actions = [{"at": k, "actions": [str(a) for a in done], "rest_s": rests[k], "at_s": passages[k]}
               for k, done in enumerate(program.actions) if done]
    return {"cycle_s": profile.duration, "lower_bound_s": bound.total_s,
            "ratio": profile.duration / bound.total_s if bound.total_s > 0.0 else None,
            "stretches": [s.to_dict() for s in bound.stretches], "moves": moves, "actions": actions,
            "rests_s": float(sum(rests))}


def cycle_lines(report: dict) -> list[str]:
    """The report as the lines ``run`` prints."""
    ratio = "" if report["ratio"] is None else f" ({report['ratio']:.2f}x)"
    lines = [f"cycle {report['cycle_s']:.3f} s, lower bound {report['lower_bound_s']:.3f} s{ratio}"]
    actions = {a["at"]: a for a in report.get("actions", ())}
    for m in report["moves"]:
        if m["from"] in actions:
            lines.append(_action_line(actions[m["from"]]))
        lines.append(f"  move {m['from']}->{m['to']} {m['kind']:<8} {m['duration_s']:.3f} s  {m['binding']}")
    last = len(report["moves"])
    if last in actions:
        lines.append(_action_line(actions[last]))
    return lines


def _action_line(entry: dict) -> str:
    """What the program does at a waypoint, and how long it stands still for it."""
    rest = f"{entry['rest_s']:.3f} s" if entry["rest_s"] > 0.0 else "no stop" if not any(
        a.startswith("wait") for a in entry["actions"]) else "0.000 s (an input's wait is not timed)"
    return f"  at {entry['at']:<6} {'; '.join(entry['actions'])}  [{rest}]"
