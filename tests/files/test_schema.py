"""The one file reader: strict YAML (numbers as YAML 1.2, no duplicate keys, bounded size, depth and
alias expansion), lines in every error, and the plausibility checks that catch unit mistakes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.errors import (
    FileFormatError,
    InvalidValueError,
    JobFileError,
    MissingFieldError,
    RobotFileError,
    UnknownFieldError,
)
from pipeline.files.robot_spec import load_robot_spec
from pipeline.files.schema import MAX_FILE_BYTES, Reader, field_name, load_document, parse_document
from pipeline.program.job import load_job

MODELS = Path(__file__).resolve().parents[2] / "models"

TWO_LINK = """\
name: two_link
convention: standard
length_unit: mm
angle_unit: deg
joints:
  - {a: 300, alpha: 0, d: 0, q_min: -90, q_max: 90, qd_max: 180, qdd_max: 500, qddd_max: 5000}
  - {a: 200, alpha: 0, d: 0, q_min: -90, q_max: 90, qd_max: 180, qdd_max: 500, qddd_max: 5000}
"""


def parse(text: str, kind=RobotFileError):
    return parse_document(text, "f.yaml", kind)


def write(tmp_path: Path, text: str | bytes, name: str = "robot.yaml") -> Path:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


# -- YAML read strictly --------------------------------------------------------------------------
@pytest.mark.parametrize("text, value", [
    ("x: 1e-7", 1e-7), ("x: 8e3", 8000.0), ("x: -2.5E+2", -250.0), ("x: .5", 0.5), ("x: 12", 12),
    ("x: 170:30", "170:30"), ("x: yes", "yes"), ("x: on", "on"), ("x: true", True), ("x: ~", None),
    ("x: '1e-7'", "1e-7"), ("x: 0x1F", "0x1F"), ("x: .inf", math.inf), ("x: 1_000", "1_000"),
])
def test_scalars_are_read_as_yaml_1_2(text, value):
    assert parse(text).data == {"x": value}


def test_numbers_written_as_1e_minus_7_are_numbers_in_files(tmp_path):
    spec = load_robot_spec(write(tmp_path, TWO_LINK.replace("qddd_max: 5000}", "qddd_max: 8e3}")))
    assert spec.joints[0].qddd_max == pytest.approx(math.radians(8000))


def test_every_field_knows_its_line():
    document = parse(TWO_LINK)
    assert document.line(("joints", 1, "a")) == 7
    assert document.line(("joints", 1, "no_such_key")) == 7      # nearest ancestor
    assert document.line(()) == 1


@pytest.mark.parametrize("text, problem", [
    ("a: 1\na: 2\n", "given twice (lines 1 and 2)"),
    ("? [1, 2]\n: x\n", "keys must be text"),
    ("x: !!python/object:os.system ls\n", "not supported"),
    ("x: !custom 3\n", "not supported"),
    ("x: 1" + "0" * 60 + "\n", "more than 40 characters"),
    ("x: [unclosed\n", "not valid YAML"),
    ("x: " + "[" * 5000 + "]" * 5000 + "\n", "nested"),
    ("x: " + "[" * 40 + "]" * 40 + "\n", "nested more than 32 levels"),
    ("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
     "c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
     "e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d, *d]\nf: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e, *e]\n"
     "g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f, *f]\nh: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g, *g]\n", "aliases"),
    ("--- a\n--- b\n", "not valid YAML"),
])
def test_hostile_or_sloppy_yaml_is_a_typed_error_at_once(text, problem):
    with pytest.raises(RobotFileError, match="^f.yaml") as error:
        parse(text)
    assert problem in str(error.value)
    assert len(str(error.value)) < 400


def test_billion_laughs_ends_fast_with_a_short_message(tmp_path):
    lines = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]" for k in range(1, 10)]
    path = write(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(RobotFileError, match="aliases"):
        load_robot_spec(path)


@pytest.mark.parametrize("content, problem", [
    (bytes(range(256)) * 4, "not UTF-8"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "not UTF-8"),
    (b"\x00\x01\x02 binary", "not valid YAML"),
    (b"name: x\n" + b"#" * (MAX_FILE_BYTES + 1), "larger than"),
    (b"", "must be a mapping"),
    (b"just text", "must be a mapping"),
])
def test_garbage_robot_file_is_a_typed_error_naming_the_file(tmp_path, content, problem):
    path = write(tmp_path, content)
    with pytest.raises(RobotFileError) as error:
        load_robot_spec(path)
    assert str(error.value).startswith(str(path)) and problem in str(error.value)


def test_unreadable_path_is_a_typed_error(tmp_path):
    with pytest.raises(JobFileError, match="cannot read"):
        load_document(tmp_path, JobFileError)                  # a folder


def test_field_names_and_error_classes():
    assert field_name(("joints", 2, "inertia", "I")) == "joints[2].inertia.I"
    assert field_name(("waypoints", 1, 2)) == "waypoints[1][2]"
    reader = Reader(parse("a: 1\n", JobFileError), JobFileError)
    with pytest.raises(JobFileError) as error:
        reader.mapping((), ("b",), ())
    assert isinstance(error.value, UnknownFieldError) and isinstance(error.value, FileFormatError)
    assert str(error.value) == "f.yaml:1: a: unknown key; allowed: b"


def test_messages_show_an_excerpt_of_huge_values(tmp_path):
    text = TWO_LINK.replace("name: two_link", "name: " + "x" * 100_000)
    with pytest.raises(InvalidValueError, match="at most 64 characters") as error:
        load_robot_spec(write(tmp_path, text))
    assert len(str(error.value)) < 300


# -- unit mistakes in robot files ----------------------------------------------------------------
def preset_text(name: str) -> str:
    return (MODELS / f"{name}.yaml").read_text()


@pytest.mark.parametrize("change, field, hint", [
    (("angle_unit: deg", "angle_unit: rad"), "joints[0]", "are these degrees?"),
    (("length_unit: mm", "length_unit: m"), "", "is length_unit: m right?"),
])
def test_unit_mistakes_in_a_preset_are_caught(tmp_path, change, field, hint):
    text = preset_text("gp7").replace(*change)
    with pytest.raises(InvalidValueError) as error:
        load_robot_spec(write(tmp_path, text))
    assert hint in str(error.value) and field in error.value.field and error.value.line is not None


def test_metres_written_under_mm_are_caught(tmp_path):
    text = TWO_LINK.replace("a: 300", "a: 0.3").replace("a: 200", "a: 0.2")
    with pytest.raises(InvalidValueError, match="reaches at most 0.5 mm.*metres under length_unit: mm"):
        load_robot_spec(write(tmp_path, text))


@pytest.mark.parametrize("old, new, field, problem", [
    ("q_min: -90, q_max: 90, qd_max: 180, qdd", "q_min: -360, q_max: 360, qd_max: 180, qdd", "joints[0].q_max",
     None),
    ("q_min: -90, q_max: 90", "q_min: -720, q_max: 720", "joints[0].q_max", "wider than three turns"),
    ("angle_unit: deg", "angle_unit: rad", "joints[0].q_max", "are these degrees?"),
    ("a: 300", "a: 1e308", "joints[0].a", "longer than any arm"),
    ("qd_max: 180, qdd_max: 500, qddd_max: 5000}\n  - {a: 200",
     "qd_max: 5e-324, qdd_max: 500, qddd_max: 5000}\n  - {a: 200", "joints[0].qd_max", "too small"),
    ("qd_max: 180, qdd_max: 500, qddd_max: 5000}\n  - {a: 200",
     "qd_max: 180000, qdd_max: 500, qddd_max: 5000}\n  - {a: 200", "joints[0].qd_max", "implausibly large"),
    ("a: 300", "a: 123456789012345678901234567890123456789012345", "joints[0].a", "more than 40 characters"),
    ("name: two_link", "name: two_link\ntool: {xyz: [0, 0, 1e308]}", "tool.xyz", "farther than"),
    ("name: two_link", "name: two_link\nname: again", "name", "given twice"),
])
def test_implausible_robot_values_name_the_field(tmp_path, old, new, field, problem):
    text = TWO_LINK.replace(old, new, 1)
    if problem is None:                      # two turns is fine: real wrists reach +-450 deg
        load_robot_spec(write(tmp_path, text))
        return
    with pytest.raises(RobotFileError) as error:
        load_robot_spec(write(tmp_path, text))
    assert error.value.field == field and problem in str(error.value)


def test_continuous_joint_may_turn_without_end(tmp_path):
    text = TWO_LINK.replace("q_min: -90, q_max: 90", "continuous: true", 1)
    spec = load_robot_spec(write(tmp_path, text))
    assert spec.joints[0].q_min == -math.inf and spec.joints[0].q_max == math.inf


def test_base_and_tool_take_a_quaternion_like_job_poses(tmp_path):
    by_rpy = load_robot_spec(write(tmp_path, TWO_LINK + "tool: {xyz: [0, 0, 100], rpy: [0, 0, 90]}\n"))
    by_quaternion = load_robot_spec(write(tmp_path, TWO_LINK + "tool: {xyz: [0, 0, 100], quaternion: "
                                                               "[0.70710678, 0, 0, 0.70710678]}\n", "q.yaml"))
    np.testing.assert_allclose(by_rpy.X_DnE, by_quaternion.X_DnE, atol=1e-8)


# -- unit mistakes in job files ------------------------------------------------------------------
def gp7_pose_job(tmp_path: Path, xyz, length_unit="mm", name="job.yaml") -> Path:
    doc = {"robot": "gp7", "length_unit": length_unit, "angle_unit": "deg", "outputs": ["csv"],
           "waypoints": [{"xyz": [560, 0, 600], "rpy": [180, 0, 0]}, {"xyz": xyz, "rpy": [180, 0, 0]}]}
    return write(tmp_path, yaml.safe_dump(doc), name)


def test_pose_in_metres_under_mm_is_caught(tmp_path):
    with pytest.raises(JobFileError, match=r"waypoints\[1\]\.xyz: is 0.6\d* mm from the base origin, closer "
                                           r"than the end frame of gp7 comes .* is length_unit: mm right\?"):
        load_job(gp7_pose_job(tmp_path, [0.56, 0.0, 0.3]))


def test_pose_in_mm_under_metres_is_caught(tmp_path):
    with pytest.raises(JobFileError, match=r"waypoints\[0\]\.xyz: is 820.7 m from the base origin, beyond the "
                                           r"reach of gp7"):
        load_job(gp7_pose_job(tmp_path, [500, 0, 600], length_unit="m"))


def test_joint_degrees_under_rad_get_a_hint(tmp_path):
    doc = {"robot": "arm6", "angle_unit": "rad", "waypoints": [[0, 0, 0, 0, 0, 0], [0, 30, 0, 0, 0, 0]]}
    with pytest.raises(JobFileError, match=r"waypoints\[1\]\[1\]: .*are these degrees\? \(angle_unit: rad\)"):
        load_job(write(tmp_path, yaml.safe_dump(doc), "job.yaml"))


@pytest.mark.parametrize("dt, ok", [("1e-7", False), ("1e-3", True), ("4e-3", True)])
def test_dt_in_exponent_notation_is_a_number(tmp_path, dt, ok):
    text = "robot: arm6\nangle_unit: rad\nwaypoints: [[0, 0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0, 0]]\n" + f"dt: {dt}\n"
    path = write(tmp_path, text, "job.yaml")
    if ok:
        assert load_job(path).dt == float(dt)
        return
    with pytest.raises(InvalidValueError, match=r"job.yaml:4: dt: must be in \[0.0001, 0.1\] s \(got 1e-07\)"):
        load_job(path)


def test_missing_unit_is_a_missing_field(tmp_path):
    text = "robot: arm6\nwaypoints: [[0, 0, 0, 0, 0, 0], [0.1, 0, 0, 0, 0, 0]]\n"
    with pytest.raises(MissingFieldError, match="angle_unit: required because joint values are given"):
        load_job(write(tmp_path, text, "job.yaml"))


def test_broken_robot_file_named_by_a_job_reports_the_robot_file(tmp_path):
    write(tmp_path, b"\xff\xfe garbage", "arm.yaml")
    job = write(tmp_path, "robot: arm.yaml\nangle_unit: deg\nwaypoints: [[0], [1]]\n", "job.yaml")
    with pytest.raises(RobotFileError, match=r"arm.yaml: document: is not UTF-8"):
        load_job(job)


@pytest.mark.parametrize("name", ["../../etc/x", "a/b", "..", "tab\there", "x" * 300])
def test_robot_names_are_safe_in_file_names(tmp_path, name):
    text = TWO_LINK.replace("name: two_link", f"name: {yaml.safe_dump(name).splitlines()[0]}")
    with pytest.raises(InvalidValueError) as error:
        load_robot_spec(write(tmp_path, text))
    assert error.value.field == "name" and error.value.line == 1
