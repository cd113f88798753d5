"""The tool's load with its inertia and the parts gripped and released (issue 40) in ABB RAPID and KUKA KRL: the GP7
payload pick and place written by write_rapid / write_krl holds the tool's load with the principal axes and moments
of its inertia (RAPID tload, KRL $LOAD), a GripLoad of the part's loaddata / a $LOAD of the total at the grip and
GripLoad load0 / the tool's $LOAD at the release; read back, the job has the same payload, parts (KRL: named by the
gripped mark), grip and release actions and loads per move, within the written rounding; what cannot be read is refused naming its
line. Files only in tmp_path."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import OutputError
from pipeline.files.arrays import inertia_matrix
from pipeline.outputs.controllers.krl import write_krl
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_krl import KrlReadError, read_krl
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.read_rapid import RapidReadError, read_rapid
from pipeline.program.actions import GRIP, RELEASE
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job
from pipeline.program.payload import Payload, principal_axes

from .test_independent_grammars import krl_report
from .test_rapid import rapidchecker_errors

#: The round trips run in the slow run (CI): test_payload_cli.py reads the loads back through the CLI in make test.
pytestmark = pytest.mark.slow

JOB = Path(__file__).resolve().parents[1] / "data" / "gp7_payload_pick_place.yaml"
#: The written rounding: mass [kg], centre of mass [m], inertia [kg m^2].
MASS_TOL, COM_TOL, INERTIA_TOL = 1e-3, 1e-5, 1e-6
#: A load whose inertia is not diagonal in the flange's axes [kg m^2] (Ixx, Iyy, Izz, Ixy, Ixz, Iyz; a body's).
TILTED = [0.004, 0.003, 0.0025, 0.0006, -0.0004, 0.0003]


def document(**changes) -> dict:
    """The payload job's document with ``changes`` (None deletes a key)."""
    doc = yaml.safe_load(JOB.read_text())
    for key, value in changes.items():
        if value is None:
            doc.pop(key)
        else:
            doc[key] = value
    return doc


def compiled(doc: dict):
    return compile_job(parse_job(doc, source=str(JOB)))


def rapid_round_trip(program):
    """(module text, document read back, program compiled from it)."""
    text = write_rapid(program, "pick")
    doc = read_program_text("rapid", text, "gp7", "pick.mod")
    return text, doc, compile_job(parse_job(doc, source="pick.mod"))


def krl_round_trip(program):
    """(src, dat, document read back, program compiled from it)."""
    src, dat = write_krl(program, "PICK")
    doc = read_program_text("krl", src, "gp7", "PICK.src", dat, "PICK.dat")
    return src, dat, doc, compile_job(parse_job(doc, source="PICK.src"))


def assert_same_load(a: Payload | None, b: Payload | None, inertia_tol: float = INERTIA_TOL) -> None:
    assert (a is None) == (b is None)
    if a is not None:
        assert a.mass == pytest.approx(b.mass, abs=MASS_TOL)
        np.testing.assert_allclose(a.com, b.com, atol=COM_TOL)
        np.testing.assert_allclose(a.inertia, b.inertia, atol=inertia_tol)


def grips_and_releases(program) -> list[list[tuple[str, int]]]:
    """Per waypoint, the grips and releases as (kind, index of the part in the job's parts), names aside."""
    order = list(program.parts)
    return [[(a.kind, order.index(a.part)) for a in program.actions_at(k) if a.kind in (GRIP, RELEASE)]
            for k in range(len(program.targets))]


def other_actions(program) -> list[tuple]:
    return [tuple(a for a in program.actions_at(k) if a.kind not in (GRIP, RELEASE))
            for k in range(len(program.targets))]


@pytest.fixture(scope="module")
def program():
    return compiled(document())


@pytest.fixture(scope="module")
def rapid(program):
    return rapid_round_trip(program)


@pytest.fixture(scope="module")
def krl(program):
    return krl_round_trip(program)


# ---- principal axes

def test_principal_axes_of_a_diagonal_inertia_are_the_flange_axes():
    moments, R = principal_axes(Payload(1.2, np.zeros(3), inertia_matrix([0.0031, 0.0029, 0.0012, 0, 0, 0])))
    np.testing.assert_array_equal(R, np.eye(3))
    np.testing.assert_array_equal(moments, [0.0031, 0.0029, 0.0012])


def test_principal_axes_rebuild_a_tilted_inertia_with_a_rotation_near_identity():
    inertia = inertia_matrix(TILTED)
    moments, R = principal_axes(Payload(1.0, np.zeros(3), inertia))
    np.testing.assert_allclose(R @ np.diag(moments) @ R.T, inertia, atol=1e-15)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0) and np.all(np.diag(R) > 0.5)


# ---- the written text

def test_rapid_writes_tload_with_inertia_and_gripload_at_the_grip_and_release(rapid):
    text = rapid[0]
    lines = [line.strip() for line in text.splitlines()]
    assert lines.count("LOCAL PERS tooldata tool_job := [TRUE,[[0,0,120],[1,0,0,0]],[1.2,[0,5,45],[1,0,0,0],0.0031,"
                       "0.0029,0.0012]];") == 1
    # the box's cog in the tool frame: 150 mm on the flange is 30 mm past the TCP 120 mm out
    assert lines.count("LOCAL PERS loaddata box := [2.5,[0,0,30],[1,0,0,0],0.0052,0.0052,0.0042];") == 1
    assert lines.count("GripLoad box;") == 1 and lines.count("GripLoad load0;") == 1
    pick = lines.index("MoveL p2, speed_500, fine, tool_job;")
    place = lines.index("MoveL p5, speed_500, fine, tool_job;")
    assert lines[pick + 1:pick + 5] == ["WaitDI part_present, 1 \\MaxTime:=2;", "SetDO gripper_close, 1;",
                                        "WaitTime \\InPos, 0.25;", "GripLoad box;"]
    assert lines[place + 1:place + 4] == ["SetDO gripper_close, 0;", "WaitTime \\InPos, 0.2;", "GripLoad load0;"]
    assert "(no inertia)" not in text and "PLACEHOLDER" not in text


def test_krl_writes_the_tool_load_and_the_total_at_the_grip_and_release(krl):
    src = krl[0]
    lines = src.splitlines()
    tool = ("$LOAD = {M 1.200,CM {X 0.000,Y 5.000,Z 45.000,A 0.0000,B 0.0000,C 0.0000},J {X 0.003100,Y 0.002900,"
            "Z 0.001200}}")
    assert lines.count(tool) == 2                                   # after the initialisation, and at the release
    assert lines.index(tool) < lines.index("PTP XP0")
    totals = [line for line in lines if line.startswith("$LOAD = {M 3.700,")]
    assert len(totals) == 1
    # tool + box: 3.7 kg at (0, 1.622, 115.946) mm; the offsets along Y and Z tilt the principal axes about X
    assert totals[0].startswith("$LOAD = {M 3.700,CM {X 0.000,Y 1.622,Z 115.946,A 0.0000,B 0.0000,C 2.09")
    pick, place = lines.index("LIN XP2"), lines.index("LIN XP5")
    assert lines[pick + 9] == "WAIT SEC 0.250" and lines[pick + 10] == totals[0]
    assert lines[place + 1:place + 4] == ["$OUT[1] = FALSE ; gripper_close", "WAIT SEC 0.200", tool]
    assert "$LOAD.M" not in src and "PLACEHOLDER" not in src
    assert krl_report({".src": src, ".dat": krl[1]}) == []


def test_rapidchecker_accepts_the_module_with_loads(rapid, tmp_path):
    if importlib.util.find_spec("rapidchecker") is None:
        pytest.skip("rapidchecker is not installed")
    assert rapidchecker_errors(tmp_path, rapid[0]).returncode == 0


# ---- read back

def test_rapid_round_trip_keeps_payload_parts_actions_and_loads(program, rapid):
    _, _, again = rapid
    assert_same_load(again.payload, program.payload)
    assert list(again.parts) == ["box"]
    assert_same_load(again.parts["box"], program.parts["box"])
    assert again.actions == program.actions
    assert len(again.loads) == len(program.loads)
    for a, b in zip(again.loads, program.loads):
        assert_same_load(a, b)


def test_krl_round_trip_keeps_payload_parts_actions_and_loads(program, krl):
    *_, again = krl
    assert_same_load(again.payload, program.payload)
    assert list(again.parts) == ["box"]               # KRL holds the total: the header's gripped mark names the part
    assert_same_load(again.parts["box"], program.parts["box"])
    assert grips_and_releases(again) == grips_and_releases(program) == (
        [[], [], [(GRIP, 0)], [], [], [(RELEASE, 0)], [], []])
    assert other_actions(again) == other_actions(program)
    for a, b in zip(again.loads, program.loads):
        assert_same_load(a, b)


@pytest.mark.parametrize("language", ["rapid", "krl"])
def test_a_tilted_inertia_round_trips_through_the_principal_axes(language):
    parts = {"box": {"mass": 2.5, "com": [10, -5, 150], "inertia": TILTED}}
    program = compiled(document(payload={"mass": 1.2, "com": [3, 5, 45], "inertia": TILTED}, parts=parts))
    again = rapid_round_trip(program)[-1] if language == "rapid" else krl_round_trip(program)[-1]
    assert_same_load(again.payload, program.payload)
    assert_same_load(next(iter(again.parts.values())), program.parts["box"], 2 * INERTIA_TOL)
    for a, b in zip(again.loads, program.loads):
        assert_same_load(a, b)


def test_parts_without_a_payload_keep_the_placeholder_and_write_the_parts(program):
    bare = compiled(document(payload=None))
    text, doc, again = rapid_round_trip(bare)
    assert "[TRUE,[[0,0,120],[1,0,0,0]],[1,[0,0,0],[1,0,0,0],0,0,0]]" in text and "PLACEHOLDER" in text
    assert "LOCAL PERS loaddata box := [2.5,[0,0,30],[1,0,0,0],0.0052,0.0052,0.0042];" in text
    assert "payload" not in doc and again.payload is None
    assert again.actions == bare.actions
    assert_same_load(again.parts["box"], bare.parts["box"])
    src, _, doc, again = krl_round_trip(bare)
    lines = src.splitlines()
    assert sum(line.startswith("$LOAD = {M 2.500,") and line.endswith("this is the parts' load alone")
               for line in lines) == 1
    assert sum(line.startswith("$LOAD = {M 0.000,") for line in lines) == 1            # nothing held: no load
    assert "payload" not in doc and again.payload is None
    assert grips_and_releases(again) == grips_and_releases(bare)
    assert_same_load(again.parts["box"], bare.parts["box"])


def test_a_job_without_payload_or_parts_reads_back_without(program):
    plain = compiled(document(payload=None, parts=None, waypoints=[
        {k: v for k, v in w.items() if k != "do"} for w in document()["waypoints"]]))
    assert "payload" not in rapid_round_trip(plain)[1] and "parts" not in rapid_round_trip(plain)[1]
    doc = krl_round_trip(plain)[2]
    assert "payload" not in doc and "parts" not in doc


# ---- what is refused, and what real programs write

def test_rapid_gripload_of_undeclared_loaddata_is_refused_naming_the_line(rapid):
    text = "\n".join(line for line in rapid[0].splitlines() if "loaddata box" not in line) + "\n"
    with pytest.raises(RapidReadError) as error:
        read_rapid(text, "gp7", source="pick.mod")
    assert text.splitlines()[error.value.line - 1].strip() == "GripLoad box;"
    assert "GripLoad box" in str(error.value) and "pick.mod" in str(error.value)


@pytest.mark.parametrize("name", ["p2", "p6", "tool_job", "load0", "fine"])
def test_a_part_named_like_the_modules_data_is_refused(name):
    doc = document()
    doc["parts"] = {name: doc["parts"]["box"]}
    doc["waypoints"] = [dict(w, do=[{**a, **({a_kind: name} if (a_kind := next(iter(a))) in (GRIP, RELEASE)
                                                  else {})} for a in w["do"]]) if "do" in w else w
                        for w in doc["waypoints"]]
    with pytest.raises(OutputError, match=name):
        write_rapid(compiled(doc), "pick")


def test_krl_partial_load_assignments_read_as_the_tool_and_as_a_grip(krl):
    """$LOAD.M / $LOAD.CM before the first motion (what write_krl wrote until now, and what tools write) are the
    tool's load; after a motion, $LOAD.M and $LOAD.CM together are one load change."""
    src, dat = krl[0], krl[1]
    lines = src.splitlines()
    tool = next(i for i, line in enumerate(lines) if line.startswith("$LOAD = {M 1.200"))
    lines[tool] = "$LOAD.M = 1.2\n$LOAD.CM = {X 0,Y 5,Z 45,A 0,B 0,C 0}"
    grip = next(i for i, line in enumerate(lines) if line.startswith("$LOAD = {M 3.700"))
    lines[grip] = "$LOAD.M = 3.7\n$LOAD.CM = {X 0,Y 1.622,Z 115.946,A 0,B 0,C 0}"
    release = next(i for i in range(len(lines) - 1, 0, -1) if lines[i].startswith("$LOAD = {M 1.200"))
    lines[release] = "$LOAD.M = 1.2\n$LOAD.CM = {X 0,Y 5,Z 45,A 0,B 0,C 0}"
    doc = read_krl("\n".join(lines) + "\n", dat, "gp7")
    assert doc["payload"]["mass"] == 1.2 and doc["payload"]["com"] == pytest.approx([0.0, 0.005, 0.045])
    assert "inertia" not in doc["payload"]                           # no $LOAD.J: a point mass
    assert doc["parts"]["part1"]["mass"] == pytest.approx(2.5)
    assert doc["parts"]["part1"]["com"] == pytest.approx([0.0, 0.0, 0.15], abs=1e-6)
    assert [a for w in doc["waypoints"] if isinstance(w, dict) for a in w.get("do", ()) if GRIP in a or RELEASE in a] \
        == [{GRIP: "part1"}, {RELEASE: "part1"}]


def test_krl_load_change_that_is_no_part_is_refused_naming_the_line(krl):
    src, dat = krl[0], krl[1]
    lines = src.splitlines()
    grip = next(i for i, line in enumerate(lines) if line.startswith("$LOAD = {M 3.700"))
    lines[grip] = "$LOAD.M = 0.8"                                  # less than the tool, and never carried before
    with pytest.raises(KrlReadError) as error:
        read_krl("\n".join(lines) + "\n", dat, "gp7", "PICK.src")
    assert error.value.line == grip + 1 and "$LOAD" in str(error.value) and "PICK.src" in str(error.value)
