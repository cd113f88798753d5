"""Real RAPID modules written by others (tests/data/programs/abb/SOURCES.md) and what pendants and RobotStudio write
(issue 37): a RobotStudio module (tabs, CR LF, no newline at the end, main calling paths, PulseDO, WaitTime, a tool in
the task's CalibData module) reads into a job whose every target is the file's, and the job compiled and re-written
by write_rapid reads the same again; the constructs the reader takes (declarations of every storage, RECORD, tool
and work object data, procedures inlined, FOR over numbers, an ending WHILE TRUE as one cycle, WaitDI, Set/Reset,
SetDO, WaitTime \\InPos, 0) read; what has no static meaning is refused naming the file, the line and the construct,
and read-program then writes nothing."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.files.poses import pose_to_quaternion_position, quaternion_position_to_pose
from pipeline.model.robot import load_robot
from pipeline.model.vendors.selection import pose_solutions
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_rapid import RapidReadError, read_rapid
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job

DATA = Path(__file__).resolve().parents[1] / "data" / "programs" / "abb"
ROBOT = str(DATA / "irb120.yaml")
TUTORIAL = DATA / "rparak_tutorial_Module1.mod"
NUMBER = r"-?\d+(?:\.\d+)?(?:E[+-]?\d+)?"
ROBTARGET = re.compile(rf"CONST robtarget (\w+):=\[\[({NUMBER}),({NUMBER}),({NUMBER})\],"
                       rf"\[({NUMBER}),({NUMBER}),({NUMBER}),({NUMBER})\]")
#: The writer rounds positions to 0.001 mm and quaternion components to 1e-6: half of each, and round-off.
WRITTEN_M, WRITTEN_Q = 0.5e-6 + 1e-12, 0.5e-6 + 1e-12


def file_text(path: Path) -> str:
    """The file's text as it is (CR LF kept)."""
    return path.read_bytes().decode("utf-8")


def calib_tool() -> np.ndarray:
    """The tframe (4, 4) [m] of smc_gripper in the tutorial's CalibData module (the task's other module)."""
    text = file_text(DATA / "rparak_tutorial_CalibData.mod")
    match = re.search(rf"smc_gripper:=\[TRUE,\[\[({NUMBER}),({NUMBER}),({NUMBER})\],\[({NUMBER}),({NUMBER}),"
                      rf"({NUMBER}),({NUMBER})\]\]", text)
    values = [float(v) for v in match.groups()]
    return quaternion_position_to_pose(np.array(values[3:]), np.array(values[:3]) / 1e3)


def path_targets(text: str, routine: str) -> list[str]:
    """The target names of the MoveL instructions of a procedure of the module, in order."""
    body = re.search(rf"PROC {routine}\(\)(.*?)ENDPROC", text, re.DOTALL).group(1)
    return re.findall(r"MoveL (\w+),", body)


@pytest.fixture(scope="module")
def tutorial() -> dict:
    return read_rapid(file_text(TUTORIAL), ROBOT, source=TUTORIAL.name, tool=calib_tool())


def test_the_tutorial_module_is_what_robotstudio_writes():
    text = file_text(TUTORIAL)
    assert "\r\n" in text and "\tPROC Path_10()" in text and not text.endswith("\n")
    assert "MoveAbsJ [[0,0,0,0,90,0],[9E9,9E9,9E9,9E9,9E9,9E9]]\\NoEOffs" in text and "PulseDO object_1_att;" in text


def test_every_target_is_the_files(tutorial):
    text = file_text(TUTORIAL)
    declared = {m.group(1): [float(v) for v in m.groups()[1:]] for m in ROBTARGET.finditer(text)}
    order = [name for path in ("Path_10", "Path_20", "Path_30") for name in path_targets(text, path)]
    # a move to where the robot is adds no waypoint: Target_10 after Path_10 (and Path_20), and the first MoveL to
    # Target_10, the TCP pose the MoveAbsJ home reached with smc_gripper
    order = [name for k, name in enumerate(order) if k > 0 and name != order[k - 1]]
    waypoints = tutorial["waypoints"]
    assert waypoints[0]["joints"] == [0.0, 0.0, 0.0, 0.0, 90.0, 0.0]
    assert len(waypoints) == 1 + len(order)
    for waypoint, name in zip(waypoints[1:], order, strict=True):
        values = declared[name]
        assert waypoint["move"] == "linear" and waypoint["speed"] == pytest.approx(0.1)
        np.testing.assert_allclose(np.array(waypoint["xyz"]) * 1e3, values[:3], atol=1e-9)
        quaternion = np.array(values[3:]) / np.linalg.norm(values[3:])
        sign = np.sign(np.dot(quaternion, waypoint["quaternion"]))
        np.testing.assert_allclose(sign * np.array(waypoint["quaternion"]), quaternion, atol=1e-12)
    np.testing.assert_allclose(tutorial["tool"]["xyz"], [0.0, 0.004e-3, 0.197001], atol=1e-12)


def test_the_tutorial_actions_and_signals(tutorial):
    waypoints = tutorial["waypoints"]
    assert waypoints[0]["do"] == [{"comment": "****** Home Position ******!"},
                                  {"comment": "****** Pick and Place - Object 1 ******!"}]
    pulses = [(k, a["pulse"]) for k, w in enumerate(waypoints) for a in w.get("do", ()) if "pulse" in a]
    assert [name for _, name in pulses] == ["object_1_att", "object_1_det", "object_2_att", "object_2_det",
                                            "object_3_att", "object_3_det"]
    for k, _ in pulses:           # PulseDO without \PLength is 0.2 s; WaitTime 1 after it; the move there is fine
        assert waypoints[k]["do"][-2:] == [{"pulse": waypoints[k]["do"][-2]["pulse"], "time": 0.2}, {"wait": 1.0}]
        assert "zone" not in waypoints[k]
    assert tutorial["signals"] == {name: {"output": None} for _, name in pulses}


@pytest.fixture(scope="module")
def rewritten(tutorial) -> tuple:
    """(the tutorial job compiled; written by write_rapid and read back; that compiled)."""
    program = compile_job(parse_job(tutorial, source=TUTORIAL.name))
    again = read_rapid(write_rapid(program, "tutorial"), ROBOT, source="tutorial.mod")
    return program, again, compile_job(parse_job(again, source="tutorial.mod"))


def test_the_tutorial_rewritten_reads_the_same(tutorial, rewritten):
    program, again, compiled = rewritten
    assert len(again["waypoints"]) == len(tutorial["waypoints"])
    for read, first in zip(again["waypoints"], tutorial["waypoints"], strict=True):
        assert read.get("do") == first.get("do") and read.get("move") == first.get("move")
        if "joints" in first:
            np.testing.assert_allclose(read["joints"], first["joints"], atol=0.5e-4 + 1e-9)
            continue
        np.testing.assert_allclose(read["xyz"], first["xyz"], atol=WRITTEN_M)
        sign = np.sign(np.dot(read["quaternion"], first["quaternion"]))
        np.testing.assert_allclose(sign * np.array(read["quaternion"]), first["quaternion"], atol=WRITTEN_Q)
    # the confdata may name the other side of a quadrant boundary an axis sits on (0 deg here): the same joints
    assert np.abs(compiled.targets - program.targets).max() <= 1e-4
    assert again["signals"] == tutorial["signals"] and compiled.actions == program.actions
    np.testing.assert_allclose(again["tool"]["xyz"], tutorial["tool"]["xyz"], atol=WRITTEN_M)


ROBOTS = DATA / "visose_robots_TestProgram_T_ROB1.mod"
#: Where the Robots plugin's own simulation ends its sample program (tests/Robots.Tests/ProgramTests.cs, "ABB sample
#: program") [rad], in its joint convention; as ABB axis angles [deg]: axis 2 = 90 deg - its axis 2, axes 3 and 5
#: the other way: the configuration the linear move reaches with ConfL \\Off.
ROBOTS_END_RAD = [-0.72007069377409672, 1.5806369662963811, -0.075569321979534809, -1.4960590345094886,
                  0.72252891341688164, 3.042104596978858]
ROBOTS_END_DEG = np.degrees(ROBOTS_END_RAD) * [1, -1, -1, 1, -1, 1] + [0, 90, 0, 0, 0, 0]


@pytest.fixture(scope="module")
def robots_sample() -> dict:
    return read_rapid(file_text(ROBOTS), ROBOT, source=ROBOTS.name)


def test_the_robots_plugin_module_reads_with_every_target_the_files(robots_sample):
    """The Robots plugin's ABB output (VAR extjoint/confdata named inside inline targets, ConfL \\Off, TASK PERS
    speeddata): its MoveAbsJ joint values and its MoveL pose are the file's; the MoveL's configuration is the one
    the linear path reaches from the joint values before (ConfL \\Off: the written [0,0,0,0] is not monitored)."""
    text = file_text(ROBOTS)
    assert "ConfL \\Off;" in text and "conf,extj]" in text and not text.endswith("\n")
    first, second = robots_sample["waypoints"]
    assert first == {"joints": [41.257, -0.5638, 4.3298, 85.7179, -41.3979, 5.7002]}
    assert second["move"] == "linear" and second["speed"] == pytest.approx(0.3) and "zone" not in second
    np.testing.assert_allclose(second["xyz"], [0.3, -0.2, 0.61], atol=1e-12)
    np.testing.assert_allclose(second["quaternion"], [0.5, 0.5, 0.5, 0.5], atol=1e-12)
    assert second["controller_config"] == {"abb": "[-1,-1,1,1]"} and "tool" not in robots_sample
    program = compile_job(parse_job(robots_sample, source=ROBOTS.name))
    end = np.degrees(program.targets[-1])
    np.testing.assert_allclose(end, ROBOTS_END_DEG, atol=2e-3)       # the plugin's own simulation, its rounding


def test_the_robots_plugin_module_rewritten_reads_the_same(robots_sample):
    program = compile_job(parse_job(robots_sample, source=ROBOTS.name))
    again = read_rapid(write_rapid(program, "robots"), ROBOT, source="robots.mod")
    assert [w.get("move") for w in again["waypoints"]] == [w.get("move") for w in robots_sample["waypoints"]]
    np.testing.assert_allclose(again["waypoints"][0]["joints"], robots_sample["waypoints"][0]["joints"],
                               atol=0.5e-4 + 1e-9)
    read, first = again["waypoints"][1], robots_sample["waypoints"][1]
    np.testing.assert_allclose(read["xyz"], first["xyz"], atol=WRITTEN_M)
    np.testing.assert_allclose(read["quaternion"], first["quaternion"], atol=WRITTEN_Q)
    assert read["controller_config"] == first["controller_config"] and read["speed"] == first["speed"]
    assert np.abs(compile_job(parse_job(again, source="robots.mod")).targets - program.targets).max() <= 1e-4


def test_conf_off_through_a_wrist_singularity_is_refused():
    """A MoveL (ConfL \\Off) along a line that passes within round-off of the wrist singularity (axis 5 at 1e-6
    rad on it): axes 4 and 6 would turn half a turn in less than FOLLOW_MIN_STEP_M of path, so which wrist the
    controller continues with has no static meaning. The same move through the pose with axis 5 at 5 deg reads."""
    robot = load_robot(ROBOT)

    def module(a5_deg: float) -> str:
        q_mid = np.radians([0.0, -16.0, 18.0, 0.0, a5_deg, 90.0])
        X_mid = robot.fk(q_mid)
        X_start, X_end = X_mid.copy(), X_mid.copy()
        X_start[1, 3] += 0.1
        X_end[1, 3] -= 0.1
        q_start = min(pose_solutions(robot, X_start[None])[0], key=lambda q: np.abs(q - q_mid).max())
        quaternion, position = pose_to_quaternion_position(X_end)
        pose = f"[[{','.join(f'{v:.6f}' for v in position * 1e3)}],[{','.join(f'{v:.9f}' for v in quaternion)}]"
        joints = ",".join(f"{v:.9f}" for v in np.degrees(q_start))
        return (f"MODULE M\nPROC main()\nConfL \\Off;\nMoveAbsJ [[{joints}],[9E9,9E9,9E9,9E9,9E9,9E9]],v100,fine,"
                f"tool0;\nMoveL {pose},[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v100,fine,tool0;\nENDPROC\nENDMODULE")

    read_rapid(module(5.0), ROBOT)
    with pytest.raises(RapidReadError) as error:
        read_rapid(module(np.degrees(1e-6)), ROBOT, source="m.mod")
    assert (error.value.line, error.value.field) == (5, "MoveL target")
    assert "passes a singularity" in error.value.problem


def test_read_program_writes_the_robots_plugin_module_as_a_job(tmp_path):
    program = tmp_path / ROBOTS.name
    program.write_bytes(ROBOTS.read_bytes())
    out = tmp_path / "job.yaml"
    assert main(["read-program", str(program), "--robot", ROBOT, "--out", str(out)]) == 0
    document = yaml.safe_load(out.read_text())
    assert [w.get("move", "joints") for w in document["waypoints"]] == ["joints", "linear"]
    assert document["waypoints"][0]["joints"] == [41.257, -0.5638, 4.3298, 85.7179, -41.3979, 5.7002]


def test_a_circular_move_with_conf_off_follows_its_arc(robots_sample):
    """The Robots module's MoveL as a MoveC through (330, 0, 610) mm: the arc leads to the same configuration; one
    through (300, 0, 700) mm passes the wrist singularity on the way and is refused."""
    text = file_text(ROBOTS)

    def arc(via: str) -> str:
        return text.replace("MoveL [[300,-200,610]", f"MoveC [[{via}],[0.5,0.5,0.5,0.5],conf,extj],[[300,-200,610]")

    document = read_rapid(arc("330,0,610"), ROBOT, source=ROBOTS.name)
    assert document["waypoints"][1]["move"] == "circular"
    np.testing.assert_allclose(document["waypoints"][1]["via"]["xyz"], [0.33, 0.0, 0.61], atol=1e-12)
    assert document["waypoints"][1]["controller_config"] == robots_sample["waypoints"][1]["controller_config"]
    with pytest.raises(RapidReadError) as error:
        read_rapid(arc("300,0,700"), ROBOT, source=ROBOTS.name)
    assert (error.value.line, error.value.field) == (11, "MoveC target") and "singularity" in error.value.problem


@pytest.mark.parametrize("target, confdata", [("[300,180,610]", "[0,0,0,1]"), ("[300,-200,610]", None)])
def test_a_joint_move_with_conf_off_takes_the_nearest_configuration(target, confdata):
    """ConfJ \\Off: a MoveJ near the start reaches the configuration nearest the joint values before, not the
    [1,1,1,1] it names; where two are about as near (axis 1 swings 82 deg, the wrists differ by half a turn) the
    reader refuses."""
    text = file_text(ROBOTS).replace("ConfL \\Off;", "ConfJ \\Off;").replace(
        "MoveL [[300,-200,610],[0.5,0.5,0.5,0.5],conf", f"MoveJ [{target},[0.5,0.5,0.5,0.5],[1,1,1,1]")
    if confdata is None:
        with pytest.raises(RapidReadError) as error:
            read_rapid(text, ROBOT, source=ROBOTS.name)
        assert (error.value.line, error.value.field) == (11, "MoveJ target")
        assert "about as near" in error.value.problem
        return
    second = read_rapid(text, ROBOT, source=ROBOTS.name)["waypoints"][1]
    assert second["move"] == "joint" and second["controller_config"] == {"abb": confdata}


def test_an_aggregate_naming_undeclared_data_is_refused():
    text = file_text(ROBOTS).replace("VAR confdata conf := [0,0,0,0];", "VAR confdata conf;")
    with pytest.raises(RapidReadError) as error:
        read_rapid(text, ROBOT, source=ROBOTS.name)
    assert (error.value.line, error.value.field) == (11, "MoveL") and "conf in an aggregate" in error.value.problem


#: A module as a pendant or RobotStudio keeps it (written for these tests): tabs, CR LF, no newline at the end, a
#: RECORD, data of every storage class, a tool and a work object declared in the module, main calling procedures,
#: comments, an ending WHILE TRUE, a FOR over numbers, WaitDI with \MaxTime, Set/Reset, SetDO, WaitTime \InPos, 0.
PENDANT = """MODULE Cell(SYSMODULE)
\tRECORD partdata
\t\tnum mass;
\tENDRECORD
\tTASK PERS tooldata tGripper:=[TRUE,[[0,0,100],[1,0,0,0]],[2,[0,0,50],[1,0,0,0],0,0,0]];
\tTASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[100,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
\tLOCAL CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
\tCONST jointtarget jClear:=[[20,0,0,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
\tCONST robtarget pPick:=[[850,0,800],[0.382683,0,0.92388,0],[0,-1,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
\tVAR num nCount:=0;
\tPERS bool bDone:=FALSE;
\tPROC main()
\t\t! start at home
\t\tMoveAbsJ jHome\\NoEOffs,v1000,fine,tGripper\\WObj:=wTable;
\t\tWHILE TRUE DO
\t\t\tPick;
\t\t\tFOR i FROM 1 TO 2 DO
\t\t\t\tMoveAbsJ jHome,v500,z50,tGripper;
\t\t\t\tMoveL pPick,v200,z10,tGripper\\WObj:=wTable;
\t\t\tENDFOR
\t\tENDWHILE
\tENDPROC
\tPROC Pick()
\t\tMoveL pPick,v200,z10,tGripper\\WObj:=wTable;
\t\tWaitDI diPart,1\\MaxTime:=2;
\t\tSet doGrip;
\t\tWaitTime 0.5;
\t\tReset doGrip;
\t\tSetDO \\Sync, doBlow,1;
\t\tMoveAbsJ jClear,v500,z50,tGripper;
\t\tWaitTime \\InPos,0;
\t\tRETURN;
\tENDPROC
ENDMODULE""".replace("\n", "\r\n")


def test_a_pendant_module_reads_with_procedures_loops_and_actions():
    document = read_rapid(PENDANT, "irb1600", source="cell.mod")
    waypoints = document["waypoints"]
    assert [w.get("move", "joints") for w in waypoints] == ["joints", "linear", "joints", "joints", "linear",
                                                            "joints", "linear"]
    assert waypoints[0]["do"] == [{"comment": "start at home"}]
    assert waypoints[1]["do"] == [{"wait_input": "diPart", "value": "on", "timeout": 2.0},
                                  {"set": "doGrip", "value": "on"}, {"wait": 0.5}, {"set": "doGrip", "value": "off"},
                                  {"set": "doBlow", "value": "on"}]
    assert "zone" not in waypoints[1] and "zone" not in waypoints[2]     # a wait there; WaitTime \InPos, 0
    assert waypoints[3]["zone"] == pytest.approx(0.05) and waypoints[4]["zone"] == pytest.approx(0.01)
    np.testing.assert_allclose(waypoints[1]["xyz"], [0.95, 0.0, 0.8], atol=1e-12)   # in wTable (x + 100 mm)
    assert document["signals"] == {"diPart": {"input": None}, "doGrip": {"output": None}, "doBlow": {"output": None}}
    assert "one cycle of the endless WHILE TRUE loop of main (cell.mod:15)" in document["description"]
    np.testing.assert_allclose(document["tool"]["xyz"], [0.0, 0.0, 0.1], atol=1e-12)
    compile_job(parse_job(document, source="cell.mod"))


def test_a_stop_that_ends_the_program_is_nothing():
    text = PENDANT.replace("\t\tWHILE TRUE DO", "\t\tFOR k FROM 1 TO 1 DO").replace("\t\tENDWHILE",
                                                                                "\t\tENDFOR\r\n\t\tStop;")
    document = read_rapid(text, "irb1600", source="cell.mod")
    assert document["waypoints"] == read_rapid(PENDANT, "irb1600")["waypoints"] and "description" not in document


def refused(text: str, source: str = "cell.mod", **keywords) -> RapidReadError:
    with pytest.raises(RapidReadError) as error:
        read_rapid(text, "irb1600", source=source, **keywords)
    return error.value


@pytest.mark.parametrize("file, line, field", [
    ("rosi_ROS_motion.mod", 45, "CONNECT"),                       # ROS-Industrial driver: interrupts, then more
    ("rparak_sorting_irb1200_T_ROB1_Module1.mod", 57, "TEST"),    # a state machine
    ("flo_abb_PickPlace.mod", 50, "PROC"),                        # targets computed from parameters (Offs)
    ("robodk_vscode_Program.mod", 26, "TPWrite"),                 # RoboDK: pendant text, STOP, a routine elsewhere
    ("sgffoen_test_movel_T_ROB1.mod", 18, "SetAO"),               # Robots plugin, milling: spindle speed (analog)
])
def test_real_driver_and_state_machine_modules_are_refused(file, line, field):
    error = refused(file_text(DATA / file), source=file)
    assert (error.source, error.line, error.field) == (file, line, field)
    assert str(error).startswith(f"{file}:{line}: {field}: ")


def test_a_generated_module_whose_confdata_names_no_solution_is_refused():
    """rparak_vinros_DP.mod (a generated path on an IRB 120 controller): its file header and LOCAL PERS data read,
    its first MoveJ's inline robtarget has confdata [0,0,0,0] where axis 1 stands at -90 deg (quadrant -1): the
    controller would stop there (ConfJ on), so the reader names that move and the configurations it has."""
    file = "rparak_vinros_DP.mod"
    text = file_text(DATA / file)
    assert text.startswith("%%%\nVERSION: 1\nLANGUAGE:ENGLISH%%%\n")
    with pytest.raises(RapidReadError) as caught:
        read_rapid(text, ROBOT, source=file)
    error = caught.value
    assert (error.source, error.line, error.field) == (file, 10, "MoveJ target")
    assert "abb configuration [0,0,0,0]: no in-limit IK solution has it" in error.problem
    assert "[-1,0,-1,0]" in error.problem


HEADER = "%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n"


def test_a_file_header_reads_as_nothing_and_keeps_line_numbers():
    """The %%% VERSION LANGUAGE %%% header ABB's system modules and RoboDK write before MODULE reads as nothing;
    errors after it name the file's own lines."""
    with_header, without = read_rapid(HEADER + PENDANT, "irb1600"), read_rapid(PENDANT, "irb1600")
    assert {k: v for k, v in with_header.items() if k != "description"} == {
        k: v for k, v in without.items() if k != "description"}
    assert "WHILE TRUE loop of main (<rapid>:19)" in with_header["description"]           # line 15 after 4 lines
    error = refused(HEADER + PENDANT.replace("\t\tReset doGrip;", "\t\tStopMove;"))
    assert error.line == 4 + PENDANT.split("\r\n").index("\t\tReset doGrip;") + 1


@pytest.mark.parametrize("header", ["%%%\r\n  VERSION:1\r\n%%%\r\n", "%%%\r\n  VERSION:one\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n",
                                    "\r\n%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n"])
def test_a_file_header_of_another_form_is_named(header):
    error = refused(header + PENDANT)
    assert (error.line, error.field) == (header.count("\r\n", 0, header.index("%%%")) + 1, "%%%")


PICK_BODY = "\t\tMoveL pPick,v200,z10,tGripper\\WObj:=wTable;"


@pytest.mark.parametrize("replacement, field, problem", [
    ("\t\tIF bDone THEN\r\n\t\t\tStop;\r\n\t\tENDIF", "IF", "branch"),
    ("\t\tTEST nCount\r\n\t\tCASE 1:\r\n\t\t\tStop;\r\n\t\tENDTEST", "TEST", "branch"),
    ("\t\tGOTO next;", "GOTO", "jump"),
    ("\t\tnext:", "next", "label"),
    ("\t\tWHILE nCount < 3 DO\r\n\t\t\tnCount:=nCount+1;\r\n\t\tENDWHILE", "WHILE", "loop on a variable"),
    ("\t\tFOR i FROM 1 TO nCount DO\r\n\t\tENDFOR", "FOR", "loop on a variable"),
    ("\t\tnCount:=nCount+1;", "nCount:=nCount+1", "assignment"),
    ("\t\tpPick.trans.z:=900;", "pPick.trans.z:=900", "assignment"),
    ("\t\tWaitUntil DInput(diPart)=1;", "WaitUntil", "expression"),
    ("\t\tCONNECT iPart WITH tPart;", "CONNECT", "interrupts"),
    ("\t\tRETURN;\r\n" + PICK_BODY, "RETURN", "jump"),
    ("\t\tISignalDI diPart,1,iPart;", "ISignalDI", "interrupt"),
    ("\t\tStopMove;", "StopMove", "path control"),
    ("\t\tClearPath;", "ClearPath", "path control"),
    ("\t\tSocketCreate sock;", "SocketCreate", "socket"),
    ("\t\tTPWrite \"hello\";", "TPWrite", "FlexPendant"),
    ("\t\tStop;", "Stop", "stops the program"),
    ("\t\tGripperOpen;", "GripperOpen", "routine the module does not hold"),
    ("\t\tWaitDI diPart,1\\MaxTime:=2\\TimeFlag:=bDone;", "WaitDI", "TimeFlag"),
    ("\t\tWaitTime -1;", "WaitTime time", "seconds"),
    ("\t\tSetDO doGrip,2;", "SetDO", "0 or 1"),
    ("\t\tSet diPart;", "Set", "used as a digital input before"),
])
def test_what_has_no_static_meaning_is_named_with_its_line(replacement, field, problem):
    text = PENDANT.replace("\t\tReset doGrip;", replacement)
    line = PENDANT.split("\r\n").index("\t\tReset doGrip;") + 1
    error = refused(text)
    assert (error.source, error.line, error.field) == ("cell.mod", line, field)
    assert problem in error.problem


@pytest.mark.parametrize("old, new, line, field, problem", [
    ("\t\tENDWHILE", "\t\tENDWHILE\r\n\t\tMoveAbsJ jHome,v500,fine,tGripper;", 15, "WHILE TRUE", "ends main"),
    ("\tPROC Pick()", "\tPROC Pick(num n)", 23, "PROC", "parameters"),
    ("\t\tRETURN;", "\t\tPick;", 32, "Pick", "recursive"),
    ("\t\t\t\tMoveAbsJ jHome,v500,z50,tGripper;", "\t\t\t\tMoveAbsJ jHome,v500,z50,tGripper\\ID:=i;", 17, "FOR i",
     "uses the loop variable"),
    ("tGripper:=[TRUE", "tOther:=[TRUE", 14, "MoveAbsJ", "pass its tframe"),
    ("\tTASK PERS wobjdata wTable:=", "\tTASK PERS wobjdata wOther:=", 24, "MoveL", "no wobjdata named wTable"),
    ("\tTRAP", "\tTRAP", None, None, None),
])
def test_structures_without_static_meaning_are_named(old, new, line, field, problem):
    if field is None:                                          # a TRAP routine after the procedures
        text = PENDANT.replace("ENDMODULE", "\tTRAP tPart\r\n\t\tStop;\r\n\tENDTRAP\r\nENDMODULE")
        line, field, problem = PENDANT.count("\r\n") + 1, "TRAP", "interrupt routine"
    else:
        assert old in PENDANT
        text = PENDANT.replace(old, new)
    error = refused(text)
    assert (error.line, error.field) == (line, field)
    assert problem in error.problem


def test_an_undeclared_tool_reads_with_the_callers_tframe():
    text = PENDANT.replace("tGripper:=[TRUE", "tOther:=[TRUE")
    tool = quaternion_position_to_pose(np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.1]))
    assert read_rapid(text, "irb1600", tool=tool)["waypoints"][1]["xyz"] == pytest.approx([0.95, 0.0, 0.8])


def test_read_program_writes_nothing_for_a_refused_module(tmp_path, capsys):
    program = tmp_path / "driver.mod"
    program.write_bytes((DATA / "rosi_ROS_motion.mod").read_bytes())
    out = tmp_path / "job.yaml"
    assert main(["read-program", str(program), "--robot", "irb1600", "--out", str(out)]) == 2
    assert f"{program}:45: CONNECT: " in capsys.readouterr().err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["driver.mod"]
