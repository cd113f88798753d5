"""The Jacobian check report: passes on every preset, fails (and says where) on a wrong model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.model.chain.drake_model import build_drake_robot
from pipeline.model.jacobian_check import EXACT_TOLERANCE, FINITE_DIFFERENCE_TOLERANCE, check_robot


def test_every_preset_passes_on_200_configurations(robot, drake_robots):
    report = check_robot(robot, samples=200, seed=7, drake=drake_robots[robot.name])
    assert report.passed, report.format()
    exact, fd_analytic, fd_drake = report.comparisons
    assert exact.worst <= EXACT_TOLERANCE
    assert fd_analytic.worst <= FINITE_DIFFERENCE_TOLERANCE and fd_drake.worst <= FINITE_DIFFERENCE_TOLERANCE
    assert set(exact.max_error) == {"fk_position", "fk_rotation", "jacobian_linear", "jacobian_angular"}
    assert report.to_dict()["passed"] is True


def test_a_wrong_drake_model_fails_and_names_the_worst_configuration(drake_robots):
    """Drake built from a GP7 whose d4 is 1 mm off: the exact comparison must fail."""
    from pipeline.model.robot import load_robot

    robot = load_robot("gp7")
    joints = list(robot.spec.joints)
    joints[3] = dataclasses.replace(joints[3], d=joints[3].d + 1e-3)
    wrong = build_drake_robot(dataclasses.replace(robot.spec, joints=tuple(joints)))
    report = check_robot(robot, samples=20, seed=1, drake=wrong)
    assert not report.passed
    exact = report.comparisons[0]
    assert not exact.passed and 0.5e-3 < exact.max_error["fk_position"] <= 1e-3 + 1e-12
    assert "FAIL" in report.format() and "worst analytic vs Drake" in report.format()
    assert len(exact.worst_configuration["fk_position"]) == 6


def test_sample_count_is_validated():
    from pipeline.model.robot import load_robot

    with pytest.raises(ConfigurationError, match="samples must be >= 1"):
        check_robot(load_robot("arm5"), samples=0)


def test_report_is_deterministic_for_a_seed(drake_robots):
    from pipeline.model.robot import load_robot

    robot = load_robot("arm6")
    a = check_robot(robot, samples=10, seed=3, drake=drake_robots["arm6"]).to_dict()
    b = check_robot(robot, samples=10, seed=3, drake=drake_robots["arm6"]).to_dict()
    assert a == b
    assert np.isfinite(a["comparisons"][0]["max_error"]["fk_position"])
