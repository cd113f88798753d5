"""Files at the edge: output folders replaced whole, atomic single files, and the file formats.

An output folder is written through ``staged_output(out_dir)``: every file goes into a fresh hidden
staging folder beside the target, and on success that folder takes the target's place in one atomic
rename, so a reader (or a run killed at any instant) sees the previous complete output or the new
one, never a mix. Only folders this package wrote (see ``OWNER_MARKER``) or empty ones are replaced.

Profiles are written as CSV (units in the column names), NPZ and JSON reports, all in SI units.
"""

from __future__ import annotations

import ctypes
import errno
import functools
import json
import os
import re
import secrets
import shutil
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .errors import OutputError
from .paths import special_kind
from .profile import Profile

#: Written into every output folder: the names of the files the package put there. A folder is
#: replaced only when it is empty, or holds this marker and nothing it does not list.
OWNER_MARKER = ".dh-pipeline-output.json"
#: Linux ``renameat2`` flag that swaps two paths atomically, and "relative to the working directory".
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same directory and an atomic rename.
    The file gets ordinary permissions (0666 less the umask). Raises OutputError when it cannot."""
    path = Path(path)
    prepare_file_target(path)
    tmp = path.with_name(_hidden_name(path.name, "tmp"))
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {exc.strerror or exc}") from exc
    finally:
        tmp.unlink(missing_ok=True)
    return path


def prepare_file_target(path: str | Path) -> None:
    """Check before any work that a single output file can go to ``path``: absent or a regular file
    (never a folder, FIFO, device or socket, which the atomic rename would replace; a symbolic link
    counts as what it points to), and its parent a folder (created if missing). Raises OutputError
    naming the path."""
    path = Path(path)
    kind = special_kind(path)
    if kind == "a folder":
        raise OutputError(f"{path}: is a folder; give a file name for this output")
    if kind is not None:
        raise OutputError(f"{path}: is {kind}, not a regular file: it is never replaced; give a file name")
    _make_parent(path)


@contextmanager
def staged_output(out_dir: str | Path) -> Iterator[Path]:
    """A fresh, empty staging folder to write a whole output set into; on leaving without an
    exception it replaces ``out_dir`` in one atomic rename, on an exception it is removed and
    ``out_dir`` is left as it was.

    Checked on entry, before any work: ``out_dir`` must be absent, empty, or an output folder of this
    package (OutputError otherwise: a file, a link, a folder holding other files, or a parent that
    cannot be created or written). Staging folders of killed runs beside it are removed first.
    """
    target = Path(os.path.abspath(out_dir))
    _check_replaceable(target)
    _make_parent(target)
    _remove_stale_staging(target)
    staging = _new_sibling(target, "staging")
    leftover: Path | None = staging
    try:
        yield staging
        leftover = _commit(staging, target)
    finally:
        if leftover is not None:
            shutil.rmtree(leftover, ignore_errors=True)


def _commit(staging: Path, target: Path) -> Path | None:
    """Mark ``staging`` as ours and swap it in (``_swap_in``); OutputError when that fails."""
    _check_replaceable(target)          # it may have changed while the caller worked
    try:
        _mark_owned(staging)
        return _swap_in(staging, target)
    except OSError as exc:
        raise OutputError(f"{target}: cannot put the new output in place: {exc.strerror or exc}") from exc


def _check_replaceable(target: Path) -> None:
    """OutputError unless ``target`` is absent, an empty folder, or an output folder of this package."""
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        kind = "a symbolic link" if target.is_symlink() else (special_kind(target) or "a file")
        raise OutputError(f"{target}: is {kind}, not an output folder; choose a folder path")
    if target.is_dir():
        try:
            foreign = sorted(set(os.listdir(target)) - _owned_names(target))
        except OSError as exc:
            raise OutputError(f"{target}: cannot read the folder: {exc.strerror}") from exc
        if foreign:
            raise OutputError(f"{target}: holds files this package did not write ({', '.join(foreign[:3])}"
                              f"{', ...' if len(foreign) > 3 else ''}); it is never replaced: choose a new or "
                              "empty folder")


def _owned_names(folder: Path) -> set[str]:
    """The marker and the names it lists, or nothing when the folder has no readable marker."""
    try:
        listed = json.loads((folder / OWNER_MARKER).read_text())["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return set()
    return {OWNER_MARKER, *(name for name in listed if isinstance(name, str))}


def _mark_owned(staging: Path) -> None:
    """Write the marker listing every file in ``staging``."""
    names = sorted(os.listdir(staging))
    (staging / OWNER_MARKER).write_text(json.dumps({"written_by": "dh-pipeline", "files": names}, indent=2) + "\n")


def _make_parent(path: Path) -> None:
    """Create the parent folder of ``path`` if missing; OutputError when that is impossible."""
    parent = path.absolute().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = "a file is in the way" if isinstance(exc, (FileExistsError, NotADirectoryError)) else exc.strerror
        raise OutputError(f"{path}: cannot create its parent folder {parent}: {reason or exc}") from exc


def _hidden_name(name: str, kind: str) -> str:
    """``.<name>.<kind>-<pid>-<random>``: a hidden sibling that names the process that made it."""
    return f".{name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"


def _new_sibling(target: Path, kind: str) -> Path:
    """Create a hidden, empty folder beside ``target`` (mode 0777 less the umask)."""
    path = target.with_name(_hidden_name(target.name, kind))
    try:
        os.mkdir(path)
    except OSError as exc:
        raise OutputError(f"{target}: cannot write into {path.parent}: {exc.strerror or exc}") from exc
    return path


def _remove_stale_staging(target: Path) -> None:
    """Remove the staging and swapped-out folders beside ``target`` whose process is gone (killed runs)."""
    pattern = re.compile(rf"\.{re.escape(target.name)}\.(staging|old)-(\d+)-[0-9a-f]+")
    try:
        siblings = list(target.parent.iterdir())
    except OSError as exc:
        raise OutputError(f"{target}: cannot read its parent folder: {exc.strerror or exc}") from exc
    stale = [path for path in siblings
             if (match := pattern.fullmatch(path.name)) and not _process_alive(int(match.group(2)))]
    for path in stale:
        shutil.rmtree(path, ignore_errors=True)


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:                 # alive, another user's
        return True
    return True


def _swap_in(staging: Path, target: Path) -> Path | None:
    """Put ``staging`` at ``target`` in one atomic rename; return the folder now holding the previous
    contents of ``target`` (None when there was none). Without renameat2 the old folder is renamed
    aside first, so for an instant there is no target (never a mix)."""
    if not target.exists():
        os.rename(staging, target)
        return None
    if _exchange(staging, target):
        return staging
    aside = target.with_name(_hidden_name(target.name, "old"))
    os.rename(target, aside)
    os.rename(staging, target)
    return aside


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically with Linux ``renameat2(RENAME_EXCHANGE)``; False where unavailable."""
    renameat2 = _renameat2()
    if renameat2 is None:
        return False
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):     # old kernel, or a file system without it
        return False
    raise OSError(code, os.strerror(code), str(b))


@functools.cache
def _renameat2():
    """libc's ``renameat2`` (glibc 2.28+), or None off Linux or where libc lacks it."""
    if not sys.platform.startswith("linux"):
        return None
    function = getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None)
    if function is not None:
        function.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
        function.restype = ctypes.c_int
    return function


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
