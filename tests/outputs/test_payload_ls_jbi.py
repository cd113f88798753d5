"""Loads in FANUC LS and Yaskawa JBI (issue 40): payload schedules / tool file loads, their mark and the readers.

* The payload pick and place (tests/data/gp7_payload_pick_place.yaml: a 1.2 kg gripper, a 2.5 kg box gripped at
  waypoint 2 and released at waypoint 5) written and read back in both languages: the same payload and parts (within
  1e-3 kg, 0.01 mm, 1e-6 kg m^2), the same grip and release actions at the same waypoints, and the read-back job
  compiled carries the same load on every move.
* The written lines: FANUC's ``PAYLOAD[1]`` before the first motion and again at the release, ``PAYLOAD[2]`` at the
  grip after the settling wait; Yaskawa's ``'dh.grip=box`` / ``'dh.release=box`` with the load now carried.
* Without the mark a ``PAYLOAD[n]`` after the first move is refused naming the file and the line (its data are on the
  controller), before it noted as before; a JBI grip whose part the mark does not state is refused naming its line.
* ``settings_mark``: the loads numbered in order of first use, the mark read back, a word too long refused; FANUC's
  10 schedules.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.outputs.controllers.fanuc_ls import KGF_CM_S2, schedule_texts, write_ls
from pipeline.outputs.controllers.read_jbi import read_jbi
from pipeline.outputs.controllers.read_ls import ControllerProgramError, read_ls
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.settings_mark import load_schedules, loads_mark, marked_loads
from pipeline.outputs.controllers.yaskawa_jbi import write_jbi
from pipeline.program.actions import GRIP, RELEASE, Action
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.payload import Payload

#: The round trips run in the slow run (CI): test_payload_cli.py reads the loads back through the CLI in make test.
pytestmark = pytest.mark.slow

DATA = Path(__file__).resolve().parents[1] / "data"
WHEN = dt.datetime(2026, 11, 27, 3, 0)
WRITERS = {"ls": write_ls, "jbi": write_jbi}
#: How closely a load reads back: mass [kg], centre of mass [m], inertia [kg m^2].
MASS_TOL, COM_TOL, INERTIA_TOL = 1e-3, 1e-5, 1e-6


@pytest.fixture(scope="module")
def carrying():
    return compile_job(load_job(DATA / "gp7_payload_pick_place.yaml"))


def written(program, language: str) -> str:
    return WRITERS[language](program, "PICK", WHEN)


def same_load(a: Payload | None, b: Payload | None) -> None:
    assert (a is None) == (b is None)
    if a is not None:
        assert abs(a.mass - b.mass) <= MASS_TOL
        assert np.abs(np.asarray(a.com) - b.com).max() <= COM_TOL
        assert np.abs(a.inertia - b.inertia).max() <= INERTIA_TOL


@pytest.mark.parametrize("language", ["ls", "jbi"])
def test_loads_grips_and_releases_read_back_as_written(carrying, language):
    document = read_program_text(language, written(carrying, language), "gp7", f"pick.{language}")
    back = compile_job(parse_job(document, source=f"pick.{language}"))
    same_load(carrying.payload, back.payload)
    assert set(back.parts) == set(carrying.parts) == {"box"}
    same_load(carrying.parts["box"], back.parts["box"])
    assert [[str(a) for a in back.actions_at(k)] for k in range(len(back.waypoints))] == \
           [[str(a) for a in carrying.actions_at(k)] for k in range(len(carrying.waypoints))]
    assert [k for k in range(len(back.waypoints)) for a in back.actions_at(k) if a.kind in (GRIP, RELEASE)] == [2, 5]
    assert len(back.loads) == len(carrying.loads)
    for load, load_back in zip(carrying.loads, back.loads):
        same_load(load, load_back)
    assert carrying.loads[2].mass == pytest.approx(3.7) and carrying.loads[1].mass == pytest.approx(1.2)
    assert "payload schedule" not in document.get("description", "")     # read, not left on the controller


def mn_lines(text: str) -> list[str]:
    """The /MN instructions without their numbers."""
    return [re.sub(r"^\s*\d+:\s*", "", line) for line in text.split("/MN\n")[1].split("/POS")[0].splitlines()]


def test_ls_selects_schedule_1_first_2_at_the_grip_and_1_at_the_release(carrying):
    text = written(carrying, "ls")
    assert text.count("PAYLOAD[2] ;") == 1 and text.count("PAYLOAD[1] ;") == 2
    lines = mn_lines(text)
    first_motion = next(i for i, line in enumerate(lines) if line.startswith("J P[1]"))
    assert lines[first_motion - 1] == "PAYLOAD[1] ;"
    grip = lines.index("PAYLOAD[2] ;")
    assert lines[grip - 1] == "WAIT   0.25(sec) ;" and lines[grip - 5].startswith("L P[3] ")   # after the grip's wait
    release = len(lines) - 1 - lines[::-1].index("PAYLOAD[1] ;")
    assert lines[release - 1] == "WAIT   0.20(sec) ;" and lines[release - 3].startswith("L P[7] ")
    header = " ".join(line[1:-2] for line in lines[:first_motion] if line.startswith("!"))
    tool, total = carrying.loads[0], carrying.loads[2]
    assert "PAYLOAD[1] tool: payload 1.2 kg, center 0.000 0.500 4.500 cm" in header
    assert f"inertia {tool.inertia[0, 0] * KGF_CM_S2:.5f}" in header
    assert "PAYLOAD[2] tool + box: payload 3.7 kg" in header
    assert abs(total.inertia[1, 2]) > 1e-5                         # the gripper's and the box's centres are apart
    assert "(the diagonal in the faceplate axes: products of inertia not held)" in header
    assert header.count("products of inertia not held") == 1        # schedule 1 is diagonal


def test_jbi_names_the_load_at_each_grip_and_release(carrying):
    text = written(carrying, "jbi")
    lines = text.split("\nNOP\n", 1)[1].splitlines()
    for line in ("'dh.grip=box", "'ARM control: load 2 from here", "'dh.release=box", "'ARM control: load 1 from here",
                 "'dh.payload.1=tool", "'dh.payload.2=tool+1"):
        assert lines.count(line) == 1, line
    grip = lines.index("'dh.grip=box")
    assert lines[grip - 1] == "TIMER T=0.25" and lines[grip + 1] == "'ARM control: load 2 from here"
    assert lines[lines.index("'dh.release=box") - 1] == "TIMER T=0.20"
    header = " ".join(line[1:] for line in lines if line.startswith("'"))
    assert "load 2 tool + box: W 3.7 kg, Xg Yg Zg 0.000 1.622 115.946 mm" in header
    assert "no INFORM instruction changes the tool file load" in header


def test_payload_after_a_move_without_the_mark_is_refused_naming_the_line(carrying):
    text = written(carrying, "ls").replace("!dh.payload.2=tool+1 ;", "!taught on the pendant ;")
    line = text.splitlines().index(next(row for row in text.splitlines() if row.endswith("PAYLOAD[2] ;"))) + 1
    with pytest.raises(ControllerProgramError, match=rf"pick\.ls.*line {line}.*PAYLOAD\[2\].*on the controller"):
        read_ls(text, "gp7", source="pick.ls")


def test_payload_before_the_first_move_without_the_mark_is_noted(carrying):
    """A pendant's program: PAYLOAD[1] before the first move and no mark: noted, as before issue 40."""
    rows = re.sub(r"!dh\.(payload|tool|part)\.[^;]*;", "!taught ;", written(carrying, "ls")).splitlines()
    changes = [i for i, row in enumerate(rows) if re.search(r"PAYLOAD\[\d\] ;", row)][1:]   # the grip's, the release's
    text = "\n".join(re.sub(r"PAYLOAD\[\d\]", "!taught", row) if i in changes else row for i, row in enumerate(rows))
    document = read_ls(text, "gp7", source="pick.ls")
    assert "PAYLOAD[1] selects a payload schedule whose data is on the controller" in document["description"]
    assert "payload" not in document and "parts" not in document


def test_a_jbi_grip_of_a_part_the_mark_does_not_state_is_refused(carrying):
    text = written(carrying, "jbi").replace("'dh.grip=box", "'dh.grip=lid")
    line = text.splitlines().index("'dh.grip=lid") + 1
    with pytest.raises(ControllerProgramError, match=rf"pick\.jbi:{line}: 'dh\.grip=lid: part lid"):
        read_jbi(text, "gp7", source="pick.jbi")


def box(mass: float) -> Payload:
    return Payload(mass, np.array([0.0, 0.0, 0.1]), np.diag([1e-3, 1e-3, 2e-3]), name="p")


def with_actions(program, actions: dict, parts: dict):
    """``program`` with these actions per waypoint (the others none) and parts."""
    per_waypoint = tuple(tuple(actions.get(k, ())) for k in range(len(program.waypoints)))
    return dataclasses.replace(program, actions=per_waypoint, parts=parts)


def test_loads_are_numbered_in_order_of_first_use(carrying):
    parts = {"a": box(1.0), "b": box(2.0)}
    program = with_actions(carrying, {1: [Action(GRIP, part="a")], 2: [Action(GRIP, part="b")],
                                      3: [Action(RELEASE, part="a")], 5: [Action(RELEASE, part="b"),
                                                                          Action(GRIP, part="a")]}, parts)
    schedules = load_schedules(program)
    assert schedules.held == ((), ("a",), ("a", "b"), ("b",))
    assert schedules.selected == {(1, 0): 2, (2, 0): 3, (3, 0): 4, (5, 0): 1, (5, 1): 2}
    mark = loads_mark(program, schedules, 32)
    assert "dh.payload.3=tool+1+2" in mark.split() and all(len(word) <= 32 for word in mark.split())
    marked = marked_loads(" ".join(f"!{word} ;" for word in mark.split()))
    assert marked.schedules == {1: frozenset(), 2: {"a"}, 3: {"a", "b"}, 4: {"b"}}
    assert marked.parts["b"] == {"mass": 2.0, "com": [0.0, 0.0, 0.1], "inertia": [1e-3, 1e-3, 2e-3, 0.0, 0.0, 0.0]}


def test_a_part_name_too_long_for_a_comment_line_is_refused(carrying):
    name = "a_part_name_of_twenty_three"
    program = with_actions(carrying, {2: [Action(GRIP, part=name)]}, {name: box(1.0)})
    with pytest.raises(ConfigurationError, match="longer than a comment line"):
        write_ls(program, "PICK", WHEN)


def test_fanuc_holds_ten_payload_schedules(carrying):
    """Five parts gripped one by one, then released one by one (10 loads); gripping the first again makes an 11th."""
    parts = {f"p{i}": box(0.1 * i) for i in range(1, 6)}
    grips = [Action(GRIP, part=name) for name in parts]
    releases = [Action(RELEASE, part=name) for name in list(parts)[:4]]
    ten = with_actions(carrying, {2: grips, 5: releases}, parts)
    assert len(load_schedules(ten).held) == 10
    assert "PAYLOAD[10] tool + p5:" in " ".join(schedule_texts(ten, load_schedules(ten)))
    eleven = with_actions(carrying, {2: grips, 5: [*releases, Action(GRIP, part="p1")]}, parts)
    with pytest.raises(ConfigurationError, match="11 distinct loads.*10 payload schedules"):
        write_ls(eleven, "PICK", WHEN)
