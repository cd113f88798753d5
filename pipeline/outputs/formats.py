"""The output file formats: profiles as CSV (units in the column names) and NPZ, and JSON reports, all in SI
units. The files go into a folder written through ``pipeline.files.atomic.staged_output``."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..timing.profile import Profile


#: CSV columns of the TCP, when a profile carries it.
TCP_COLUMNS = ["tcp_x_m", "tcp_y_m", "tcp_z_m", "tcp_speed_m_s", "tcp_accel_m_s2"]


def profile_columns(revolute: Sequence[bool], torques: bool = False, tcp: bool = False) -> list[str]:
    """CSV column names with units: ``t_s``, ``q1_rad``, ``qd1_rad_s``, ``qdd1_rad_s2``, ``qddd1_rad_s3``
    (``m`` for prismatic joints), with ``torques`` ``tau1_N_m`` (``N`` for prismatic), and with ``tcp``
    the TCP's position, speed and acceleration (TCP_COLUMNS); joints numbered from 1."""
    units = ["rad" if r else "m" for r in revolute]
    columns = ["t_s"]
    for name, suffix in (("q", ""), ("qd", "_s"), ("qdd", "_s2"), ("qddd", "_s3")):
        columns += [f"{name}{j + 1}_{unit}{suffix}" for j, unit in enumerate(units)]
    if torques:
        columns += [f"tau{j + 1}_{'N_m' if r else 'N'}" for j, r in enumerate(revolute)]
    return columns + (TCP_COLUMNS if tcp else [])


def write_profile_csv(path: str | Path, profile: Profile, revolute: Sequence[bool]) -> None:
    """The profile as CSV: one row per sample, columns ``profile_columns`` [SI units]."""
    blocks = [profile.t, profile.q, profile.qd, profile.qdd, profile.qddd]
    if profile.tau is not None:
        blocks.append(profile.tau)
    if profile.tcp is not None:
        blocks += [profile.tcp.position, profile.tcp.speed, profile.tcp.accel]
    table = np.column_stack(blocks) + 0.0   # no "-0"
    header = ",".join(profile_columns(revolute, torques=profile.tau is not None, tcp=profile.tcp is not None))
    np.savetxt(path, table, fmt="%.12g", delimiter=",", header=header, comments="")


def write_profile_npz(path: str | Path, profile: Profile, extra: dict | None = None) -> None:
    """The profile as NPZ: ``t`` (N,) [s], ``q``, ``qd``, ``qdd``, ``qddd`` (N, dof) [SI], ``joint_names``,
    ``tau`` (N, dof) [N m or N] when the profile carries torques, ``tcp_position`` (N, 3) [m],
    ``tcp_speed`` [m/s], ``tcp_accel`` [m/s^2] (N,) when it carries the TCP, and the ``extra`` arrays
    (the program's, ``pipeline.program.model.program_arrays``)."""
    arrays = {"t": profile.t, "q": profile.q, "qd": profile.qd, "qdd": profile.qdd, "qddd": profile.qddd,
              "joint_names": np.array(profile.joint_names), **(extra or {})}
    if profile.tau is not None:
        arrays["tau"] = profile.tau
    if profile.tcp is not None:
        arrays.update(tcp_position=profile.tcp.position, tcp_speed=profile.tcp.speed, tcp_accel=profile.tcp.accel)
    with open(path, "wb") as handle:
        np.savez(handle, **arrays)


def write_json(path: str | Path, data: dict) -> None:
    """``data`` as indented JSON; NumPy scalars and arrays become numbers and lists."""
    Path(path).write_text(json.dumps(data, indent=2, default=_json_default) + "\n")


def _json_default(value):
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")
