"""Fanuc J2/J3 coupling and pendant joint lists."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.model.robot import load_robot
from pipeline.model.vendors.pendant import (
    fanuc_pendant_to_serial,
    fanuc_serial_to_pendant,
    parse_pendant_list,
    pendant_list,
)


def test_round_trip_in_degrees_and_radians(rng):
    robot = load_robot("lrmate200id")
    Q = robot.random_configurations(rng, 100)
    for unit in ("deg", "rad"):
        np.testing.assert_allclose(fanuc_pendant_to_serial(fanuc_serial_to_pendant(Q, unit), unit), Q, atol=1e-12)


def test_documented_coupling_j3_pendant_is_q3_minus_q2():
    pendant = fanuc_serial_to_pendant(np.radians([10, 20, 50, 0, -30, 90]))
    np.testing.assert_allclose(pendant, [10, 20, 30, 0, -30, 90], atol=1e-12)


def test_moving_j2_alone_on_the_pendant_keeps_the_forearm_attitude():
    """The reason for the convention: pendant J3 fixed, J2 moved -> the forearm (link 3) keeps its
    orientation in the base frame, while the serial q3 has to change."""
    robot = load_robot("lrmate200id")
    forearm = []
    for j2 in (-30.0, 0.0, 25.0, 60.0):
        q = fanuc_pendant_to_serial([15, j2, -10, 0, 0, 0])
        forearm.append(robot.fk_all(q)[3][:3, :3])
    for R in forearm[1:]:
        np.testing.assert_allclose(R, forearm[0], atol=1e-12)


def test_pendant_lists():
    q = np.radians([10, -5.5, 0, 180, 45.25, -360])
    text = pendant_list(q)
    assert text.startswith("J1 10.000  J2 -5.500") and text.endswith("[deg]")
    np.testing.assert_allclose(parse_pendant_list([10, -5.5, 0, 180, 45.25, -360]), q)
    assert "J6 -6.283" in pendant_list(q, unit="rad")


@pytest.mark.parametrize("bad", [np.zeros(5), [0, 0, np.nan, 0, 0, 0]])
def test_bad_input_is_a_typed_error(bad):
    with pytest.raises(ConfigurationError):
        fanuc_serial_to_pendant(bad)
    with pytest.raises(ConfigurationError):
        pendant_list(np.zeros(6), unit="grad")
