"""Jobs accept a vendor configuration per pose waypoint (issue 26): ``controller_config: {vendor: fields}`` names
one closed-form branch and 2 pi representative, and compile_job takes exactly the solution
pipeline.model.vendors.selection selects for it. Bad values, unknown vendors, arms of the UR family and
configurations no solution has are JobFileErrors naming the file, the line and the field; our ``config`` beside
it must name the same branch."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import JobFileError
from pipeline.model.vendors.configuration import configurations
from pipeline.model.vendors.selection import select_solution
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import load_job, parse_job

from ..outputs.test_urscript import TESTS
from .test_job_moves import START, line_of, write

#: Pose targets with several in-limit solutions on either side of axis 1, off the wrist's flip boundaries.
GP7_POSE = {"xyz": [500, 300, 330], "rpy": [170, 10, 20]}
IRB_POSE = {"xyz": [700, 200, 600], "rpy": [170, 10, 20]}


def job_doc(robot: str, waypoints: list, **changes) -> dict:
    """A job of ``robot`` in mm and deg through ``waypoints``; ``changes`` set keys (None: drop the key)."""
    job = {"robot": robot, "length_unit": "mm", "angle_unit": "deg", "start": START, "waypoints": waypoints,
           "outputs": ["json"]}
    job.update(changes)
    return {key: value for key, value in job.items() if value is not None}


def solved(doc: dict) -> tuple:
    """(the job, its waypoints solved)."""
    job = parse_job(doc)
    return job, solve_waypoints(job)


def expected(job, k: int, vendor: str, fields) -> np.ndarray:
    """What selection answers for waypoint k's pose and the configuration ``fields``."""
    return select_solution(job.robot, job.waypoints[k].X_BE, fields, vendor)


def refused(tmp_path, doc: dict, field: str, words: str, compile_it: bool = False) -> JobFileError:
    """The JobFileError of the job written as a file (at reading, or at compiling), checked to name the file,
    ``field`` and its line, and to say ``words``."""
    path = write(tmp_path, doc)
    with pytest.raises(JobFileError) as error:
        job = load_job(path)
        if compile_it:
            solve_waypoints(job)
    assert (error.value.field, error.value.line) == (field, line_of(path, field)), str(error.value)
    assert words in str(error.value) and str(error.value).startswith(f"{path}:{error.value.line}: {field}: ")
    return error.value


@pytest.mark.parametrize("fields, branch", [
    ([0, 1, 1, 0, 0, 0], "shoulder back, elbow up, wrist noflip"),
    ([1, 1, 1, 1, 1, 0], "shoulder back, elbow up, wrist flip"),
    ([1, 0, 0, 0, 0, 0], "shoulder front, elbow up, wrist noflip"),
])
def test_gp7_pose_lands_on_the_yaskawa_rconf_branch_and_turn(fields, branch):
    """A GP7 pose (with a tool) with an RCONF lands on selection's solution: its branch, R and T turns."""
    doc = job_doc("gp7", [{**GP7_POSE, "controller_config": {"yaskawa": fields}}, GP7_POSE],
                  tool={"xyz": [0, 0, 120], "rpy": [0, 0, 0]}, allow_branch_change=True)
    job, solutions = solved(doc)
    q = solutions[0].q
    np.testing.assert_allclose(q, expected(job, 0, "yaskawa", fields), atol=1e-12)
    assert tuple(configurations(job.robot, q, "yaskawa")) == tuple(fields)
    assert (solutions[0].branch, solutions[0].method, solutions[0].solutions) == (branch, "analytic", 1)
    assert solutions[0].position_error < 1e-9 and solutions[0].rotation_error < 1e-9
    assert solutions[0].to_dict()["controller_config"] == {"yaskawa": ",".join(map(str, fields))}
    assert solutions[1].to_dict()["controller_config"] is None       # report.json: as the waypoint named it


def test_the_rconf_fixes_the_2pi_representative():
    """RCONF o (R >= 180 deg) tells two solutions apart that differ only by a turn of axis R."""
    pair = [[1, 0, 0, 0, 0, 0], [1, 0, 0, 1, 0, 0]]
    qs = [solved(job_doc("gp7", [{**GP7_POSE, "controller_config": {"yaskawa": f}}, GP7_POSE],
                         allow_branch_change=True))[1][0].q for f in pair]
    assert abs(abs(qs[0][3] - qs[1][3]) - 2 * np.pi) < 1e-9 and np.allclose(np.delete(qs[0], 3), np.delete(qs[1], 3))


@pytest.mark.parametrize("value, fields, branch", [
    ([0, -3, 4, 1], (0, -3, 4, 1), "shoulder front, elbow up, wrist flip"),
    ("[0,-1,2,0]", (0, -1, 2, 0), "shoulder front, elbow up, wrist noflip"),
    ([-2, -3, -3, 6], (-2, -3, -3, 6), "shoulder back, elbow up, wrist noflip"),
])
def test_irb1600_pose_lands_on_the_abb_confdata_branch_and_turn(value, fields, branch):
    """An IRB 1600 pose with a confdata (a list, or RAPID's text) lands on selection's solution."""
    doc = job_doc("irb1600", [{**IRB_POSE, "controller_config": {"abb": value}}, IRB_POSE], start=None,
                  allow_branch_change=True)
    job, solutions = solved(doc)
    assert job.waypoints[0].controller_config == ("abb", fields)
    np.testing.assert_allclose(solutions[0].q, expected(job, 0, "abb", fields), atol=1e-12)
    assert tuple(configurations(job.robot, solutions[0].q, "abb")) == fields
    assert solutions[0].branch == branch


def test_fanuc_and_kuka_texts_are_read():
    """FANUC's CONFIG text on an LR Mate and KUKA's S/T text on an IRB 1600 (no published map: the identity)."""
    fanuc = parse_job(job_doc("lrmate200id", [{"xyz": [400, 100, 300], "rpy": [180, 0, 0],
                                               "controller_config": {"fanuc": "N U T, 0, 0, 0"}}, [0] * 6]))
    kuka = parse_job(job_doc("irb1600", [{**IRB_POSE, "controller_config": {"kuka": "S 'B010', T 'B100011'"}},
                                         [0] * 6]))
    assert fanuc.waypoints[0].controller_config == ("fanuc", (0, 1, 1, 0, 0, 0))
    assert kuka.waypoints[0].controller_config == ("kuka", (2, 0b100011))


def test_a_consistent_config_beside_it_is_accepted():
    """Our config naming the same branch (all of it, or a part) is accepted and kept."""
    for config in ({"shoulder": "back", "elbow": "up", "wrist": "noflip"}, {"shoulder": "back"}, "N U B"):
        doc = job_doc("gp7", [{**GP7_POSE, "controller_config": {"yaskawa": [0, 1, 1, 0, 0, 0]}, "config": config},
                              GP7_POSE], allow_branch_change=True)
        solutions = solved(doc)[1]
        assert solutions[0].branch == "shoulder back, elbow up, wrist noflip" and solutions[0].config


def test_an_inconsistent_config_beside_it_is_refused(tmp_path):
    """Our config naming another branch than the vendor configuration's solution: an error on config."""
    doc = job_doc("gp7", [{**GP7_POSE, "controller_config": {"yaskawa": [0, 1, 1, 0, 0, 0]},
                           "config": {"shoulder": "front"}}, GP7_POSE], allow_branch_change=True)
    error = refused(tmp_path, doc, "waypoints[0].config", "is on the branch 'shoulder back, elbow up, wrist noflip'",
                    compile_it=True)
    assert "shoulder front" in error.problem and "0,1,1,0,0,0" in error.problem


@pytest.mark.parametrize("value, words", [
    ({"abb": [0, 0, 0]}, "is 4 integers (cf1, cf4, cf6, cfx)"),
    ({"abb": [0, 0, 0, 9]}, "field cfx must be an integer from 0 to 7, got 9"),
    ({"abb": [0, 0.5, 0, 1]}, "field cf4 must be an integer"),
    ({"fanuc": "X U T, 0, 0, 0"}, "not a fanuc configuration"),
    ({"yaskawa": [0, 0, 0, 0, 0, 2]}, "field q must be an integer from 0 to 1, got 2"),
    ({"kuka": {"S": 2, "T": 35}}, "a kuka configuration is 2 integers (S, T)"),
])
def test_bad_fields_are_refused_with_their_line(tmp_path, value, words):
    """Malformed fields: the vendor's parser's message, at controller_config.<vendor>'s line."""
    doc = job_doc("gp7", [{**GP7_POSE, "controller_config": value}, GP7_POSE])
    vendor = next(iter(value))
    error = refused(tmp_path, doc, f"waypoints[0].controller_config.{vendor}", words)
    assert error.value == value[vendor]


@pytest.mark.parametrize("value, words", [
    ({"staubli": [0, 0, 0, 1]}, "names the vendor 'staubli'; the vendors: abb, fanuc, yaskawa, kuka"),
    ([0, 0, 0, 1], "is one controller vendor and its configuration data, e.g. {abb: [0, -1, 1, 2]}"),
    ({"abb": [0, 0, 0, 1], "kuka": [2, 0]}, "is one controller vendor"),
])
def test_bad_shapes_and_vendors_are_refused_with_their_line(tmp_path, value, words):
    """Not a one-vendor mapping, or an unknown vendor: an error at controller_config's line naming the vendors."""
    doc = job_doc("gp7", [{**GP7_POSE, "controller_config": value}, GP7_POSE])
    refused(tmp_path, doc, "waypoints[0].controller_config", words)


def test_a_target_other_than_the_full_pose_is_refused(tmp_path):
    """A vendor configuration names a solution of the full pose."""
    doc = job_doc("gp7", [{**GP7_POSE, "target": "position", "controller_config": {"abb": [0, 0, 0, 1]}},
                          GP7_POSE])
    refused(tmp_path, doc, "waypoints[0].controller_config.abb", "target must be pose")


def test_the_ur_family_has_no_vendor_fields(tmp_path):
    """A UR5 (the UR family) has no vendor configuration data: refused naming the robot, its family and config:."""
    doc = job_doc(str(TESTS / "data" / "ur5.yaml"), [
        [0, -90, 90, -90, -90, 0], {"xyz": [-303.2, -301.1, 325], "rpy": [180, 0, 0],
                                    "controller_config": {"kuka": [2, 0]}}], start=None)
    error = refused(tmp_path, doc, "waypoints[1].controller_config.kuka", "the UR family")
    assert "spherical wrist" in error.problem and "config:" in error.problem


def test_a_configuration_no_solution_has_is_refused_with_those_that_exist(tmp_path):
    """confdata with cf1 = 1 where axis 1 is near 17 or -163 deg: the error names the line, the value and the
    configurations of the pose's solutions."""
    doc = job_doc("irb1600", [{**IRB_POSE, "controller_config": {"abb": [1, 0, 0, 1]}}, IRB_POSE], start=None)
    error = refused(tmp_path, doc, "waypoints[0].controller_config.abb", "no in-limit IK solution has it",
                    compile_it=True)
    job = parse_job(doc)
    have = configurations(job.robot, expected(job, 0, "abb", [0, 1, 0, 1]), "abb")
    assert error.value == "[1,0,0,1]" and "[" + ",".join(map(str, have)) + "]" in error.problem


def test_a_branch_change_it_names_is_refused_unless_allowed(tmp_path):
    """A vendor configuration on another branch than the previous pose's: refused at the waypoint's line, naming
    both branches; accepted with allow_branch_change."""
    waypoints = [GP7_POSE, {**GP7_POSE, "controller_config": {"yaskawa": [0, 1, 1, 0, 0, 0]}}]
    refused(tmp_path, job_doc("gp7", waypoints), "waypoints[1]", "to 'shoulder back, elbow up, wrist noflip', the "
            "branch of yaskawa configuration 0,1,1,0,0,0", compile_it=True)
    solutions = solved(job_doc("gp7", waypoints, allow_branch_change=True))[1]
    assert solutions[1].branch_changed and solutions[1].branch == "shoulder back, elbow up, wrist noflip"
