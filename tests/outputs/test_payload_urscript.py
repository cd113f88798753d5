"""The payload in URScript (issue 40): the UR5 twin of the GP7 payload pick and place (tests/data/programs/ur/
ur5_payload_pick_place.yaml: a 1.2 kg gripper, a 2.5 kg box gripped at waypoint 2 and released at waypoint 5) written
by write_urscript (set_target_payload of the total carried, before the first move and at the grip and the release)
and read back by read_urscript gives the same tool's load, parts, grips and releases and loads per move; PolyScope's
older set_payload reads the same way; what cannot be parts is refused naming the line."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.read_urscript import UrscriptReadError, read_urscript
from pipeline.outputs.controllers.urscript import MAX_REPLAY_LINES, write_urscript
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.timing import time_program

from . import structure_checks
from .test_urscript_actions import ROBOT, actions

lark = pytest.importorskip("lark", reason="lark (pip install lark) parses the URScript grammar")

TESTS = Path(__file__).resolve().parents[1]
JOB = TESTS / "data" / "programs" / "ur" / "ur5_payload_pick_place.yaml"
#: The round trip keeps the loads within: mass [kg], centre of mass [m], inertia [kg m^2].
MASS_TOL, COM_TOL, INERTIA_TOL = 1e-3, 1e-5, 1e-6
TOOL = "set_target_payload(1.2, [0.0, 0.005, 0.045], [0.0031, 0.0029, 0.0012, 0.0, 0.0, 0.0])"
GRIP = ("set_target_payload(3.7, [0.0, 0.001621622, 0.115945946], [0.017259459, 0.017039189, 0.00542027, 0.0, 0.0, "
        "0.000425676])")


@pytest.fixture(scope="module")
def payload_job():
    """(program, its native URScript, the document read_program_text reads from it, that document compiled)."""
    program = compile_job(load_job(JOB))
    text = write_urscript(program, "payload_pick")
    document = read_program_text("urscript", text, ROBOT, "payload_pick.script")
    return program, text, document, compile_job(parse_job(document, source="payload_pick.script"))


def assert_same_load(read, written):
    assert (read is None) == (written is None)
    if written is not None:
        assert abs(read.mass - written.mass) <= MASS_TOL
        assert np.allclose(read.com, written.com, rtol=0.0, atol=COM_TOL)
        assert np.allclose(read.inertia, written.inertia, rtol=0.0, atol=INERTIA_TOL)


def named(program, names: dict[str, str]) -> list[list[dict]]:
    """``program``'s actions per waypoint with its parts renamed (``names``: read name -> job name)."""
    return [[{key: names.get(value, value) if key in ("grip", "release") else value for key, value in action.items()}
             for action in waypoint] for waypoint in actions(program)]


def test_the_payload_and_parts_read_back_within_rounding(payload_job):
    program, _, document, again = payload_job
    assert_same_load(again.payload, program.payload)
    assert list(again.parts) == ["box"] and list(document["parts"]) == ["box"]     # named by the gripped mark
    assert_same_load(again.parts["box"], program.parts["box"])


def test_the_grips_and_releases_read_back_at_the_same_waypoints(payload_job):
    program, _, _, again = payload_job
    assert named(again, {"part1": "box"}) == actions(program)
    assert [k for k, a in enumerate(actions(again)) if any("grip" in x or "release" in x for x in a)] == [2, 5]
    used = {name: signal for name, signal in program.signals.items() if name != "blow_off"}     # the job names it only
    assert again.signals == used and again.stops == program.stops


def test_the_read_back_job_carries_the_same_load_on_each_move(payload_job):
    program, _, _, again = payload_job
    assert len(again.loads) == len(program.loads) == 7
    for read, written in zip(again.loads, program.loads):
        assert_same_load(read, written)
    assert [round(load.mass, 6) for load in again.loads] == [1.2, 1.2, 3.7, 3.7, 3.7, 1.2, 1.2]


def test_the_total_carried_is_set_before_the_first_move_and_at_the_grip_and_release(payload_job):
    _, text, _, _ = payload_job
    body = [line.strip() for line in text.splitlines()]
    moves = [i for i, line in enumerate(body) if re.match(r"move[jlc]\(", line)]
    tool = [i for i, line in enumerate(body) if line == TOOL]
    assert body.count(GRIP) == 1 and len(tool) == 2
    assert len([line for line in body if "payload(" in line and not line.startswith("#")]) == 3
    assert tool[0] < moves[0]                                                   # the tool's load before any motion
    assert body[body.index(GRIP) - 1] == "sleep(0.25)"                          # in its place among the actions
    assert body[tool[1] - 1] == "sleep(0.2)" and body[tool[1] - 2] == "set_standard_digital_out(1, False)"
    assert text.count("set_target_payload needs PolyScope 5.10 or later") == 1
    assert "PLACEHOLDER" not in text
    assert structure_checks.urscript_problems(text, MAX_REPLAY_LINES) == []


def test_the_servoj_replay_changes_the_payload_too(payload_job):
    program, _, document, _ = payload_job
    with_replay = write_urscript(program, "payload_pick", time_program(program))
    replay = with_replay[with_replay.index("def certified_replay():"):].splitlines()
    servoj = [i for i, line in enumerate(replay) if "servoj(" in line]
    grip, release = replay.index(f"    {GRIP}"), replay.index(f"    {TOOL}")
    assert servoj[0] < grip < release < servoj[-1]
    assert read_program_text("urscript", with_replay, ROBOT, "payload_pick.script") == document


def test_polyscope_set_payload_reads_the_same_parts_as_point_masses(payload_job):
    """set_payload(m, cog) (before SW 5.10, and what PolyScope writes): the same grip and release, inertia 0."""
    program, text, _, _ = payload_job
    legacy = re.sub(r"set_target_payload\(([^\[]*\[[^\]]*\]), \[[^\]]*\]\)", r"set_payload(\1)", text)
    statements = [line.strip() for line in legacy.splitlines() if "payload(" in line and "#" not in line]
    assert len(statements) == 3 and all(line.startswith("set_payload(") for line in statements)
    document = read_urscript(legacy, ROBOT, "legacy.script")
    box = program.parts["box"]
    assert document["payload"] == {"mass": 1.2, "com": [0.0, 0.005, 0.045]}
    assert document["parts"]["part1"]["mass"] == 2.5 and "inertia" not in document["parts"]["part1"]
    assert np.allclose(document["parts"]["part1"]["com"], box.com, rtol=0.0, atol=COM_TOL)
    assert [a for w in document["waypoints"] for a in w.get("do", []) if "grip" in a or "release" in a] == [
        {"grip": "part1"}, {"release": "part1"}]


def test_parts_without_a_tool_load_are_written_alone_and_read_back(payload_job):
    program, _, _, _ = payload_job
    text = write_urscript(dataclasses.replace(program, payload=None), "payload_pick")
    body = [line.strip() for line in text.splitlines()]
    assert any(line.startswith("# the job gives no tool's load (unknown)") for line in body)
    assert "PLACEHOLDER" not in text
    empty = "set_target_payload(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])"
    box = "set_target_payload(2.5, [0.0, 0.0, 0.15], [0.0052, 0.0052, 0.0042, 0.0, 0.0, 0.0])"
    assert body.count(box) == 1 and body.count(empty) == 1 and body.index(box) < body.index(empty)
    document = read_urscript(text, ROBOT, "parts_only.script")
    assert "payload" not in document
    assert document["parts"] == {"part1": {"mass": 2.5, "com": [0.0, 0.0, 0.15],
                                           "inertia": [0.0052, 0.0052, 0.0042, 0.0, 0.0, 0.0]}}


@pytest.mark.parametrize("statement, problem", [
    ("set_payload(0.5, [0.0, 0.0, 0.0])", (r"sets 0.5 kg: neither more than the 3.7 kg carried \(a grip\) nor a "
                                           r"load carried before \(1.2 kg, 3.7 kg")),
    ("set_target_payload(1.2, [0.0, 0.005, 0.045], [0.0031, 0.0029, 0.0012, 0.0, 0.0, 0.0], 0.5, 1)",
     r"set_target_payload takes m, cog, inertia, transition_time"),
    ("set_payload(-1.0, [0.0, 0.0, 0.0])", r"needs a mass \[kg\] >= 0"),
    ("set_target_payload(1.2, [0.0, 0.005, 0.045], [0.0031, 0.0029, -0.0012, 0.0, 0.0, 0.0])",
     r"the inertia is no body's: its principal moments must be >= 0"),
])
def test_a_payload_that_is_no_grip_nor_release_is_refused_naming_the_line(payload_job, statement, problem):
    _, text, _, _ = payload_job
    lines = text.splitlines()
    release = [i for i, line in enumerate(lines) if line.strip() == TOOL][1]
    lines[release] = f"  {statement}"
    where = rf"^bad.script:{release + 1}: {re.escape(statement[:40])}"
    with pytest.raises(UrscriptReadError, match=rf"{where}.*: {problem}"):
        read_urscript("\n".join(lines), ROBOT, "bad.script")


def test_a_grip_whose_difference_is_no_body_is_refused():
    """The total's inertia smaller than the tool's: the part's would be negative."""
    text = ("def p():\n  set_target_payload(1.0, [0.0, 0.0, 0.0], [0.01, 0.01, 0.01, 0.0, 0.0, 0.0])\n"
            "  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n"
            "  set_target_payload(2.0, [0.0, 0.0, 0.0], [0.001, 0.001, 0.001, 0.0, 0.0, 0.0])\n"
            "  movej([0.1, -1.5, 1.5, -1.5, -1.5, 0.0])\nend\n")
    with pytest.raises(UrscriptReadError, match=r"^p.script:4: set_target_payload\(2.0.*the part it adds \(1 kg to the "
                                                r"1 kg carried\) has no body's inertia"):
        read_urscript(text, ROBOT, "p.script")


def test_a_part_gripped_again_keeps_its_name_and_the_same_total_changes_nothing():
    """PolyScope's Loop n times flattened: the same grip and release each turn is the same part."""
    grip = "  set_payload(3.0, [0.0, 0.0, 0.1])\n"
    release = "  set_payload(1.0, [0.0, 0.0, 0.05])\n"
    text = ("def p():\n  set_payload(1.0, [0.0, 0.0, 0.05])\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n"
            f"{grip}{grip}  movej([0.1, -1.5, 1.5, -1.5, -1.5, 0.0])\n{release}"
            f"  movej([0.2, -1.5, 1.5, -1.5, -1.5, 0.0])\n{grip}  movej([0.3, -1.5, 1.5, -1.5, -1.5, 0.0])\n{release}"
            "end\n")
    document = read_urscript(text, ROBOT, "p.script")
    assert list(document["parts"]) == ["part1"]
    assert [w.get("do") for w in document["waypoints"]] == [[{"grip": "part1"}], [{"release": "part1"}],
                                                             [{"grip": "part1"}], [{"release": "part1"}]]
    assert document["parts"]["part1"] == {"mass": 2.0, "com": [0.0, 0.0, 0.125]}
