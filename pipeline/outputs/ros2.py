"""A profile as ROS 2 controller input: a ``trajectory_msgs/msg/JointTrajectory`` message.

``joint_trajectory(profile)`` builds the message as plain data (dicts, lists, floats, ints), field
names as in the message definitions: ``header`` (stamp 0, which joint_trajectory_controller reads as
"start now"; empty frame_id), ``joint_names``, and one point per sample with ``positions`` [rad or
m], ``velocities`` [rad/s or m/s], ``accelerations`` [rad/s^2 or m/s^2], ``effort`` (always empty:
joint_trajectory_controller refuses points with efforts unless it commands torques; a torque-limited
profile's torques are in profile.csv) and ``time_from_start``
(builtin_interfaces/Duration: ``sec`` and ``nanosec`` in [0, 1e9), the sample time rounded to the
nearest ns). ``write_ros2_yaml`` writes it as the YAML ``ros2 topic pub`` takes, ``write_json_trajectory``
as JSON; floats are written so that they read back exactly. A profile the controller would reject
(times not strictly increasing after rounding to ns, a negative time, non-finite values, sizes that do
not match the joint names) is an OutputError, and nothing is written.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from ..errors import OutputError
from ..timing.profile import Profile

NS_PER_S = 1_000_000_000
#: libyaml's emitter when PyYAML has it (the same text, faster), else the pure-Python one.
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def joint_trajectory(profile: Profile) -> dict:
    """The JointTrajectory message of ``profile`` as plain data (see the module docstring) [SI units].
    Raises OutputError, naming the samples, when the controller would reject it."""
    _check_values(profile)
    stamps = time_from_start(profile.t)
    points = [{"positions": q, "velocities": qd, "accelerations": qdd, "effort": [], "time_from_start": stamp}
              for q, qd, qdd, stamp in zip(profile.q.tolist(), profile.qd.tolist(), profile.qdd.tolist(), stamps)]
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
            "joint_names": list(profile.joint_names),
            "points": points}


def time_from_start(t: np.ndarray) -> list[dict]:
    """Sample times ``t`` (N,) [s] as builtin_interfaces/Duration values ``{sec, nanosec}``: rounded to
    the nearest ns, nanosec in [0, 1e9). Raises OutputError when a time is negative or not finite, or
    when two rounded times are not strictly increasing (samples less than 1 ns apart)."""
    t = np.asarray(t, dtype=float)
    if not np.isfinite(t).all() or (t < 0).any():
        k = int(np.flatnonzero(~np.isfinite(t) | (t < 0))[0])
        raise OutputError(f"sample {k}: time {float(t[k])!r} s is negative or not finite; a JointTrajectory's "
                          "time_from_start must be a finite time from 0 on")
    ns = [int(value) for value in np.rint(t * NS_PER_S)]
    for k in range(1, len(ns)):
        if ns[k] <= ns[k - 1]:
            raise OutputError(f"samples {k - 1} and {k} (t = {float(t[k - 1])!r} s and {float(t[k])!r} s) get "
                              f"time_from_start {ns[k - 1]} ns and {ns[k]} ns after rounding to whole ns; "
                              "joint_trajectory_controller rejects times that do not strictly increase: use "
                              "samples at least 1 ns apart")
    return [{"sec": sec, "nanosec": nanosec} for sec, nanosec in (divmod(value, NS_PER_S) for value in ns)]


def _check_values(profile: Profile) -> None:
    """OutputError unless t is (N,) with N >= 1, and q, qd, qdd (and tau) are finite and (N, joints)."""
    if np.ndim(profile.t) != 1 or len(profile.t) == 0:
        raise OutputError(f"a JointTrajectory needs t of shape (N,), N >= 1 (got {np.shape(profile.t)})")
    shape = (len(profile.t), len(profile.joint_names))
    arrays = {"q": profile.q, "qd": profile.qd, "qdd": profile.qdd, "tau": profile.tau}
    for name, values in arrays.items():
        if values is None:
            continue
        if np.shape(values) != shape:
            raise OutputError(f"{name} has shape {np.shape(values)}, not {shape}: one row per sample, one "
                              "column per joint name")
        if not np.isfinite(values).all():
            k, j = np.argwhere(~np.isfinite(values))[0]
            raise OutputError(f"sample {k}: {name} of joint {profile.joint_names[j]} is {float(values[k, j])}; "
                              "a trajectory sent to a controller must be finite")


def write_ros2_yaml(path: str | Path, profile: Profile) -> None:
    """The profile as a JointTrajectory message in YAML, for ``ros2 topic pub`` [SI units]; nothing is
    written when the message would be rejected (OutputError)."""
    text = yaml.dump(joint_trajectory(profile), Dumper=_DUMPER, sort_keys=False, default_flow_style=None,
                     width=1 << 20)
    Path(path).write_text(text, encoding="utf-8")


def write_json_trajectory(path: str | Path, profile: Profile) -> None:
    """The profile as a JointTrajectory message in JSON (the same content as ``write_ros2_yaml``) [SI
    units]; nothing is written when the message would be rejected (OutputError)."""
    text = json.dumps(joint_trajectory(profile), allow_nan=False) + "\n"
    Path(path).write_text(text, encoding="utf-8")
