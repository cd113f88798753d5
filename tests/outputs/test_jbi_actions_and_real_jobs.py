"""Yaskawa INFORM actions and real jobs (pipeline.outputs.controllers.yaskawa_jbi / read_jbi, issue 37).

* The GP7 gripper pick and place written with its actions (DOUT, PULSE T=, TIMER, WAIT IN# T= with the PAUSE IF
  check, comments) reads back with equal actions and signal names, and the same targets.
* Real jobs of others (tests/data/programs/yaskawa, SOURCES.md): each is refused naming the file, the line and the
  construct (none of the permissively licensed real jobs found has static motion alone: calls, branches, skills,
  station groups, waits on outputs, a tool set at run time, a pause); the tool-changer job with its CALL line removed
  (the issue's "with the I/O lines removed it reads") is refused at ``///TOOL 1`` instead of taking the flange, and
  with its tool given at its pulse data, which need the robot's pulse ratios; RoboDK's sample job is refused construct
  by construct (SETE/SETTOOL, MSG, PAUSE, CALL), then at its ``///TOOL 9`` and its pulse data.
* A job in the style of those real jobs (no ///COMM, //ARGINFO, ////FRAME, ///LVARS, tab indentation, CR LF, pulse
  data, BASE data, position variables, a user frame, a variable assignment, actions before the first move), GP7
  sized: its targets read as the file gives them, and re-written by our writer it reads the same again.
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.poses import rpy_position_to_pose
from pipeline.outputs.controllers.read_jbi import read_jbi
from pipeline.outputs.controllers.read_ls import ControllerProgramError
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.outputs.controllers.yaskawa_jbi import write_jbi
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job

from .test_read_ls import check_round_trip

DATA = Path(__file__).resolve().parents[1] / "data"
REAL = DATA / "programs" / "yaskawa"
WHEN = dt.datetime(2026, 11, 27, 3, 0)
#: The caller's pulse ratios of the job below [pulses/deg] (a controller's own come from its parameters).
PPD = (1000.0, 1000.0, 1000.0, 800.0, 800.0, 500.0)
#: The tool file 1 of the job below: 120 mm along the flange's z [m].
TOOL_1 = rpy_position_to_pose(np.zeros(3), np.array([0.0, 0.0, 0.12]))


@pytest.fixture(scope="module")
def gripper():
    return compile_job(load_job(DATA / "gp7_gripper_pick_place.yaml"))


def actions_of(program) -> list[list[str]]:
    return [[str(a) for a in program.actions_at(k)] for k in range(len(program.waypoints))]


def test_gripper_actions_are_written_in_inform(gripper):
    text = write_jbi(gripper, "GRIP", WHEN)
    body = text.split("\nNOP\n", 1)[1]
    expected = ["MOVJ C00000 VJ=100.00", "DOUT OT#(1) OFF", "MOVL C00002 V=500.0", "WAIT IN#(3)=ON T=2.00",
                "PAUSE IF IN#(3)=OFF", "DOUT OT#(1) ON", "TIMER T=0.25", "MOVL C00006 V=500.0", "'release the part",
                "DOUT OT#(1) OFF", "PULSE OT#(2) T=0.10", "TIMER T=0.20"]
    lines = body.splitlines()
    assert [line for line in lines if line in expected] == expected      # in this order, each once
    for entry in ("'dh.signal.gripper_close=out1", "'dh.signal.part_present=in3", "'dh.signal.blow_off=out2"):
        assert entry in lines


def test_gripper_actions_read_back_equal(gripper):
    """Written and read back (with read_program's signal names): the same actions and signals, targets within the
    file's rounding."""
    document = read_program_text("jbi", write_jbi(gripper, "GRIP", WHEN), "gp7", "grip.jbi")
    reread = compile_job(parse_job(document, source="grip.jbi", name="grip"))
    assert actions_of(reread) == actions_of(gripper)
    assert reread.signals == gripper.signals
    for q, q_back in zip(gripper.targets, reread.targets):
        assert np.abs(q_back - q).max() < 1e-4


def test_a_wait_with_timeout_without_the_pause_check_is_refused(gripper):
    text = write_jbi(gripper, "GRIP", WHEN).replace("PAUSE IF IN#(3)=OFF\n", "")
    with pytest.raises(ControllerProgramError, match=r"grip.jbi:\d+: WAIT IN#\(3\)=ON T=2.00: after T= the job goes "
                                                     r"on whether or not the input came"):
        read_jbi(text, "gp7", source="grip.jbi")


def test_a_wait_without_time_is_a_wait_without_timeout(gripper):
    text = write_jbi(gripper, "GRIP", WHEN).replace("WAIT IN#(3)=ON T=2.00\nPAUSE IF IN#(3)=OFF", "WAIT IN#(3)=ON")
    do = read_jbi(text, "gp7")["waypoints"][2]["do"]
    assert do[0] == {"wait_input": "di3", "value": "on"}


def gripper_document(**signals) -> dict:
    import yaml

    document = yaml.safe_load((DATA / "gp7_gripper_pick_place.yaml").read_text())
    document["signals"].update(signals)
    return document


def test_a_signal_without_a_number_is_refused():
    program = compile_job(parse_job(gripper_document(blow_off={"output": None}), source="g.yaml", name="g"))
    with pytest.raises(ConfigurationError, match="signal 'blow_off' has no number; INFORM addresses I/O by number"):
        write_jbi(program, "GRIP", WHEN)


def test_a_time_beyond_inform_is_refused():
    document = gripper_document()
    document["waypoints"][5]["do"][3] = {"wait": 700}
    program = compile_job(parse_job(document, source="g.yaml", name="g"))
    with pytest.raises(ConfigurationError, match=r"waypoint 5: wait 700 s: 700 s is not an INFORM time T="):
        write_jbi(program, "GRIP", WHEN)


@pytest.mark.parametrize("name, line, construct", [
    ("yis_TEST1.JBI", 31, "SET LP000 P100: sets LP000, a position or system variable"),
    ("rosi_INIT_ROS.JBI", 14, r"WAIT OT#\(890\)=ON: not read"),
    ("rosi_ROS_S1.JBI", 8, "///GROUP1 ST1: only a robot alone"),
    ("ags_SAMPLE_TC.JBI", 34, "CALL JOB:TOOLCHANGE ARGFI025: calls another job"),
    ("ags_TESTSPINDLE.JBI", 13, "CALL JOB:SET-SPINDLE: calls another job"),
    ("ags_HOME_TOOLCHANGER.JBI", 11, r"PULSE OT#\(212\): a pulse without T="),
    ("ags_FORMCUT.JBI", 20, 'SKILLSND SL5 "barcodeScan": sends a command to another program'),
    ("ags_TC_FULL_CHANGE.JBI", 42, "IFTHENEXP B009<1: a branch on a condition known only when the job runs"),
    ("robodk_PROGRAM.JBI", 32, r"SETE P00095 \(1\) -30000: sets P00095, a position or system variable"),
])
def test_real_jobs_are_refused_naming_line_and_construct(name, line, construct):
    with pytest.raises(ControllerProgramError, match=rf"^{name}:{line}: {construct}"):
        read_jbi((REAL / name).read_text(), "gp7", source=name)


def assert_refused_at_tool_then_pulses(text: str, source: str, tool_refusal: str) -> None:
    """``text`` read as ``source`` is refused at its tool file (``tool_refusal``: the message's pattern after
    ``source:``), and given the tool, at its first pulse point, line 8."""
    with pytest.raises(ControllerProgramError, match=rf"^{source}:{tool_refusal}"):
        read_jbi(text, "gp7", source=source)
    with pytest.raises(ControllerProgramError, match=rf"^{source}:8: C00000: pulse data need the robot's pulses per "
                                                     "degree"):
        read_jbi(text, "gp7", tool=TOOL_1, source=source)


def test_a_real_job_without_its_call_is_refused_at_its_tool_then_at_its_pulses():
    """The issue: with the refused line removed the job reads on, and ///TOOL 1 is not silently the flange."""
    text = (REAL / "ags_SAMPLE_TC.JBI").read_text().replace("CALL JOB:TOOLCHANGE ARGFI025\n", "")
    assert_refused_at_tool_then_pulses(text, "SAMPLE_TC", r"5: ///TOOL 1: tool file 1's data is on the controller, "
                                       r"not in the file: give it \(read_jbi's tool\)")


#: RoboDK's sample job: (a construct it holds, why it is refused, the lines removed to read on past it), in file order.
ROBODK_REFUSALS = [
    ("SETE P00095 (1) -30000", "sets P00095, a position or system variable", r"(SETE|SETTOOL) [^\n]*\n"),
    ('MSG "Stop the robot until the "', "an instruction this reader does not read", r'MSG "[^\n]*\n'),
    ("PAUSE", "the job stops until an operator restarts it", r"PAUSE\n"),
    ("CALL JOB:Subprog", "calls another job", r"CALL [^\n]*\n"),
]


def test_the_robodk_job_is_refused_construct_by_construct():
    """RoboDK's sample job (MIT): each construct without static meaning is refused in turn, naming its line; with all
    of them removed, its ``///TOOL 9`` (the tool file its SETTOOL line writes from P00095 when the job runs, P00095's
    other elements and type being on the controller) and its pulse data are what the file does not hold."""
    text = (REAL / "robodk_PROGRAM.JBI").read_text()
    for construct, why, removed in ROBODK_REFUSALS:
        line = text[:text.index(construct)].count("\n") + 1
        with pytest.raises(ControllerProgramError, match=rf"^PROGRAM:{line}: {re.escape(construct)}: {why}"):
            read_jbi(text, "gp7", source="PROGRAM")
        text = re.sub(removed, "", text)
    assert_refused_at_tool_then_pulses(text, "PROGRAM", r"\d+: ///TOOL 9: tool file 9's data is on the controller, "
                                       "not in the file")


def test_a_job_without_motion_is_refused():
    text = (REAL / "rosi_INIT_ROS.JBI").read_text().replace("WAIT OT#(890)=ON\n", "")
    with pytest.raises(ControllerProgramError, match=r"//INST: no motion instruction \(MOVJ, MOVL, MOVC\): a job of "
                                                     "actions alone has no pose"):
        read_jbi(text, "gp7", source="INIT_ROS")


#: A job in the style of the real ones above (AGSweeney's SAMPLE_TC and TC_FULL_CHANGE, tshikina's TEST1), GP7 sized.
REAL_STYLE = """/JOB
//NAME PICK-REAL-STYLE
//POS
///NPOS 1,0,0,4,0,0
///TOOL 1
///POSTYPE PULSE
///PULSE
C00000=0,0,0,0,-72000,0
///POSTYPE BASE
///RECTAN
///RCONF 0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0
P00010=500.000,350.000,0.000,180.0000,0.0000,35.0000
P00011=500.000,350.000,-130.000,180.0000,0.0000,35.0000
///USER 2
///POSTYPE USER
///RECTAN
///RCONF 0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0
P00020=0.000,0.000,0.000,-179.9988,-0.0019,-35.0000
P00021=0.000,0.000,-130.000,180.0000,0.0000,-35.0000
//ARGINFO
///ARGTYPE B,,,,,,,
///COMMENT
PART TYPE

//INST
///DATE 2026/05/06 11:28
///ATTR SC,RW
////FRAME BASE
///GROUP1 RB1
///LVARS 1,0,0,0,0,0,0,0
NOP
'PICK AND PLACE
SET I025 1
DOUT OT#(1) OFF
MOVJ C00000 VJ=25.00 PL=0
MOVJ P010 VJ=50.00 PL=3
MOVL P011 V=200.0 PL=0
WAIT IN#(3)=ON
\tDOUT OT#(1) ON
\t TIMER T=0.500
MOVL P010 V=200.0 PL=3
MOVJ P020 VJ=50.00
MOVL P021 V=200.0 PL=0
'RELEASE
DOUT OT#(1) OFF
PULSE OT#(2) T=0.10
TIMER T=0.20
MOVL P020 V=200.0
MOVJ C00000 VJ=25.00
END
""".replace("\n", "\r\n")
#: User frame 2 in the robot frame [m]: 500 mm along x, -350 mm along y.
FRAME_2 = rpy_position_to_pose(np.zeros(3), np.array([0.5, -0.35, 0.0]))


def read_real_style(**keywords) -> dict:
    return read_jbi(REAL_STYLE, "gp7", **{"tool": TOOL_1, "frame": FRAME_2, "pulses_per_degree": PPD, **keywords})


def test_a_real_style_job_reads_as_the_file_gives_it():
    document = read_real_style()
    waypoints = document["waypoints"]
    assert [w.get("move") for w in waypoints] == [None, "joint", "linear", "linear", "joint", "linear", "linear", None]
    np.testing.assert_allclose(waypoints[0]["joints"], [0, 0, 0, 0, -90, 0])          # -72000 pulses / 800 per deg
    assert waypoints[7] == {"joints": [0.0, 0.0, 0.0, 0.0, -90.0, 0.0], "speed": 25.0}
    np.testing.assert_allclose(waypoints[2]["xyz"], [0.5, 0.35, -0.13 + 0.33], atol=1e-12)    # BASE: robot frame
    np.testing.assert_allclose(waypoints[5]["xyz"], [0.5, -0.35, -0.13 + 0.33], atol=1e-12)   # USER 2: + frame
    assert (waypoints[1]["speed"], waypoints[1]["zone"], waypoints[2]["speed"]) == (50.0, 0.05, 0.2)
    assert waypoints[0]["do"] == [{"set": "do1", "value": "off"}]                       # before the first move
    assert waypoints[2]["do"] == [{"wait_input": "di3", "value": "on"}, {"set": "do1", "value": "on"},
                                  {"wait": 0.5}]
    assert waypoints[5]["do"] == [{"comment": "RELEASE"}, {"set": "do1", "value": "off"},
                                  {"pulse": "do2", "time": 0.1}, {"wait": 0.2}]
    assert document["signals"] == {"di3": {"input": 3}, "do1": {"output": 1}, "do2": {"output": 2}}
    assert "1 assignment(s) of variables skipped" in document["description"]
    assert "the actions before the first move run at the first waypoint" in document["description"]
    np.testing.assert_allclose(document["tool"]["xyz"], [0.0, 0.0, 0.12], atol=1e-12)


def test_a_real_style_job_rewritten_by_our_writer_reads_the_same():
    program = compile_job(parse_job(read_real_style(), source="real.jbi", name="real"))
    reread = compile_job(parse_job(read_jbi(write_jbi(program, "REAL", WHEN), "gp7"), source="w.jbi", name="w"))
    check_round_trip(program, reread, 0.001, 0.01, 1e-12, (1e-4, 1e-4))
    assert actions_of(reread) == actions_of(program)


@pytest.mark.parametrize("keywords, match", [
    ({"tool": None}, r"^<jbi>:5: ///TOOL 1: tool file 1's data is on the controller"),
    ({"frame": None}, r"^<jbi>:14: ///USER 2: user frame 2's data is on the controller"),
    ({"pulses_per_degree": None}, r"^<jbi>:8: C00000: pulse data need"),
])
def test_what_the_file_does_not_hold_is_refused_naming_the_line(keywords, match):
    with pytest.raises(ControllerProgramError, match=match):
        read_real_style(**keywords)


@pytest.mark.parametrize("edit, match", [
    (("MOVL P011 V=200.0 PL=0", "MOVL P011 V=200.0 PL=0 DEC=20"),
     r":{line}: MOVL P011 V=200.0 PL=0 DEC=20: DEC=20: a per-move acceleration ratio"),
    (("MOVL P011 V=200.0 PL=0", "MOVL P011 V=200.0 NWAIT"), r":{line}: MOVL P011 V=200.0 NWAIT: NWAIT: not read"),
    (("TIMER T=0.20", "JUMP *L1 IF IN#(4)=ON"), r":{line}: JUMP \*L1 IF IN#\(4\)=ON: a jump has no static meaning"),
    (("TIMER T=0.20", "*L1"), r":{line}: \*L1: a label"),
    (("SET I025 1", "SET P010 P011"), r":{line}: SET P010 P011: sets P010, a position or system variable"),
    (("TIMER T=0.20", "TSYNC 1"), r":{line}: TSYNC 1: synchronises with another task"),
    (("TIMER T=0.20", "TIMER T=LI005"), r":{line}: TIMER T=LI005: not read"),
    (("MOVJ P020 VJ=50.00", "MOVS P020 V=50.0"), r":{line}: MOVS P020 V=50.0: an instruction this reader does not read"),
    (("///GROUP1 RB1", "///GROUP1 RB1,BS1"), r":{line}: ///GROUP1 RB1,BS1: only a robot alone"),
    (("MOVJ P020 VJ=50.00", "MOVJ P030 VJ=50.00"), r":{line}: P00030: not in //POS \(a position variable's value"),
])
def test_constructs_without_static_meaning_are_refused_naming_file_line_and_construct(edit, match):
    text = REAL_STYLE.replace(*edit, 1)
    assert text != REAL_STYLE
    line = text[:text.index(edit[1])].count("\n") + 1
    with pytest.raises(ControllerProgramError, match=r"^real.jbi" + match.replace("{line}", str(line))):
        read_jbi(text, "gp7", tool=TOOL_1, frame=FRAME_2, pulses_per_degree=PPD, source="real.jbi")


def test_an_endless_loop_around_the_whole_job_reads_as_one_cycle():
    looped = REAL_STYLE.replace("NOP\r\n", "NOP\r\n*CYCLE\r\n").replace("\r\nEND", "\r\nJUMP *CYCLE\r\nEND")
    document = read_real_style_text(looped)
    assert "the endless loop around the whole job (*CYCLE ... JUMP *CYCLE) read as one cycle" in document["description"]
    assert document["waypoints"] == read_real_style()["waypoints"]
    with pytest.raises(ControllerProgramError, match=r":32: \*CYCLE: a label: the target of a jump"):
        read_real_style_text(looped.replace("JUMP *CYCLE", "JUMP *CYCLE IF IN#(1)=ON"))


def read_real_style_text(text: str) -> dict:
    return read_jbi(text, "gp7", tool=TOOL_1, frame=FRAME_2, pulses_per_degree=PPD)


def test_a_job_without_comm_reads(gripper):
    """Real jobs often have no ///COMM (the issue: refused at ///ATTR before)."""
    text = write_jbi(gripper, "GRIP", WHEN)
    without = "\n".join(line for line in text.split("\n") if not line.startswith("///COMM"))
    assert read_jbi(without, "gp7") == read_jbi(text, "gp7")


def test_a_linear_move_to_pulse_data_is_the_pose_of_its_joints():
    text = REAL_STYLE.replace("MOVJ C00000 VJ=25.00\r\nEND", "MOVL C00000 V=200.0\r\nEND")
    last = read_real_style_text(text)["waypoints"][-1]
    assert last["move"] == "linear" and last["controller_config"] == {"yaskawa": "0,0,0,0,0,0"}
    np.testing.assert_allclose(last["xyz"], [0.04 + 0.44, 0.0, 0.33 + 0.445 + 0.04 - 0.08 - 0.12], atol=1e-9)  # GP7 DH


def test_an_action_inside_an_arc_is_refused(gripper):
    text = write_jbi(gripper, "GRIP", WHEN).replace("MOVC C00004 V=500.0\n", "MOVC C00004 V=500.0\nTIMER T=0.10\n")
    with pytest.raises(ControllerProgramError, match=r"TIMER T=0.10: an action inside an arc"):
        read_jbi(text, "gp7")
