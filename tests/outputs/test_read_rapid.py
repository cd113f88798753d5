"""Reading ABB RAPID modules back into jobs (pipeline.outputs.controllers.read_rapid, issue 26): demo job -> compile_job ->
write_rapid -> read_rapid -> parse_job -> compile_job gives the same targets (within the format's rounding: 0.001 mm
and 1e-6 per quaternion component for robtargets, 0.0001 deg for jointtargets), the same branches, move kinds,
speeds (m/s, and a joint move's fraction within the 1 ms its \\T is rounded up by) and zones; a pendant-style
rewrite of a written module (case, comments, line breaks, predefined data, inline targets) reads the same."""

from __future__ import annotations

import dataclasses
import importlib.util
import types
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.model.ik.branches import configuration_labels
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_rapid import RapidReadError, read_rapid
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

from .test_rapid import rapidchecker_errors

JOBS = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
DEMOS = {"irb1600_tool_moves": "irb1600", "irb1600_joint_moves": "irb1600", "gp7_pick_place": "gp7"}
#: Re-read joint values agree within this [rad]: a robtarget is rounded to 0.0005 mm and 5e-7 per quaternion
#: component (about 1e-6 rad, moved by the arm's Jacobian; test_rapid.py's bound), a jointtarget to 0.00005 deg.
TARGET_TOLERANCE_RAD = 1e-4
#: Positions (targets, vias) are written to 0.001 mm: half of that [m].
POSITION_TOLERANCE_M = 0.5e-6 + 1e-12
#: A work object's uframe is rounded as a robtarget is (0.0005 mm, 5e-7 per quaternion component, about 1e-6 rad
#: over targets about 1 m away): a target read through it moves by up to about 2e-6 [m, and per component].
WOBJ_ROUNDING = 2e-6


@pytest.fixture(scope="module")
def round_trips() -> dict:
    """Each demo's (program, module text, read document, program compiled from it)."""
    out = {}
    for name, robot in DEMOS.items():
        program = compile_job(load_job(JOBS / f"{name}.yaml"))
        text = write_rapid(program, name)
        document = read_rapid(text, robot)
        out[name] = program, text, document, compile_job(parse_job(document, source=f"{name}.mod"))
    return out


def joint_move_time(program, move) -> float:
    """The \\T [s] write_rapid gives a joint move (unrounded)."""
    q_from = program.targets[move.end - 1]
    return float(np.max(np.abs(move.target - q_from) / (move.speed * program.limits.qd_max)))


@pytest.mark.parametrize("name", DEMOS)
def test_round_trip_gives_the_same_targets_and_branches(round_trips, name):
    program, _, _, again = round_trips[name]
    assert len(again.targets) == len(program.targets)
    assert np.abs(again.targets - program.targets).max() <= TARGET_TOLERANCE_RAD
    assert configuration_labels(again.robot, again.targets) == configuration_labels(program.robot, program.targets)
    np.testing.assert_allclose(again.tool.X_FT, program.tool.X_FT, atol=1e-12)


@pytest.mark.parametrize("name", DEMOS)
def test_round_trip_gives_the_same_moves_speeds_and_zones(round_trips, name):
    program, _, _, again = round_trips[name]
    for move, read in zip(program.moves, again.moves, strict=True):
        assert read.kind == move.kind
        assert read.zone == pytest.approx(move.zone, abs=1e-12)
        if move.is_tool_move:
            assert read.speed == pytest.approx(move.speed, rel=1e-9)
            np.testing.assert_allclose(read.X_BT[:3, 3], move.X_BT[:3, 3], atol=POSITION_TOLERANCE_M)
        else:       # \T rounded up to 1 ms: the fraction read back is at most 1 ms / T below the written one
            assert move.speed * (1.0 - 1e-3 / joint_move_time(program, move)) - 1e-9 <= read.speed <= move.speed
        if move.kind == "circular":
            np.testing.assert_allclose(read.via, move.via, atol=POSITION_TOLERANCE_M)
    assert again.stops == program.stops


def test_document_units_tool_and_configurations(round_trips):
    _, _, document, _ = round_trips["gp7_pick_place"]
    assert (document["robot"], document["length_unit"], document["angle_unit"]) == ("gp7", "m", "deg")
    assert document["tool"]["xyz"] == pytest.approx([0.0, 0.0, 0.12])
    first, second = document["waypoints"][:2]
    assert set(first) == {"joints"}                       # the approach MoveAbsJ j0: where the motion starts
    assert second["move"] == "joint" and second["config"] == {"shoulder": "front", "elbow": "up", "wrist": "flip"}
    assert 99.0 < second["speed"] <= 100.0                # vmax\T: the leading axis at its full speed
    assert "tool" not in round_trips["irb1600_joint_moves"][2]


def pendant_style(text: str) -> str:
    """The irb1600_tool_moves module as a pendant might hold it: identifiers in other case, other spacing, comments,
    a robtarget
    split over lines, predefined speeddata v400 and zonedata z40 (the same values), VAR and LOCAL storage, an
    inline CirPoint, the tool's \\WObj:=wobj0 written out and ConfL \\Off."""
    lines = []
    for line in text.splitlines():
        line = line.replace("speed_400", "v400").replace("zone_40", "z40")
        line = line.replace("tool_job;", "tool_job\\WObj:=wobj0;")
        if "speeddata" in line or "zonedata" in line or line.lstrip().startswith("!"):
            continue
        if "CONST robtarget p2" in line:
            line = line.replace("LOCAL CONST", "VAR").replace("],[", "],\n      ! orientation, then confdata\n      [")
        lines.append(line.upper() if line.lstrip().startswith("Move") else line.replace("tool_job", "Tool_Job"))
    body = "\n".join(lines) + "\n".replace("ConfL\\On;", "ConfL \\Off ;  ! the pendant's default")
    via = next(line for line in text.splitlines() if "robtarget c5" in line).split(":= ")[1].rstrip(";")
    return body.replace("MOVEC C5,", f"MOVEC {via},\n      ")


def test_a_pendant_style_module_reads_the_same(round_trips, tmp_path):
    _, text, document, _ = round_trips["irb1600_tool_moves"]
    rewritten = pendant_style(text)
    assert rewritten != text and "V400, Z40" in rewritten and "! orientation" in rewritten and "MOVEC [[" in rewritten
    assert read_rapid(rewritten, "irb1600") == document
    if importlib.util.find_spec("rapidchecker") is not None:      # the rewrite is RAPID to an independent grammar
        assert rapidchecker_errors(tmp_path, rewritten).returncode == 0


def test_a_work_object_maps_targets_to_the_base_frame(round_trips):
    program, _, document, _ = round_trips["irb1600_tool_moves"]
    X_WB = np.eye(4)
    X_WB[:3, :3] = Rotation.from_euler("z", 30, degrees=True).as_matrix()
    X_WB[:3, 3] = [1.0, 0.5, 0.2]
    placed = dataclasses.replace(program, cell=types.SimpleNamespace(X_WB=X_WB))
    text = write_rapid(placed, "placed")
    assert "\\WObj:=wobj_base;" in text
    assert_same_document(read_rapid(text, "irb1600", base_in_world=X_WB), document, atol=WOBJ_ROUNDING)
    # Without the base frame the targets are read in the controller's world frame, out of the arm's reach.
    with pytest.raises(RapidReadError, match="no in-limit IK solution"):
        read_rapid(text, "irb1600")


def assert_same_document(ours, theirs, atol: float) -> None:
    """Two documents with the same keys, strings equal and numbers within ``atol``."""
    if isinstance(ours, dict):
        assert ours.keys() == theirs.keys()
        for key in ours:
            assert_same_document(ours[key], theirs[key], atol)
    elif isinstance(ours, list):
        assert len(ours) == len(theirs)
        for a, b in zip(ours, theirs):
            assert_same_document(a, b, atol)
    elif isinstance(ours, str):
        assert ours == theirs
    else:
        assert ours == pytest.approx(theirs, abs=atol)


MINIMAL = """MODULE m
  CONST jointtarget j0 := [[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p1 := [[950,0,900],[0.382683,0,0.92388,0],[0,-1,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveAbsJ j0, v100, fine, tool0;
    {second}
  ENDPROC
ENDMODULE
"""


@pytest.mark.parametrize("second, field", [
    ("StopMove;", "StopMove"),
    ("MoveL p9, v100, fine, tool0;", "MoveL"),
    ("MoveL p1, v100, fine, tool9;", "MoveL"),
    ("MoveL p1, vmax\\T:=2, fine, tool0;", "MoveL"),
    ("MoveL p1, v100, fine;", "MoveL"),
    ("MoveL p1, v100 fine, tool0;", "syntax"),
])
def test_what_is_not_read_is_named(second, field):
    with pytest.raises(RapidReadError) as error:
        read_rapid(MINIMAL.replace("{second}", second), "irb1600")
    assert error.value.field == field


def test_a_confdata_no_solution_has_is_named():
    text = MINIMAL.replace("{second}", "MoveL p1, v100, fine, tool0;").replace("[0,-1,0,0]", "[2,-1,0,0]")
    with pytest.raises(RapidReadError, match="abb configuration") as error:
        read_rapid(text, "irb1600")
    assert error.value.field == "p1"


def test_predefined_speeds_and_zones():
    text = MINIMAL.replace("{second}", "MoveL p1, v200, z10, tool0;\n    MoveAbsJ j0, v1000, fine, tool0;")
    _, second, third = read_rapid(text, "irb1600")["waypoints"]
    assert (second["speed"], second["zone"]) == (0.2, 0.01)
    assert "speed" not in third and "zone" not in third   # no \T: the job's default; the end is a stop
