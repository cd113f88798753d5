"""The output formats: CSV columns with units, NPZ and JSON contents."""

from __future__ import annotations

import json

import numpy as np

from pipeline.files.robot_spec import Limits
from pipeline.outputs.formats import profile_columns, write_json, write_profile_csv, write_profile_npz
from pipeline.timing.profile import Profile


def small_profile() -> Profile:
    t = np.linspace(0.0, 1.0, 5)
    q = np.column_stack([np.sin(t), 0.1 * t])
    limits = Limits(np.array([-2.0, 0.0]), np.array([2.0, 0.5]), np.array([2.0, 1.0]), np.array([5.0, 5.0]), None)
    return Profile(t, q, np.cos(t)[:, None] * [1, 0] + [0, 0.1], -q * [1, 0], -np.cos(t)[:, None] * [1, 0],
                   "test", limits, ("J1", "slide"))


def test_csv_columns_carry_units_and_metres_for_prismatic_joints(tmp_path):
    assert profile_columns([True, False]) == [
        "t_s", "q1_rad", "q2_m", "qd1_rad_s", "qd2_m_s", "qdd1_rad_s2", "qdd2_m_s2", "qddd1_rad_s3", "qddd2_m_s3"]
    profile = small_profile()
    write_profile_csv(tmp_path / "p.csv", profile, [True, False])
    lines = (tmp_path / "p.csv").read_text().splitlines()
    assert lines[0] == ",".join(profile_columns([True, False])) and len(lines) == 1 + len(profile.t)
    table = np.loadtxt(tmp_path / "p.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 1:3], profile.q, rtol=1e-11, atol=1e-12)


def test_npz_holds_every_quantity_and_the_joint_names(tmp_path):
    profile = small_profile()
    write_profile_npz(tmp_path / "p.npz", profile)
    with np.load(tmp_path / "p.npz") as data:
        for name in ("t", "q", "qd", "qdd", "qddd"):
            np.testing.assert_array_equal(data[name], getattr(profile, name))
        assert tuple(data["joint_names"]) == ("J1", "slide")


def test_json_turns_numpy_values_into_numbers(tmp_path):
    write_json(tmp_path / "r.json", {"a": np.float64(1.5), "b": np.arange(3), "c": np.bool_(True)})
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1.5, "b": [0, 1, 2], "c": True}
