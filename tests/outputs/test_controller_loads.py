"""Files a controller loads without edits (issue 35): one test per defect found in the written programs: KRL's
PTP approximation per controller generation, reserved names, load data, FANUC's frame selection, no Yaskawa zone
into an arc's repeated start, URScript's call of its program and replay guard, RAPID's LOCAL scope and names, and
never writing one job's program over another's. Files only in tmp_path.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.errors import ControllerLintError, OutputError
from pipeline.outputs.controllers.fanuc_ls import write_ls
from pipeline.outputs.controllers.krl import write_krl
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_krl import read_krl
from pipeline.outputs.controllers.read_ls import read_ls
from pipeline.outputs.controllers.read_urscript import read_urscript
from pipeline.outputs.controllers.urscript import MAX_REPLAY_LINES, resample, write_urscript
from pipeline.outputs.controllers.yaskawa_jbi import write_jbi
from pipeline.program.compile import compile_job
from pipeline.program.job import Payload, load_job, parse_job
from pipeline.program.model import CIRCULAR
from pipeline.runner import program_name

from .test_urscript import UR5_JOB

ROOT = Path(__file__).resolve().parents[2]
JOBS = ROOT / "trajectories" / "jobs"
GP7_JOB = JOBS / "gp7_pick_place.yaml"
PAYLOAD = Payload(2.5, np.array([0.0, 0.01, 0.08]))


@pytest.fixture(scope="module")
def gp7():
    return compile_job(load_job(GP7_JOB))


@pytest.fixture(scope="module")
def ur5():
    """test_urscript's UR5 job compiled: URScript is written for UR arms only."""
    return compile_job(parse_job(UR5_JOB, source="ur5_job.yaml"))


def test_krl_default_generation_writes_c_ptp_on_ptp_and_reads_back(gp7):
    """KR C2 / KSS 5 (and krl.g4) take only C_PTP after PTP: no `PTP ... C_DIS` without C_PTP by default."""
    program = dataclasses.replace(gp7, moves=tuple(dataclasses.replace(m, zone=0.02) if m.end == 1 else m
                                                   for m in gp7.moves), stops=tuple(k for k in gp7.stops if k != 1))
    src, dat = write_krl(program, "GP7")
    ptp = [line for line in src.splitlines() if line.startswith("PTP ")]
    assert "PTP XP1 C_PTP C_DIS" in ptp                       # a LIN follows: C_DIS for the PTP-CP transition
    assert not any(line.endswith(" C_DIS") and "C_PTP" not in line for line in ptp)
    lines = src.splitlines()
    i = lines.index("PTP XP1 C_PTP C_DIS")
    assert re.fullmatch(r"\$APO\.CPTP = \d+", lines[i - 1]) and lines[i - 2] == "$APO.CDIS = 20.000"
    assert read_krl(src, dat, "gp7")["waypoints"][1]["zone"] == pytest.approx(0.02)
    kss8, _ = write_krl(program, "GP7", generation="kss8")
    assert "PTP XP1 C_DIS" in kss8.splitlines() and "C_PTP" not in kss8
    with pytest.raises(OutputError, match="generation"):
        write_krl(program, "GP7", generation="krc4")


@pytest.mark.parametrize("language, reserved", [("krl", "END"), ("krl", "XP1"), ("rapid", "MODULE"),
                                                ("rapid", "tool_job"), ("jbi", "NOP"), ("ls", "END"),
                                                ("urscript", "def")])
def test_reserved_job_names_get_a_prefix_and_are_refused_as_given(gp7, ur5, language, reserved):
    """`DEF END( )` is not KRL: a job named END becomes P_END; the writers refuse a reserved name (URScript's on
    the UR5, an arm it writes for)."""
    assert program_name(language, reserved).upper() == f"P_{reserved}".upper()
    writers = {"krl": write_krl, "rapid": write_rapid, "jbi": write_jbi, "ls": write_ls, "urscript": write_urscript}
    with pytest.raises((ControllerLintError, OutputError), match="name"):
        writers[language](ur5 if language == "urscript" else gp7, reserved)


def test_payload_is_written_in_every_language_and_a_placeholder_without(gp7, ur5):
    loaded = dataclasses.replace(gp7, payload=PAYLOAD)
    src, _ = write_krl(loaded, "GP7")
    assert "$LOAD = {M 2.500,CM {X 0.000,Y 10.000,Z 80.000,A 0.0000,B 0.0000,C 0.0000},J {X 0.000000,Y 0.000000,Z " \
        "0.000000}}" in src.splitlines()
    assert "PLACEHOLDER" in write_krl(gp7, "GP7")[0]
    assert "[TRUE,[[0,0,120],[1,0,0,0]],[2.5,[0,10,80],[1,0,0,0],0,0,0]]" in write_rapid(loaded, "GP7")
    assert "PLACEHOLDER" in write_rapid(gp7, "GP7")
    script = write_urscript(dataclasses.replace(ur5, payload=PAYLOAD), "ur5")
    assert "  set_target_payload(2.5, [0.0, 0.01, 0.08], [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])" in script.splitlines()
    assert read_urscript(script, UR5_JOB["robot"])["payload"] == {"mass": 2.5, "com": [0.0, 0.01, 0.08]}
    assert "PLACEHOLDER" in write_urscript(ur5, "ur5")
    for writer, said in ((write_ls, "payload 2.5 kg"), (write_jbi, "W 2.5 kg")):      # FANUC schedule, tool file
        assert said in writer(loaded, "GP7") and "PLACEHOLDER" in writer(gp7, "GP7")


def test_job_payload_is_validated(tmp_path):
    document = yaml.safe_load(GP7_JOB.read_text())
    job = parse_job({**document, "payload": {"mass": 2.5, "com": [0, 10, 80]}}, str(GP7_JOB), "gp7_pick_place")
    assert job.payload.mass == 2.5 and np.allclose(job.payload.com, [0.0, 0.01, 0.08])
    for bad, where in (({"mass": -1}, "mass"), ({"com": [0, 0, 1]}, "mass"), ({"mass": 1, "com": [0, 1]}, "com"),
                       ({"mass": 1, "cog": [0, 0, 0]}, "cog")):
        with pytest.raises(Exception, match=where):
            parse_job({**document, "payload": bad}, str(GP7_JOB), "gp7_pick_place")


def test_ls_selects_the_frames_its_points_name(gp7):
    text = write_ls(gp7, "GP7")
    main_lines = text.split("/MN\n")[1].splitlines()
    assert main_lines[:2] == ["   1:  UFRAME_NUM=0 ;", "   2:  UTOOL_NUM=1 ;"]
    assert set(re.findall(r"UF : (\d+), UT : (\d+)", text)) == {("0", "1")}
    assert "percentage, not a distance" in " ".join(re.findall(r"!(.*?) ;", text))     # CNT kept, and why
    read_ls(text, "gp7")                                      # the reader takes the selection lines


def test_jbi_has_no_zone_into_an_arc_and_ends_with_end(gp7):
    """Waypoint 3 (zone 60 mm) is followed by an arc whose first MOVC repeats it: no PL there."""
    assert gp7.moves[2].zone > 0.0 and gp7.moves[3].kind == CIRCULAR
    instructions = write_jbi(gp7, "GP7").split("//INST\n")[1].splitlines()
    moves = [line for line in instructions if line.startswith("MOV")]
    for before, after in zip(moves, moves[1:]):
        if after.startswith("MOVC") and not before.startswith("MOVC"):
            assert "PL=" not in before, before
    assert [line for line in instructions if not line.startswith(("///", "'"))][0] == "NOP"
    assert instructions[-1] == "END"


def test_urscript_calls_its_program(ur5):
    lines = write_urscript(ur5, "ur5").splitlines()
    assert lines[0] == "def ur5():" and lines[-2:] == ["end", "ur5()"]
    with pytest.raises(Exception, match="other"):
        read_urscript("\n".join(lines[:-1] + ["other()"]) + "\n", UR5_JOB["robot"])


def test_urscript_replay_guard_names_the_length_and_a_period_that_fits():
    t = np.linspace(0.0, 600.0, 11)
    profile = SimpleNamespace(t=t, q=np.zeros((11, 6)), qd=np.zeros((11, 6)))     # what resample reads
    with pytest.raises(OutputError, match=r"600\.0 s profile .* 300,000 lines.*--servo-period 0\.01 would fit"):
        resample(profile, 0.002)
    assert len(resample(profile, 600.0 / MAX_REPLAY_LINES)) == MAX_REPLAY_LINES


def test_rapid_declares_its_data_local_and_a_unique_entry(gp7):
    text = write_rapid(gp7, "gp7_pick_place")
    declarations = [line.strip() for line in text.splitlines() if re.match(r"\s+(LOCAL|PERS|CONST|TASK|VAR)\b", line)]
    assert declarations and all(line.startswith("LOCAL ") for line in declarations)
    assert "  PROC main_gp7_pick_place()" in text.splitlines() and "PROC main()" not in text
    assert program_name("rapid", "tool_job") == "P_tool_job"


def written(tmp_path: Path, job: str, *extra: str) -> int:
    return main(["program", str(tmp_path / f"{job}.yaml"), "--lang", "jbi", "--out", str(tmp_path / "out"), *extra])


@pytest.mark.slow                                   # some 5 s: two jobs compiled, timed and written
def test_another_jobs_program_is_never_overwritten(tmp_path, capsys):
    """gp7_pick_place and gp7_pick_place2 both make GP7_PICK.jbi: the second is refused (exit 2) naming both
    jobs, the first file is untouched; --force replaces it."""
    for job in ("gp7_pick_place", "gp7_pick_place2"):
        (tmp_path / f"{job}.yaml").write_text(GP7_JOB.read_text())
    assert written(tmp_path, "gp7_pick_place") == 0
    first = (tmp_path / "out" / "GP7_PICK.jbi").read_bytes()
    assert b"job=gp7_pick_place\n" in first
    assert written(tmp_path, "gp7_pick_place") == 0            # the same job again: replaced
    capsys.readouterr()
    assert written(tmp_path, "gp7_pick_place2") == 2
    error = capsys.readouterr().err
    assert "gp7_pick_place2" in error and "job gp7_pick_place," in error and "GP7_PIC2" in error
    assert re.sub(rb"///DATE [^\n]*", b"", (tmp_path / "out" / "GP7_PICK.jbi").read_bytes()) == \
        re.sub(rb"///DATE [^\n]*", b"", first)
    assert written(tmp_path, "gp7_pick_place2", "--force") == 0
    assert b"job=gp7_pick_place2\n" in (tmp_path / "out" / "GP7_PICK.jbi").read_bytes()
