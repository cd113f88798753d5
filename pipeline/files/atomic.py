"""Files written safely: output folders replaced whole (only folders the package wrote, or empty ones) and
atomic single files (never over a special file).

An output folder is written through ``staged_output(out_dir)``: every file goes into a fresh hidden
staging folder beside the target, and on success that folder takes the target's place in one atomic
rename, so a reader (or a run killed at any instant) sees the previous complete output or the new
one, never a mix. Only folders this package wrote (see ``OWNER_MARKER``) or empty ones are replaced.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import functools
import hashlib
import json
import os
import re
import secrets
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import OutputError
from .special import special_kind

#: Written into every output folder: the names of the files the package put there. A folder is
#: replaced only when it is empty, or holds this marker and nothing it does not list.
OWNER_MARKER = ".dh-pipeline-output.json"
#: Every single file the package writes names it within its first MARK_BYTES bytes (a comment, a JSON key, a
#: PNG text chunk): an existing file without it was not written here and is replaced only when asked.
WRITTEN_BY = "dh-pipeline"
MARK_BYTES = 4096
#: A file written for one job (a controller program) also names that job within its first MARK_BYTES, as one
#: word ``job=<name>`` (``job_mark``) at most JOB_MARK_CHARS long (a pendant's 32-character comment line): writing
#: another job's file over it is refused unless asked (``prepare_file_target``).
JOB_MARK, JOB_MARK_CHARS = "job=", 32
_JOB_MARK_FOUND = re.compile(rf"(?<![A-Za-z0-9_]){JOB_MARK}([A-Za-z0-9_.+~-]+)")
#: Linux ``renameat2`` flag that swaps two paths atomically, and "relative to the working directory".
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def write_text_atomic(path: str | Path, text: str, replace: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` as ``write_bytes_atomic`` does."""
    return write_bytes_atomic(path, text.encode("utf-8"), replace)


def write_bytes_atomic(path: str | Path, data: bytes, replace: bool = False) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same directory and an atomic rename.
    The file gets ordinary permissions (0666 less the umask). Raises OutputError when it cannot, or when
    ``path`` holds a file the package did not write and ``replace`` is not asked (``prepare_file_target``)."""
    path = Path(path)
    prepare_file_target(path, replace)
    tmp = path.with_name(_hidden_name(path.name, "tmp"))
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {exc.strerror or exc}") from exc
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write the file: {exc.strerror or exc}") from exc
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
    return path


def prepare_file_target(path: str | Path, replace: bool = False, job: str | None = None,
                        suggestion: str = "") -> None:
    """Check before any work that a single output file can go to ``path``: absent, or a regular file this
    package wrote (WRITTEN_BY within its first MARK_BYTES; any regular file with ``replace``) and, when ``job``
    names the job the new file is written for, not for another job (its ``job_mark``; ``suggestion`` says how to
    keep both), never a folder, FIFO, device or socket (which the atomic rename would replace; a symbolic link
    counts as what it points to), and its parent a folder (created if missing) we may write in. Raises
    OutputError naming the path (and both jobs)."""
    path = Path(path)
    kind = special_kind(path)
    if kind == "a folder":
        raise OutputError(f"{path}: is a folder; give a file name for this output")
    if kind is not None:
        raise OutputError(f"{path}: is {kind}, not a regular file: it is never replaced; give a file name")
    if not replace and os.path.exists(path) and not written_here(path):
        raise OutputError(f"{path}: exists and was not written by {WRITTEN_BY}: it is not replaced; give another "
                          "name, or ask for the replacement (--force)")
    other = None if replace or job is None or not os.path.exists(path) else marked_job(path)
    if other is not None and other != job_mark(job)[len(JOB_MARK):]:
        raise OutputError(f"{path}: holds the program of job {other}, not of job {job}: it is not replaced"
                          f"{'; ' + suggestion if suggestion else ''}; or ask for the replacement (--force)")
    _make_parent(path)
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise OutputError(f"{path}: cannot write in the folder {path.parent}: it is not writable")


def job_mark(job: str) -> str:
    """``job=<name>``: the job's name with every character but letters, digits and ``_ . + -`` as ``_``; a name
    longer than the mark allows is cut and ends in ``~`` and 6 hex digits of its SHA-256 (still one per job)."""
    name = re.sub(r"[^A-Za-z0-9_.+-]", "_", job)
    room = JOB_MARK_CHARS - len(JOB_MARK)
    if len(name) > room:
        name = f"{name[:room - 7]}~{hashlib.sha256(job.encode()).hexdigest()[:6]}"
    return JOB_MARK + name


def marked_job(path: Path) -> str | None:
    """The job a file names (``job_mark``, within its first MARK_BYTES), or None."""
    try:
        with open(path, "rb") as handle:
            found = _JOB_MARK_FOUND.search(handle.read(MARK_BYTES).decode("utf-8", "replace"))
    except OSError:
        return None
    return None if found is None else found.group(1)


def written_here(path: Path) -> bool:
    """Whether the regular file ``path`` names WRITTEN_BY within its first MARK_BYTES bytes."""
    try:
        with open(path, "rb") as handle:
            return WRITTEN_BY.encode() in handle.read(MARK_BYTES)
    except OSError:
        return False


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
