"""The job's timing settings in a written program's header and read back (``settings_mark``), and the round trip
``program`` -> ``read-program`` -> ``run`` they make faithful (``bench.written``): a jerk-limited job at a speed
scale below 1 comes back timed as it was written, in every language of a six-axis arm."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.bench.written import measure_job
from pipeline.outputs.controllers.settings_mark import marked_settings, settings_mark, with_written_settings
from pipeline.program.job import load_job
from pipeline.runner import timed_program

DEMO = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"


def test_the_mark_names_the_settings_and_reads_back():
    job = load_job(DEMO / "lrmate200id_quaternion_poses.yaml")
    program, _, _ = timed_program(job)
    mark = settings_mark(program)
    assert mark == "dh.timing=topp3 dh.path=monotone dh.speed_scale=0.7"
    assert marked_settings(f"! {mark} !") == {"timing": "topp3", "path": "monotone", "speed_scale": 0.7}


@pytest.mark.parametrize("text", ["dh.timing=fast", "dh.speed_scale=2", "dh.speed_scale=nan", "dh.speed_scale=0",
                                  "dh.tcp_accel_max=-1", "dh.tcp_accel_max=inf", "xdh.timing=topp3"])
def test_a_mark_dh_pipeline_would_not_write_is_left_out(text):
    assert marked_settings(text) == {}


def test_speeds_written_at_the_scale_are_read_back_at_full_scale():
    document = {"waypoints": [[0.0] * 6, {"joints": [1.0] * 6, "speed": 42.0},
                              {"xyz": [0.5, 0, 0.5], "move": "linear", "speed": 0.3},
                              {"joints": [0.0] * 6, "speed": 60.3}],
                "tcp_accel_max": 0.36 * 2.5}
    out = with_written_settings(document, "dh.timing=toppra dh.speed_scale=0.6 dh.tcp_accel_max=9")
    assert out["speed_scale"] == 0.6 and out["timing"] == "toppra"
    assert [w["speed"] for w in out["waypoints"][1:]] == pytest.approx([70.0, 0.5, 100.0])
    assert out["tcp_accel_max"] == pytest.approx(2.5)          # the program's own (PathAccLim), not the mark's
    assert document["waypoints"][1]["speed"] == 42.0           # a new document
    ruckig = with_written_settings(document, "dh.timing=ruckig dh.speed_scale=0.6")
    assert "speed" not in ruckig["waypoints"][1] and ruckig["waypoints"][2]["speed"] == pytest.approx(0.5)


def test_a_program_without_the_mark_reads_as_before():
    document = {"waypoints": [[0.0] * 6, {"joints": [1.0] * 6, "speed": 42.0}]}
    assert with_written_settings(document, "MODULE m\n  MoveAbsJ j1, v100, fine, tool0;\nENDMODULE") is document


@pytest.mark.parametrize("name, languages", [
    pytest.param("arm6_joint_rad", ("rapid", "krl", "ls", "jbi"), marks=pytest.mark.slow),
    pytest.param("lrmate200id_quaternion_poses", ("rapid", "krl", "ls", "jbi"), marks=pytest.mark.slow),
])
def test_a_jerk_limited_scaled_job_comes_back_as_written(name, languages):
    """ruckig at speed scale 0.6 and topp3 at 0.7: read back without the mark they came back 0.63x and 0.48x as
    long (toppra, full scale); with it, the same duration in every language and the same stops."""
    for record in measure_job(load_job(DEMO / f"{name}.yaml"), languages):
        assert record.error == "" and record.read_back_passed and record.same_stops, record
        assert record.ratio == pytest.approx(1.0, abs=1e-3), record


@pytest.mark.slow
def test_a_short_topp3_job_at_half_speed_comes_back_from_ls_as_written(tmp_path):
    """The same in make test, on a short job: three GP7 joint waypoints, topp3 at speed scale 0.5, FANUC LS (whose
    comments wrap the mark over lines)."""
    import yaml

    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump({"robot": "gp7", "angle_unit": "deg", "timing": "topp3", "speed_scale": 0.5,
                                    "waypoints": [[0, 0, 0, 0, -90, 0], [30, 10, 10, 0, -80, 20],
                                                  [60, 0, 20, 0, -70, 0]]}))
    record, = measure_job(load_job(path), ("ls",))
    assert record.error == "" and record.read_back_passed and record.same_stops, record
    assert record.ratio == pytest.approx(1.0, abs=1e-3), record


@pytest.mark.slow                                   # some 9 s
def test_a_ur5_job_comes_back_from_urscript_as_written(tmp_path):
    """URScript too (its blend radii, the mark in a # comment): a UR5 job at speed scale 0.5 timed by topp3."""
    import yaml

    from .test_urscript import UR5_JOB

    path = tmp_path / "ur5_scaled.yaml"
    path.write_text(yaml.safe_dump({**UR5_JOB, "speed_scale": 0.5, "timing": "topp3"}))
    record, = measure_job(load_job(path))                        # the language that fits a UR arm: URScript
    assert record.error == "" and record.read_back_passed and record.same_stops, record
    assert record.ratio == pytest.approx(1.0, abs=1e-3), record


def test_the_gripped_mark_names_a_total_loads_parts_only_when_it_names_each_once():
    from pipeline.outputs.controllers.settings_mark import with_part_names

    document = {"parts": {"part1": {"mass": 1.0}, "part2": {"mass": 2.0}},
                "waypoints": [{"joints": [0] * 6, "do": [{"grip": "part1"}]}, {"joints": [0] * 6, "do": [
                    {"release": "part1"}, {"grip": "part2"}, {"set": "part1", "value": "on"}]}]}
    named = with_part_names(document, "; dh.gripped.1=box dh.gripped.2=lid")
    assert list(named["parts"]) == ["box", "lid"]
    assert named["waypoints"][1]["do"] == [{"release": "box"}, {"grip": "lid"}, {"set": "part1", "value": "on"}]
    for text in ("; dh.gripped.1=box", "; dh.gripped.1=box dh.gripped.2=box", "; no mark"):
        assert with_part_names(document, text) is document
