"""Batches and maps on Dask (``pipeline.scale``): the demo jobs on a 2-worker LocalCluster equal their
serial runs (``python -m pipeline run``, each in a process of its own) file for file, jobs that plan
repeat their own run whatever ran before them, a map on the workers equals the one computed in this
process, a job planned by detours and the roadmap gives the same profile in any process, a worker
killed mid-run loses nothing, failed jobs are rows, bad input is typed, and the
command line (``batch``, ``reach``: exit codes, one-line errors, nothing written when interrupted).

Every cluster here is a LocalCluster on 127.0.0.1 (worker processes, no dashboard); every output goes to
tmp_path.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import pipeline.scale.batch
import pipeline.scale.reach
from pipeline.__main__ import main
from pipeline.errors import ClusterError, ScaleInputError
from pipeline.files.atomic import OWNER_MARKER
from pipeline.scale import cluster as cluster_module
from pipeline.scale import dask_client, reachability_map, run_batch
from pipeline.scale.batch import COLUMNS, SUMMARY_CSV, SUMMARY_JSON, job_files
from pipeline.scale.cluster import local_client
from pipeline.scale.result import FILES

ROOT = Path(__file__).resolve().parents[2]
JOBS = ROOT / "trajectories" / "jobs"
CELL = ROOT / "models" / "cells" / "gp7_wall_cell.yaml"
#: Keys of report.json measured by the wall clock (how long IK, timing, planning took): the only
#: values a run on other processes may change.
WALL_CLOCK_KEYS = {"compute_s", "ruckig_compute_s_per_segment", "plan_time_s", "simplify_time_s"}
#: The map compared across processes: the IRB 1600's flange, coarse.
MAP = dict(step=0.15, orientations=8, seed=2)
MAP_ARRAYS = ("fraction", "manipulability", "branches")


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of 2 worker processes for the module."""
    with local_client(2) as client:
        yield client


@pytest.fixture(scope="module")
def serial_runs(tmp_path_factory):
    """``serial_runs(files)``: the folder holding each job file's output in <stem>/, each job run by
    ``run_serially`` once per module (the batch tests compare against the same runs)."""
    folder = tmp_path_factory.mktemp("serial")

    def run(files: list[Path]) -> Path:
        run_serially([path for path in files if not (folder / path.stem).exists()], folder)
        return folder

    return run


@pytest.fixture(scope="module")
def serial_map():
    return reachability_map("irb1600", **MAP)


def without_wall_clock(value):
    if isinstance(value, dict):
        return {k: without_wall_clock(v) for k, v in value.items() if k not in WALL_CLOCK_KEYS}
    if isinstance(value, list):
        return [without_wall_clock(v) for v in value]
    return value


def assert_same_job_output(expected: Path, actual: Path) -> None:
    """Two output folders of one job: the same files; CSV, HTML, PNG, YAML and marker byte for byte,
    NPZ arrays exactly, report.json equal but for WALL_CLOCK_KEYS."""
    names = sorted(p.name for p in expected.iterdir())
    assert sorted(p.name for p in actual.iterdir()) == names
    for name in names:
        if name.endswith(".npz"):
            with np.load(expected / name) as a, np.load(actual / name) as b:
                assert sorted(a.files) == sorted(b.files)
                for key in a.files:
                    np.testing.assert_array_equal(a[key], b[key], err_msg=f"{expected.name}/{name}:{key}")
        elif name == "report.json":
            assert without_wall_clock(json.loads((actual / name).read_text())) == \
                without_wall_clock(json.loads((expected / name).read_text())), f"{expected.name}/{name}"
        else:
            assert (actual / name).read_bytes() == (expected / name).read_bytes(), f"{expected.name}/{name}"


# -- on the cluster -------------------------------------------------------------------------------------
def run_serially(files: list[Path], out: Path) -> None:
    """Each job file run by `python -m pipeline run`, one after the other, each in a process of its own."""
    for path in files:
        subprocess.run([sys.executable, "-m", "pipeline", "run", str(path), "--out", str(out / path.stem)],
                       check=True, capture_output=True)


def check_batch_equals_serial_runs(client, files: list[Path], serial: Path, tmp_path: Path) -> None:
    """The job files run one by one by `python -m pipeline run` (their outputs in ``serial``), then as a
    batch on the client's workers: the same files, and summary rows that say what each job's own report says."""
    outcome = run_batch(files, tmp_path / "batch", client=client)
    assert outcome.workers == 2 and not outcome.failed
    batch = tmp_path / "batch"
    assert sorted(p.name for p in batch.iterdir()) == sorted([OWNER_MARKER, SUMMARY_CSV, SUMMARY_JSON,
                                                              *(p.stem for p in files)])
    for path in files:
        assert_same_job_output(serial / path.stem, batch / path.stem)
    rows = (batch / SUMMARY_CSV).read_text().splitlines()
    assert rows[0] == ",".join(COLUMNS) and len(rows) == len(files) + 1
    summary = json.loads((batch / SUMMARY_JSON).read_text())
    assert summary["ok"] == len(files) and summary["run"]["workers"] == 2
    for row in summary["jobs"]:                            # the rows say what each job's own report says
        report = json.loads((batch / row["job"] / "report.json").read_text())
        assert row["status"] == "ok" and row["duration_s"] == report["duration_s"]
        assert row["samples"] == report["samples"] and row["compute_s"] > 0
        assert row["max_ratio_qd"] == report["limits"]["timed"]["max_ratio"]["qd"]
        clearance = (report["cell"] or {}).get("clearance")
        assert row["clearance_m"] == ("" if clearance is None else clearance["min_distance_m"])


@pytest.mark.slow                                  # every demo job on two workers: about 19 s
def test_demo_jobs_on_two_workers_equal_their_serial_runs_file_for_file(client, serial_runs, tmp_path):
    """A cell with planning, numeric IK with topp3, tool moves with TCP limits: the most varied three."""
    files = [JOBS / f"{name}.yaml" for name in ("gp7_cell_pick_place", "arm5_position_axis", "irb1600_tool_moves")]
    check_batch_equals_serial_runs(client, files, serial_runs(files), tmp_path)


@pytest.mark.slow
def test_all_demo_jobs_on_two_workers_equal_their_serial_runs_file_for_file(client, serial_runs, tmp_path):
    files = sorted(JOBS.glob("*.yaml"))
    check_batch_equals_serial_runs(client, files, serial_runs(files), tmp_path)


@pytest.mark.slow
def test_the_summary_csv_is_the_same_byte_for_byte_in_this_process_and_on_workers(client, tmp_path):
    bad = tmp_path / "jobs" / "broken.yaml"
    bad.parent.mkdir()
    bad.write_text("robot: gp7\nwaypoints: [\n")
    jobs = [JOBS / "arm6_joint_rad.yaml", bad, JOBS / "irb1600_joint_moves.yaml"]
    serial, parallel = run_batch(jobs, tmp_path / "serial"), run_batch(jobs, tmp_path / "parallel", client=client)
    assert (tmp_path / "serial" / SUMMARY_CSV).read_bytes() == (tmp_path / "parallel" / SUMMARY_CSV).read_bytes()
    assert [r["status"] for r in serial.failed] == ["failed"] and serial.workers == 1 and parallel.workers == 2
    assert not (tmp_path / "parallel" / "broken").exists()


@pytest.mark.slow                      # some 12 s (a cluster); the demo jobs on two workers stay in make test
def test_a_map_on_two_workers_equals_the_map_in_this_process(client, serial_map):
    parallel = reachability_map("irb1600", **MAP, client=client, chunk_poses=3000)
    assert parallel.workers == 2 and parallel.chunks > serial_map.chunks
    for name in MAP_ARRAYS:
        np.testing.assert_array_equal(getattr(parallel, name), getattr(serial_map, name))
    assert parallel.summary()["volume_m3"] == serial_map.summary()["volume_m3"]


@pytest.mark.slow                                  # the cell's checker on each worker: about 6 s
def test_a_map_in_a_cell_on_two_workers_equals_the_map_in_this_process(client):
    kwargs = dict(step=0.2, orientations=2, tool_axis_cone=30.0)
    serial = reachability_map(CELL, **kwargs)
    parallel = reachability_map(CELL, **kwargs, client=client)
    for name in MAP_ARRAYS:
        np.testing.assert_array_equal(getattr(parallel, name), getattr(serial, name))
    assert serial.volume_m3() > 0


def _in_a_thread(function) -> tuple[threading.Thread, dict]:
    """Start ``function()`` in a thread; the dict gets its ``result`` or its ``error``."""
    outcome: dict = {}

    def run():
        try:
            outcome["result"] = function()
        except BaseException as exc:             # reported by the test, not lost in the thread
            outcome["error"] = exc

    running = threading.Thread(target=run)
    running.start()
    return running, outcome


def _kill_a_busy_worker(client, running: threading.Thread) -> int:
    """SIGKILL the process of a worker that is computing a task of the map; returns its pid."""
    pids = client.run(os.getpid)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        busy = [address for address, keys in client.processing().items() if keys and address in pids]
        if busy and running.is_alive():
            time.sleep(0.05)                     # into the task
            assert running.is_alive(), "the map finished before a worker could be killed: make it larger"
            os.kill(pids[busy[0]], signal.SIGKILL)
            return pids[busy[0]]
        time.sleep(0.02)
    raise AssertionError("no worker ever got a task of the map")


@pytest.mark.slow
def test_a_worker_killed_during_a_map_loses_nothing(client, serial_map):
    running, outcome = _in_a_thread(lambda: reachability_map("irb1600", **MAP, client=client, chunk_poses=500))
    killed = _kill_a_busy_worker(client, running)
    running.join(timeout=300)
    assert not running.is_alive() and "error" not in outcome, outcome.get("error")
    for name in MAP_ARRAYS:
        np.testing.assert_array_equal(getattr(outcome["result"], name), getattr(serial_map, name))
    deadline = time.monotonic() + 60                       # the nanny starts a new worker process
    while len(client.scheduler_info()["workers"]) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert killed not in client.run(os.getpid).values()


@pytest.mark.slow
def test_a_worker_killed_during_a_batch_loses_nothing(client, serial_runs, tmp_path):
    serial = serial_runs(sorted(JOBS.glob("*.yaml")))
    running, outcome = _in_a_thread(lambda: run_batch(JOBS, tmp_path / "batch", client=client))
    _kill_a_busy_worker(client, running)
    running.join(timeout=600)
    assert not running.is_alive() and "error" not in outcome, outcome.get("error")
    assert not outcome["result"].failed
    for path in sorted(JOBS.glob("*.yaml")):
        assert_same_job_output(serial / path.stem, tmp_path / "batch" / path.stem)


def test_importing_the_package_starts_no_dask_and_no_drake():
    from ..test_layering import loaded_by

    loaded = loaded_by("pipeline.scale")
    assert not [name for name in loaded if name.split(".")[0] in ("dask", "distributed", "pydrake", "matplotlib")]


@pytest.mark.slow                                  # planned jobs in fresh processes: about 15 s
def test_a_job_that_plans_gets_the_plans_of_its_own_run_whatever_ran_before_it(tmp_path):
    """Two copies of the demo cell job in one batch (in this process, which has planned before) plan as a
    fresh `python -m pipeline run` of it does, byte for byte (its moves take deterministic detours)."""
    for name in ("first", "second"):
        shutil.copy(JOBS / "gp7_cell_pick_place.yaml", tmp_path / f"{name}.yaml")
        text = (tmp_path / f"{name}.yaml").read_text().replace("../../models/", f"{ROOT}/models/")
        (tmp_path / f"{name}.yaml").write_text(text)
    run_batch([tmp_path / "first.yaml", tmp_path / "second.yaml"], tmp_path / "batch")
    run_serially([JOBS / "gp7_cell_pick_place.yaml"], tmp_path / "run")
    first, second = ((tmp_path / "batch" / name / "profile.csv").read_bytes() for name in ("first", "second"))
    assert first == second == (tmp_path / "run" / "gp7_cell_pick_place" / "profile.csv").read_bytes()
    moves = json.loads((tmp_path / "batch" / "first" / "report.json").read_text())["program"]["moves"]
    assert [move["planned"]["planner"] for move in moves if move["planned"]] == ["detour", "detour"]


def shelf_job(path: Path) -> Path:
    """A job through five targets of the IRB 1600 bookshelf problem set (``bench plan``): its planned moves
    take a detour and routes through the cell's roadmap (OMPL's search: ``tests/cell/test_planning.py``)."""
    from pipeline.bench.plan_sets import cell_file, problem_set, set_model

    queries = problem_set("irb1600_bookshelf", set_model("irb1600_bookshelf"), count=20, seed=0).queries[4:8]
    targets = [queries[0].start] + [q.goal for q in queries]
    path.write_text(f"cell: {cell_file('irb1600_bookshelf')}\nangle_unit: rad\nplan: collision_free\nwaypoints:\n"
                    + "".join(f"  - {[float(v) for v in q]}\n" for q in targets))
    return path


@pytest.mark.slow                                  # a Dask batch and a fresh process: about 30 s
def test_a_job_planned_by_detours_and_the_roadmap_is_the_same_in_any_process(client, tmp_path):
    """The same profile, byte for byte: in a fresh ``python -m pipeline run``, twice in this process (the
    second with the cell's roadmap already warm), and in a Dask batch of two copies on 2 workers."""
    path = shelf_job(tmp_path / "shelf.yaml")
    shutil.copy(path, tmp_path / "copy.yaml")
    run_serially([path], tmp_path / "run")
    for name in ("here_1", "here_2"):
        assert main(["run", str(path), "--out", str(tmp_path / name)]) == 0
    run_batch([path, tmp_path / "copy.yaml"], tmp_path / "batch", client=client)
    profiles = [(tmp_path / folder / "profile.csv").read_bytes()
                for folder in ("run/shelf", "here_1", "here_2", "batch/shelf", "batch/copy")]
    assert all(profile == profiles[0] for profile in profiles)
    moves = json.loads((tmp_path / "run" / "shelf" / "report.json").read_text())["program"]["moves"]
    assert {"detour", "roadmap"} <= {move["planned"]["planner"] for move in moves}


# -- failed jobs are rows -------------------------------------------------------------------------------
def test_failed_jobs_are_rows_with_their_typed_error(tmp_path, monkeypatch):
    outcome = run_batch([JOBS / "arm6_joint_rad.yaml"], tmp_path / "few", max_samples=10)
    (row,) = outcome.failed
    assert row["status"] == "failed" and row["error_type"] == "ProfileSizeError" and "10" in row["error"]
    assert sorted(p.name for p in (tmp_path / "few").iterdir()) == [OWNER_MARKER, SUMMARY_CSV, SUMMARY_JSON]

    def broken(job, out, max_samples):
        raise RuntimeError("a bug\nover two lines")

    monkeypatch.setattr(pipeline.scale.batch, "run_job", broken)
    outcome = run_batch([JOBS / "arm6_joint_rad.yaml"], tmp_path / "bug")
    (row,) = outcome.failed
    assert (row["status"], row["error_type"]) == ("internal error", "RuntimeError")
    assert row["error"] == "a bug over two lines"
    summary = json.loads((tmp_path / "bug" / SUMMARY_JSON).read_text())
    assert summary["failed"] == 1 and summary["jobs"][0]["error_type"] == "RuntimeError"


# -- bad input ------------------------------------------------------------------------------------------
def test_bad_job_lists_are_typed_errors_naming_the_jobs(tmp_path):
    with pytest.raises(ScaleInputError, match="no job files") as info:
        run_batch([], tmp_path / "out")
    assert info.value.field == "jobs"
    (tmp_path / "empty").mkdir()
    with pytest.raises(ScaleInputError, match="no job files"):
        job_files([tmp_path / "empty"])
    with pytest.raises(ScaleInputError, match="no such job file.*missing.yaml"):
        job_files([tmp_path / "missing.yaml"])
    (tmp_path / "other").mkdir()
    shutil.copy(JOBS / "gp7_pick_place.yaml", tmp_path / "other")
    with pytest.raises(ScaleInputError, match="two jobs named 'gp7_pick_place'"):
        job_files([JOBS, tmp_path / "other"])
    assert not (tmp_path / "out").exists()


def test_bad_cluster_options_are_typed_errors_naming_them(monkeypatch):
    with pytest.raises(ScaleInputError) as info:
        with dask_client(workers=2, scheduler="tcp://127.0.0.1:8786"):
            pass
    assert info.value.field == "--workers/--scheduler" and "tcp://127.0.0.1:8786" in str(info.value)
    with pytest.raises(ScaleInputError, match="--workers"):
        with dask_client(workers=0):
            pass
    with dask_client(workers=1) as none:
        assert none is None
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT_S", 0.5)
    with pytest.raises(ClusterError, match="tcp://127.0.0.1:9"):
        with dask_client(scheduler="tcp://127.0.0.1:9"):
            pass


# -- the command line -----------------------------------------------------------------------------------
@pytest.mark.slow
def test_cli_batch_in_this_process_writes_a_folder_per_job_and_exits_1_when_one_failed(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["batch", str(JOBS / "arm6_joint_rad.yaml"), "--out", str(out), "--workers", "1"]) == 0
    assert (out / "arm6_joint_rad" / "profile.csv").is_file()
    bad = tmp_path / "bad.yaml"
    bad.write_text("robot: gp7\n")
    assert main(["batch", str(JOBS / "arm6_joint_rad.yaml"), str(bad), "--out", str(out), "--workers", "1"]) == 1
    text = capsys.readouterr().out
    assert "1 ok, 1 failed" in text and "bad: failed" in text
    assert sorted(p.name for p in out.iterdir()) == [OWNER_MARKER, "arm6_joint_rad", SUMMARY_CSV, SUMMARY_JSON]


@pytest.mark.parametrize("args, named", [
    (["batch", str(JOBS), "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "--workers/--scheduler"),
    (["batch", "nowhere/"], "nowhere"),
    (["reach", "nope"], "nope"),
    (["reach", "gp7", "--step", "0"], "--step"),
    (["reach", "gp7", "--step", "-5"], "--step"),
    (["reach", "gp7", "--orientations", "0"], "--orientations"),
    (["reach", "gp7", "--tool-axis-cone", "200"], "tool_axis_cone"),
    (["reach", "arm5", "--point", "wrist"], "arm5"),
    (["reach", "gp7", "--point", "elbow"], "point: must be one of end, wrist (got 'elbow')"),
    (["reach", "gp7", "--workers", "0"], "--workers"),
])
def test_cli_bad_input_exits_2_with_one_line_naming_it_and_writes_nothing(args, named, tmp_path, capsys):
    try:
        code = main([*args, "--out", str(tmp_path / "out")])
    except SystemExit as exc:                          # argparse's own checks
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("error: ") and err.count("\n") == 1 and named in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_cli_reach_writes_the_map_files(tmp_path, capsys):
    out = tmp_path / "map"
    assert main(["reach", "irb1600", "--out", str(out), "--step", "250", "--orientations", "2",
                 "--point", "wrist", "--workers", "1", "--seed", "4"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted([OWNER_MARKER, *FILES.values()])
    summary = json.loads((out / FILES["json"]).read_text())
    assert summary["point"] == "wrist" and summary["step_m"] == 0.25 and summary["seed"] == 4
    assert "reach" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["batch", "reach"])
def test_cli_interrupted_leaves_no_output(command, tmp_path, monkeypatch, capsys):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline.scale.batch if command == "batch" else pipeline.scale.reach,
                        "run_job" if command == "batch" else "_solve_targets", interrupted)
    target = str(JOBS / "arm6_joint_rad.yaml") if command == "batch" else "gp7"
    assert main([command, target, "--out", str(tmp_path / "out"), "--workers", "1"]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
