"""The certified motion as RAPID and KRL write it (issue 36, "What is written is what was certified"):
``controller_motion.certified_moves`` chooses the targets and zones, the writers render them.

* The demo cell job (``gp7_cell_pick_place``: planned moves over a wall, tool moves, zones of 75 mm), written in
  RAPID and KRL and read back, has an exact stop only where its certified profile stops (``program.stops``, where the
  profile's speed is zero) and a zone everywhere else.
* The joint targets written for its planned moves, read back, lie on the certified path: each is a sample of the
  certified profile, read back within 1e-6 rad on every axis (rounded to 0.0001 deg).
* Its written-program certificate passes (limits and clearance in the cell); the modelled controller path stays
  within WRITTEN_DEVIATION_RAD of the certified path away from the program's own zones, and the cycle time as written
  is within 1.15x of the certified one (stop and go at the planner's vertices took 1.4x).
* ``program`` prints the cycle time as written beside the certified one, and the file's header carries the verdict.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.outputs.controllers.controller_motion import (
    WRITTEN_DEVIATION_RAD,
    certified_moves,
    point_to_polyline,
    written_moves,
    written_program_certificate,
)
from pipeline.outputs.controllers.read_krl import read_krl
from pipeline.outputs.controllers.read_rapid import read_rapid
from pipeline.program.job import load_job
from pipeline.runner import collision_model, program_texts, timed_program

JOB = Path(__file__).resolve().parents[2] / "pipeline" / "demo_jobs" / "gp7_cell_pick_place.yaml"
LANGUAGES = ("rapid", "krl")
#: Written joint values are rounded to 0.0001 deg (8.7e-7 rad at most): on the certified path within 1e-6 rad.
ON_PATH_RAD = 1e-6


@cache
def cell():
    job = load_job(JOB)
    scene = collision_model(job)
    program, _, profile = timed_program(job)
    return job, program, profile, scene, certified_moves(program, profile, scene)


@cache
def read_back(language: str) -> list[dict]:
    """The waypoints of the cell job written in ``language`` with its certified motion and read back."""
    job, program, profile, _, written = cell()
    texts = program_texts(job, language, program, profile, "DEMO", written=written)
    if language == "rapid":
        document = read_rapid(texts[".mod"], "gp7")
    else:
        document = read_krl(texts[".src"], texts[".dat"], "gp7")
    return [w if isinstance(w, dict) else {"joints": w} for w in document["waypoints"]]


def _stopped_at(profile, t: float) -> bool:
    i = int(np.argmin(np.abs(profile.t - t)))
    return float(np.abs(profile.qd[i]).max()) <= 1e-6


@pytest.mark.parametrize("language", LANGUAGES)
def test_exact_stops_only_where_the_certified_profile_stops(language):
    _, program, profile, _, written = cell()
    waypoints = read_back(language)
    assert len(waypoints) == 1 + len(written.moves)         # the start, then one per written move
    passages = profile.details.passages_s
    for w, read in zip(written.moves, waypoints[1:]):
        stops = _stopped_at(profile, passages[w.source]) and w.target is program.moves[w.source - 1].target
        assert (read.get("zone", 0.0) == 0.0) == stops, (w.source, read)
        assert (not w.has_zone) == stops
    # the job's stops: waypoints 1, 4 and 6; the planner's vertices with exact stops (the writers without the
    # certified motion) stop 8 times (issue 36: RAPID ``fine`` 8 times)
    assert sum(not w.has_zone for w in written.moves) == len(program.stops) - 1
    assert sum(not w.has_zone for w in written_moves(program)) == 8


@pytest.mark.parametrize("language", LANGUAGES)
def test_planned_moves_joint_targets_lie_on_the_certified_path(language):
    _, program, profile, _, written = cell()
    waypoints = read_back(language)
    inner = 0
    for w, read in zip(written.moves, waypoints[1:]):
        move = program.moves[w.source - 1]
        if move.planned is None:
            continue
        if w.target is move.target:
            continue         # the planned move's end: the program's waypoint (passed within its zone, or a stop)
        q = np.radians(read["joints"])
        assert np.abs(q - w.target).max() <= ON_PATH_RAD            # written as chosen
        inner += 1
        # a sample of the certified profile, read back within 1e-6 rad on every axis (0.0001 deg rounding)
        nearest = profile.q[np.argmin(np.linalg.norm(profile.q - w.target, axis=1))]
        assert np.abs(nearest - w.target).max() == 0.0
        assert np.abs(q - nearest).max() <= ON_PATH_RAD, (w.source, read)
        assert point_to_polyline(q, profile.q)[0] <= np.sqrt(len(q)) * ON_PATH_RAD
    assert inner >= 2 * len([m for m in program.moves if m.planned is not None])


def test_the_written_program_certificate_passes():
    _, program, profile, scene, written = cell()
    certificate = written.certificate
    assert certificate.passed, certificate.limits
    assert certificate.min_clearance_m >= scene.clearance_m
    assert certificate.duration_s <= 1.15 * profile.duration
    stop_and_go = written_program_certificate(program, written_moves(program), profile, scene)[1]
    assert certificate.duration_s < stop_and_go.duration_s
    # away from the program's own zones (whose corners are the controller's, not the certified blend), the
    # modelled path keeps within the stated deviation of the certified one
    inner = [k for k, w in enumerate(written.moves) if program.moves[w.source - 1].planned is not None
             and w.target is not program.moves[w.source - 1].target]
    beside_own_zone = {k for k in range(len(written.moves)) if any(
        j >= 0 and written.moves[j].has_zone and written.moves[j].target is program.moves[written.moves[j].source - 1]
        .target for j in (k - 1, k))}
    bounded = [k for k in inner if k not in beside_own_zone]
    assert bounded
    assert certificate.deviation_rad[bounded].max() <= WRITTEN_DEVIATION_RAD
    assert tuple(bounded) == written.bounded and written.bounded_deviation_rad <= WRITTEN_DEVIATION_RAD
    assert certificate.max_deviation_rad <= 2 * WRITTEN_DEVIATION_RAD
    assert written.changes == ()


@pytest.mark.parametrize("language", LANGUAGES)
def test_program_prints_both_cycle_times(language, tmp_path, capsys):
    assert main(["program", str(JOB), "--lang", language, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    _, _, profile, _, written = cell()
    assert f"the certified profile takes {profile.duration:.4f} s" in out
    assert f"as written: {written.timing.duration_s:.4f} s (certified {profile.duration:.4f} s)" in out
    assert "written-program certificate passed" in out
    text = next(tmp_path.glob("*.mod" if language == "rapid" else "*.src")).read_text()
    text = " ".join(line.strip().lstrip("!;").strip() for line in text.splitlines())     # comments unwrapped
    assert "certificate PASSED" in text and f"cycle time as written {written.timing.duration_s:.3f} s" in text


@pytest.mark.parametrize("language", LANGUAGES)
def test_program_read_program_run_in_the_cell_without_planning(language, tmp_path, capsys):
    """The issue's round trip: ``program`` -> ``read-program`` (the planned moves come back as the joint targets they
    were written as, with their zones, in the job's length unit) -> ``run`` in the same cell without planning: certified
    (limits and clearance), within 1.15x of the certified duration, stopping exactly where the original stops."""
    job, _, profile, _, written = cell()
    assert main(["program", str(JOB), "--lang", language, "--out", str(tmp_path)]) == 0
    source = next(tmp_path.glob("*.mod" if language == "rapid" else "*.src"))
    read = tmp_path / "read.yaml"
    assert main(["read-program", str(source), "--robot", "gp7", "--out", str(read)]) == 0
    text = read.read_text()
    assert "plan:" not in text
    read.write_text(text.replace("robot: gp7\n", f"robot: gp7\ncell: {job.cell.name}\n", 1))
    out = tmp_path / "run"
    assert main(["run", str(read), "--out", str(out)]) == 0
    capsys.readouterr()
    report = json.loads((out / "report.json").read_text())
    assert report["limits"]["timed"]["passed"] and report["cell"]["clearance"]["passed"]
    assert report["duration_s"] <= 1.15 * profile.duration
    assert report["program"]["stops"] == [0] + [k + 1 for k, w in enumerate(written.moves) if not w.has_zone]
    zones = [w.get("zone", 0.0) for w in load_yaml_waypoints(read)]
    assert zones[1:-1] == pytest.approx([w.zone_m * 1e3 for w in written.moves[:-1]], abs=1e-3)   # mm, as written


def load_yaml_waypoints(path: Path) -> list[dict]:
    import yaml

    return [w if isinstance(w, dict) else {"joints": w} for w in yaml.safe_load(path.read_text())["waypoints"]]
