"""The tool kept level on planned moves (``plan_tilt_max``): planned, timed and certified, judged here by
forward kinematics at every profile sample; a job without the limit tilts the carried part."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.cell.tilt import TiltLimit, certify_tilt
from pipeline.errors import JobFileError
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job
from pipeline.program.timing import time_program
from pipeline.runner import collision_model

CELL = Path(__file__).resolve().parents[2] / "models" / "cells" / "gp7_wall_cell.yaml"
#: A carry over the wall whose quickest detour, unconstrained, turns the gripper 60 deg off the vertical.
CARRY = f"""
cell: {CELL}
length_unit: mm
angle_unit: deg
tool: {{xyz: [0, 0, 120], rpy: [0, 0, 0]}}
start: [0, 0, 0, 0, -90, 0]
plan: collision_free
waypoints:
  - {{xyz: [400, 200, 200], rpy: [180, 0, 57.3]}}
  - {{xyz: [750, -250, 200], rpy: [180, 0, -57.3], move: joint}}
"""


def _timed(tmp_path: Path, extra: str = ""):
    path = tmp_path / "carry.yaml"
    path.write_text(CARRY.replace("plan: collision_free", "plan: collision_free\n" + extra))
    job = load_job(path)
    scene = collision_model(job)
    program = compile_job(job, scene)
    return job, program, time_program(program, scene)


def _tilt_deg(job, profile) -> np.ndarray:
    """The angle between the TCP's z axis and the vertical at every sample [deg], by FK."""
    z = job.robot.fk_batch(profile.q)[:, :3, 2]
    return np.degrees(np.arccos(np.clip(np.abs(z[:, 2]), 0.0, 1.0)))


def test_a_tilt_limited_carry_keeps_the_tool_level_and_is_certified(tmp_path):
    job, program, profile = _timed(tmp_path, "plan_tilt_max: 10")
    assert program.moves[0].planned.planner != "direct"
    assert np.degrees(job.plan_tilt_max) == pytest.approx(10.0)
    assert _tilt_deg(job, profile).max() <= 10.0
    report = profile.details.tilt
    assert report["passed"] and report["worst_deg"] <= 10.0 and report["max_deg"] == pytest.approx(10.0)
    assert profile.certificate.passed and profile.certificate.clearance.passed


def test_without_the_limit_the_same_carry_tilts_and_the_certificate_says_so(tmp_path):
    job, program, profile = _timed(tmp_path)
    assert profile.details.tilt is None
    assert _tilt_deg(job, profile).max() > 30.0
    limit = TiltLimit(np.eye(3), np.radians(10.0))
    report = certify_tilt(job.robot, limit, profile, [(0.0, profile.duration)])
    assert not report.passed and np.degrees(report.worst_rad) > 30.0
    # the bound between samples is never below the samples' own tilt
    assert np.degrees(report.worst_rad) >= _tilt_deg(job, profile).max() - 1e-9


def test_the_certificate_judges_only_the_planned_spans(tmp_path):
    job, _, profile = _timed(tmp_path)
    limit = TiltLimit(np.eye(3), np.radians(10.0))
    assert certify_tilt(job.robot, limit, profile, []).passed
    first = certify_tilt(job.robot, limit, profile, [(0.0, 0.0)])
    assert first.passed == bool(_tilt_deg(job, profile)[0] <= 10.0)


@pytest.mark.parametrize("extra, field, problem", [
    ("plan_tilt_max: 100", "plan_tilt_max", "must be in (0, 90] deg"),
    ("plan_tilt_max: 0", "plan_tilt_max", "must be in (0, 90] deg"),
])
def test_bad_tilt_limits_are_refused_with_the_field(tmp_path, extra, field, problem):
    path = tmp_path / "carry.yaml"
    path.write_text(CARRY.replace("plan: collision_free", "plan: collision_free\n" + extra))
    with pytest.raises(JobFileError) as error:
        load_job(path)
    assert field in str(error.value) and problem in str(error.value)


def test_a_tilt_limit_needs_planning(tmp_path):
    path = tmp_path / "carry.yaml"
    path.write_text(CARRY.replace("plan: collision_free", "plan_tilt_max: 10"))
    with pytest.raises(JobFileError, match="plan_tilt_max.*plan: collision_free"):
        load_job(path)


def test_an_end_beyond_the_limit_is_a_planning_error(tmp_path):
    from pipeline.cell.planning import plan_joint_path
    from pipeline.errors import PlanningError

    job, program, _ = _timed(tmp_path)
    scene = collision_model(job)
    limit = TiltLimit(np.eye(3), np.radians(10.0))
    tilted = program.targets[0].copy()
    tilted[4] += np.radians(20.0)
    with pytest.raises(PlanningError, match="start configuration tilts the tool 2[0-9.]+ deg"):
        plan_joint_path(scene, tilted, program.targets[1], tilt=limit)
