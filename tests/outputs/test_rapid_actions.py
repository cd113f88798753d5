"""Process actions in ABB RAPID modules (issue 37): the GP7 gripper pick and place written by write_rapid has each
waypoint's actions right after its last move (waypoint 0's after the approach), as SetDO, PulseDO \\PLength,
WaitTime \\InPos, WaitDI \\MaxTime and ! comments, with the signals' numbers in the header mark; read back by
read_rapid (and read_program_text) the job has the same actions and signals; a signal name RAPID cannot hold is
refused naming it."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import pytest

from pipeline.errors import OutputError
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.read_rapid import read_rapid
from pipeline.program.actions import Action
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

from .test_rapid import instructions, rapidchecker_errors

JOB = Path(__file__).resolve().parents[1] / "data" / "gp7_gripper_pick_place.yaml"


@pytest.fixture(scope="module")
def gripper():
    """(program, module text, job document read back through read_program_text, program compiled from it)."""
    program = compile_job(load_job(JOB))
    text = write_rapid(program, "gripper")
    document = read_program_text("rapid", text, "gp7", "gripper.mod")
    return program, text, document, compile_job(parse_job(document, source="gripper.mod"))


def test_actions_follow_the_last_move_of_their_waypoint(gripper):
    _, text, _, _ = gripper
    lines = instructions(text)
    approach = next(i for i, line in enumerate(lines) if line.startswith("MoveAbsJ j0"))
    pick = next(i for i, line in enumerate(lines) if line.startswith("MoveL p2,"))
    place = next(i for i, line in enumerate(lines) if line.startswith("MoveL p5,"))
    assert lines[approach + 2] == "SetDO gripper_close, 0;"          # after PathAccLim, before the first move
    assert lines[pick + 1:pick + 4] == ["WaitDI part_present, 1 \\MaxTime:=2;", "SetDO gripper_close, 1;",
                                        "WaitTime \\InPos, 0.25;"]
    assert lines[place + 1:place + 5] == ["! release the part", "SetDO gripper_close, 0;",
                                          "PulseDO \\PLength:=0.1, blow_off;", "WaitTime \\InPos, 0.2;"]
    assert "MoveL p2, speed_500, fine," in text and "MoveL p5, speed_500, fine," in text   # the waits stop there
    assert "dh.signal.gripper_close=out1 dh.signal.part_present=in3 dh.signal.blow_off=out2" in text


def test_actions_and_signals_read_back_equal(gripper):
    program, _, document, again = gripper
    assert again.actions == program.actions
    assert again.signals == program.signals
    assert document["signals"] == {"gripper_close": {"output": 1}, "part_present": {"input": 3},
                                   "blow_off": {"output": 2}}


def test_without_the_mark_signals_have_no_number(gripper):
    _, text, _, _ = gripper
    unmarked = "\n".join(line for line in text.splitlines() if "dh.signal." not in line)
    document = read_rapid(unmarked, "gp7")
    assert document["signals"] == {"gripper_close": {"output": None}, "part_present": {"input": None},
                                   "blow_off": {"output": None}}
    assert compile_job(parse_job(document, source="unmarked.mod")).actions == gripper[0].actions


@pytest.mark.parametrize("name", ["While", "proc", "x" * 33, "P2", "tool_job", "fine", "main_gripper"])
def test_a_signal_rapid_cannot_name_is_refused(gripper, name):
    program = gripper[0]
    actions = list(program.actions)
    actions[0] = (Action("set", name, True),)
    with pytest.raises(OutputError, match="signal name") as error:
        write_rapid(dataclasses.replace(program, actions=tuple(actions)), "gripper")
    assert name in str(error.value)


@pytest.mark.slow
def test_rapidchecker_accepts_the_module_with_actions(gripper, tmp_path):
    if importlib.util.find_spec("rapidchecker") is None:
        pytest.skip("rapidchecker (pip install rapidchecker) is not installed")
    result = rapidchecker_errors(tmp_path, gripper[1])
    assert result.returncode == 0, result.stdout + result.stderr
