"""Reading URScript programs back into jobs (pipeline.outputs.controllers.read_urscript, issue 26): the UR5 job of
test_urscript.py (joint, linear and circular moves, a zone) -> compile_job -> write_urscript -> read_urscript ->
parse_job -> compile_job gives the same targets (within the format's rounding, 1e-6 m and rad), the same branches
(URScript has no configuration: a pose's branch is the one nearest the previous target, which is the program's
when its moves do not jump branches), move kinds, speeds and zones; the servoj replay is skipped (the same job with
or without it); a PolyScope-style rewrite (global variables, positional arguments, comments) reads the same."""

from __future__ import annotations

import re

import numpy as np
import pytest

from pipeline.model.ik import solve_ik_batch
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.robot import load_robot
from pipeline.outputs.controllers.read_urscript import UrscriptReadError, read_urscript
from pipeline.outputs.controllers.urscript import joints, pose, write_urscript
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job
from pipeline.program.timing import time_program

from .test_urscript import TESTS, UR5_JOB

ROBOT = UR5_JOB["robot"]
#: Poses and joint values are written to 1e-6 (m, rad): a pose re-solved moves the joints by about that over the
#: arm's Jacobian, 1e-5 rad leaves room for it.
TARGET_TOLERANCE_RAD = 1e-5
#: movej's v is written to 1e-6 rad/s: the fraction of the joint speed limit read back is that close.
SPEED_ROUNDING = 1e-6


@pytest.fixture(scope="module")
def ur5():
    """(program, its native URScript, the document read from it, the program compiled from that)."""
    program = compile_job(parse_job(UR5_JOB, source=str(TESTS / "ur5_job.yaml")))
    text = write_urscript(program, "ur5_moves")
    document = read_urscript(text, ROBOT)
    return program, text, document, compile_job(parse_job(document, source="ur5_moves.script"))


def test_round_trip_gives_the_same_targets_and_branches(ur5):
    program, _, _, again = ur5
    assert len(again.targets) == len(program.targets)
    assert np.abs(again.targets - program.targets).max() <= TARGET_TOLERANCE_RAD
    assert configuration_labels(again.robot, again.targets) == configuration_labels(program.robot, program.targets)
    np.testing.assert_allclose(again.tool.X_FT, program.tool.X_FT, atol=1e-12)


def test_round_trip_gives_the_same_moves_speeds_and_zones(ur5):
    program, _, document, again = ur5
    for move, read in zip(program.moves, again.moves, strict=True):
        assert read.kind == move.kind
        assert read.zone == pytest.approx(move.zone, abs=1e-12)
        assert read.speed == pytest.approx(move.speed, abs=SPEED_ROUNDING)
        if move.kind == "circular":
            np.testing.assert_allclose(read.via, move.via, atol=0.5e-6 + 1e-12)
    assert again.stops == program.stops
    assert document["tcp_accel_max"] == pytest.approx(program.tcp_accel_max)
    assert [set(w) >= {"xyz", "quaternion", "config"} for w in document["waypoints"]] == [False, False, True, True,
                                                                                          True, False]


def test_the_servoj_replay_is_skipped(ur5):
    program, _, document, _ = ur5
    with_replay = write_urscript(program, "ur5_replay", time_program(program))
    assert "servoj(" in with_replay
    assert read_urscript(with_replay, ROBOT) == document


def polyscope_style(text: str) -> str:
    """The native program as PolyScope might export it: every pose a global variable, the tool moves' arguments by
    position (movel(pose, a, v, t, r)), comments and blank lines."""
    lines, count = [], 0
    for line in text.splitlines():
        line = re.sub(r"^(\s*)movel\((p\[[^\]]*\]), a=([^,]+), v=([^,]+), r=([^)]+)\)", r"\1movel(\2, \3, \4, 0, \5)",
                      line)
        for found in re.findall(r"p\[[^\]]*\]", line) if "movel" in line or "movec" in line else []:
            count += 1
            lines.append(f"  global Waypoint_{count}_p={found}   # taught")
            line = line.replace(found, f"Waypoint_{count}_p")
        lines += [line, ""] if line.strip().startswith("move") else [line]
    return "\n".join(lines)


def test_a_polyscope_style_program_reads_the_same(ur5):
    _, text, document, _ = ur5
    rewritten = polyscope_style(text)
    assert "global Waypoint_1_p=p[" in rewritten and re.search(r"movel\(Waypoint_\d_p, 1.2, 0.25, 0, ", rewritten)
    assert read_urscript(rewritten, ROBOT) == document


def test_a_pose_takes_the_branch_nearest_the_previous_target():
    """One pose after joint targets on two branches: read on the branch of each."""
    ur5 = load_robot(ROBOT)
    q = np.radians([30.0, -100.0, 100.0, -90.0, -90.0, 30.0])
    X = ur5.fk(q)
    solutions = [s.q for s in solve_ik_batch(ur5, X[None], method="analytic")[0].solutions]
    labels = configuration_labels(ur5, np.array(solutions))
    assert len(set(labels)) >= 2
    for q_branch, label in zip(solutions[:4], labels):
        text = f"def p():\n  movej({joints(q_branch)})\n  movel({pose(X)}, a=1.2, v=0.25, r=0.0)\nend\n"
        config = read_urscript(text, ROBOT)["waypoints"][1]["config"]
        assert ", ".join(f"{k} {v}" for k, v in config.items()) == label


@pytest.mark.parametrize("statement, field", [
    ("movel(p1, a=1.2, v=0.25)", "movel(p1, a=1.2, v=0.25)"),
    ("movel(p[0.4, 0.1, 0.4, 0.0, 3.14, 0.0], t=2.0)", "movel(t=...)"),
    ("movel(p[0.4, 0.1, 0.4, 0.0, 3.14, 0.0], a=1.2, v=0.25, s=1)", "movel(s=...)"),
    ("movel(p[0.4, 0.1, 0.4], a=1.2, v=0.25)", "movel(p[0.4, 0.1, 0.4], a=1.2, v=0.25)"),
    ("movej([0.0, 1.0])", "movej([0.0, 1.0])"),
    ("set_tcp(p[0.0, 0.0, 0.1, 0.0, 0.0, 0.0])", "set_tcp(p[0.0, 0.0, 0.1, 0.0, 0.0, 0.0])"),
    ("servoj([0.0, -1.5, 1.5, -1.5, -1.5, 0.0], t=0.002)", "servoj([0.0, -1.5, 1.5, -1.5, -1.5, 0.0], t=0.002)"),
    ("movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0]", "syntax"),
])
def test_what_is_not_read_is_named(statement, field):
    text = f"def p():\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n  {statement}\nend\n"
    with pytest.raises(UrscriptReadError) as error:
        read_urscript(text, ROBOT, source="p.script")
    assert error.value.field == field
    assert error.value.line == 3 and error.value.source == "p.script"
