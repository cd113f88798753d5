"""Output folders end to end: a run replaces the folder whole, a killed run leaves the previous
complete output (or none), a bad --out fails before any work, and an oversized profile is refused
before it is made."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import pipeline.runner
from pipeline.errors import OutputError
from pipeline.files.atomic import OWNER_MARKER
from pipeline.program.job import load_job
from pipeline.runner import FILE_NAMES, run_job, run_job_file

ROOT = Path(__file__).resolve().parents[2]
JOBS = ROOT / "trajectories" / "jobs"
GP7_JOB = JOBS / "gp7_pick_place.yaml"            # every output, html and arm_png included
#: How long a reader of a FIFO may take to refuse it before it counts as blocked on it [s] (a refusal takes
#: milliseconds; a blocked open never returns): generous, for a machine busy with other work.
BLOCKED_AFTER_S = 60.0


def job_file(tmp_path: Path, source: Path, name: str, **changes) -> Path:
    """A copy of a demo job with some fields changed, in tmp_path."""
    doc = {**yaml.safe_load(source.read_text()), **changes}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def small_job(tmp_path: Path) -> Path:
    """The arm6 demo job writing only csv and json."""
    return job_file(tmp_path, JOBS / "arm6_joint_rad.yaml", "arm6_small", outputs=["csv", "json"])


def cli(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "pipeline", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pipeline", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300)


def file_names(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


@pytest.mark.slow
def test_a_second_job_replaces_the_first_jobs_outputs(tmp_path):
    out = tmp_path / "out"
    first = run_job_file(GP7_JOB, out)
    assert {p.name for p in first.files} == set(FILE_NAMES.values()) == file_names(out) - {OWNER_MARKER}
    second = run_job_file(small_job(tmp_path), out)
    assert file_names(out) == {"profile.csv", "report.json", OWNER_MARKER}
    assert [p.name for p in second.files] == ["profile.csv", "report.json"]
    assert json.loads((out / "report.json").read_text())["job"] == "arm6_small"
    table = np.loadtxt(out / "profile.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], second.profile.t, rtol=0, atol=1e-9)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm6_small.yaml", "out"]


def assert_one_complete_run(out: Path, references: dict[str, dict]) -> str | None:
    """``out`` is absent (allowed where renameat2 is missing) or holds exactly the files of one
    complete earlier run; returns that job's name (None when absent)."""
    if not out.exists():
        return None
    name = json.loads((out / "report.json").read_text())["job"]
    reference = references[name]
    assert file_names(out) == reference["files"], name
    assert (out / "profile.csv").read_bytes() == reference["csv"], name
    assert json.loads((out / OWNER_MARKER).read_text())["files"] == sorted(reference["files"] - {OWNER_MARKER})
    return name


def kill_trials(tmp_path: Path, trials: int, seed: int) -> None:
    """Complete runs of two jobs into one folder, then runs of the other job SIGKILLed at random
    delays: after each, the folder holds one complete run; the next run clears the stale staging."""
    jobs = {"gp7_pick_place": GP7_JOB, "arm6_small": small_job(tmp_path)}
    out = tmp_path / "runs" / "out"
    references = {}
    for name, path in jobs.items():
        run_job_file(path, out)
        references[name] = {"files": file_names(out), "csv": (out / "profile.csv").read_bytes()}
    rng = np.random.default_rng(seed)
    current = "arm6_small"
    for delay in rng.uniform(0.3, 2.0, trials):
        other = next(name for name in jobs if name != current)
        process = cli("run", str(jobs[other]), "--out", str(out), cwd=tmp_path)
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.communicate(timeout=60)
        current = assert_one_complete_run(out, references) or current
    run_job_file(jobs["arm6_small"], out)                       # cleans what the killed runs left
    assert file_names(out.parent) == {"out"}
    assert_one_complete_run(out, references)


@pytest.mark.slow
def test_a_killed_run_leaves_the_previous_complete_output(tmp_path):
    kill_trials(tmp_path, trials=3, seed=1)


@pytest.mark.slow
def test_many_killed_runs_never_mix_outputs(tmp_path):
    kill_trials(tmp_path, trials=10, seed=2)


@pytest.mark.parametrize("where", ["file", pytest.param("under_a_file", marks=pytest.mark.slow),
                                   pytest.param("proc", marks=pytest.mark.slow)])
def test_bad_out_exits_2_at_once_with_one_line_and_creates_nothing(tmp_path, where):
    (tmp_path / "afile").write_text("mine")
    out = {"file": tmp_path / "afile", "under_a_file": tmp_path / "afile" / "out",
           "proc": Path("/proc/dh-pipeline-test/out")}[where]
    result = run_cli("run", str(GP7_JOB), "--out", str(out), cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(f"error: {out}: ")
    assert "Traceback" not in result.stderr
    assert file_names(tmp_path) == {"afile"} and (tmp_path / "afile").read_text() == "mine"


def test_the_output_folder_is_checked_before_any_work(tmp_path, monkeypatch):
    def never(job, scene=None):
        pytest.fail("IK ran before the output folder was checked")

    monkeypatch.setattr(pipeline.runner, "compile_job", never)
    (tmp_path / "afile").write_text("mine")
    with pytest.raises(OutputError, match="is a file"):
        run_job(load_job(GP7_JOB), tmp_path / "afile")


@pytest.mark.slow
def test_an_oversized_profile_is_refused_at_once_and_nothing_is_written(tmp_path):
    slow = job_file(tmp_path, GP7_JOB, "slow", speed_scale=0.001, dt=0.0001)
    result = run_cli("run", str(slow), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    message = result.stderr
    assert message.startswith(f"error: {slow}: the profile would last ") and "dt = 0.0001 s" in message
    assert "500,000" in message and "--max-samples" in message
    assert file_names(tmp_path) == {"slow.yaml"}


def test_max_samples_raises_the_limit(tmp_path, capsys):
    from pipeline.__main__ import main

    job = str(small_job(tmp_path))
    out = str(tmp_path / "out")
    assert main(["run", job, "--out", out, "--max-samples", "1000"]) == 2
    assert "above the limit of 1,000" in capsys.readouterr().err and not Path(out).exists()
    assert main(["run", job, "--out", out, "--max-samples", "2000"]) == 0
    assert json.loads((Path(out) / "report.json").read_text())["samples"] > 1000


# -- special files are never replaced, never read (fuzz finding 1 of issue 22) ------------------------
def special_files(tmp_path: Path) -> dict[str, Path]:
    """A FIFO and a Unix socket in tmp_path (the kinds a user can make without root; a device such as
    /dev/null is refused by the same check, and is never used in a test)."""
    import os
    import socket

    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    sock_path = tmp_path / "sock.yaml"
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(sock_path))
    sock.close()
    return {"a FIFO": fifo, "a socket": sock_path}


def output_commands(target: Path) -> dict[str, list[str]]:
    """Every command that writes a user path, its output pointed at ``target``."""
    return {"import-urdf": ["import-urdf", str(ROOT / "tests" / "data" / "urdf" / "motoman_gp7.urdf"),
                            "--out", str(target)],
            "export": ["export", "gp7", "--urdf", str(target)],
            "run": ["run", str(JOBS / "arm6_joint_rad.yaml"), "--out", str(target)],
            "check": ["check", "arm6", "--samples", "1", "--out", str(target)],
            "batch": ["batch", str(JOBS / "arm6_joint_rad.yaml"), "--out", str(target), "--workers", "1"],
            "reach": ["reach", "arm6", "--step", "400", "--orientations", "1", "--out", str(target),
                      "--workers", "1"]}


def test_no_command_replaces_a_fifo_or_a_socket_with_a_regular_file(tmp_path, capsys):
    from pipeline.__main__ import main

    for kind, path in special_files(tmp_path).items():
        for command, args in output_commands(path).items():
            assert main(args) == 2, (kind, command)
            err = capsys.readouterr().err
            assert err.startswith("error: ") and kind in err and str(path.name) in err, (command, err)
            assert path.exists() and not path.is_file(), (kind, command)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe.yaml", "sock.yaml"]     # nothing else left


def test_a_link_to_a_special_file_is_refused_like_the_file(tmp_path):
    from pipeline.files.atomic import write_text_atomic

    link = tmp_path / "link.yaml"
    link.symlink_to(special_files(tmp_path)["a FIFO"])
    with pytest.raises(OutputError, match="is a FIFO"):
        write_text_atomic(link, "text")
    assert link.is_symlink()


def read_without_blocking(read, path: Path):
    """``read(path)`` for a FIFO ``path``, in a thread: it must end within BLOCKED_AFTER_S (a reader that
    opens the FIFO would wait for a writer forever: the test opens and closes one to set it free,
    then fails). Returns the exception it raised."""
    import threading

    outcome = {}

    def target():
        try:
            read(path)
        except Exception as exc:            # noqa: BLE001 - handed to the test
            outcome["error"] = exc

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(BLOCKED_AFTER_S)
    blocked = thread.is_alive()
    if blocked:
        with open(path, "wb"):              # a writer: the blocked open returns, the read sees EOF
            pass
        thread.join()
    assert not blocked, f"reading {path} blocked on the FIFO"
    return outcome.get("error")


@pytest.mark.parametrize("reader", ["job", "robot", "cell", "urdf"])
def test_input_files_that_are_fifos_are_refused_without_blocking(tmp_path, reader):
    from pipeline.cell.cell_file import load_cell
    from pipeline.errors import PipelineError
    from pipeline.model.robot import load_robot
    from pipeline.urdf import import_urdf

    read = {"job": load_job, "robot": load_robot, "cell": load_cell, "urdf": import_urdf}[reader]
    fifo = special_files(tmp_path)["a FIFO"]
    error = read_without_blocking(read, fifo)
    assert isinstance(error, PipelineError) and fifo.name in str(error), error
    assert reader in ("robot", "cell") or "FIFO" in str(error), error      # those two look for regular files only
