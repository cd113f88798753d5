"""The job reader's moves: per-move speeds, joint waypoints as {joints, speed, zone}, zones between any two
moves, tcp_speed_limit, and what tcp_speed_max means now (the default speed of tool moves). Reader only:
load_job and parse_job, nothing timed."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import JobFileError
from pipeline.program.job import JointWaypoint, PoseWaypoint, load_job, parse_job

START = [0, 0, 0, 0, -90, 0]
ABOVE = {"xyz": [500, 300, 330], "rpy": [180, 0, 0]}
OVER = {"xyz": [500, -300, 330], "rpy": [180, 0, 0]}
DOWN = {"xyz": [500, -300, 200], "rpy": [180, 0, 0]}


def gp7_job(waypoints: list, **changes) -> dict:
    """A GP7 job in mm and deg through ``waypoints``; ``changes`` set keys (None: drop the key)."""
    job = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 500, "start": START,
           "waypoints": waypoints, "outputs": ["json"]}
    job.update(changes)
    return {key: value for key, value in job.items() if value is not None}


def write(tmp_path: Path, job: dict) -> Path:
    """The job as a file: one top-level key per line, each waypoint on its own line (JSON is YAML), so
    that waypoints[k] is on the line after ``waypoints:`` plus k."""
    lines = [f"{key}: {json.dumps(value)}" for key, value in job.items() if key != "waypoints"]
    lines += ["waypoints:"] + [f"  - {json.dumps(w)}" for w in job["waypoints"]]
    path = tmp_path / "job.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def line_of(path: Path, field: str) -> int:
    """The file line of a top-level key or of waypoints[k] (as ``write`` lays them out); a missing key's
    error names the document's first line."""
    lines = path.read_text().splitlines()
    if field.startswith("waypoints["):
        return lines.index("waypoints:") + 2 + int(field.split("[")[1].split("]")[0])
    return next((i for i, text in enumerate(lines, 1) if text.startswith(f"{field.split('.')[0]}:")), 1)


def test_speeds_and_zones_are_stored_in_si_units():
    """A tool move's speed mm/s -> m/s, a joint move's percentage -> a fraction, zones mm -> m."""
    job = parse_job(gp7_job([ABOVE, {**OVER, "speed": 40, "zone": 30}, {**DOWN, "move": "linear", "speed": 250,
                                                                          "zone": 20}, [0, 10, 0, 0, -60, 0]],
                            tcp_speed_limit=750))
    joint_move, line, last = job.waypoints[1:]
    assert (joint_move.move, joint_move.speed, joint_move.zone) == ("joint", pytest.approx(0.4), pytest.approx(0.03))
    assert (line.move, line.speed, line.zone) == ("linear", pytest.approx(0.25), pytest.approx(0.02))
    assert (last.speed, last.zone) == (None, 0.0)
    assert job.waypoints[0].speed is None and job.tcp_speed_limit == pytest.approx(0.75)
    in_metres = parse_job(gp7_job([{"xyz": [0.5, 0.3, 0.33], "rpy": [180, 0, 0]},
                                   {"xyz": [0.5, 0.3, 0.2], "rpy": [180, 0, 0], "move": "linear", "speed": 0.25}],
                                  length_unit="m", tcp_speed_max=None, tcp_speed_limit=0.5))
    assert in_metres.waypoints[1].speed == pytest.approx(0.25) and in_metres.tcp_speed_limit == pytest.approx(0.5)


def test_joint_waypoints_may_be_mappings_with_a_speed_and_a_zone():
    """{joints, speed, zone}: joints in the file's angle unit as a list is, speed a percentage, zone in mm; a
    plain list stays a joint waypoint without a zone or a speed of its own."""
    job = parse_job(gp7_job([START, {"joints": [30, 10, 0, 0, -60, 0], "speed": 50, "zone": 25},
                             {"joints": [-30, 10, 0, 0, -60, 0]}, [0, 20, 0, 0, -60, 0]]))
    first, mapped, bare, last = job.waypoints
    assert all(isinstance(w, JointWaypoint) for w in job.waypoints)
    np.testing.assert_allclose(mapped.q, np.radians([30, 10, 0, 0, -60, 0]), atol=1e-15)
    assert (mapped.speed, mapped.zone, mapped.move) == (pytest.approx(0.5), pytest.approx(0.025), "joint")
    assert (bare.speed, bare.zone, first.speed, first.zone) == (None, 0.0, None, 0.0)
    np.testing.assert_allclose(last.q, np.radians([0, 20, 0, 0, -60, 0]), atol=1e-15)


@pytest.mark.parametrize("zone_at, waypoints", [
    ("joint -> linear", [ABOVE, {**OVER, "zone": 40}, {**DOWN, "move": "linear"}]),
    ("linear -> joint", [ABOVE, {**OVER, "move": "linear", "zone": 40}, DOWN]),
    ("joint -> joint", [START, {"joints": [30, 10, 0, 0, -60, 0], "zone": 40}, [-30, 10, 0, 0, -60, 0]]),
    ("linear -> linear", [ABOVE, {**OVER, "move": "linear", "zone": 40}, {**DOWN, "move": "linear"}]),
], ids=lambda value: value if isinstance(value, str) else "")
def test_zones_are_accepted_between_any_two_moves(zone_at, waypoints):
    assert parse_job(gp7_job(waypoints)).waypoints[1].zone == pytest.approx(0.04)


def test_tcp_speed_max_is_optional_when_every_tool_move_has_its_speed():
    job = parse_job(gp7_job([ABOVE, {**OVER, "move": "linear", "speed": 300}, {**DOWN, "move": "linear",
                                                                               "speed": 100}], tcp_speed_max=None))
    assert job.tcp_speed_max is None and [w.speed for w in job.waypoints[1:]] == [pytest.approx(0.3),
                                                                               pytest.approx(0.1)]


#: name -> (job, the field named, words of the message).
JOINT_JOB = [START, {"joints": [30, 10, 0, 0, -60, 0], "zone": 20}, [-30, 10, 0, 0, -60, 0]]
ERRORS = {
    "tool move speed in m/s under mm": (gp7_job([ABOVE, {**OVER, "move": "linear", "speed": 0.25}]),
                                        "waypoints[1].speed", "is this m/s? Under length_unit: mm, 0.25 is 0.25 mm/s"),
    "tool move speed beyond any arm": (gp7_job([ABOVE, {**OVER, "move": "linear", "speed": 50_000}]),
                                       "waypoints[1].speed", "above any arm"),
    "joint move given a TCP speed": (gp7_job([ABOVE, {**OVER, "speed": 250}]), "waypoints[1].speed",
                                     "joint moves take a percentage of the joint speed limits; 250 looks like a TCP "
                                     "speed in mm/s: give the move `move: linear` or write a percentage"),
    "joint move speed 0": (gp7_job([ABOVE, {**OVER, "speed": 0}]), "waypoints[1].speed", "must be in > 0 %"),
    "joint mapping speed above 100": (gp7_job([START, {"joints": [30, 10, 0, 0, -60, 0], "speed": 120}]),
                                      "waypoints[1].speed", "percentage of the joint speed limits, in (0, 100]"),
    "speed on the first waypoint": (gp7_job([{**ABOVE, "speed": 50}, OVER]), "waypoints[0].speed",
                                    "it has no move to it to give a speed"),
    "speed on the first joint mapping": (gp7_job([{"joints": START, "speed": 50}, OVER]), "waypoints[0].speed",
                                         "it has no move to it to give a speed"),
    "zone on the first waypoint": (gp7_job([{**ABOVE, "zone": 30}, OVER, DOWN]), "waypoints[0].zone",
                                   "the motion starts at rest on the first waypoint"),
    "zone on the last waypoint": (gp7_job([ABOVE, OVER, {**DOWN, "move": "linear", "zone": 30}]), "waypoints[2].zone",
                                  "the motion ends at rest on the last waypoint"),
    "zone on the last joint mapping": (gp7_job([START, {"joints": START, "zone": 30}]), "waypoints[1].zone",
                                       "the motion ends at rest on the last waypoint"),
    "negative zone": (gp7_job([ABOVE, {**OVER, "zone": -5}, DOWN]), "waypoints[1].zone", "must be in >= 0 mm"),
    "tool move without a speed nor tcp_speed_max": (
        gp7_job([ABOVE, {**OVER, "move": "linear", "speed": 300}, {**DOWN, "move": "linear"}], tcp_speed_max=None),
        "tcp_speed_max", "required because waypoint 2 is a linear move and gives no speed of its own"),
    "tcp_speed_limit in m/s under mm": (gp7_job([ABOVE, OVER], tcp_speed_limit=0.25), "tcp_speed_limit",
                                        "is this m/s?"),
    "tcp_speed_limit beyond any arm": (gp7_job([ABOVE, OVER], tcp_speed_limit=50_000), "tcp_speed_limit",
                                       "above any arm"),
    "tcp_speed_limit with ruckig": (gp7_job([START, [30, 10, 0, 0, -60, 0]], timing="ruckig", tcp_speed_max=None,
                                            tcp_speed_limit=250), "timing", "TCP limits need toppra or topp3"),
    "a zone with ruckig": (gp7_job(JOINT_JOB, timing="ruckig", tcp_speed_max=None), "waypoints[1].zone",
                           "zones and per-move speeds need toppra or topp3"),
    "a speed with ruckig": (gp7_job([START, {"joints": [30, 10, 0, 0, -60, 0], "speed": 50}], timing="ruckig",
                                    tcp_speed_max=None), "waypoints[1].speed",
                            "zones and per-move speeds need toppra or topp3"),
    "a joint mapping with a move": (gp7_job([START, {"joints": START, "move": "linear"}]), "waypoints[1].move",
                                    "unknown key; allowed: joints, speed, zone"),
    "a joint zone without length_unit": (gp7_job(JOINT_JOB, length_unit=None, tcp_speed_max=None), "length_unit",
                                         "required because a joint waypoint gives a zone"),
}


@pytest.mark.parametrize("case", list(ERRORS), ids=list(ERRORS))
def test_bad_moves_are_refused_naming_the_field_and_its_line(tmp_path, case):
    job, field, words = ERRORS[case]
    path = write(tmp_path, job)
    with pytest.raises(JobFileError) as error:
        load_job(path)
    assert (error.value.field, error.value.line) == (field, line_of(path, field)), str(error.value)
    assert words in error.value.problem and str(error.value).startswith(f"{path}:{error.value.line}: {field}: ")


def test_ruckig_takes_joint_mappings_without_a_zone_or_a_speed():
    """ruckig refuses zones and per-move speeds, not joint mappings without them (nor zone: 0)."""
    job = parse_job(gp7_job([START, {"joints": [30, 10, 0, 0, -60, 0], "zone": 0}], timing="ruckig",
                            tcp_speed_max=None))
    assert job.timing == "ruckig" and job.waypoints[1].zone == 0.0


@pytest.mark.parametrize("key, value", [("tcp_speed_max", 500), ("tcp_accel_max", 2500)])
def test_tcp_limits_of_tool_moves_without_tool_moves_are_warned_about(tmp_path, caplog, key, value):
    """They no longer limit joint moves: the job runs, a warning names the file, the line and the key."""
    path = write(tmp_path, gp7_job([ABOVE, OVER], **{"tcp_speed_max": None, key: value}))
    with caplog.at_level(logging.WARNING, logger="pipeline.program.job"):
        job = load_job(path)
    assert getattr(job, key) > 0
    [record] = [r for r in caplog.records if r.name == "pipeline.program.job"]
    assert record.levelno == logging.WARNING
    message = record.getMessage()
    assert message.startswith(f"{path}:{line_of(path, key)}: {key}: no longer limits anything") and \
        "tcp_speed_limit" in message


def test_no_warning_when_tool_moves_use_the_tcp_limits(caplog):
    with caplog.at_level(logging.WARNING, logger="pipeline.program.job"):
        parse_job(gp7_job([ABOVE, {**OVER, "move": "linear"}], tcp_accel_max=2500))
    assert not [r for r in caplog.records if r.name == "pipeline.program.job"]


def test_tcp_speed_limit_is_a_tcp_limit_for_the_default_outputs():
    """The TCP figure is written by default with a TCP speed limit, even without tool moves."""
    job = parse_job(gp7_job([ABOVE, OVER], tcp_speed_max=None, tcp_speed_limit=250, outputs=None))
    assert "tcp_png" in job.outputs and job.tcp_speed_limit == pytest.approx(0.25)
    assert "tcp_png" not in parse_job(gp7_job([ABOVE, OVER], tcp_speed_max=None, outputs=None)).outputs
    assert parse_job(gp7_job([ABOVE, OVER], tcp_speed_max=None, tcp_speed_limit=250,
                             outputs=["tcp_png"])).outputs == ("tcp_png",)


def test_a_pose_joint_move_at_100_percent_is_the_whole_joint_speed():
    """The bound is inclusive: 100 -> 1, and a small percentage is a fraction, not a unit mistake."""
    job = parse_job(gp7_job([ABOVE, {**OVER, "speed": 100}, {**DOWN, "speed": 0.5}]))
    assert [w.speed for w in job.waypoints[1:]] == [1.0, pytest.approx(0.005)]
    assert all(isinstance(w, PoseWaypoint) and w.move == "joint" for w in job.waypoints)


def test_the_job_format_examples_in_the_readme_read():
    """The first two YAML blocks of trajectories/README.md (the job keys, then the tool moves in the first
    block's robot and units) are jobs the reader takes, with the speeds and zones their comments say."""
    text = (Path(__file__).resolve().parents[2] / "trajectories" / "README.md").read_text()
    keys, tool_moves = (yaml.safe_load(block.split("```")[0]) for block in text.split("```yaml\n")[1:3])
    job = parse_job(keys, base_dir=Path(__file__).resolve().parents[2] / "trajectories" / "jobs")
    assert (job.waypoints[1].speed, job.waypoints[1].zone) == (pytest.approx(0.5), pytest.approx(0.04))
    units = {key: keys[key] for key in ("robot", "length_unit", "angle_unit")}
    job = parse_job({**units, **tool_moves})
    assert [w.speed for w in job.waypoints] == [None, pytest.approx(0.25), None, None, None, pytest.approx(0.8)]
    assert [w.zone for w in job.waypoints] == [0.0, 0.0, pytest.approx(0.05), pytest.approx(0.06), 0.0, 0.0]
    assert job.tcp_speed_limit == pytest.approx(1.0)
