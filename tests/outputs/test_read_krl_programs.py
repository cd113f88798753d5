"""KRL actions and what pendants and other tools write (pipeline.outputs.controllers.krl / read_krl):

* the GP7 pick and place with every action kind, written and read back: equal actions, signals and targets; the
  KRL the writer writes for them (WAIT SEC, PULSE, the $TIMER timeout pattern) and that krl.g4 accepts it;
* a program in the form of KSS 8.3 inline forms (our own text, in the pendant's format: INI fold, PTP HOME, PDAT /
  LDAT / FDAT records, BAS parameters, OUT / WAIT / WAIT FOR / PULSE / comment folds) on a KR 6 R700 sixx: targets,
  speeds, zones, tool and actions as the file gives them;
* FOR over constants flattened, an outer LOOP as one cycle, calls of the file's routines read in place;
* a real RoboDK program (a .src without a .dat) read on a KR 16-2 test robot: targets, tool and speeds as the file gives
  them, and the same again after our writer writes it;
* what has no static meaning refused naming file, line and construct, among them the permissive real programs of
  tests/data/programs/kuka (SOURCES.md)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.errors import OutputError
from pipeline.model.ik.result import rotation_angle
from pipeline.model.vendors.controller import controller_frames
from pipeline.outputs.controllers.krl import abc_rotation, write_krl
from pipeline.outputs.controllers.read_krl import HOME, KrlReadError, read_krl
from pipeline.outputs.controllers.read_program import read_program_text
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.urdf import import_urdf

from .test_independent_grammars import krl_report

ROOT = Path(__file__).resolve().parents[2]
REAL = ROOT / "tests" / "data" / "programs" / "kuka"
#: Re-read targets land this close to the exported joints [deg] (test_read_krl.py).
TARGET_TOL_DEG = 0.002


@pytest.fixture(scope="module")
def gripper():
    return compile_job(load_job(ROOT / "tests" / "data" / "gp7_gripper_pick_place.yaml"))


@pytest.fixture(scope="module")
def gripper_files(gripper):
    return write_krl(gripper, "PICK")


def test_the_gripper_job_written_and_read_back_has_its_actions_signals_and_targets(gripper, gripper_files):
    src, dat = gripper_files
    again = compile_job(parse_job(read_program_text("krl", src, "gp7", "PICK.src", dat, "PICK.dat")))
    assert again.signals == gripper.signals
    assert [again.actions_at(k) for k in range(len(again.targets))] == \
        [gripper.actions_at(k) for k in range(len(gripper.targets))]
    assert np.degrees(np.abs(again.targets - gripper.targets)).max() < TARGET_TOL_DEG
    assert [m.zone for m in again.moves] == pytest.approx([m.zone for m in gripper.moves], abs=1e-9)


def test_the_actions_are_written_in_krl_after_their_waypoints_motion(gripper_files):
    src, dat = gripper_files
    lines = src.splitlines()
    assert "; dh.signal.gripper_close=out1 dh.signal.part_present=in3 dh.signal.blow_off=out2" in lines
    assert lines[lines.index("PTP XP0") + 1] == "$OUT[1] = FALSE ; gripper_close"
    after_pick = lines[lines.index("LIN XP2") + 1:lines.index("LIN XP2") + 10]
    assert after_pick == ["$TIMER[1] = 0", "$TIMER_STOP[1] = FALSE", "WAIT FOR $IN[3] OR ($TIMER[1] > 2000)",
                          "$TIMER_STOP[1] = TRUE", "IF NOT $IN[3] THEN", "HALT ; part_present: no on within 2 s",
                          "ENDIF", "$OUT[1] = TRUE ; gripper_close", "WAIT SEC 0.250"]
    after_place = lines[lines.index("LIN XP5") + 1:lines.index("LIN XP5") + 5]
    assert after_place == ["; release the part", "$OUT[1] = FALSE ; gripper_close",
                           "PULSE($OUT[2], TRUE, 0.100) ; blow_off", "WAIT SEC 0.200"]
    assert krl_report({".src": src, ".dat": dat}) == []


def test_a_signal_without_a_number_is_refused_by_the_writer(gripper):
    unnumbered = dict(gripper.signals, blow_off=gripper.signals["blow_off"].__class__("blow_off", "output", None))
    program = gripper.__class__(**{**gripper.__dict__, "signals": unnumbered})
    with pytest.raises(OutputError, match="blow_off"):
        write_krl(program, "PICK")


def test_a_wait_for_an_input_without_timeout_and_a_signal_name_read(gripper_files):
    src, dat = gripper_files
    pattern = ("$TIMER[1] = 0\n$TIMER_STOP[1] = FALSE\nWAIT FOR $IN[3] OR ($TIMER[1] > 2000)\n$TIMER_STOP[1] = TRUE\n"
               "IF NOT $IN[3] THEN\nHALT ; part_present: no on within 2 s\nENDIF\n")
    assert pattern in src
    plain = src.replace(pattern, "WAIT FOR (part_ok == TRUE)\n")
    named = dat.replace("ENDDAT", "SIGNAL part_ok $IN[3]\nENDDAT")
    doc = read_krl(plain, named, "gp7")
    assert doc["waypoints"][2]["do"][0] == {"wait_input": "part_ok", "value": "on"}
    assert doc["signals"]["part_ok"] == {"input": 3}


# ---- a program in the pendant's inline forms (our own text, KSS 8.3's format), on a KR 6 R700 sixx
PENDANT_SRC = """&ACCESS RVP
&REL 3
&PARAM TEMPLATE = C:\\KRC\\Roboter\\Template\\vorgabe
&PARAM EDITMASK = *
DEF pendant( )
;FOLD INI;%{PE}
  ;FOLD BASISTECH INI
    GLOBAL INTERRUPT DECL 3 WHEN $STOPMESS==TRUE DO IR_STOPM ( )
    INTERRUPT ON 3
    BAS (#INITMOV,0 )
  ;ENDFOLD (BASISTECH INI)
  ;FOLD USER INI
    ;Make your modifications here

  ;ENDFOLD (USER INI)
;ENDFOLD (INI)

;FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME, 3:, 5:100, 7:DEFAULT
$BWDSTART = FALSE
PDAT_ACT=PDEFAULT
FDAT_ACT=FHOME
BAS (#PTP_PARAMS,100 )
$H_POS=XHOME
PTP  XHOME
;ENDFOLD
;FOLD OUT 1 'gripper' State=FALSE ;%{PE}%R 8.3.31,%MKUKATPBASIS,%COUT,%VOUTX,%P 2:1, 3:gripper, 5:FALSE, 6:
$OUT[1]=FALSE
;ENDFOLD
;FOLD PTP P1 CONT Vel=50 % PDAT1 Tool[1]:gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:P1, 3:C_DIS, 5:50, 7:PDAT1
$BWDSTART=FALSE
PDAT_ACT=PPDAT1
FDAT_ACT=FP1
BAS(#PTP_PARAMS,50)
SET_CD_PARAMS (0)
PTP XP1 C_DIS
;ENDFOLD
;FOLD LIN P2 Vel=0.25 m/s CPDAT1 Tool[1]:gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VLIN,%P 1:LIN, 2:P2, 3:, 5:0.25, 7:CPDAT1
$BWDSTART=FALSE
LDAT_ACT=LCPDAT1
FDAT_ACT=FP2
BAS(#CP_PARAMS,0.25)
SET_CD_PARAMS (0)
LIN XP2
;ENDFOLD
;FOLD WAIT FOR ( IN 3 'part present' );%{PE}%R 8.3.31,%MKUKATPBASIS,%CEXT_WAIT_FOR,%VEXT_WAIT_FOR,%P 2:, 4:, 5:$IN, 6:3, 7:part present, 9:
WAIT FOR  ( $IN[3] )
;ENDFOLD
;FOLD OUT 1 'gripper' State=TRUE ;%{PE}%R 8.3.31,%MKUKATPBASIS,%COUT,%VOUTX,%P 2:1, 3:gripper, 5:TRUE, 6:
$OUT[1]=TRUE
;ENDFOLD
;FOLD WAIT Time=0.5 sec;%{PE}%R 8.3.31,%MKUKATPBASIS,%CWAIT,%VWAIT,%P 2:0.5
WAIT SEC 0.5
;ENDFOLD
;FOLD ; leave the fixture;%{PE}%R 8.3.31,%MKUKATPBASIS,%CCOMMENT,%VNORMAL,%P 2:leave the fixture
;ENDFOLD
;FOLD LIN P1 CONT Vel=0.5 m/s CPDAT2 Tool[1]:gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VLIN,%P 1:LIN, 2:P1, 3:C_DIS C_DIS, 5:0.5, 7:CPDAT2
$BWDSTART=FALSE
LDAT_ACT=LCPDAT2
FDAT_ACT=FP1
BAS(#CP_PARAMS,0.5)
SET_CD_PARAMS (0)
LIN XP1 C_DIS C_DIS
;ENDFOLD
;FOLD PTP P4 Vel=100 % PDAT2 Tool[1]:gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:P4, 3:, 5:100, 7:PDAT2
$BWDSTART=FALSE
PDAT_ACT=PPDAT2
FDAT_ACT=FP4
BAS(#PTP_PARAMS,100)
SET_CD_PARAMS (0)
PTP XP4
;ENDFOLD
;FOLD LIN P3 Vel=0.25 m/s CPDAT1 Tool[1]:gripper Base[0];%{PE}%R 8.3.31,%MKUKATPBASIS,%CMOVE,%VLIN,%P 1:LIN, 2:P3, 3:, 5:0.25, 7:CPDAT1
$BWDSTART=FALSE
LDAT_ACT=LCPDAT1
FDAT_ACT=FP3
BAS(#CP_PARAMS,0.25)
SET_CD_PARAMS (0)
LIN XP3
;ENDFOLD
;FOLD PULSE 2 'blow off' State=TRUE CONT Time=0.2 sec;%{PE}%R 8.3.31,%MKUKATPBASIS,%COUT,%VPULSE,%P 2:2, 3:blow off, 5:TRUE, 6:CONTINUE, 8:0.2
CONTINUE
PULSE($OUT[2], TRUE, 0.2)
;ENDFOLD
;FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME, 3:, 5:100, 7:DEFAULT
$BWDSTART = FALSE
PDAT_ACT=PDEFAULT
FDAT_ACT=FHOME
BAS (#PTP_PARAMS,100 )
$H_POS=XHOME
PTP  XHOME
;ENDFOLD

END
"""
PENDANT_DAT = """&ACCESS RVP
&REL 3
&PARAM TEMPLATE = C:\\KRC\\Roboter\\Template\\vorgabe
&PARAM EDITMASK = *
DEFDAT  pendant
;FOLD EXTERNAL DECLARATIONS;%{PE}%MKUKATPBASIS,%CEXT,%VCOMMON,%P
;FOLD BASISTECH EXT;%{PE}%MKUKATPBASIS,%CEXT,%VEXT,%P
EXT  BAS (BAS_COMMAND  :IN,REAL  :IN )
DECL INT SUCCESS
;ENDFOLD (BASISTECH EXT)
;FOLD USER EXT;%{E}%MKUKATPUSER,%CEXT,%VEXT,%P
;Make here your modifications

;ENDFOLD (USER EXT)
;ENDFOLD (EXTERNAL DECLARATIONS)
DECL BASIS_SUGG_T LAST_BASIS={POINT1[] "P3                      ",POINT2[] "P3                      ",CP_PARAMS[] "CPDAT1                  ",PTP_PARAMS[] "PDAT2                   ",CONT[] "                        ",CP_VEL[] "0.25                    ",PTP_VEL[] "100                     ",SYNC_PARAMS[] "SYNCDAT                 ",SPL_NAME[] "S0                      ",A_PARAMS[] "ADAT0                   "}
DECL E6POS XP1={X 486.710,Y -198.529,Z 464.034,A -32.5034,B 58.9646,C -8.4512,S 2,T 34,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL PDAT PPDAT1={VEL 50.0000,ACC 100.000,APO_DIST 20.0000,APO_MODE #CDIS,GEAR_JERK 50.0000,EXAX_IGN 0}
DECL E6POS XP2={X 518.082,Y -205.198,Z 389.114,A -29.7782,B 59.2545,C -7.1074,S 2,T 34,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP2={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL LDAT LCPDAT1={VEL 2.00000,ACC 100.000,APO_DIST 100.000,APO_FAC 50.0000,AXIS_VEL 100.000,AXIS_ACC 100.000,ORI_TYP #VAR,CIRC_TYP #BASE,JERK_FAC 50.0000,GEAR_JERK 50.0000,EXAX_IGN 0}
DECL LDAT LCPDAT2={VEL 2.00000,ACC 100.000,APO_DIST 10.0000,APO_FAC 50.0000,AXIS_VEL 100.000,AXIS_ACC 100.000,ORI_TYP #VAR,CIRC_TYP #BASE,JERK_FAC 50.0000,GEAR_JERK 50.0000,EXAX_IGN 0}
DECL E6POS XP3={X 501.690,Y 159.216,Z 401.500,A 41.7652,B 72.8194,C 17.1943,S 2,T 11,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP3={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL E6POS XP4={X 494.089,Y 157.179,Z 488.441,A 32.3556,B 63.5170,C 7.0945,S 2,T 11,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL FDAT FP4={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}
DECL PDAT PPDAT2={VEL 100.000,ACC 100.000,APO_DIST 100.000,APO_MODE #CDIS,GEAR_JERK 50.0000,EXAX_IGN 0}
ENDDAT
"""
#: The pendant program's tool 1 [m]: 100 mm along $FLANGE's x (out of the flange), in $FLANGE.
TOOL_IN_FLANGE = np.array([[1.0, 0, 0, 0.1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


@pytest.fixture(scope="module")
def kr6(tmp_path_factory) -> str:
    """The KR 6 R700 sixx robot file imported from the ROS-Industrial URDF with a kuka controller section."""
    imported = import_urdf(ROOT / "tests" / "data" / "urdf" / "kuka_kr6r700sixx.urdf", time_to_full_speed=0.3,
                           controller="kuka")
    return str(imported.write(tmp_path_factory.mktemp("kr6") / "kr6.yaml"))


@pytest.fixture(scope="module")
def pendant(kr6):
    program = compile_job(parse_job({**_pendant_doc(kr6), "robot": kr6}))
    return _pendant_doc(kr6), program


def _pendant_doc(kr6: str) -> dict:
    from pipeline.model.robot import load_robot
    X_FT = controller_frames(load_robot(kr6), "kuka")[1] @ TOOL_IN_FLANGE
    return read_krl(PENDANT_SRC, PENDANT_DAT, kr6, "pendant.src", "pendant.dat", tool=X_FT)


def e6pos(name: str) -> np.ndarray:
    """The pose (4, 4) [m] of an E6POS of PENDANT_DAT."""
    line = next(line for line in PENDANT_DAT.splitlines() if line.startswith(f"DECL E6POS {name}="))
    values = {k: float(v) for k, v in (part.split() for part in line.split("{")[1].split(",")[:6])}
    X = np.eye(4)
    X[:3, :3] = abc_rotation(values["A"], values["B"], values["C"])
    X[:3, 3] = np.array([values["X"], values["Y"], values["Z"]]) / 1000.0
    return X


def test_a_pendant_program_reads_its_targets_speeds_zones_and_tool(pendant):
    doc, program = pendant
    waypoints = doc["waypoints"]
    assert waypoints[0]["joints"] == [HOME[f"A{i}"] for i in range(1, 7)]          # PTP XHOME: KSS's default home
    assert [w.get("move") for w in waypoints[1:]] == ["joint", "linear", "linear", "joint", "linear", None]
    assert [w["speed"] for w in waypoints[1:]] == [50.0, 0.25, 0.5, 100.0, 0.25, 100.0]     # BAS(#..._PARAMS, v)
    assert [w.get("zone", 0.0) for w in waypoints[1:]] == [0.02, 0.0, 0.01, 0.0, 0.0, 0.0]  # PDAT1 / LDAT2 APO_DIST
    robot = program.robot
    for k, name in ((1, "XP1"), (2, "XP2"), (3, "XP1"), (4, "XP4"), (5, "XP3")):
        X = robot.fk(program.targets[k])                        # the tool's pose in our base = $ROBROOT here
        assert np.linalg.norm(X[:3, 3] - e6pos(name)[:3, 3]) < 1e-6
        assert rotation_angle(X[:3, :3].T @ e6pos(name)[:3, :3]) < np.radians(1e-4)
    np.testing.assert_allclose(np.degrees(program.targets[-1]), [HOME[f"A{i}"] for i in range(1, 7)], atol=1e-9)


def test_a_pendant_programs_out_wait_pulse_and_comment_folds_are_actions(pendant):
    doc, program = pendant
    assert doc["signals"] == {"do1": {"output": 1}, "di3": {"input": 3}, "do2": {"output": 2}}
    actions = {k: w["do"] for k, w in enumerate(doc["waypoints"]) if "do" in w}
    assert actions == {0: [{"set": "do1", "value": "off"}],
                       2: [{"wait_input": "di3", "value": "on"}, {"set": "do1", "value": "on"}, {"wait": 0.5},
                           {"comment": "leave the fixture"}],
                       5: [{"pulse": "do2", "time": 0.2}]}
    assert program.rest_at(2) == pytest.approx(0.5)


def test_a_pendant_program_rewritten_by_our_writer_reads_the_same(pendant, kr6):
    _, program = pendant
    src, dat = write_krl(program, "PENDANT")
    assert krl_report({".src": src, ".dat": dat}) == []
    again = compile_job(parse_job(read_program_text("krl", src, kr6, "PENDANT.src", dat, "PENDANT.dat")))
    assert np.degrees(np.abs(again.targets - program.targets)).max() < TARGET_TOL_DEG
    assert [again.actions_at(k) for k in range(len(again.targets))] == \
        [program.actions_at(k) for k in range(len(program.targets))]
    assert [m.zone for m in again.moves] == pytest.approx([m.zone for m in program.moves], abs=1e-9)
    assert np.abs(again.tool.X_FT - program.tool.X_FT).max() < 1e-6


def test_a_tool_number_without_its_data_is_refused_naming_line_and_number(kr6):
    with pytest.raises(KrlReadError) as error:
        read_krl(PENDANT_SRC, PENDANT_DAT, kr6, "pendant.src", "pendant.dat")
    assert error.value.field == "tool 1" and error.value.line == PENDANT_SRC.splitlines().index("FDAT_ACT=FP1") + 1


# ---- blocks
def small(body: str) -> str:
    return f"DEF small( )\n$VEL.CP = 0.1\n$VEL_AXIS[1] = 20\n{body}\nEND\n"


SMALL_DAT = ("DEFDAT small\nDECL E6AXIS XA={A1 0,A2 10,A3 -10,A4 0,A5 -60,A6 0}\n"
             "DECL E6AXIS XB={A1 20,A2 10,A3 -10,A4 0,A5 -60,A6 0}\nENDDAT\n")


def test_a_for_over_constants_is_flattened_and_indexes_system_variables():
    doc = read_krl(small("FOR I = 2 TO 6\n  $VEL_AXIS[I] = 20\nENDFOR\nPTP XA\nFOR J = 1 TO 2\nPTP XB\nPTP XA\nENDFOR"),
                   SMALL_DAT, "gp7")
    assert len(doc["waypoints"]) == 5 and doc["waypoints"][1]["speed"] == 20.0


def test_an_outer_loop_is_one_cycle_and_a_routine_of_the_file_is_read_in_place():
    src = small("FOR I = 2 TO 6\n$VEL_AXIS[I] = 20\nENDFOR\nPTP XA\nLOOP\nGO( )\nENDLOOP") + \
        "DEF GO( )\nPTP XB\nWAIT SEC 1\nPTP XA\nEND\n"
    doc = read_krl(src, SMALL_DAT, "gp7", "small.src")
    assert len(doc["waypoints"]) == 3 and doc["waypoints"][1]["do"] == [{"wait": 1.0}]
    assert "one cycle of its endless LOOP (line 8)" in doc["description"]


@pytest.mark.parametrize("body, field, line", [
    ("PTP XA\nWHILE $IN[1]\nPTP XB\nENDWHILE", "WHILE $IN[1]", 5),
    ("PTP XA\nIF $IN[1] THEN\nPTP XB\nENDIF", "IF", 5),
    ("PTP XA\nREPEAT\nPTP XB\nUNTIL $IN[1]", "REPEAT", 5),
    ("PTP XA\nLOOP\nPTP XB\nENDLOOP\nPTP XA", "LOOP", 5),
    ("INTERRUPT DECL 5 WHEN $IN[2] DO STOPIT( )\nPTP XA", "INTERRUPT", 4),
    ("PTP XA\nret = EKI_Init(\"CONNECT\")", "ret = EKI_Init(\"CONNECT\")", 5),
    ("PTP XA\nPICK( )", "PICK()", 5),
    ("PTP XA\nHALT", "HALT", 5),
    ("PTP XA\ncount = 3", "COUNT", 5),
    ("PTP XA\nLIN {X 500, Y 0}", "{X 500, Y 0}", 5),
])
def test_what_has_no_static_meaning_is_refused_naming_file_line_and_construct(body, field, line):
    with pytest.raises(KrlReadError) as error:
        read_krl(small(body), SMALL_DAT, "gp7", "small.src")
    assert (error.value.source, error.value.field, error.value.line) == ("small.src", field, line)


def test_a_ptp_to_the_live_axis_angles_before_every_motion_is_read_past():
    """RoboDK's "Quickly skip BCO": PTP $AXIS_ACT moves nothing; the next motion is the first waypoint."""
    speeds = "FOR I = 2 TO 6\n$VEL_AXIS[I] = 20\nENDFOR\n"
    plain = read_krl(small(speeds + "PTP XA\nPTP XB"), SMALL_DAT, "gp7")
    skipped = read_krl(small(speeds + "PTP $AXIS_ACT\nPTP XA\nPTP XB"), SMALL_DAT, "gp7")
    assert skipped["waypoints"] == plain["waypoints"]


@pytest.mark.parametrize("body, field, line", [
    ("PTP XA\nPTP $AXIS_ACT", "PTP $AXIS_ACT", 5),
    ("PTP $AXIS_ACT C_PTP\nPTP XA", "PTP $AXIS_ACT C_PTP", 4),
    ("LIN $POS_ACT\nPTP XA", "LIN $POS_ACT", 4),
])
def test_a_motion_to_a_live_position_elsewhere_is_refused_naming_its_line(body, field, line):
    with pytest.raises(KrlReadError, match="live position") as error:
        read_krl(small(body), SMALL_DAT, "gp7", "small.src")
    assert (error.value.field, error.value.line) == (field, line)


def test_a_lin_without_a_speed_in_the_file_is_refused_naming_its_line():
    src = "DEF small( )\nBAS (#INITMOV,0 )\n$VEL_AXIS[1] = 20\nPTP XA\nLIN XB\nEND\n"
    with pytest.raises(KrlReadError, match="controller's default") as error:
        read_krl(src.replace("$VEL_AXIS[1] = 20", "BAS(#VEL_PTP, 20)"), SMALL_DAT, "gp7", "small.src")
    assert (error.value.field, error.value.line) == ("$VEL.CP", 5)


@pytest.mark.parametrize("name, field, line, construct", [
    ("kuka_eki_hw_interface", "elements_read = eki_hw_iface_get(joint_pos_tgt)", 72, "EKI_"),
    ("ros_rsi", 'ret = RSI_CREATE("ros_rsi.rsi",CONTID,TRUE)', 72, "RSI_"),
    ("robodk_Program", "Wait for StrClear($LOOP_MSG[])", 56, "StrClear"),
])
def test_the_real_driver_and_generated_programs_are_refused_naming_line_and_construct(name, field, line, construct):
    """tests/data/programs/kuka (SOURCES.md): ROS-Industrial's EKI and RSI driver programs and RoboDK's example (its
    ``PTP $AXIS_ACT`` on line 36 read past; refused at its first message line)."""
    src = (REAL / f"{name}.src").read_text()
    dat = (REAL / f"{name}.dat").read_text() if (REAL / f"{name}.dat").exists() else ""
    with pytest.raises(KrlReadError) as error:
        read_krl(src, dat, "gp7", f"{name}.src", f"{name}.dat")
    assert (error.value.source, error.value.field, error.value.line) == (f"{name}.src", field, line)
    assert construct in str(error.value)


# ---- a real RoboDK program (RoboDK-API's Import_KUKA_SRC_Program.py, MIT / Apache-2.0): a .src without a .dat,
# $BASE and $TOOL frames, a PTP to axis values, then LIN aggregates with $VEL.CP, on a KR 16-2 test robot
MILLING = REAL / "robodk_api_Milling.src"
_AGGREGATE = re.compile(r"^(PTP|LIN|\$BASE|\$TOOL) =? ?\{(?:FRAME: )?([^}]*)\}", re.MULTILINE)


@pytest.fixture(scope="module")
def kr16(tmp_path_factory) -> str:
    """The KR 16-2 test robot (tests/data/programs/kuka/kuka_kr16_2.urdf) with a kuka controller section."""
    imported = import_urdf(REAL / "kuka_kr16_2.urdf", time_to_full_speed=0.3, controller="kuka")
    return str(imported.write(tmp_path_factory.mktemp("kr16") / "kr16.yaml"))


@pytest.fixture(scope="module")
def milling(kr16):
    doc = read_krl(MILLING.read_text(), None, kr16, MILLING.name)
    return doc, compile_job(parse_job(doc))


def milling_aggregates() -> list[tuple[str, dict]]:
    """(keyword, {component: value}) of the file's PTP, LIN, $BASE and $TOOL aggregates, in file order."""
    return [(m[1], {k: float(v) for k, v in (part.split() for part in m[2].split(","))})
            for m in _AGGREGATE.finditer(MILLING.read_text())]


def kuka_frame(values: dict) -> np.ndarray:
    """The pose (4, 4) [m] of X, Y, Z [mm], A, B, C [deg] (KRL's frame: R = Rz(A) Ry(B) Rx(C))."""
    X = np.eye(4)
    X[:3, :3] = abc_rotation(values["A"], values["B"], values["C"])
    X[:3, 3] = np.array([values["X"], values["Y"], values["Z"]]) / 1000.0
    return X


def test_a_robodk_program_without_a_dat_reads_its_targets_tool_and_speeds(milling):
    """Every target equals the file's: the PTP's axis values, the LINs' frames in $BASE with the tool $TOOL (the
    file's 0.001 mm and 0.001 deg), and $VEL.CP before each LIN."""
    doc, program = milling
    found = milling_aggregates()
    base, tool = (next(v for k, v in found if k == name) for name in ("$BASE", "$TOOL"))
    motions = [(k, v) for k, v in found if k in ("PTP", "LIN")]
    robot = program.robot
    np.testing.assert_allclose(np.degrees(program.targets[0]), [motions[0][1][f"A{i}"] for i in range(1, 7)],
                               atol=1e-9)
    X_base, X_flange = controller_frames(robot, "kuka")
    np.testing.assert_allclose(program.tool.X_FT, X_flange @ kuka_frame(tool), atol=1e-12)
    for k, (_, values) in enumerate(motions[1:], start=1):
        expected = X_base @ kuka_frame(base) @ kuka_frame(values)
        X = robot.fk(program.targets[k])
        assert np.linalg.norm(X[:3, 3] - expected[:3, 3]) < 1e-6
        assert rotation_angle(X[:3, :3].T @ expected[:3, :3]) < np.radians(1e-3)
    assert isinstance(doc["waypoints"][0], list) and [w["move"] for w in doc["waypoints"][1:]] == ["linear"] * 6
    assert [w["speed"] for w in doc["waypoints"][1:]] == [1.0, 0.02117, 0.02117, 0.02117, 0.02117, 1.0]


def test_a_robodk_program_rewritten_by_our_writer_reads_the_same(milling, kr16):
    """Our .src and .dat of the read job read back to the same targets, tool and speeds ($VEL.CP as our writer
    rounds it: 0.001 m/s)."""
    _, program = milling
    src, dat = write_krl(program, "MILLING")
    assert krl_report({".src": src, ".dat": dat}) == []
    again = compile_job(parse_job(read_program_text("krl", src, kr16, "MILLING.src", dat, "MILLING.dat")))
    assert np.degrees(np.abs(again.targets - program.targets)).max() < TARGET_TOL_DEG
    assert np.abs(again.tool.X_FT - program.tool.X_FT).max() < 1e-6
    assert [m.speed for m in again.moves] == pytest.approx([m.speed for m in program.moves], abs=5e-4)
    assert [m.kind for m in again.moves] == [m.kind for m in program.moves]


def test_read_program_writes_nothing_for_a_refused_program(tmp_path, capsys):
    for suffix in (".src", ".dat"):
        (tmp_path / f"eki{suffix}").write_bytes((REAL / f"kuka_eki_hw_interface{suffix}").read_bytes())
    code = main(["read-program", str(tmp_path / "eki.src"), "--robot", "gp7", "--out", str(tmp_path / "eki.yaml")])
    _, err = capsys.readouterr()
    assert code == 2 and f"{tmp_path / 'eki.src'}:72: " in err and "EKI_" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eki.dat", "eki.src"]


def test_outputs_at_an_approximated_waypoint_switch_by_trigger_and_read_back():
    """A set at the zoned waypoint 3 (60 mm): TRIGGER WHEN DISTANCE=1 before its motion, no exact stop."""
    document = yaml.safe_load((ROOT / "tests" / "data" / "gp7_gripper_pick_place.yaml").read_text())
    waypoints = [dict(w) for w in document["waypoints"]]
    waypoints[3]["do"] = [{"set": "blow_off", "value": "on"}, {"pulse": "gripper_close", "time": 0.5}]
    program = compile_job(parse_job({**document, "waypoints": waypoints}))
    src, dat = write_krl(program, "PICK")
    lines = src.splitlines()
    at = lines.index("LIN XP3 C_DIS")
    assert lines[at - 2:at] == ["TRIGGER WHEN DISTANCE=1 DELAY=0 DO $OUT[2] = TRUE ; blow_off",
                                "TRIGGER WHEN DISTANCE=1 DELAY=0 DO PULSE($OUT[1], TRUE, 0.500) ; gripper_close"]
    again = compile_job(parse_job(read_program_text("krl", src, "gp7", "PICK.src", dat, "PICK.dat")))
    assert again.actions_at(3) == program.actions_at(3) and again.moves[2].zone == pytest.approx(0.06)
    assert krl_report({".src": src, ".dat": dat}) == []


def test_a_base_number_is_the_callers_frame(gripper_files):
    """$BASE = BASE_DATA[2] with ``frame`` = 10 mm along x: the .dat's points 10 mm less in X are the same targets;
    without ``frame`` the reader names the line and number."""
    src, dat = gripper_files
    shifted = re.sub(r"\{X (-?[0-9.]+),", lambda m: f"{{X {float(m[1]) - 10.0:.3f},", dat)
    based = src.replace("$BASE = $ROBROOT", "$BASE = BASE_DATA[2]")
    frame = np.eye(4)
    frame[0, 3] = 0.01
    again = read_krl(based, shifted, "gp7", frame=frame)["waypoints"]
    for before, after in zip(read_krl(src, dat, "gp7")["waypoints"], again):
        if isinstance(before, dict) and "xyz" in before:
            np.testing.assert_allclose(after["xyz"], before["xyz"], atol=1e-9)
    with pytest.raises(KrlReadError) as error:
        read_krl(based, shifted, "gp7", "PICK.src")
    assert error.value.field == "frame 2" and src.splitlines()[error.value.line - 1] == "$BASE = $ROBROOT"
