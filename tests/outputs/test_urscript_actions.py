"""Actions in URScript (issue 37): the UR5 twin of the GP7 gripper pick and place (tests/data/programs/ur/
ur5_gripper_pick_place.yaml: every action kind) written by write_urscript and read back by read_urscript gives the
same actions and signals; the instructions are URScript's own (set_standard_digital_out, sleep, PolyScope's Wait node
for an input, a pulse thread, comments), the signals mark names the job's signals, the servoj replay runs the actions
too, and what URScript cannot number is refused."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from pipeline.errors import OutputError
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.read_urscript import UrscriptReadError, read_urscript
from pipeline.outputs.controllers.urscript import MAX_REPLAY_LINES, write_urscript
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.timing import time_program
from pipeline.runner import program_texts

from . import structure_checks

lark = pytest.importorskip("lark", reason="lark (pip install lark) parses the URScript grammar")

TESTS = Path(__file__).resolve().parents[1]
JOB = TESTS / "data" / "programs" / "ur" / "ur5_gripper_pick_place.yaml"
ROBOT = str(TESTS / "data" / "ur5.yaml")


@pytest.fixture(scope="module")
def gripper():
    """(program, its native URScript, the document read_program_text reads from it)."""
    program = compile_job(load_job(JOB))
    text = write_urscript(program, "gripper_pick")
    return program, text, read_program_text("urscript", text, ROBOT, "gripper_pick.script")


def actions(program) -> list[list[dict]]:
    return [[action.to_document() for action in program.actions_at(k)] for k in range(len(program.targets))]


def test_the_actions_read_back_equal(gripper):
    program, _, document = gripper
    again = compile_job(parse_job(document, source="gripper_pick.script"))
    assert actions(again) == actions(program)
    assert again.signals == program.signals
    assert again.stops == program.stops


def test_the_instructions_are_urscript_and_polyscope_own(gripper):
    _, text, _ = gripper
    body = [line.strip() for line in text.splitlines()]
    assert "set_standard_digital_out(1, False)" in body and "set_standard_digital_out(1, True)" in body
    assert "sleep(0.25)" in body and "# release the part" in body and "run dh_pulse_1()" in body
    thread = body.index("thread dh_pulse_1():")
    assert body[thread + 1:thread + 5] == ["set_standard_digital_out(2, True)", "sleep(0.1)",
                                           "set_standard_digital_out(2, False)", "end"]
    wait = body.index("while (not(get_standard_digital_in(3) == True)):")
    assert body[wait - 1] == "dh_waited = 0.0" and body[wait + 1] == "if (dh_waited >= 2.0):"
    assert "dh.signal.gripper_close=out1 dh.signal.part_present=in3 dh.signal.blow_off=out2" in text
    assert structure_checks.urscript_problems(text, MAX_REPLAY_LINES) == []


def test_each_action_follows_the_last_move_into_its_waypoint(gripper):
    """Waypoint 0's after the approach movej; a wait after a move with r=0 (the robot at rest)."""
    _, text, _ = gripper
    body = [line.strip() for line in text.splitlines()]
    moves = [i for i, line in enumerate(body) if re.match(r"move[jlc]\(", line)]
    assert body[moves[0] + 1] == "set_standard_digital_out(1, False)"
    for i, line in enumerate(body):
        if line.startswith("sleep(0.2"):
            previous = max(m for m in moves if m < i)
            assert body[previous].endswith("r=0.0)")


def test_the_servoj_replay_runs_the_actions_and_reads_the_same(gripper):
    program, _, document = gripper
    with_replay = write_urscript(program, "gripper_pick", time_program(program))
    replay = with_replay[with_replay.index("def certified_replay():"):]
    for line in ("set_standard_digital_out(1, True)", "run dh_pulse_1()", "# release the part",
                 "while (not(get_standard_digital_in(3) == True)):"):
        assert line in replay
    assert "sleep(0.25)" not in replay            # the profile rests for the waits
    servoj = [i for i, line in enumerate(replay.splitlines()) if "servoj(" in line]
    grip = replay.splitlines().index("    set_standard_digital_out(1, True)")
    assert servoj[0] < grip < servoj[-1]
    assert read_program_text("urscript", with_replay, ROBOT, "gripper_pick.script") == document
    assert structure_checks.urscript_problems(with_replay, MAX_REPLAY_LINES) == []


def on_other_outputs(program, numbers: dict[str, int]):
    """``program`` with its signals renumbered (``numbers``: name -> number)."""
    signals = {name: dataclasses.replace(signal, number=numbers.get(name, signal.number))
               for name, signal in program.signals.items()}
    return dataclasses.replace(program, signals=signals)


def test_configurable_and_tool_io_are_numbered_8_and_16_on(gripper):
    program, _, _ = gripper
    moved = on_other_outputs(program, {"gripper_close": 17, "blow_off": 9, "part_present": 16})
    text = write_urscript(moved, "gripper_pick")
    assert "set_tool_digital_out(1, True)" in text and "set_configurable_digital_out(1, True)" in text
    assert "while (not(get_tool_digital_in(0) == True)):" in text
    document = read_urscript(text, ROBOT)
    assert document["signals"] == {"tool_do1": {"output": 17}, "tool_di0": {"input": 16}, "conf_do1": {"output": 9}}
    assert actions(compile_job(parse_job(read_program_text("urscript", text, ROBOT, "p.script"),
                                         source="p.script"))) == actions(program)


@pytest.mark.parametrize("numbers, match", [
    ({"gripper_close": None}, r"signal gripper_close: URScript numbers its digital I/O"),
    ({"blow_off": 18}, r"signal blow_off: output 18 is not a UR digital output"),
])
def test_a_signal_urscript_cannot_number_is_refused(gripper, numbers, match):
    program, _, _ = gripper
    with pytest.raises(OutputError, match=match):
        write_urscript(on_other_outputs(program, numbers), "gripper_pick")


def test_polyscope_wait_without_timeout_reads_as_a_wait_for_ever():
    text = ("def p():\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n  $ 3 \"Wait DI[4]=LO\"\n"
            "  while (not(get_standard_digital_in(4) == False)):\n    sync()\n  end\n"
            "  set_digital_out(2, True)\n  movej([0.1, -1.5, 1.5, -1.5, -1.5, 0.0])\nend\n")
    document = read_urscript(text, ROBOT)
    assert document["waypoints"][0]["do"] == [{"wait_input": "di4", "value": "off"}, {"set": "do2", "value": "on"}]
    assert document["signals"] == {"di4": {"input": 4}, "do2": {"output": 2}}


def test_a_timeout_pattern_that_differs_is_refused():
    text = ("def p():\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n  dh_waited = 0.0\n"
            "  while (not(get_standard_digital_in(3) == True)):\n    if (dh_waited >= 2.0):\n      halt\n    end\n"
            "    sleep(0.01)\n    dh_waited = dh_waited + 0.01\n  end\nend\n")
    with pytest.raises(UrscriptReadError, match=r"<urscript>:4: while \(not\(get_standard_digital_in\(3\) == True\)\): "
                                                r"a loop on a variable or an input"):
        read_urscript(text, ROBOT)



@pytest.mark.slow
def test_the_certified_motion_program_the_runner_writes_reads_the_same_actions(gripper):
    """runner.program_texts (what `run --lang urscript` writes: the certified motion and its replay), read back."""
    program, _, _ = gripper
    job = load_job(JOB)
    text = program_texts(job, "urscript", program, time_program(program))[".script"]
    read = read_program_text("urscript", text, ROBOT, "gripper_pick.script")
    assert actions(compile_job(parse_job(read, source="gripper_pick.script"))) == actions(program)


def test_a_polyscope_comment_node_reads_as_a_comment_a_job_holds():
    text = ("def p():\n  # header: not an action\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n"
            "  $ 3 \"'the part's edge first'\"\n  # 'the part's edge first'\n  # " + "x" * 130 + "\n"
            "  movej([0.1, -1.5, 1.5, -1.5, -1.5, 0.0])\nend\n")
    document = read_urscript(text, ROBOT)
    assert document["waypoints"][0]["do"] == [{"comment": "the parts edge first"}, {"comment": "x" * 120}]
    parse_job(document, source="p.script")
