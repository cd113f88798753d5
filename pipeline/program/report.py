"""The cycle-time report: per move its duration and the limit that binds it most of the time, and the
program's lower bound beside its cycle time.

A move lasts from the passage of its start waypoint to the passage of its end waypoint (at a zone, the
middle of the blend; at a stop, the stop). At each sample the binding limit is the one closest to
its bound: joint i's speed (against its move's speed fraction), joint i's acceleration, joint i's torque (where
torques are limited: with what the flange carries there), the TCP's speed or acceleration (where limited); a move's
is the one binding at most of its samples (and a joint torque at its limit on fewer, with its share of the time), noting
when blends of its stretch were narrowed to keep the joint limits or the clearance, and a "singularity
slow-down" when a tool move's track allows the TCP less than the move's speed.
"""

from __future__ import annotations

import dataclasses
from collections import Counter

import numpy as np

from pathlib import Path

from ..model.payload_limits import wrist_loads
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
    if limits.tau_max is not None and profile.tau is not None:
        columns.append(np.abs(profile.tau) / limits.tau_max)
        names += [f"joint {name} torque" for name in profile.joint_names]
    if profile.tcp is not None:
        columns += [(profile.tcp.speed / tcp_speed)[:, None], (profile.tcp.accel / tcp_accel)[:, None]]
        names += ["TCP speed", "TCP acceleration"]
    ratios = np.hstack(columns)
    return [names[i] for i in np.argmax(ratios, axis=1)]


#: A torque at this fraction of its limit or more binds (the timing holds it at 1 where it does).
TORQUE_BINDS = 0.99


def _torque_note(profile: Profile, samples: slice, binding: str) -> str:
    """", joint J torque at its limit N% of the time" when a joint's torque reaches TORQUE_BINDS of its limit on
    some of a move's ``samples`` but is not its ``binding`` limit; "" otherwise."""
    if profile.tau is None or profile.limits.tau_max is None or samples.stop <= samples.start:
        return ""
    ratios = np.abs(profile.tau[samples]) / profile.limits.tau_max
    joint = int(np.argmax(np.max(ratios, axis=0)))
    label = f"joint {profile.joint_names[joint]} torque"
    if ratios[:, joint].max() < TORQUE_BINDS or binding == label:
        return ""
    return f", {label} at its limit {np.mean(ratios[:, joint] >= TORQUE_BINDS):.0%} of the time"


def cycle_report(program: Program, profile: Profile, bound: LowerBound | None = None) -> dict:
    """The report (JSON-ready): ``cycle_s``, ``lower_bound_s``, their ratio, the stretches' bounds, per move its
    waypoints, kind, duration [s] (from leaving its start waypoint to passing its end), binding limit and what it
    carries (``carrying``: the load's name and mass, when the job grips parts; else None), and per
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
        binding += _torque_note(profile, slice(starts[k], ends[k]), binding)
        if narrowed.get(int(stretch_ends[k])):
            binding += " (blends narrowed to keep the limits or the clearance)"
        if move.track is not None and move.track.along.slowest_tcp_speed < move.speed * program.speed_scale:
            binding += " (singularity slow-down)"
        load = program.load_after(k)
        moves.append({"from": k, "to": k + 1, "kind": move.kind, "duration_s": t1 - t0, "binding": binding,
                      "carrying": None if load is None or not program.parts else f"{load.name} {load.mass:g} kg"})
    actions = [{"at": k, "actions": [str(a) for a in done], "rest_s": rests[k], "at_s": passages[k]}
               for k, done in enumerate(program.actions) if done]
    return {"cycle_s": profile.duration, "lower_bound_s": bound.total_s,
            "ratio": profile.duration / bound.total_s if bound.total_s > 0.0 else None,
            "stretches": [s.to_dict() for s in bound.stretches], "moves": moves, "actions": actions,
            "rests_s": float(sum(rests)), "payload": payload_report(program, profile)}


def payload_report(program: Program, profile: Profile) -> dict | None:
    """What the program carries (None: the job gives no payload and no parts): per distinct load its mass [kg],
    centre of mass [mm, flange frame], rated payload and what it puts on each wrist axis of the robot file's payload
    diagram (``pipeline.model.payload_limits``), and whether the joint torques are certified (peak/limit per
    joint) or why not."""
    if program.payload is None and not program.parts:
        return None
    spec = program.flange_spec
    carried = {}
    for k in range(len(program.moves) + 1):
        load = program.load_after(k)
        if load is not None:
            carried.setdefault(load.name, load)
    rated = None if spec.payload_limits is None else spec.payload_limits.rated_kg
    loads = [{"load": name, "mass_kg": load.mass, "com_mm": (load.com * 1e3).tolist(), "rated_kg": rated,
              "wrist": [dataclasses.asdict(w) for w in wrist_loads(spec, load)]} for name, load in carried.items()]
    if profile.tau is not None and profile.limits.tau_max is not None:
        ratios = np.max(np.abs(profile.tau), axis=0) / profile.limits.tau_max
        torques = {"certified": True, "peak_ratio": ratios.tolist()}
    else:
        torques = {"certified": False, "reason": f"{Path(spec.source).name} gives no joint torque limits (tau_max) "
                   "with link inertias: the torques are not computed (the payload diagram is checked)"}
    return {"loads": loads, "torques": torques,
            "diagram_source": None if spec.payload_limits is None else spec.payload_limits.source}


def cycle_lines(report: dict) -> list[str]:
    """The report as the lines ``run`` prints."""
    ratio = "" if report["ratio"] is None else f" ({report['ratio']:.2f}x)"
    lines = [f"cycle {report['cycle_s']:.3f} s, lower bound {report['lower_bound_s']:.3f} s{ratio}"]
    actions = {a["at"]: a for a in report.get("actions", ())}
    for m in report["moves"]:
        if m["from"] in actions:
            lines.append(_action_line(actions[m["from"]]))
        carrying = f"  [carrying {m['carrying']}]" if m.get("carrying") else ""
        lines.append(f"  move {m['from']}->{m['to']} {m['kind']:<8} {m['duration_s']:.3f} s  {m['binding']}{carrying}")
    last = len(report["moves"])
    if last in actions:
        lines.append(_action_line(actions[last]))
    if report.get("payload"):
        lines += _payload_lines(report["payload"])
    return lines


def _payload_lines(payload: dict) -> list[str]:
    """Per load what it puts on the wrist against the payload diagram, and the torques' verdict."""
    lines = []
    for entry in payload["loads"]:
        parts = [f"rated {entry['rated_kg']:g} kg"] if entry["rated_kg"] is not None else []
        for w in entry["wrist"]:
            if w["moment_limit"] is not None:
                parts.append(f"{w['joint']} {w['moment_n_m']:.2f}/{w['moment_limit']:g} N m")
            if w["inertia_limit"] is not None:
                parts.append(f"{w['joint']} {w['inertia_kg_m2']:.3f}/{w['inertia_limit']:g} kg m^2")
        diagram = f": {', '.join(parts)}" if parts else ": no payload diagram in the robot file"
        lines.append(f"carrying {entry['load']} {entry['mass_kg']:g} kg{diagram}")
    torques = payload["torques"]
    if torques["certified"]:
        worst = int(np.argmax(torques["peak_ratio"]))
        lines.append(f"torques certified with the payload of each move: peak/limit {max(torques['peak_ratio']):.4f} "
                     f"(joint {worst + 1})")
    else:
        lines.append(f"torques not certified: {torques['reason']}")
    return lines


def _action_line(entry: dict) -> str:
    """What the program does at a waypoint, and how long it stands still for it."""
    rest = f"{entry['rest_s']:.3f} s" if entry["rest_s"] > 0.0 else "no stop" if not any(
        a.startswith("wait") for a in entry["actions"]) else "0.000 s (an input's wait is not timed)"
    return f"  at {entry['at']:<6} {'; '.join(entry['actions'])}  [{rest}]"
