"""FANUC .ls actions and real programs (pipeline.outputs.controllers.fanuc_ls, read_ls).

* The gripper pick and place (tests/data/gp7_gripper_pick_place.yaml) written and read back: the same actions (kind,
  signal, value, times within the file's steps) and signals.
* Real programs of others (tests/data/programs/fanuc/SOURCES.md): EXAMPLE.LS (printed by a controller, Apache-2.0) and
  TMPA.LS (written by a Python tool, Apache-2.0) read into jobs whose every target is the file's point (numbers read
  here by a regular expression, not by the reader) within the file's rounding, and written again by our writer read
  the same; the others are refused naming the file, the line and the construct.
* A small program of ours (``OURS``, marked as ours) mirrors what the issue reports real pendant files hold
  (FILE_NAME = SAB951, LOCAL_REGISTERS, /APPL, UFRAME_NUM=0, point comments, FANUC's ``.000``) and, one line at a
  time, each construct the reader refuses.
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.model.robot import load_robot
from pipeline.model.vendors.axes import joint_values
from pipeline.outputs.controllers.fanuc_ls import controller_frame, controller_pose, rounding_bound, write_ls
from pipeline.outputs.controllers.read_ls import ControllerProgramError, read_ls
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

DATA = Path(__file__).resolve().parents[1] / "data"
PROGRAMS = DATA / "programs" / "fanuc"
WHEN = dt.datetime(2026, 11, 28, 3, 0, 0)
#: The files' own rounding: 0.001 mm and deg, half a step either way.
HALF_STEP = 0.0005


@pytest.fixture(scope="module")
def gripper():
    return compile_job(load_job(DATA / "gp7_gripper_pick_place.yaml"))


def same_actions(program, reread) -> None:
    """Per waypoint the same actions: kind, signal, value and times within the file's steps (0.1 s pulse, 0.01 s
    wait and timeout), comments equal."""
    for k in range(len(program.waypoints)):
        written, back = program.actions_at(k), reread.actions_at(k)
        assert [(a.kind, a.signal, a.value, a.text) for a in back] == \
               [(a.kind, a.signal, a.value, a.text) for a in written], k
        for a, b in zip(written, back):
            for field, step in (("time_s", 0.1 if a.kind == "pulse" else 0.01), ("timeout_s", 0.01)):
                if getattr(a, field) is not None:
                    assert abs(getattr(b, field) - getattr(a, field)) <= step / 2 + 1e-12
    assert reread.signals == program.signals


def test_gripper_actions_are_written_in_tp_and_read_back(gripper):
    text = write_ls(gripper, "GRIP", WHEN)
    for line in ("DO[1:gripper_close]=OFF ;", "$WAITTMOUT=200 ;", "WAIT DI[3:part_present]=ON TIMEOUT,LBL[999] ;",
                 "DO[1:gripper_close]=ON ;", "WAIT   0.25(sec) ;", "!release the part ;",
                 "DO[2:blow_off]=PULSE,0.1sec ;", "END ;", "LBL[999:input timeout] ;", "UALM[1] ;", "ABORT ;",
                 "!dh.signal.gripper_close=out1 ;"):
        assert line in text, line
    mn = text.split("/MN\n")[1].split("/POS")[0]
    assert mn.index("L P[3] 500mm/sec FINE") < mn.index("TIMEOUT") < mn.index("L P[4]")    # after the pick, at rest
    reread = compile_job(parse_job(read_program_text("ls", text, "gp7", "grip.ls")))
    same_actions(gripper, reread)
    assert [reread.rest_at(k) for k in range(len(reread.waypoints))] == \
           pytest.approx([gripper.rest_at(k) for k in range(len(gripper.waypoints))])


def test_a_long_comment_continues_on_the_next_lines(gripper, tmp_path):
    text = (DATA / "gp7_gripper_pick_place.yaml").read_text().replace(
        "{comment: release the part}", "{comment: release the part over the conveyor and check the light curtain}")
    path = tmp_path / "long.yaml"
    path.write_text(text)
    program = compile_job(load_job(path))
    written = write_ls(program, "GRIP", WHEN)
    assert "!release the part over the+ ;" in written
    same_actions(program, compile_job(parse_job(read_program_text("ls", written, "gp7", "grip.ls"))))


def test_a_signal_without_a_number_is_refused(tmp_path):
    text = (DATA / "gp7_gripper_pick_place.yaml").read_text().replace("blow_off: {output: 2}", "blow_off: {output: null}")
    path = tmp_path / "unnumbered.yaml"
    path.write_text(text)
    with pytest.raises(ConfigurationError, match="signal 'blow_off' has no number"):
        write_ls(compile_job(load_job(path)), "GRIP", WHEN)


#: The real programs read (SOURCES.md): file, test arm, tool (UT 1 on the flange: the file does not hold it), user
#: frame (UF 1 of TMPA.LS: the source's README sets it at the bottom of the base, shifted along z only).
REAL = {
    "EXAMPLE.LS": ("m20ia_test.yaml", np.eye(4), None),
    "TMPA.LS": ("r2000ic165f_test.yaml", np.eye(4), rpy_position_to_pose(np.zeros(3), np.array([0.0, 0.0, -0.670]))),
}
_POINT = re.compile(r"P\[(\d+)[^\]]*\]\{\s*GP1:\s*UF : \d+, UT : \d+,\s*(?:CONFIG : '[^']*',)?(.*?)\n\};", re.DOTALL)
_VALUE = re.compile(r"([XYZWPR]|J\d)\s*=\s*(-?\d*\.\d+)")


def file_points(text: str) -> dict[int, dict[str, float]]:
    """P index -> {axis: value} of a program's /POS, read by regular expressions (independent of the reader)."""
    return {int(index): {axis: float(v) for axis, v in _VALUE.findall(body)} for index, body in _POINT.findall(text)}


def motion_refs(text: str) -> list[int]:
    """The P index each motion line goes to (a C move's end point), in order."""
    mn = text.split("/MN")[1].split("/POS")[0]
    return [int(m) for m in re.findall(r"^\s*\d*:\s*[JL] P\[(\d+)|^\s*:\s*P\[(\d+)", mn, re.MULTILINE) for m in m if m]


def read_real(name: str) -> tuple[dict, str, object]:
    robot_file, tool, frame = REAL[name]
    text = (PROGRAMS / name).read_text()
    document = read_ls(text, str(PROGRAMS / robot_file), tool=tool, frame=frame, source=name)
    return document, text, load_robot(PROGRAMS / robot_file)


@pytest.mark.parametrize("name", REAL)
def test_real_program_targets_are_the_files_points(name):
    document, text, robot = read_real(name)
    program = compile_job(parse_job(document))
    _, tool, frame = REAL[name]
    X_B_UF = controller_frame(robot, "fanuc")[0] @ (np.eye(4) if frame is None else frame)
    points = file_points(text)
    refs = motion_refs(text)
    assert len(refs) == len(program.targets)
    for ref, q in zip(refs, program.targets):
        values = points[ref]
        if "X" not in values:
            assert np.allclose(q, joint_values(robot, [values[f"J{i}"] for i in range(1, 7)], "fanuc"), atol=1e-12)
            continue
        X_file = controller_pose(X_B_UF, [values[a] for a in "XYZ"], [values[a] for a in "WPR"])
        X = program.robot.fk(q) @ tool
        assert np.abs(X[:3, 3] - X_file[:3, 3]).max() * 1000 <= HALF_STEP
        angle = np.arccos(np.clip((np.trace(X[:3, :3].T @ X_file[:3, :3]) - 1) / 2, -1, 1))
        assert np.degrees(angle) <= HALF_STEP


@pytest.mark.parametrize("name", REAL)
def test_real_program_written_again_reads_the_same(name, tmp_path):
    document, _, _ = read_real(name)
    program = compile_job(parse_job(document))
    text = write_ls(program, "AGAIN", WHEN)
    again = compile_job(parse_job(read_program_text("ls", text, str(PROGRAMS / REAL[name][0]), "again.ls")))
    assert [m.kind for m in again.moves] == [m.kind for m in program.moves]
    for q, q_again in zip(program.targets, again.targets):
        assert np.all(np.abs(q_again - q) <= rounding_bound(program.robot, q, 0.001, 0.001))
    for move, back in zip(program.moves, again.moves):
        assert abs(back.speed * again.speed_scale - move.speed * program.speed_scale) <= 0.01
    same_actions(program, again)


def test_example_ls_reads_the_pendants_header_override_and_payload():
    document, _, _ = read_real("EXAMPLE.LS")
    assert document["speed_scale"] == 0.3                           # OVERRIDE=30%
    assert "PAYLOAD[1:spray]" in document["description"]
    assert [w.get("move") for w in document["waypoints"][1:]] == ["joint", "linear", "circular", "linear"]
    via = file_points((PROGRAMS / "EXAMPLE.LS").read_text())[4]                 # C P[4] / : P[5]: the via point
    assert document["waypoints"][3]["via"]["xyz"] == pytest.approx([via["X"] / 1000, via["Y"] / 1000,
                                                                    via["Z"] / 1000 + 0.525], abs=1e-12)


def test_tmpa_ls_reads_its_output_as_a_signal():
    document, _, _ = read_real("TMPA.LS")
    assert document["signals"] == {"do103": {"output": 103}}
    assert document["waypoints"][-1]["do"] == [{"set": "do103", "value": "off"}]


def test_tmpa_ls_needs_its_user_frame():
    with pytest.raises(ControllerProgramError, match=r"TMPA.LS:5: line 5: user frame 1 .*not in the file"):
        read_ls((PROGRAMS / "TMPA.LS").read_text(), str(PROGRAMS / "r2000ic165f_test.yaml"), tool=np.eye(4),
                source="TMPA.LS")


@pytest.mark.parametrize("name, robot, match", [
    ("rosi_ros_movesm.ls", "lrmate200id", r"rosi_ros_movesm.ls:24: line 24: F\[1:ROS-I rdy\]=\(OFF\): a register or flag"),
    ("TEST.LS", "m20ia_test.yaml", r"TEST.LS:7: line 7: RUN DATARECORDER: a call of another program"),
    ("TMPB.LS", "m20ia_test.yaml", r"TMPB.LS:12: P\[1\]: motion group GP2: only one motion group"),
    ("gofanuc_test.ls", "r2000ic165f_test.yaml", r"gofanuc_test.ls:37: P\[2\]: .*F D B, -1, -1, 1: no in-limit IK"),
])
def test_real_programs_refused_name_file_line_and_construct(name, robot, match):
    robot = robot if robot == "lrmate200id" else str(PROGRAMS / robot)
    with pytest.raises(ControllerProgramError, match=match):
        read_ls((PROGRAMS / name).read_text(), robot, tool=np.eye(4), source=name)


# A program of ours (not a copy): the header and point forms real pendant files use (the SAB951 report).
OURS = """/PROG  OURS
/ATTR
OWNER\t\t= MNEDITOR;
COMMENT\t\t= "ours";
PROG_SIZE\t= 0;
CREATE\t\t= DATE 26-11-28  TIME 10:00:00;
MODIFIED\t= DATE 26-11-28  TIME 10:00:00;
FILE_NAME\t= SAB951;
VERSION\t\t= 0;
LINE_COUNT\t= 4;
MEMORY_SIZE\t= 0;
PROTECT\t\t= READ_WRITE;
TCD:  STACK_SIZE\t= 0,
      TASK_PRIORITY\t= 50,
      TIME_SLICE\t= 0,
      BUSY_LAMP_OFF\t= 0,
      ABORT_REQUEST\t= 0,
      PAUSE_REQUEST\t= 0;
DEFAULT_GROUP\t= 1,*,*,*,*;
CONTROL_CODE\t= 00000000 00000000;
LOCAL_REGISTERS\t= 0,0,0;
/APPL

AUTO_SINGULARITY_HEADER;
  ENABLE_SINGULARITY_AVOIDANCE   : TRUE;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% FINE    ;
   4:L P[2:Prise cloueur] 250mm/sec FINE    ;
/POS
P[1]{
   GP1:
\tUF : 0, UT : 0,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =   400.000  mm,\tY =     0.000  mm,\tZ =   170.000  mm,
\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg
};
P[2:"Prise cloueur"]{
   GP1:
\tUF : 0, UT : 0,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =   400.000  mm,\tY =   100.000  mm,\tZ =   170.000  mm,
\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg
};
/END
"""
#: The file line of OURS's L move (an instruction inserted before it lands on this line).
L_LINE = OURS.splitlines().index("   4:L P[2:Prise cloueur] 250mm/sec FINE    ;") + 1


def with_line(instruction: str, text: str = OURS) -> str:
    """``text`` (OURS) with one /MN instruction inserted just before the L move."""
    return re.sub(r"^( *\d+:L P\[2:)", lambda m: f"   0:  {instruction} ;\n{m.group(1)}", text, count=1, flags=re.MULTILINE)


def test_our_pendant_style_program_reads():
    document = read_ls(OURS, "lrmate200id", source="ours.ls")
    assert document["waypoints"][1]["xyz"] == pytest.approx([0.4, 0.1, 0.5])        # world frame 330 mm up
    assert "tool" not in document                                                     # UT 0: the flange


def test_fanucs_number_format_reads_as_the_same_numbers():
    short = re.sub(r"(?<![\d.])0\.000", ".000", OURS)
    assert "     .000  mm" in short
    assert read_ls(short, "lrmate200id") == read_ls(OURS, "lrmate200id")


def test_actions_of_a_pendant_program():
    text = with_line("DO[2:OFF:Cil2Retract]=ON", with_line("WAIT DI[4:part here]=OFF", with_line("WAIT    .25(sec)")))
    document = read_ls(text, "lrmate200id")
    assert document["waypoints"][0]["do"] == [{"wait": 0.25}, {"wait_input": "di4", "value": "off"},
                                              {"set": "Cil2Retract", "value": "on"}]
    assert document["signals"] == {"di4": {"input": 4}, "Cil2Retract": {"output": 2}}


def test_offset_by_a_position_register_the_file_sets():
    elements = [f"PR[5,{i}]={v}" for i, v in enumerate(["10", "(-20)", "30.5", "0", "0", "0"], start=1)]
    text = OURS.replace("   3:J P[1]", "".join(f"   0:  {e} ;\n" for e in elements) + "   3:J P[1]")
    text = text.replace("250mm/sec FINE    ;", "250mm/sec FINE Offset,PR[5:shift]    ;")
    shifted = read_ls(text, "lrmate200id")["waypoints"][1]["xyz"]
    assert shifted == pytest.approx([0.41, 0.08, 0.5305])


@pytest.mark.parametrize("instruction, match", [
    ("JMP LBL[1]", "JMP LBL\\[1\\]: a jump"),
    ("LBL[1]", "LBL\\[1\\]: a label"),
    ("IF R[1]=1,JMP LBL[2]", "IF R\\[1\\]=1,JMP LBL\\[2\\]: a branch"),
    ("SELECT R[1]=1,JMP LBL[2]", "SELECT .*: a branch on a register"),
    ("CALL PICK", "CALL PICK: a call of another program"),
    ("SKIP CONDITION DI[3]=ON", "SKIP CONDITION DI\\[3\\]=ON: a skip condition"),
    ("R[1]=R[1]+1", "R\\[1\\]=R\\[1\\]\\+1: a register or flag assignment"),
    ("RO[1]=ON", "RO\\[1\\]=ON: robot I/O"),
    ("DO[1]=PULSE", "DO\\[1\\]=PULSE: a pulse without a width"),
    ("WAIT (F[2:ready])", "WAIT \\(F\\[2:ready\\]\\): a wait on a condition"),
    ("WAIT DI[1]=ON TIMEOUT,LBL[7]", "a timeout without \\$WAITTMOUT"),
    ("OVERRIDE=50%", "OVERRIDE=50%: an override is read before the first move only"),
    ("UTOOL_NUM=R[28]", "UTOOL_NUM=R\\[28\\]: selects a frame by a register"),
    ("J PR[1:home] 100% FINE", "J PR\\[1:home\\] 100% FINE: a target in a position register"),
    ("L P[1] R[26]mm/sec FINE", "speed R\\[26\\]mm/sec is a register"),
    ("L P[1] 100mm/sec FINE ACC10", "ACC10: an acceleration override"),
    ("L P[1] 100mm/sec FINE Tool_Offset,PR[8]", "Tool_Offset,PR\\[8\\]: read only where the file sets"),
    ("L P[1] 100mm/sec FINE INC", "INC: a motion option this reader does not read"),
    ("A P[1] 100mm/sec FINE", "A P\\[1\\] 100mm/sec FINE: an arc move"),
    ("UFRAME[9:STRIP_DRILL]=PR[9]", "UFRAME\\[9:STRIP_DRILL\\]=PR\\[9\\]: sets a frame's data"),
    ("J P[1] R[23]% FINE", "speed R\\[23\\]% is a register"),
    ("WAIT RI[1]=ON", "WAIT RI\\[1\\]=ON: robot I/O"),
])
def test_each_refused_construct_names_file_line_and_construct(instruction, match):
    with pytest.raises(ControllerProgramError, match=rf"ours.ls:{L_LINE}: line {L_LINE}: .*{match}"):
        read_ls(with_line(instruction), "lrmate200id", source="ours.ls")


@pytest.mark.parametrize("edits, match", [
    ([("UTOOL_NUM=0", "UTOOL_NUM=2"), ("UT : 0", "UT : 2")], "ours.ls:28: line 28: tool 2 .*not in the file"),
    ([("UFRAME_NUM=0", "UFRAME_NUM=3"), ("UF : 0", "UF : 3")], "ours.ls:27: line 27: user frame 3 .*not in the file"),
    ([("UTOOL_NUM=0", "UTOOL_NUM=2")], "ours.ls:33: P\\[1\\]: UT : 0, but UTOOL_NUM=2: .*frame mismatch"),
    ([("R =     0.000 deg\n};\n/END", "R =     0.000 deg,\n\tE1=   120.000  mm\n};\n/END")],
     "ours.ls:39: P\\[2\\]: extended axes"),
    ([("R =     0.000 deg\n};\n/END", "R =     0.000 deg\n   GP2:\n\tUF : 0, UT : 0,\t\n\tJ1=     6.428 deg\n};\n/END")],
     "ours.ls:38: P\\[2\\]: motion group GP2"),
])
def test_frames_tools_and_extended_axes_not_in_the_file(edits, match):
    text = OURS
    for edit in edits:
        text = text.replace(*edit)
    with pytest.raises(ControllerProgramError, match=match):
        read_ls(text, "lrmate200id", source="ours.ls")


def test_an_extended_axis_at_zero_is_ignored():
    text = OURS.replace("R =     0.000 deg\n};\n/END", "R =     0.000 deg,\n\tE1=     0.000  mm\n};\n/END")
    assert read_ls(text, "lrmate200id") == read_ls(OURS, "lrmate200id")


def test_an_endless_outer_loop_reads_as_one_cycle():
    looped = OURS.replace("   3:J P[1]", "   0:  LBL[1:cycle] ;\n   3:J P[1]").replace("/POS", "   5:  JMP LBL[1] ;\n/POS", 1)
    document = read_ls(looped, "lrmate200id")
    assert "endless loop (LBL[1] at line 29, JMP back at line 32) reads as one cycle" in document["description"]
    assert document["waypoints"] == read_ls(OURS, "lrmate200id")["waypoints"]
    with pytest.raises(ControllerProgramError, match="ours.ls:29: line 29: LBL\\[1\\]: a label without the JMP"):
        read_ls(looped.replace("   5:  JMP LBL[1] ;\n", ""), "lrmate200id", source="ours.ls")
    with pytest.raises(ControllerProgramError, match="ours.ls:33: line 33: DO\\[1\\]=ON: after the outer loop"):
        read_ls(looped.replace("/POS", "   6:  DO[1]=ON ;\n/POS", 1), "lrmate200id", source="ours.ls")


def test_a_timeout_label_must_be_the_alarm_pattern():
    timed = with_line("WAIT DI[1]=ON TIMEOUT,LBL[7]", with_line("$WAITTMOUT=150"))
    pattern = "   6:  END ;\n   7:  LBL[7:timeout] ;\n   8:  UALM[1] ;\n   9:  ABORT ;\n/POS"
    document = read_ls(timed.replace("/POS", pattern, 1), "lrmate200id")
    assert document["waypoints"][0]["do"] == [{"wait_input": "di1", "value": "on", "timeout": 1.5}]
    with pytest.raises(ControllerProgramError, match="TIMEOUT,LBL\\[7\\]: the label must be"):
        read_ls(timed.replace("/POS", pattern.replace("UALM[1] ;\n   9:  ABORT", "UALM[1]"), 1), "lrmate200id")


@pytest.mark.slow
def test_nothing_is_written_when_a_signal_has_no_number(tmp_path, capsys):
    """``program --lang ls`` of a job whose signal has no number: one error line naming it, no file (compiles and
    times the job: a few seconds)."""
    from pipeline.__main__ import main

    text = (DATA / "gp7_gripper_pick_place.yaml").read_text().replace("blow_off: {output: 2}", "blow_off: {output: null}")
    job = tmp_path / "unnumbered.yaml"
    job.write_text(text)
    out = tmp_path / "out"
    assert main(["program", str(job), "--lang", "ls", "--out", str(out)]) != 0
    assert "signal 'blow_off' has no number" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())
