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
import re
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
from pipeline.runner import collision_model, program_texts, timed_program, zone_differences

JOB = Path(__file__).resolve().parents[2] / "trajectories" / "jobs" / "gp7_cell_pick_place.yaml"
#: RAPID in make test, KRL too in the slow run (the same motion, written twice).
EACH = ("rapid", pytest.param("krl", marks=pytest.mark.slow))
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


@pytest.mark.slow
@pytest.mark.parametrize("language", EACH)
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


@pytest.mark.parametrize("language", EACH)
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


@pytest.mark.slow
@pytest.mark.parametrize("language", EACH)
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


@pytest.mark.slow
@pytest.mark.parametrize("language", EACH)
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
    # the same motion, not a faster one: the TCP acceleration limit comes back (RAPID PathAccLim, KRL $ACC.CP)
    assert report["duration_s"] >= profile.duration - 1e-3
    assert "tcp_accel_max: 2500" in text
    assert report["program"]["stops"] == [0] + [k + 1 for k, w in enumerate(written.moves) if not w.has_zone]
    zones = [w.get("zone", 0.0) for w in load_yaml_waypoints(read)]
    assert zones[1:-1] == pytest.approx([w.zone_m * 1e3 for w in written.moves[:-1]], abs=1e-3)   # mm, as written


def load_yaml_waypoints(path: Path) -> list[dict]:
    import yaml

    return [w if isinstance(w, dict) else {"joints": w} for w in yaml.safe_load(path.read_text())["waypoints"]]


# -- FANUC LS, Yaskawa JBI and URScript write the certified motion too -------------------------------------------
#: An LS or JBI motion line: its instruction and what ends it (FANUC: FINE / CNTn; Yaskawa: PL=n or nothing).
LS_MOTION = re.compile(r"^\s*\d+:\s+[JLC] P\[\d+\].*?(FINE|CNT\d+) ;$")
LS_ARC_END = re.compile(r"^\s*:\s+P\[\d+\].*?(FINE|CNT\d+) ;$")
JBI_MOTION = re.compile(r"^MOV[JLC] C\d{5} V\S*=\S+( PL=\d)?( FPT)?$")


def _terminations(language: str, text: str) -> list[str]:
    """Per written motion (the approach to the start first), how it ends: "" for an exact stop, else the zone."""
    if language == "ls":
        ends = [m.group(1) for line in text.splitlines() if (m := LS_MOTION.match(line) or LS_ARC_END.match(line))]
        return ["" if end == "FINE" else end for end in ends]
    return [(m.group(1) or "").strip() for line in text.splitlines() if (m := JBI_MOTION.match(line))]


@pytest.mark.parametrize("language", ("ls", "jbi"))
def test_ls_and_jbi_stop_exactly_only_where_the_certified_profile_stops(language):
    """The demo cell job in LS and JBI: a motion per written move (the certified path's joint targets for its planned
    moves), an exact stop (FINE, no PL) only where the certified profile stops, CNT / PL everywhere else, the
    closest to each zone, the rule and the per-move difference in the header."""
    job, program, profile, _, written = cell()
    text = next(iter(program_texts(job, language, program, profile, "DEMO", written=written).values()))
    ends = _terminations(language, text)
    assert len(ends) == 1 + len(written.moves) and ends[0] == ""
    passages = profile.details.passages_s
    for w, end in zip(written.moves, ends[1:]):
        stops = _stopped_at(profile, passages[w.source]) and w.target is program.moves[w.source - 1].target
        assert (end == "") == stops, (w.source, end)
    assert sum(end == "" for end in ends[1:]) == len(program.stops) - 1
    comment = re.compile(r"^\s*\d+:\s+!(.*) ;$" if language == "ls" else r"^'(.*)$")
    flat = " ".join(m.group(1).strip() for line in text.splitlines() if (m := comment.match(line)))
    assert "certificate PASSED" in flat
    if language == "ls":
        assert "CNTn = ceil(100 zone / reach)" in flat and "closest CNT at or above the zone, not equal" in flat
        assert all(re.fullmatch(r"CNT\d+", end) and 1 <= int(end[3:]) <= 100 for end in ends if end)
    else:
        assert "PL1..PL8 = 12.5/25/50/100/200/400/800/1600 mm is an ASSUMPTION" in flat
        assert all(re.fullmatch(r"PL=[1-8]", end) for end in ends if end)
    assert len(zone_differences(language, program, written)) == sum(w.has_zone for w in written.moves)


def _ur5_job(tmp_path: Path, outputs: list[str]) -> Path:
    import yaml

    from .test_urscript import UR5_JOB

    path = tmp_path / "ur5_moves.yaml"
    path.write_text(yaml.safe_dump({**UR5_JOB, "outputs": outputs}))
    return path


def test_urscript_writes_blend_radii_where_the_motion_flows(tmp_path):
    """A UR5 job in URScript: native_moves writes one move per written move, its blend radius r the written zone
    exactly [m], r = 0 only where the certified profile stops."""
    job = load_job(_ur5_job(tmp_path, ["json"]))
    program, _, profile = timed_program(job)
    written = certified_moves(program, profile)
    text = program_texts(job, "urscript", program, profile, written=written)[".script"]
    native = text.split("def native_moves():", 1)[1].split("\n  end", 1)[0]
    radii = [float(r) for r in re.findall(r"^\s*move[jlc]\(.*, r=([0-9.]+)(?:, mode=0)?\)$", native, re.MULTILINE)]
    assert len(radii) == 1 + len(written.moves) and radii[0] == 0.0
    assert radii[1:] == pytest.approx([w.zone_m for w in written.moves], abs=1e-6)
    for w, r in zip(written.moves, radii[1:]):
        assert (r == 0.0) == (w.source in program.stops and w.target is program.moves[w.source - 1].target)
    assert any(r > 0.0 for r in radii)
    flat = " ".join(line.strip()[1:].strip() for line in text.splitlines() if line.strip().startswith("#"))
    assert "blend radii r are the written zones exactly" in flat and "certificate PASSED" in flat


@pytest.mark.slow
def test_run_writes_the_written_program_certificate_into_report_json(tmp_path, capsys):
    """``run`` of a job listing controller outputs: report.json carries the written program's certificate per
    language (verdict, smallest clearance in a cell, largest deviation, duration as written beside the certified
    one, exact stops, zone changes with their cost, what LS/JBI write instead of each zone), and ``run`` prints the
    cycle time as written beside the certified one."""
    job_path = tmp_path / "cell.yaml"
    text = JOB.read_text()
    job_path.write_text(re.sub(r"^outputs: .*$", "outputs: [json, ls, jbi]", text, flags=re.MULTILINE))
    assert main(["run", str(job_path), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    _, program, _, scene, written = cell()
    for language in ("ls", "jbi"):
        w = report["written_programs"][language]
        assert w["passed"] and w["clearance_passed"] and w["min_clearance_m"] >= scene.clearance_m
        assert w["duration_s"] == pytest.approx(written.timing.duration_s, rel=1e-6)
        assert w["certified_duration_s"] == pytest.approx(report["duration_s"])
        assert w["exact_stops"] == w["job_exact_stops"] - 1 == len(program.stops) - 1
        assert w["max_deviation_rad"] == pytest.approx(written.certificate.max_deviation_rad)
        assert w["zone_changes"] == [] and len(w["zone_differences"]) == sum(m.has_zone for m in written.moves)
        # with the zones the language writes (CNT's n % of its reach, the assumed PL distances): still certified
        own = w["language_zones"]
        assert own["passed"] and own["min_clearance_m"] >= scene.clearance_m
        assert own["duration_s"] <= 1.15 * report["duration_s"]
        title = {"ls": "FANUC LS", "jbi": "Yaskawa INFORM"}[language]
        assert (f"{title} as written: {w['duration_s']:.4f} s (certified {report['duration_s']:.4f} s), "
                "written-program certificate passed") in out
    assert (tmp_path / "out" / "program.ls").exists() and (tmp_path / "out" / "program.jbi").exists()


# -- joint moves as the certified motion (the demo jobs of joint waypoints) ------------------------------------
DEMO = JOB.parent


@cache
def demo(name: str):
    job = load_job(DEMO / f"{name}.yaml")
    program, _, profile = timed_program(job)
    return program, profile, certified_moves(program, profile, collision_model(job))


@pytest.mark.parametrize("name", ["irb1600_joint_moves", "arm5_joint_spline",
                                  pytest.param("arm6_joint_rad", marks=pytest.mark.slow)])
def test_joint_moves_are_written_as_the_certified_motion(name):
    """Plain joint moves: within 1.15x of the certified duration as written (straight joint segments with z0 corners
    took 1.14x for the IRB 1600's blended path and 1.31x for arm6), certified, an exact stop only where the certified
    profile is at rest, a zone everywhere else (no job-specific zone dropped)."""
    program, profile, written = demo(name)
    assert written.certificate.passed, written.certificate.limits
    assert written.certificate.duration_s <= 1.15 * profile.duration
    passages = profile.details.passages_s
    for w in written.moves:
        end = w.target is program.moves[w.source - 1].target
        assert (not w.has_zone) == (end and _stopped_at(profile, passages[w.source])), (name, w.source)
    # no zone changed; a jerk-limited job's curved joint moves (ruckig's, at rest at each waypoint) are written
    # straight, each reported with the certified path's departure from it
    assert all("written as one joint move" in change for change in written.changes)
    assert bool(written.changes) == (program.timing == "ruckig")


def test_a_curved_joint_move_is_written_as_joint_targets_on_the_certified_path():
    """arm5_joint_spline (a spline through joint waypoints, toppra): each joint move whose certified path departs
    from the straight segment by more than the bound is written as samples of the certified profile with zones, the
    modelled path within WRITTEN_DEVIATION_RAD of the certified one; read back, the same targets and zones."""
    program, profile, written = demo("arm5_joint_spline")
    inner = [w for w in written.moves if w.target is not program.moves[w.source - 1].target]
    assert len(inner) > len(program.moves)
    for w in inner:
        assert np.linalg.norm(profile.q - w.target, axis=1).min() == 0.0      # a sample of the certified profile
        assert w.has_zone
    assert written.bounded and written.bounded_deviation_rad <= WRITTEN_DEVIATION_RAD


def test_a_straight_enough_joint_move_keeps_one_target_and_takes_the_certified_corner():
    """irb1600_joint_moves (lines with blended corners): the certified path misses each inner waypoint by its blend;
    written as one joint move per waypoint with a zone of the blend's TCP reach (no extra targets)."""
    program, _, written = demo("irb1600_joint_moves")
    assert len(written.moves) == len(program.moves)
    assert all(w.zone_m >= 0.05 for w in written.moves[:-1]) and not written.moves[-1].has_zone


@pytest.mark.parametrize("language", EACH)
def test_curved_joint_moves_are_written_and_read_back_as_their_joint_targets(language, tmp_path):
    """The IRB 1600 joint job on its default (monotone spline) path: its joint moves depart from the straight segments,
    so each is written as joint targets on the certified path with zones (within 1.15x of the certified duration,
    the modelled path within WRITTEN_DEVIATION_RAD away from the job's own zones); read back, exactly the written
    moves (no extra waypoint), each target within 1e-6 rad and each zone as written."""
    source = tmp_path / "irb1600_spline.yaml"
    source.write_text((DEMO / "irb1600_joint_moves.yaml").read_text().replace("path: linear\n", ""))
    job = load_job(source)
    program, _, profile = timed_program(job)
    written = certified_moves(program, profile, collision_model(job))
    assert len(written.moves) > 2 * len(program.moves)
    assert written.certificate.passed and written.changes == ()
    assert written.certificate.duration_s <= 1.15 * profile.duration
    assert written.bounded_deviation_rad <= WRITTEN_DEVIATION_RAD
    texts = program_texts(job, language, program, profile, "SPLINE", written=written)
    document = (read_rapid(texts[".mod"], "irb1600") if language == "rapid"
                else read_krl(texts[".src"], texts[".dat"], "irb1600"))
    waypoints = [w if isinstance(w, dict) else {"joints": w} for w in document["waypoints"]]
    assert len(waypoints) == 1 + len(written.moves)
    for w, read in zip(written.moves, waypoints[1:]):
        assert np.abs(np.radians(read["joints"]) - w.target).max() <= ON_PATH_RAD
        assert read.get("zone", 0.0) == pytest.approx(w.zone_m, abs=1e-6)
