"""Files at the edge: atomic writes, so a failure never leaves a half-written output behind.

Profiles are written as CSV (units in the column names), NPZ and JSON reports, all in SI units.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

from .profile import Profile


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same directory and an atomic rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_files_atomic(out_dir: str | Path, writers: Mapping[str, Callable[[Path], None]]) -> list[Path]:
    """Write a set of files into ``out_dir`` all or nothing.

    ``writers`` maps file names to functions writing that file at the path they are given. Every file
    is written into a temporary directory beside ``out_dir`` first and moved into place only once all
    are complete; if any writer fails, the temporary directory is removed and ``out_dir`` is left as it
    was (not even created). Returns the final paths, in the order of ``writers``.
    """
    out_dir = Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=f".{out_dir.name}.", suffix=".tmp"))
    try:
        for name, write in writers.items():
            write(staging / name)
        out_dir.mkdir(exist_ok=True)
        for name in writers:
            os.replace(staging / name, out_dir / name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return [out_dir / name for name in writers]


def profile_columns(revolute: Sequence[bool], torques: bool = False) -> list[str]:
    """CSV column names with units: ``t_s``, ``q1_rad``, ``qd1_rad_s``, ``qdd1_rad_s2``, ``qddd1_rad_s3``
    (``m`` for prismatic joints), and with ``torques`` ``tau1_N_m`` (``N`` for prismatic); joints
    numbered from 1."""
    units = ["rad" if r else "m" for r in revolute]
    columns = ["t_s"]
    for name, suffix in (("q", ""), ("qd", "_s"), ("qdd", "_s2"), ("qddd", "_s3")):
        columns += [f"{name}{j + 1}_{unit}{suffix}" for j, unit in enumerate(units)]
    if torques:
        columns += [f"tau{j + 1}_{'N_m' if r else 'N'}" for j, r in enumerate(revolute)]
    return columns


def write_profile_csv(path: str | Path, profile: Profile, revolute: Sequence[bool]) -> None:
    """The profile as CSV: one row per sample, columns ``profile_columns`` [SI units]."""
    blocks = [profile.t, profile.q, profile.qd, profile.qdd, profile.qddd]
    if profile.tau is not None:
        blocks.append(profile.tau)
    table = np.column_stack(blocks) + 0.0   # no "-0"
    header = ",".join(profile_columns(revolute, torques=profile.tau is not None))
    np.savetxt(path, table, fmt="%.12g", delimiter=",", header=header, comments="")


def write_profile_npz(path: str | Path, profile: Profile) -> None:
    """The profile as NPZ: ``t`` (N,) [s], ``q``, ``qd``, ``qdd``, ``qddd`` (N, dof) [SI], ``joint_names``,
    and ``tau`` (N, dof) [N m or N] when the profile carries torques."""
    arrays = {"t": profile.t, "q": profile.q, "qd": profile.qd, "qdd": profile.qdd, "qddd": profile.qddd,
              "joint_names": np.array(profile.joint_names)}
    if profile.tau is not None:
        arrays["tau"] = profile.tau
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
