"""A job document read from a controller program, in the units its language writes: RAPID, LS, JBI and KRL
in millimetres (LS, JBI and KRL orientations as roll, pitch, yaw in degrees, RAPID's as its own quaternions),
URScript in metres. The readers give SI lengths (``length_unit: m``); this rewrites the document's lengths
(positions, via points, the tool, zones, TCP speeds and accelerations of tool moves and of the job, the centres of
mass of the payload and the parts; inertias stay in kg m^2 whatever the length unit)."""

from __future__ import annotations

import numpy as np

from ...files.poses import quaternion_position_to_pose, rotation_to_rpy

#: Language -> (length unit, whether orientations are written as rpy).
PROGRAM_UNITS = {"rapid": ("mm", False), "ls": ("mm", True), "jbi": ("mm", True), "krl": ("mm", True),
                 "urscript": ("m", False)}
#: Language -> how the job read from it writes orientations, against the program's own (the job's rpy: roll about x,
#: pitch about y, yaw about z, fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)).
ORIENTATIONS = {"rapid": "quaternions [w, x, y, z] as the program's rot [q1, q2, q3, q4]",
                "ls": "rpy [deg] = the program's W, P, R", "jbi": "rpy [deg] = the program's Rx, Ry, Rz",
                "krl": "rpy [deg] = the program's C, B, A (A about z, B about y, C about x)",
                "urscript": "quaternions [w, x, y, z] of the program's rotation vectors"}
#: Decimals kept of a length in mm (the readers' values are exact to far less).
MM_DECIMALS = 9
#: The job's TCP keys, lengths per second^k.
_JOB_LENGTHS = ("tcp_speed_max", "tcp_accel_max", "tcp_speed_limit")


def units_line(language: str) -> str:
    """A comment line saying the job's units and how its orientations stand for the program's."""
    return f"# lengths in {PROGRAM_UNITS[language][0]}; orientations as {ORIENTATIONS[language]}"


def in_program_units(document: dict, language: str) -> dict:
    """``document`` (length_unit m, angle_unit deg) rewritten in ``language``'s units (a new dict)."""
    unit, as_rpy = PROGRAM_UNITS[language]
    if unit == "m":
        return document
    out = {**document, "length_unit": "mm"}
    for key in _JOB_LENGTHS:
        if key in out:
            out[key] = _mm(out[key])
    if isinstance(out.get("tool"), dict):
        out["tool"] = _pose(out["tool"], as_rpy)
    out["waypoints"] = [_waypoint(w, as_rpy) for w in document["waypoints"]]
    if isinstance(out.get("payload"), dict):
        out["payload"] = _load(out["payload"])
    if isinstance(out.get("parts"), dict):
        out["parts"] = {name: _load(part) for name, part in out["parts"].items()}
    return out


def _load(entry: dict) -> dict:
    """A load entry with its centre of mass in mm."""
    return {**entry, "com": _mm(entry["com"])} if "com" in entry else entry


def _waypoint(waypoint, as_rpy: bool):
    if not isinstance(waypoint, dict):
        return waypoint                                     # joint values: degrees already
    if "xyz" not in waypoint:                               # joint values with move keys: the zone is a length
        return {**waypoint, "zone": _mm(waypoint["zone"])} if "zone" in waypoint else waypoint
    out = _pose(waypoint, as_rpy)
    if "via" in out:
        out["via"] = {**out["via"], "xyz": _mm(out["via"]["xyz"])}
    if "zone" in out:
        out["zone"] = _mm(out["zone"])
    if "speed" in out and out.get("move", "joint") != "joint":
        out["speed"] = _mm(out["speed"])                    # a tool move's TCP speed; a joint move's is a %
    return out


def _pose(entry: dict, as_rpy: bool) -> dict:
    """A pose entry with its xyz in mm, and with ``as_rpy`` its quaternion as rpy [deg] (the keys kept in order)."""
    out = {**entry, "xyz": _mm(entry["xyz"])}
    if not (as_rpy and "quaternion" in entry):
        return out
    R = quaternion_position_to_pose(np.array(entry["quaternion"], dtype=float), np.zeros(3))[:3, :3]
    rpy = [round(float(v), MM_DECIMALS) + 0.0 for v in np.degrees(rotation_to_rpy(R))]
    return {"xyz": out["xyz"], "rpy": rpy, **{k: v for k, v in out.items() if k not in ("xyz", "quaternion")}}


def _mm(value):
    """Metres (a number or a list) -> millimetres, rounded to MM_DECIMALS."""
    if isinstance(value, list):
        return [_mm(v) for v in value]
    return round(float(value) * 1e3, MM_DECIMALS) + 0.0
