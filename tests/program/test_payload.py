"""What the robot carries: loads combined and taken apart, the job's payload and parts with their grip and release
actions, the makers' payload diagram (pipeline.model.payload_limits) and Drake's inverse dynamics with a payload."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.__main__ import main
from pipeline.errors import JobFileError, RobotFileError
from pipeline.files.arrays import inertia_matrix
from pipeline.files.robot_spec import STANDARD_GRAVITY, parse_robot_spec
from pipeline.files.robot_writer import robot_document
from pipeline.model.chain.drake_model import build_drake_robot
from pipeline.model.payload_limits import payload_problems, wrist_loads
from pipeline.model.robot import load_robot
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.payload import Payload, combined, removed
from pipeline.program.report import cycle_lines, cycle_report
from pipeline.program.timing import time_program

DATA = Path(__file__).resolve().parents[1] / "data"
PAYLOAD_JOB = DATA / "gp7_payload_pick_place.yaml"
GP7_FILE = Path(__file__).resolve().parents[2] / "models" / "gp7.yaml"


def payload_document() -> dict:
    return yaml.safe_load(PAYLOAD_JOB.read_text())


def cuboid(mass: float, size: tuple[float, float, float], centre) -> Payload:
    """A solid cuboid [kg, m] centred at ``centre`` [m] in the flange frame."""
    a, b, c = size
    inertia = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) * mass / 12.0
    return Payload(mass, np.asarray(centre, dtype=float), inertia, "cuboid", "cuboid")


def test_two_loads_combined_are_the_body_they_make_and_taking_one_away_gives_the_other():
    lower, upper = cuboid(2.0, (0.1, 0.1, 0.1), [0, 0, 0.05]), cuboid(2.0, (0.1, 0.1, 0.1), [0, 0, 0.15])
    both = combined([lower, upper])
    whole = cuboid(4.0, (0.1, 0.1, 0.2), [0, 0, 0.1])     # the two cubes stacked are one 0.1 x 0.1 x 0.2 cuboid
    assert both.mass == pytest.approx(4.0) and np.allclose(both.com, whole.com)
    assert np.allclose(both.inertia, whole.inertia, atol=1e-15)
    back = removed(both, upper, "lower")
    assert back.mass == pytest.approx(2.0) and np.allclose(back.com, lower.com) and np.allclose(back.inertia,
                                                                                                  lower.inertia)
    assert removed(both, both, "none") is None


def test_the_job_reads_the_tool_load_and_the_parts_and_the_program_carries_them_per_move():
    job = load_job(PAYLOAD_JOB)
    assert job.payload.mass == 1.2 and np.allclose(job.payload.com, [0, 0.005, 0.045])
    assert np.allclose(job.payload.inertia, np.diag([0.0031, 0.0029, 0.0012]))
    assert job.payload.source.startswith("gripper")
    program = compile_job(job)
    assert [load.name for load in program.loads] == ["tool"] * 2 + ["tool + box"] * 3 + ["tool"] * 2
    assert program.loads[2].mass == pytest.approx(3.7)
    assert {2, 5} <= set(program.stops)              # the load changes at rest


def test_a_grip_or_a_release_stops_the_motion_even_without_a_wait():
    document = payload_document()
    document["waypoints"][2]["do"] = [{"grip": "box"}]
    document["waypoints"][3]["do"] = [{"release": "box"}]
    document["waypoints"][3].pop("zone")
    document["waypoints"][5]["do"] = [{"wait": 0.2}]
    program = compile_job(parse_job(document, source="job.yaml"))
    assert {2, 3} <= set(program.stops)


def _with(change) -> dict:
    document = payload_document()
    change(document)
    return document


BAD_LOADS = {
    "inertia in kg mm^2": (lambda d: d["parts"]["box"].update(inertia=[5200, 5200, 4200, 0, 0, 0]),
                           "parts.box.inertia", "are these kg mm^2"),
    "no body's inertia": (lambda d: d["parts"]["box"].update(inertia=[0.001, 0.001, 0.01, 0, 0, 0]),
                          "parts.box.inertia", "triangle inequality"),
    "a grip of no part": (lambda d: d["waypoints"][2]["do"].append({"grip": "lid"}), "waypoints[2].do[4].grip",
                          "names no part of the job's parts: table (box)"),
    "a part gripped twice": (lambda d: d["waypoints"][3].update(zone=0, do=[{"grip": "box"}]),
                             "waypoints[3].do[0].grip", "already holds this part"),
    "a release of a part not held": (lambda d: d["waypoints"][1].update(do=[{"release": "box"}]),
                                     "waypoints[1].do[0].release", "does not hold this part"),
    "a zone where the load changes": (lambda d: d["waypoints"][3].update(do=[{"release": "box"}]), "waypoints[3].zone",
                                      "wait or change the load there"),
    "a part's name": (lambda d: d["parts"].update({"2box": {"mass": 1.0}}), "parts.2box", "a part's name"),
    "a mass in grams": (lambda d: d["parts"]["box"].update(mass=2500), "parts.box", "is the mass in grams?"),
}


@pytest.mark.parametrize("case", list(BAD_LOADS), ids=list(BAD_LOADS))
def test_bad_loads_and_grips_are_job_file_errors_naming_the_field(case):
    change, field, problem = BAD_LOADS[case]
    with pytest.raises(JobFileError) as error:
        parse_job(_with(change), source="job.yaml")
    assert f"job.yaml: {field}: " in str(error.value) and problem in str(error.value)


def test_wrist_loads_follow_the_makers_moment_arms_on_the_gp7():
    """GP7: the T axis is the flange's z axis; the B-axis rotation centre lies on it 80 mm behind the flange (d6)."""
    spec = load_robot("gp7").spec
    load = Payload(4.0, np.array([0.03, -0.04, 0.12]), np.diag([0.01, 0.02, 0.03]))
    by_joint = {w.joint: w for w in wrist_loads(spec, load)}
    r, d = 0.05, np.array([0.03, -0.04, 0.2])
    assert by_joint["T"].arm_m == pytest.approx(r, abs=1e-12)
    assert by_joint["T"].moment_n_m == pytest.approx(4.0 * STANDARD_GRAVITY * r)
    assert by_joint["T"].inertia_kg_m2 == pytest.approx(0.03 + 4.0 * r * r)
    worst = np.linalg.eigvalsh(load.inertia + 4.0 * (d @ d * np.eye(3) - np.outer(d, d)))[-1]
    for axis in "RB":
        assert by_joint[axis].arm_m == pytest.approx(np.linalg.norm(d), abs=1e-12)
        assert by_joint[axis].inertia_kg_m2 == pytest.approx(worst)
    assert payload_problems(spec, load) == []


def test_a_tool_and_part_beyond_the_gp7s_wrist_moment_is_refused_naming_axis_moment_and_limit(tmp_path, capsys):
    document = payload_document()
    document["parts"]["box"].update(mass=4.0, com=[0, 0, 330])       # tool + box 5.2 kg, within the rated 7 kg
    path = tmp_path / "heavy.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    out_dir = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out_dir)]) == 2
    message = capsys.readouterr().err
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if text.strip().startswith("box:"))
    assert message.startswith(f"error: {path}:{line}: parts.box: tool + box (5.2 kg) is beyond the gp7's payload")
    arm = (1.2 * np.array([0, 0.005, 0.045]) + 4.0 * np.array([0, 0, 0.33])) / 5.2 + [0, 0, 0.080]   # from the B centre
    moment = 5.2 * STANDARD_GRAVITY * np.linalg.norm(arm)
    assert f"the moment about axis B is {moment:.3g} N m" in message and "above the allowable 17 N m" in message
    assert "rated payload" not in message and "axis T" not in message
    assert not out_dir.exists()


def test_the_payload_diagram_is_read_checked_and_written_back():
    document = yaml.safe_load(GP7_FILE.read_text())
    spec = parse_robot_spec(document, source="gp7.yaml")
    assert spec.payload_limits.rated_kg == 7 and spec.payload_limits.wrist[5] == (10.0, 0.2)
    again = parse_robot_spec(robot_document(spec), source="again.yaml").payload_limits
    assert again.rated_kg == 7 and again.wrist == spec.payload_limits.wrist and again.source == spec.payload_limits.source
    bad = copy.deepcopy(document)
    bad["payload_limits"]["wrist"]["U"] = {"moment": 30}
    with pytest.raises(RobotFileError, match=r"payload_limits\.wrist\.U: names no wrist joint \(the last three: R, B, T\)"):
        parse_robot_spec(bad, source="gp7.yaml")
    bad = copy.deepcopy(document)
    bad["payload_limits"]["wrist"]["T"] = {}
    with pytest.raises(RobotFileError, match="gives neither moment"):
        parse_robot_spec(bad, source="gp7.yaml")


def test_drakes_inverse_dynamics_carries_the_payload_on_the_flange_and_only_when_given():
    """A point mass on the GP7's flange at q = 0 (flange z along base x) adds m g (x - a1) to joint L's torque."""
    drake = build_drake_robot(load_robot("gp7").spec)
    zero = np.zeros(6)
    bare = drake.inverse_dynamics(zero, zero, zero)[0]
    mass, com = 5.0, np.array([0.0, 0.0, 0.1])
    loaded = drake.inverse_dynamics(zero, zero, zero, Payload(mass, com))[0]
    lever = 0.560 + 0.1 - 0.040                      # flange x + com along base x - the L axis's x (a1)
    assert loaded[1] - bare[1] == pytest.approx(-mass * 9.81 * lever, rel=1e-9)
    assert np.array_equal(drake.inverse_dynamics(zero, zero, zero)[0], bare)


def test_the_cycle_report_says_what_each_move_carries_and_why_torques_are_not_certified():
    program = compile_job(load_job(PAYLOAD_JOB))
    report = cycle_report(program, time_program(program))
    assert [m["carrying"] for m in report["moves"]][1:3] == ["tool 1.2 kg", "tool + box 3.7 kg"]
    assert [entry["load"] for entry in report["payload"]["loads"]] == ["tool", "tool + box"]
    assert not report["payload"]["torques"]["certified"] and "gp7.yaml gives no joint torque limits" in \
        report["payload"]["torques"]["reason"]
    lines = cycle_lines(report)
    assert any(line.startswith("carrying tool + box 3.7 kg: rated 7 kg, R 7.11/17 N m") for line in lines)


def test_an_inertia_given_as_six_numbers_is_the_symmetric_matrix():
    assert np.array_equal(inertia_matrix([1, 2, 3, 4, 5, 6]), [[1, 4, 5], [4, 2, 6], [5, 6, 3]])


def test_the_parts_held_after_each_action_follow_the_grips_and_releases_in_order():
    from pipeline.program.actions import GRIP, RELEASE, Action, held_after

    actions = ((Action(GRIP, part="box"),), (Action(GRIP, part="lid"), Action(RELEASE, part="box")), ())
    assert [held_after(actions, 1, i) for i in range(2)] == [("box", "lid"), ("lid",)]
    assert held_after(actions, 0) == ("box",) and held_after(actions, 1) == held_after(actions, 2) == ("lid",)
