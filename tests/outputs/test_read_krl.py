"""KUKA KRL reader (pipeline.outputs.controllers.read_krl): demo job -> compile_job -> write_krl -> read_krl -> parse_job ->
compile_job gives the same targets within the format's rounding (X, Y, Z to 0.001 mm, A, B, C and axis angles to
0.0001 deg), the same branches, move kinds, speeds (to the written $VEL_AXIS % and $VEL.CP m/s), zones and tool; a
pendant-style copy of a written program (attributes, folds, lower case, spacing, bit constants) reads the same;
what is outside the subset is a KrlReadError naming the line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import FileFormatError
from pipeline.model.ik.branches import configuration_labels
from pipeline.outputs.controllers.krl import write_krl
from pipeline.outputs.controllers.read_krl import KrlReadError, load_krl, read_krl
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

ROOT = Path(__file__).resolve().parents[2]
JOBS = ("arm6_joint_rad", "gp7_pick_place", "irb1600_tool_moves")
ROBOTS = {"arm6_joint_rad": "arm6", "gp7_pick_place": "gp7", "irb1600_tool_moves": "irb1600"}
#: Re-read targets land this close to the exported joints [deg]: the written rounding moves the joints by at
#: most 2e-4 deg on these jobs (tests/outputs/test_krl.py), axis angles by at most 0.5e-4 deg.
TARGET_TOL_DEG = 0.002
#: Written positions are rounded to 0.001 mm: a via point or tool is off by at most half of it per axis [m].
POSITION_TOL_M = 0.5e-6 * np.sqrt(3) + 1e-12


@pytest.fixture(scope="module")
def programs():
    return {name: compile_job(load_job(ROOT / "trajectories" / "jobs" / f"{name}.yaml")) for name in JOBS}


@pytest.fixture(scope="module")
def written(programs):
    return {name: write_krl(program, name.upper()) for name, program in programs.items()}


def read_back(job: str, src: str, dat: str):
    return compile_job(parse_job(read_krl(src, dat, ROBOTS[job])))


@pytest.mark.parametrize("job", JOBS)
def test_round_trip_gives_the_same_targets_branches_moves_speeds_and_zones(programs, written, job):
    program = programs[job]
    again = read_back(job, *written[job])
    assert np.degrees(np.abs(again.targets - program.targets)).max() < TARGET_TOL_DEG
    assert configuration_labels(again.robot, again.targets) == configuration_labels(program.robot, program.targets)
    assert [m.kind for m in again.moves] == [m.kind for m in program.moves]
    for before, after in zip(program.moves, again.moves):
        written_speed = before.speed * program.speed_scale
        step = 1e-3 if before.is_tool_move else 0.005              # $VEL.CP to 0.001 m/s, $VEL_AXIS to 1 %
        assert abs(after.speed * again.speed_scale - written_speed) <= step + 1e-12
        assert after.zone == pytest.approx(before.zone, abs=1e-9)
        if before.via is not None:
            assert np.linalg.norm(after.via - before.via) <= POSITION_TOL_M
    assert np.abs(again.tool.X_FT - program.tool.X_FT).max() <= POSITION_TOL_M
    assert again.tcp_accel_max == program.tcp_accel_max


def test_status_and_turn_become_the_branch_and_axis_points_joints(programs, written):
    """The GP7's PTP and LIN targets are E6POS with S and T: each waypoint's config is the exported branch; the
    arm6 job's E6AXIS points are joint waypoints in degrees."""
    program = programs["gp7_pick_place"]
    doc = read_krl(*written["gp7_pick_place"], "gp7")
    labels = configuration_labels(program.robot, program.targets)
    for k, waypoint in enumerate(doc["waypoints"]):
        if isinstance(waypoint, dict) and "config" in waypoint:
            assert ", ".join(f"{key} {name}" for key, name in waypoint["config"].items()) == labels[k]
    assert sum("config" in w for w in doc["waypoints"] if isinstance(w, dict)) == len(program.moves)
    doc = read_krl(*written["arm6_joint_rad"], "arm6")
    joints = [w if isinstance(w, list) else w["joints"] for w in doc["waypoints"]]
    np.testing.assert_allclose(np.radians(joints), programs["arm6_joint_rad"].targets, atol=np.radians(0.5e-4) + 1e-12)
    assert all(w["speed"] == 60.0 for w in doc["waypoints"][1:])          # speed 1.0 x speed_scale 0.6


def pendant_style(src: str, dat: str) -> tuple[str, str]:
    """The program as a pendant or an editor may show it: attribute lines, folds, comments, lower-case keywords and
    names, other spacing, CRLF line ends, Status and Turn as bit constants, DEFDAT ... PUBLIC."""
    head = "&ACCESS RVP\n&REL 3\n&PARAM EDITMASK = *\n"
    src_lines = []
    for line in src.splitlines():
        if line.startswith(("PTP", "LIN", "CIRC")):
            src_lines += [";FOLD " + line, "  " + line.lower().replace(",", " ,  "), ";ENDFOLD"]
        elif line.startswith("$"):
            src_lines.append(line.lower().replace(" = ", "=") + "   ; set")
        else:
            src_lines.append(line)
    bits = re.sub(r"S (\d+),T (\d+)", lambda m: f"S 'B{int(m[1]):03b}', T 'b{int(m[2]):06b}'", dat)
    public = re.sub(r"^DEFDAT (\w+)", lambda m: f"DEFDAT  {m[1].lower()} PUBLIC", bits, flags=re.MULTILINE)
    dat_lines = public.replace("DECL ", "decl ").splitlines()
    dat_lines = [dat_lines[0], "", "; points taught on the pendant"] + [f"  {line}" for line in dat_lines[1:]]
    return head + "\r\n".join(src_lines) + "\r\n", head + "\n".join(dat_lines) + "\n"


def test_a_pendant_style_program_reads_the_same(written):
    src, dat = written["gp7_pick_place"]
    styled_src, styled_dat = pendant_style(src, dat)
    assert "'B" in styled_dat and "ptp" in styled_src and "PUBLIC" in styled_dat
    assert read_krl(styled_src, styled_dat, "gp7") == read_krl(src, dat, "gp7")


def test_load_krl_reads_the_src_and_dat_files(written, tmp_path):
    src, dat = written["irb1600_tool_moves"]
    (tmp_path / "IRB.src").write_text(src)
    (tmp_path / "IRB.dat").write_text(dat)
    assert load_krl(tmp_path / "IRB.src", "irb1600") == read_krl(src, dat, "irb1600")


def with_line(src: str, old: str, new: str) -> str:
    assert old in src
    return src.replace(old, new, 1)


@pytest.mark.parametrize("change, field", [
    (("CIRC XA4, XP4 C_DIS", "CIRC XA4, XP4 C_VEL"), "C_VEL"),
    (("LIN XP2", "LIN XP99"), "XP99"),
    (("$VEL_AXIS[3] = 100", "$VEL_AXIS[3] = 50"), "$VEL_AXIS"),
    (("$BASE = $ROBROOT", "$BASE = BASE_DATA[2]"), "frame 2"),
    (("$BASE = $ROBROOT", "$BASE = $AXIS_ACT"), "$BASE"),
    (("$VEL.CP = 0.500", "$VEL.CP = $VEL_MA.CP"), "$VEL.CP"),
])
def test_what_is_outside_the_subset_is_refused_naming_the_line(written, change, field):
    src, dat = written["gp7_pick_place"]
    bad = with_line(src, *change)
    with pytest.raises(KrlReadError) as error:
        read_krl(bad, dat, "gp7", src_name="GP7.src")
    assert error.value.field == field and error.value.line is not None and error.value.source == "GP7.src"
    assert isinstance(error.value, FileFormatError)


def test_syntax_errors_and_swapped_files_are_refused(written):
    src, dat = written["gp7_pick_place"]
    with pytest.raises(KrlReadError) as error:
        read_krl(with_line(src, "PTP XP1", "PTP XP1 XP2"), dat, "gp7")
    assert error.value.field == "PTP XP1 XP2" and error.value.line is not None and "not KRL" in error.value.problem
    with pytest.raises(KrlReadError) as error:
        read_krl(dat, src, "gp7")
    assert error.value.field == "src"                   # the .src given is a data list


def test_a_first_e6pos_gives_the_start_its_status_and_turn_select(programs, written):
    """Without the BCO run to XP0, the GP7 program starts at XP1, an E6POS: the joint values its S and T select
    are the job's IK seed (start), so the re-read job starts on the exported 2 pi variant."""
    src, dat = written["gp7_pick_place"]
    doc = read_krl(with_line(src, "PTP XP0\n", ""), dat, "gp7")
    program = programs["gp7_pick_place"]
    assert "config" in doc["waypoints"][0] and "move" not in doc["waypoints"][0]
    np.testing.assert_allclose(doc["start"], np.degrees(program.targets[1]), atol=TARGET_TOL_DEG)
    again = compile_job(parse_job(doc))
    assert np.degrees(np.abs(again.targets - program.targets[1:])).max() < TARGET_TOL_DEG
