"""Yaskawa .jbi reader (pipeline.outputs.controllers.read_jbi): the demo jobs written by ``write_jbi``, read back into
job documents, validated by ``parse_job`` and compiled again: the same move kinds, the same targets within the
file's rounding (0.001 mm, 0.01 deg carried to the joints by ``fanuc_ls.rounding_bound``), the same branches
and 2 pi representatives, the same via points and speeds (0.01 %, 0.1 mm/s); zones are the PL level's
distance in the writer's table. A copy as a controller might save it (CR LF, other spacing, added comments)
reads the same."""

from __future__ import annotations

import dataclasses
import datetime as dt
import re

import numpy as np
import pytest

from pipeline.model.ik.branches import configuration_labels
from pipeline.model.vendors import configurations
from pipeline.outputs.controllers.read_jbi import read_jbi
from pipeline.outputs.controllers.read_ls import ControllerProgramError
from pipeline.outputs.controllers.yaskawa_jbi import PL_MM, pl_level, write_jbi, written_zone
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

from .test_fanuc_ls import CARTESIAN_JOBS, JOBS
from .test_read_ls import check_round_trip

WHEN = dt.datetime(2026, 11, 27, 3, 0)


@pytest.fixture(scope="module")
def programs():
    """The demo jobs compiled (a few tens of ms each)."""
    return {name: compile_job(load_job(JOBS / f"{name}.yaml")) for name in CARTESIAN_JOBS}


def with_pl_zones(program):
    """``program`` with each zone as written (none into an arc: ``written_zone``) replaced by its PL level's
    distance (what the controller rounds by)."""
    levels = [pl_level(written_zone(program, m)) for m in program.moves]
    moves = tuple(dataclasses.replace(m, zone=PL_MM[level - 1] / 1000.0 if level else 0.0)
                  for m, level in zip(program.moves, levels))
    return dataclasses.replace(program, moves=moves)


@pytest.mark.parametrize("name", CARTESIAN_JOBS)
def test_round_trip(programs, name):
    program = programs[name]
    document = read_jbi(write_jbi(program, "DEMO", WHEN), program.robot.name)
    reread = compile_job(parse_job(document))
    check_round_trip(with_pl_zones(program), reread, 0.001, 0.01, 1e-12, (1e-4, 1e-4))


def controller_style(text: str) -> str:
    """``text`` as another tool might save it: spaces after commas and around =, comments added between
    instructions, CR LF line ends."""
    text = re.sub(r"^(C\d{5})=", r"\1 = ", text, flags=re.MULTILINE)
    text = text.replace("NOP\n", "NOP\n'taught on the pendant\n", 1).replace("\nMOVL", "\n'next\nMOVL", 1)
    text = re.sub(r"^(MOV[JLC]) ", r"\1  ", text, flags=re.MULTILINE)
    return text.replace("\n", "\r\n")


@pytest.mark.parametrize("name", CARTESIAN_JOBS)
def test_controller_style_reads_the_same(programs, name):
    program = programs[name]
    text = write_jbi(program, "DEMO", WHEN)
    document = read_jbi(controller_style(text), program.robot.name)
    commented = [w for w in document["waypoints"] if w.get("do") == [{"comment": "next"}]]
    assert len(commented) == ("\nMOVL" in text)     # the comment added after a move: an action of its waypoint
    for waypoint in commented:
        del waypoint["do"]
    assert document == read_jbi(text, program.robot.name)


def test_robot_frame_undone(programs):
    """The GP7's points are written in its robot frame, 330 mm above the mounting face."""
    program = programs["gp7_pick_place"]
    text = write_jbi(program, "DEMO", WHEN)
    z_written = float(re.search(r"^C00000=[^,]+,[^,]+,([^,]+),", text, flags=re.MULTILINE).group(1))
    first = read_jbi(text, "gp7")["waypoints"][0]
    assert first["xyz"][2] == pytest.approx(z_written / 1000.0 + 0.330, abs=1e-12)


def test_pl_levels_follow_the_table(programs):
    """PL n reads as level n's distance in the writer's table, or in the controller's own."""
    program = programs["gp7_pick_place"]
    text = write_jbi(program, "DEMO", WHEN)
    zones = [w.get("zone") for w in read_jbi(text, "gp7")["waypoints"]]
    assert zones == [None, None, None, 0.05, 0.05, None, 0.05, None]      # 60 mm -> PL3 (50 mm), into the arc too
    controller = (10, 20, 40, 80, 160, 320, 640, 1280)
    zones = [w.get("zone") for w in read_jbi(text, "gp7", pl_mm=controller)["waypoints"]]
    assert zones == [None, None, None, 0.04, 0.04, None, 0.04, None]
    assert "zone" not in read_jbi(text.replace("PL=3", "PL=0"), "gp7")["waypoints"][4]


def test_rconf_in_force_selects_the_branch(programs):
    """A ///RCONF applies to the points after it: the flipped wrist's RCONF (q4 and q6 turned by 180 deg, q5
    negated) before C00001 selects the flipped solution there; the writer's RCONF restored after it keeps
    the others."""
    program = programs["irb1600_tool_moves"]
    q = program.targets[1].copy()
    q[[3, 5]] -= np.sign(q[[3, 5]]) * np.pi
    q[4] = -q[4]
    text = write_jbi(program, "DEMO", WHEN)
    before = text[:text.index("C00001=")]
    written = before[before.rindex("///RCONF"):].splitlines()[0]
    flipped = "///RCONF " + ",".join(str(v) for v in [*configurations(program.robot, q, "yaskawa"), *[0] * 18])
    text = text.replace("C00001=", f"{flipped}\nC00001=", 1).replace("C00002=", f"{written}\nC00002=", 1)
    document = read_jbi(text, "irb1600")
    labels = configuration_labels(program.robot, program.targets)
    assert [", ".join(f"{k} {v}" for k, v in w["config"].items()) for w in document["waypoints"]] == \
        [labels[0], configuration_labels(program.robot, q)[0], *labels[2:]]
    assert configuration_labels(program.robot, q)[0] != labels[1]


@pytest.mark.parametrize("edit, match", [
    (("MOVL C00002", "MOVL C00099"), "C00099"),
    (("MOVC C00004", "MOVC C00099"), "C00099: not in //POS"),
    (("MOVC C00004 V=500.0\n", ""), "three MOVC"),
    (("VJ=100.00", "VJ=100.00 XX"), "XX: not read"),
])
def test_errors_name_what_is_wrong(programs, edit, match):
    text = write_jbi(programs["gp7_pick_place"], "DEMO", WHEN).replace(*edit, 1)
    with pytest.raises(ControllerProgramError, match=match):
        read_jbi(text, "gp7", source="demo.jbi")
