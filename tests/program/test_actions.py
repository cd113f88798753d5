"""Process actions: read from the job, carried by the program, and a wait is a rest of its length in the profile,
the lower bound, the cycle report and the written program's timing."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import JobFileError
from pipeline.outputs.controllers.controller_motion import certified_moves
from pipeline.program.actions import PULSE, SET, WAIT, WAIT_INPUT, Action, Signal
from pipeline.program.job import parse_job
from pipeline.program.report import cycle_lines
from pipeline.runner import reported_program

GRIPPER_JOB = Path(__file__).resolve().parents[1] / "data" / "gp7_gripper_pick_place.yaml"
#: The gripper job's waits: 0.25 s at the pick (waypoint 2), 0.2 s at the place (waypoint 5).
RESTS = {2: 0.25, 5: 0.2}


def gripper_document() -> dict:
    import yaml

    return yaml.safe_load(GRIPPER_JOB.read_text())


def without_actions(document: dict) -> dict:
    out = copy.deepcopy(document)
    out.pop("signals")
    for waypoint in out["waypoints"]:
        waypoint.pop("do", None)
    return out


@pytest.fixture(scope="module")
def timed():
    """(program, profile, report) of the gripper job and of the same job without its actions."""
    document = gripper_document()
    with_actions = reported_program(parse_job(document, str(GRIPPER_JOB), "gripper"))
    bare = reported_program(parse_job(without_actions(document), "<bare>", "bare"))
    return with_actions, bare


def test_actions_and_signals_are_read_in_order():
    job = parse_job(gripper_document(), str(GRIPPER_JOB), "gripper")
    assert job.signals["part_present"] == Signal("part_present", "input", 3)
    assert job.waypoints[2].actions == (Action(WAIT_INPUT, "part_present", True, timeout_s=2.0),
                                        Action(SET, "gripper_close", True), Action(WAIT, time_s=0.25))
    assert [a.kind for a in job.waypoints[5].actions] == ["comment", SET, PULSE, WAIT]
    assert job.waypoints[5].actions[2] == Action(PULSE, "blow_off", True, time_s=0.1)
    assert job.waypoints[1].actions == ()


def test_a_wait_is_a_rest_of_its_length_in_the_certified_profile(timed):
    (program, profile, report), (_, bare_profile, bare_report) = timed
    assert profile.certificate.passed
    assert profile.duration == pytest.approx(bare_profile.duration + sum(RESTS.values()), abs=1e-9)
    passages = profile.details.passages_s
    for k, rest in RESTS.items():
        assert k in program.stops
        inside = (profile.t >= passages[k]) & (profile.t <= passages[k] + rest)
        assert inside.sum() >= rest / program.dt
        assert np.abs(profile.qd[inside]).max() < 1e-12      # the stop sample itself: round-off of its back end
        assert np.ptp(profile.q[inside], axis=0).max() < 1e-12
    # the motion itself is the same: each move lasts as long as without the actions
    durations = [m["duration_s"] for m in report["cycle"]["moves"]]
    assert durations == pytest.approx([m["duration_s"] for m in bare_report["cycle"]["moves"]], abs=1e-9)
    assert report["cycle"]["lower_bound_s"] == pytest.approx(bare_report["cycle"]["lower_bound_s"] + 0.45, abs=1e-12)


def test_the_cycle_report_names_the_actions_and_their_rest(timed):
    (_, _, report), _ = timed
    actions = {a["at"]: a for a in report["cycle"]["actions"]}
    assert sorted(actions) == [0, 2, 5]
    assert actions[2]["actions"] == ["wait for part_present on (timeout 2 s)", "set gripper_close on", "wait 0.25 s"]
    assert actions[2]["rest_s"] == pytest.approx(0.25)
    assert report["cycle"]["rests_s"] == pytest.approx(0.45)
    lines = cycle_lines(report["cycle"])
    at_pick = next(i for i, line in enumerate(lines) if line.lstrip().startswith("at 2 "))
    assert "[0.250 s]" in lines[at_pick] and lines[at_pick + 1].lstrip().startswith("move 2->3")
    assert "[no stop]" in next(line for line in lines if line.lstrip().startswith("at 0 "))


def test_the_written_program_rests_for_the_waits_too(timed):
    (program, profile, _), (bare_program, bare_profile, _) = timed
    written = certified_moves(program, profile)
    bare = certified_moves(bare_program, bare_profile)
    assert written.timing.duration_s == pytest.approx(bare.timing.duration_s + 0.45, abs=1e-9)


def test_a_wait_between_joint_moves_makes_a_stop():
    job = parse_job({"robot": "gp7", "angle_unit": "deg", "signals": {"clamp": {"output": 4}},
                     "waypoints": [[0, 0, 0, 0, -90, 0], {"joints": [30, 0, 0, 0, -90, 0], "do": [{"wait": 0.1}]},
                                   {"joints": [60, 0, 0, 0, -90, 0], "do": [{"set": "clamp", "value": "on"}]},
                                   [90, 0, 0, 0, -90, 0]]}, "<joint>", "joint")
    program, profile, _ = reported_program(job)
    assert program.stops == (0, 1, 3)                 # the set at waypoint 2 does not stop the motion
    assert profile.details.rests_s == (0.0, 0.1, 0.0, 0.0)


BAD_ACTIONS = [
    ({"set": "gripper", "value": "on"}, "names no signal", "waypoints[1].do[0].set"),
    ({"set": "part_present", "value": "on"}, "is a digital input", "waypoints[1].do[0].set"),
    ({"wait_input": "gripper_close", "value": "on"}, "is a digital output", "waypoints[1].do[0].wait_input"),
    ({"wait": 250}, "at most 3600", None),
    ({"wait": 5000}, "milliseconds", "waypoints[1].do[0].wait"),
    ({"wait": 0}, "must be in", "waypoints[1].do[0].wait"),
    ({"set": "gripper_close", "value": "maybe"}, "must be on or off", "waypoints[1].do[0].value"),
    ({"set": "gripper_close"}, "required key is missing", "waypoints[1].do[0].value"),
    ({"wait": 1, "set": "gripper_close"}, "must be one action", "waypoints[1].do[0]"),
    ({"comment": "two\nlines"}, "one line", "waypoints[1].do[0].comment"),
    ({"pulse": "gripper_close", "time": 0.1, "value": "on"}, "unknown key", "waypoints[1].do[0].value"),
]


@pytest.mark.parametrize("action, problem, field", BAD_ACTIONS)
def test_bad_actions_name_the_field(action, problem, field):
    document = gripper_document()
    document["waypoints"][1]["do"] = [action]
    if problem == "at most 3600":
        parse_job(document, "job.yaml", "job")           # 250 s is a plausible wait
        return
    with pytest.raises(JobFileError, match=problem) as error:
        parse_job(document, "job.yaml", "job")
    assert field in str(error.value)


def test_a_wait_where_the_waypoint_has_a_zone_is_refused():
    document = gripper_document()
    document["waypoints"][3]["do"] = [{"wait": 0.1}]          # waypoint 3 has a 60 mm zone
    with pytest.raises(JobFileError, match="actions wait or change the load there, so the motion stops: remove the zone"):
        parse_job(document, "job.yaml", "job")


@pytest.mark.parametrize("signals, problem", [
    ({"1grip": {"output": 1}}, "a signal's name is a letter"),
    ({"grip": {"out": 1}}, "must be {output: N} or {input: N}"),
    ({"grip": {"output": -1}}, "whole number"),
    ({"grip": {"output": 2.5}}, "whole number"),
])
def test_bad_signal_tables_are_refused(signals, problem):
    document = without_actions(gripper_document())
    document["signals"] = signals
    with pytest.raises(JobFileError, match=problem):
        parse_job(document, "job.yaml", "job")
