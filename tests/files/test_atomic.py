"""Files written safely: folders replaced whole (staged_output) and single atomic files."""

from __future__ import annotations

import errno
import os
import re
import stat
import subprocess
import sys
from pathlib import Path

import pytest

import pipeline.files.atomic
from pipeline.errors import OutputError
from pipeline.files.atomic import OWNER_MARKER, WRITTEN_BY, staged_output, write_text_atomic, written_here


def write_set(out, files: dict[str, str]) -> None:
    """Write ``files`` (name -> text) through staged_output(out)."""
    with staged_output(out) as staging:
        for name, text in files.items():
            (staging / name).write_text(text)


def visible(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name != OWNER_MARKER)


def test_a_second_set_replaces_the_first_whole(tmp_path):
    out = tmp_path / "out" / "job"
    write_set(out, {"a.txt": "a", "b.txt": "b", "c.txt": "c"})
    assert visible(out) == ["a.txt", "b.txt", "c.txt"] and (out / OWNER_MARKER).is_file()
    write_set(out, {"b.txt": "new b"})
    assert visible(out) == ["b.txt"] and (out / "b.txt").read_text() == "new b"
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["job"]          # no staging left


def test_without_renameat2_the_old_folder_is_renamed_aside(tmp_path, monkeypatch):
    monkeypatch.setattr(pipeline.files.atomic, "_exchange", lambda a, b: False)
    out = tmp_path / "job"
    write_set(out, {"a.txt": "a"})
    write_set(out, {"b.txt": "b"})
    assert visible(out) == ["b.txt"] and [p.name for p in tmp_path.iterdir()] == ["job"]


def fail(path):
    path.write_text("half")
    raise RuntimeError("disk full")


def test_failing_writer_leaves_nothing_behind(tmp_path):
    out = tmp_path / "job"
    with pytest.raises(RuntimeError, match="disk full"):
        with staged_output(out) as staging:
            fail(staging / "a.txt")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("error", [RuntimeError("disk full"), KeyboardInterrupt()])
def test_failing_writer_keeps_the_previous_outputs(tmp_path, error):
    out = tmp_path / "job"
    write_set(out, {"a.txt": "old"})
    with pytest.raises(type(error)):
        with staged_output(out) as staging:
            (staging / "a.txt").write_text("new")
            raise error
    assert [p.name for p in tmp_path.iterdir()] == ["job"]
    assert visible(out) == ["a.txt"] and (out / "a.txt").read_text() == "old"


def test_a_file_or_an_unwritable_place_is_refused_before_anything_is_made(tmp_path):
    (tmp_path / "afile").write_text("mine")
    for out in (tmp_path / "afile", tmp_path / "afile" / "out", Path("/proc/dh-pipeline-test/out")):
        with pytest.raises(OutputError, match=re.escape(str(out))):
            with staged_output(out):
                pytest.fail("entered the stage")
    assert [p.name for p in tmp_path.iterdir()] == ["afile"] and (tmp_path / "afile").read_text() == "mine"


def test_a_folder_holding_other_files_is_never_replaced(tmp_path):
    home = tmp_path / "home"
    home.mkdir()
    (home / "thesis.tex").write_text("years of work")
    with pytest.raises(OutputError, match="did not write.*thesis.tex"):
        write_set(home, {"a.txt": "a"})
    assert [p.name for p in home.iterdir()] == ["thesis.tex"] and [p.name for p in tmp_path.iterdir()] == ["home"]
    out = tmp_path / "out"
    write_set(out, {"a.txt": "a"})
    (out / "notes.txt").write_text("added by hand")                 # not listed in the marker
    with pytest.raises(OutputError, match="notes.txt"):
        write_set(out, {"a.txt": "b"})
    assert (out / "a.txt").read_text() == "a"


def test_an_empty_folder_is_filled(tmp_path):
    (tmp_path / "empty").mkdir()
    write_set(tmp_path / "empty", {"a.txt": "a"})
    assert visible(tmp_path / "empty") == ["a.txt"]


def dead_pid() -> int:
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def test_staging_of_dead_processes_is_removed_at_the_next_run(tmp_path):
    dead = tmp_path / f".job.staging-{dead_pid()}-0123abcd"
    aside = tmp_path / f".job.old-{dead_pid()}-0123abcd"
    live = tmp_path / f".job.staging-{os.getpid()}-0123abcd"       # a run still going: kept
    other = tmp_path / f".jobs.staging-{dead_pid()}-0123abcd"       # another target's: kept
    for folder in (dead, aside, live, other):
        folder.mkdir()
        (folder / "profile.csv").write_text("half")
    write_set(tmp_path / "job", {"a.txt": "a"})
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["job", live.name, other.name])


def test_outputs_get_ordinary_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        write_set(tmp_path / "job", {"a.txt": "a"})
        single = write_text_atomic(tmp_path / "d" / "x.json", "{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "job").stat().st_mode) == 0o755
    for path in (tmp_path / "job" / "a.txt", tmp_path / "job" / OWNER_MARKER, single):
        assert stat.S_IMODE(path.stat().st_mode) == 0o644, path


def test_write_text_atomic_creates_the_directory(tmp_path):
    path = write_text_atomic(tmp_path / "d" / "x.json", "{}")
    assert path.read_text() == "{}" and [p.name for p in path.parent.iterdir()] == ["x.json"]


def test_write_text_atomic_refuses_a_folder(tmp_path):
    with pytest.raises(OutputError, match="is a folder"):
        write_text_atomic(tmp_path, "{}")
    assert list(tmp_path.iterdir()) == []


def test_a_file_not_written_here_is_never_replaced_without_asking(tmp_path):
    """A user's notes.yaml at the path of an output: refused, naming it, and kept; replaced only when asked."""
    notes = tmp_path / "notes.yaml"
    notes.write_text("my notes\n")
    with pytest.raises(OutputError, match=r"notes.yaml: exists and was not written by dh-pipeline.*--force"):
        write_text_atomic(notes, f"# written by {WRITTEN_BY}\n")
    assert notes.read_text() == "my notes\n"
    write_text_atomic(notes, f"# written by {WRITTEN_BY}\n", replace=True)
    assert notes.read_text() == f"# written by {WRITTEN_BY}\n"
    write_text_atomic(notes, f"# written by {WRITTEN_BY}, again\n")       # ours now: replaced without asking
    assert written_here(notes) and "again" in notes.read_text()


def test_a_read_only_place_is_an_output_error_not_an_os_error(tmp_path, monkeypatch):
    """On a read-only file system nothing can be created nor removed: the temporary file's clean-up must not
    turn the refusal into an OSError (it did: ``unlink`` of the file never made raised EROFS)."""
    def read_only(*_args, **_kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(pipeline.files.atomic.os, "open", read_only)
    monkeypatch.setattr(Path, "unlink", read_only)
    with pytest.raises(OutputError, match="Read-only file system"):
        write_text_atomic(tmp_path / "robot.urdf", "<robot/>")
