"""Real URScript programs, as PolyScope writes them (issue 37: "Polyscope's own output is refused at line 2"), read by
read_urscript (tests/data/programs/ur/SOURCES.md for their sources and licences):

* UR's timing_debug.script (PolyScope 5, UR5e): installation preambles, rpc_factory, threads, markers, register
  writes, a loop forever, movej(get_inverse_kin(Waypoint_n_p, qnear=Waypoint_n_q)) -> two pose waypoints equal to
  the Waypoint_n_p globals, each solved near its Waypoint_n_q;
* rparak's Move_Circle.script (UR10e): poses computed from a waypoint and a radius, movep and two movec with blend
  radii in a loop forever -> the circle's four poses;
* rparak's PickAndPlace_App_Final.script: a state machine (if on a variable) -> refused at line 83.

Each read program, compiled and re-written by write_urscript, reads into the same targets; every refused construct
is named with the file and line, and read-program writes nothing then."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from pipeline.__main__ import main
from pipeline.model.robot import load_robot
from pipeline.outputs.controllers.read_urscript import UrscriptReadError, read_urscript
from pipeline.outputs.controllers.urscript import write_urscript
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job

pytest.importorskip("lark", reason="lark (pip install lark) parses the URScript grammar")

PROGRAMS = Path(__file__).resolve().parents[1] / "data" / "programs" / "ur"
UR5E, UR10E = str(PROGRAMS / "ur5e.yaml"), str(PROGRAMS / "ur10e.yaml")
#: The programs' poses are written to 1e-12 m and rad: a read target equals them to round-off.
ROUND_OFF = 1e-9
#: Our writer writes 1e-6 m and rad: a re-solved pose moves the joints by about that over the arm's Jacobian.
TARGET_TOLERANCE_RAD = 1e-5


def text(name: str) -> str:
    return (PROGRAMS / name).read_text()


def globals_of(program: str, suffix: str) -> dict[str, list[float]]:
    """The program's ``global NAME_<suffix>=p[...]`` (suffix p) or ``=[...]`` (suffix q) values by NAME."""
    pattern = rf"global (\w+)_{suffix}={'p' if suffix == 'p' else ''}\[([^\]]*)\]"
    return {name: [float(v) for v in values.split(",")] for name, values in re.findall(pattern, program)}


def rotvec(waypoint: dict) -> np.ndarray:
    w, x, y, z = waypoint["quaternion"]
    return Rotation.from_quat([x, y, z, w]).as_rotvec()


def same_rotation(a, b, atol: float = ROUND_OFF) -> bool:
    return np.allclose(Rotation.from_rotvec(a).as_matrix(), Rotation.from_rotvec(b).as_matrix(), atol=atol)


def reread(document: dict, robot: str, source: str):
    """(the program compiled from ``document``, the one compiled from its URScript by write_urscript read again)."""
    program = compile_job(parse_job(document, source=source))
    again = read_urscript(write_urscript(program, "again"), robot, source="again.script")
    return program, compile_job(parse_job(again, source="again.script"))


@pytest.fixture(scope="module")
def timing_debug() -> dict:
    return read_urscript(text("ur_timing_debug.script"), UR5E, source="ur_timing_debug.script")


@pytest.fixture(scope="module")
def move_circle() -> dict:
    return read_urscript(text("rparak_Move_Circle.script"), UR10E, source="rparak_Move_Circle.script")


def test_polyscope_5_output_reads_its_waypoints(timing_debug):
    poses, nears = globals_of(text("ur_timing_debug.script"), "p"), globals_of(text("ur_timing_debug.script"), "q")
    waypoints = timing_debug["waypoints"]
    assert [w["move"] for w in waypoints] == ["joint", "joint"]
    for waypoint, name in zip(waypoints, ["Waypoint_1", "Waypoint_2"], strict=True):
        assert np.allclose(waypoint["xyz"], poses[name][:3], atol=ROUND_OFF)
        assert same_rotation(rotvec(waypoint), poses[name][3:])
    program = compile_job(parse_job(timing_debug, source="ur_timing_debug.script"))
    for q, name in zip(program.targets, ["Waypoint_1", "Waypoint_2"]):      # solved near the recorded qnear
        assert np.abs(q - nears[name]).max() < 0.01
    assert waypoints[1]["speed"] == pytest.approx(100 * 1.0471975511965976 / np.radians(180))


def test_polyscope_5_output_says_what_it_skipped(timing_debug):
    description = timing_debug["description"]
    for said in ("one cycle of the endless loop 'while (True):' at line 171", "Thread_2, Thread_4, Thread_1, Thread_3",
                 "write_output_integer_register (lines 59, 61, 63, 65, 67, 174, 177, 181)", "modbus_add_signal",
                 "show_monitor"):
        assert said in description


def test_the_recorded_joints_are_the_poses_of_the_arms_they_name():
    """The robot files the programs are read with: UR10e's Waypoint_Home_q is its Waypoint_Home_p exactly; the UR5e
    timing_debug's qnear lies within 2 mm of its typed-in poses (UR5 and UR10 tables miss by far more)."""
    circle = text("rparak_Move_Circle.script")
    X = load_robot(UR10E).fk(np.array(globals_of(circle, "q")["Waypoint_Home"]))
    home = globals_of(circle, "p")["Waypoint_Home"]
    assert np.allclose(X[:3, 3], home[:3], atol=1e-6)
    assert same_rotation(Rotation.from_matrix(X[:3, :3]).as_rotvec(), home[3:], atol=1e-6)
    debug = text("ur_timing_debug.script")
    poses, nears = globals_of(debug, "p"), globals_of(debug, "q")
    for robot, bound in ((UR5E, 2e-3), (str(PROGRAMS.parents[1] / "ur5.yaml"), None)):
        misses = [np.linalg.norm(load_robot(robot).fk(np.array(nears[n]))[:3, 3] - poses[n][:3]) for n in poses]
        assert max(misses) < bound if bound else min(misses) > 0.05


def test_move_circle_reads_the_circle_it_computes(move_circle):
    home = np.array(globals_of(text("rparak_Move_Circle.script"), "p")["Waypoint_Home"])
    radius = 0.050
    waypoints = move_circle["waypoints"]
    expected = [home[:3], home[:3] + [radius, 0, 0], home[:3] - [radius, 0, 0], home[:3] + [radius, 0, 0]]
    assert [w["move"] for w in waypoints] == ["joint", "linear", "circular", "circular"]
    for waypoint, xyz in zip(waypoints, expected, strict=True):
        assert np.allclose(waypoint["xyz"], xyz, atol=ROUND_OFF)
        assert same_rotation(rotvec(waypoint), home[3:])
    assert np.allclose(waypoints[2]["via"]["xyz"], home[:3] + [0, radius, 0], atol=ROUND_OFF)
    assert np.allclose(waypoints[3]["via"]["xyz"], home[:3] - [0, radius, 0], atol=ROUND_OFF)
    assert [w.get("zone") for w in waypoints] == [None, 0.025, 0.025, None]
    assert [w.get("speed") for w in waypoints[1:]] == [0.25, 0.25, 0.25] and move_circle["tcp_accel_max"] == 1.2


def test_move_circle_home_is_solved_near_its_recorded_joints(move_circle):
    program = compile_job(parse_job(move_circle, source="rparak_Move_Circle.script"))
    q_home = globals_of(text("rparak_Move_Circle.script"), "q")["Waypoint_Home"]
    assert np.abs(program.targets[0] - q_home).max() < 1e-5


@pytest.mark.parametrize("name, robot", [("ur_timing_debug.script", UR5E), ("rparak_Move_Circle.script", UR10E)])
def test_a_real_program_rewritten_by_our_writer_reads_the_same(name, robot):
    program, again = reread(read_urscript(text(name), robot, source=name), robot, name)
    assert len(again.targets) == len(program.targets)
    assert np.abs(again.targets - program.targets).max() <= TARGET_TOLERANCE_RAD
    assert [m.kind for m in again.moves] == [m.kind for m in program.moves]


def test_a_state_machine_is_refused_at_its_branch():
    with pytest.raises(UrscriptReadError) as error:
        read_urscript(text("rparak_PickAndPlace_App_Final.script"), UR10E,
                      source="rparak_PickAndPlace_App_Final.script")
    assert str(error.value).startswith("rparak_PickAndPlace_App_Final.script:83: if (1 == switch_1): a branch on a "
                                       "variable or an input")


START = ("def prog():\n  global Waypoint_1_p=p[.1, -.4, .3, 0.0, 3.14, 0.0]\n"
         "  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n")


@pytest.mark.parametrize("statement, construct, problem", [
    ("if (get_standard_digital_in(0) == True):\n    movel(Waypoint_1_p)\n  end",
     "if (get_standard_digital_in(0) == True)", "a branch on a variable or an input"),
    ("while (n < 3):\n    movel(Waypoint_1_p)\n  end", "while (n < 3)", "a loop on a variable or an input"),
    ("rq_wait_for_gripper_connected()", "rq_wait_for_gripper_connected()", "not a function read here"),
    ('socket_open("127.0.0.1", 63352, "1")', 'socket_open("127.0.0.1", 63352, "1")', "not a function read here"),
    ("conn.eip_monitor.show()", "conn.eip_monitor.show()", "calls a method of an object"),
    ('popup("check the part", blocking=True)', 'popup("check the part", blocking=True)', "not a function read here"),
    ("movel(get_actual_tcp_pose())", "movel(get_actual_tcp_pose())", "get_actual_tcp_pose() is not a static function"),
    ("thread t():\n    movel(Waypoint_1_p)\n  end", "thread t()", "a thread that moves the robot"),
    ("kill t", "kill t", "no static meaning"),
    ("def grip():\n    set_standard_digital_out(0, True)\n  end\n  grip()", "grip()", "a function the program defines"),
])
def test_what_has_no_static_meaning_is_refused_naming_line_and_construct(statement, construct, problem):
    with pytest.raises(UrscriptReadError) as error:
        read_urscript(f"{START}  {statement}\nend\n", UR5E, source="prog.script")
    assert error.value.source == "prog.script" and error.value.field == construct and problem in error.value.problem
    assert error.value.line == 4 + statement.count("\n") * (construct == "grip()")


def test_a_urcap_program_node_is_refused_where_it_calls_its_functions():
    """pharmbio/robotlab's dan_delid.script (cited, not copied: SOURCES.md) calls Robotiq's URCap functions, defined in
    its installation preamble, in every gripper node: the same construct in a program of our own."""
    program = ("def delid():\n  def rq_set_pos_spd_for(pos, speed, force, gripper_socket=\"1\"):\n"
               "    socket_set_var(\"POS\", pos, gripper_socket)\n  end\n"
               "  global pick_p=p[.2, -.5, .7, 1.57, 0.0, 0.0]\n"
               "  movel(pick_p, a=1.2, v=0.25)\n  # begin: URCap Program Node\n  rq_set_pos_spd_for(255, 0, 0, \"1\")\n"
               "  # end: URCap Program Node\nend\n")
    with pytest.raises(UrscriptReadError, match=r"delid.script:8: rq_set_pos_spd_for\(255, 0, 0, \"1\"\): calls "
                                                r"rq_set_pos_spd_for, a function the program defines"):
        read_urscript(program, UR10E, source="delid.script")


def test_read_program_writes_the_real_program_and_nothing_for_a_refused_one(tmp_path, capsys):
    out = tmp_path / "debug.yaml"
    assert main(["read-program", str(PROGRAMS / "ur_timing_debug.script"), "--robot", UR5E, "--out", str(out)]) == 0
    assert "2 waypoints" in capsys.readouterr().out
    assert len(yaml.safe_load(out.read_text())["waypoints"]) == 2
    refused = tmp_path / "pick.yaml"
    code = main(["read-program", str(PROGRAMS / "rparak_PickAndPlace_App_Final.script"), "--robot", UR10E,
                 "--out", str(refused)])
    assert code != 0 and not refused.exists()
    assert "PickAndPlace_App_Final.script:83: if (1 == switch_1)" in capsys.readouterr().err


LOOP = ("def prog():\n  global Waypoint_1_p=p[.1, -.4, .3, 0.0, 3.14, 0.0]\n"
        "  global Waypoint_2_p=p[.1, -.4, .4, 0.0, 3.14, 0.0]\n"
        "  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n  $ 5 \"Loop 3 times\"\n  Loop_1 = 0\n  while (Loop_1 < 3):\n"
        "    # down and up\n    movel(Waypoint_1_p, a=1.2, v=0.25)\n    movel(Waypoint_2_p, a=1.2, v=0.25)\n"
        "    Loop_1 = Loop_1 + 1\n  end\nend\n")


def test_polyscope_loop_n_times_is_flattened():
    document = read_urscript(LOOP, UR5E, source="loop.script")
    waypoints = document["waypoints"]
    assert len(waypoints) == 7 and [w["xyz"][2] for w in waypoints[1:]] == [0.3, 0.4] * 3
    assert [w.get("do") for w in waypoints[::2]] == [[{"comment": "down and up"}]] * 3 + [None]
    assert "flattened the loops on fixed counters at line 7 (3 turns)" in document["description"]


@pytest.mark.parametrize("change, construct", [
    ("Loop_1 = Loop_1 + 0", "while (Loop_1 < 3)"),                 # a turn leaves its counter as it was
    ("Loop_1 = get_standard_digital_in(0)", "while (Loop_1 < 3)"),  # the counter becomes an input
])
def test_a_loop_that_does_not_end_or_reads_an_input_is_refused(change, construct):
    with pytest.raises(UrscriptReadError) as error:
        read_urscript(LOOP.replace("Loop_1 = Loop_1 + 1", change), UR5E, source="loop.script")
    assert (error.value.line, error.value.field) == (7, construct)


def test_poses_the_program_computes_from_constants_are_evaluated():
    """pose_trans of a feature and an offset (PolyScope's moves relative to a plane), an element assignment and
    rpy2rotvec (as rparak's pick and place computes its points)."""
    program = ("def prog():\n  global Plane_1=p[.1, -.5, .2, 0.0, 0.0, 1.5707963267948966]\n"
               "  global Point_p=p[.1, -.4, .3, 0.0, 3.14, 0.0]\n  Point_p[2]=0.415+0.2\n"
               "  global rot=rpy2rotvec([3.14159, 0.0, d2r(90)])\n  Point_p[3]=rot[0]\n  Point_p[4]=rot[1]\n"
               "  Point_p[5]=rot[2]\n  movej([0.0, -1.5, 1.5, -1.5, -1.5, 0.0])\n"
               "  movel(pose_trans(Plane_1, p[0.1, 0.0, 0.05, 3.14159, 0.0, 0.0]))\n  movel(Point_p)\nend\n")
    first, second = read_urscript(program, UR5E, source="prog.script")["waypoints"][1:]
    plane = Rotation.from_rotvec([0, 0, np.pi / 2])
    assert np.allclose(first["xyz"], np.array([.1, -.5, .2]) + plane.apply([0.1, 0.0, 0.05]), atol=ROUND_OFF)
    assert same_rotation(rotvec(first), (plane * Rotation.from_rotvec([3.14159, 0, 0])).as_rotvec())
    assert np.allclose(second["xyz"], [.1, -.4, 0.615], atol=ROUND_OFF)
    assert same_rotation(rotvec(second), Rotation.from_euler("xyz", [3.14159, 0.0, np.pi / 2]).as_rotvec())
