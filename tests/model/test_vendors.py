"""Controller axis angles and configuration data (pipeline.model.vendors): published pairs, the property
pose + configuration -> the original joint values, and bad input."""

from __future__ import annotations

import time

import numpy as np
import pytest

from pipeline.errors import ConfigurationError, ConfigurationNotFoundError, VendorConfigurationError
from pipeline.model.ik.branches import configuration_labels
from pipeline.model.robot import load_robot, robot_with_tool
from pipeline.model.vendors import (
    VENDORS,
    axis_angles,
    axis_map,
    configurations,
    format_configuration,
    parse_configuration,
    select_solution,
    select_solutions,
)
from pipeline.model.vendors.configuration import fanuc_turns, mismatched_field
from pipeline.model.vendors.sides import arm_sides
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR

#: Each preset with its maker's controller (arm6 has none: the identity map on a KUKA controller).
PRESET_VENDORS = {"irb1600": "abb", "lrmate200id": "fanuc", "gp7": "yaskawa", "arm6": "kuka"}
#: Draws this close to a singular set are dropped [rad for q5, m for the shoulder, sine for the elbow].
SINGULAR_MARGIN = 1e-6
#: The closed form's q4 and q6 lose accuracy as eps / q5^2 near the wrist singularity: 1e-9 rad holds
#: from this |q5| [rad] on (measured over 10^5 draws per preset: every miss of 1e-9 had |q5| < 2.1e-4).
WRIST_ACCURATE = 1e-3


def deg(*values) -> np.ndarray:
    return np.radians(np.array(values, dtype=float))


# -- published pairs --------------------------------------------------------------------------------------
@pytest.mark.parametrize("joints, quadrants, axis5_negative", [
    ((22.50953, 5.58534, 8.15717, 67.51143, -24.42689, -64.06258), (0, 0, -1), 1),
    ((0, 3.94, -14.73, 0, 14.39, 0), (0, 0, 0), 0),
])
def test_abb_quadrants_and_axis5_bit_of_robodks_abb_post_test(joints, quadrants, axis5_negative):
    """RoboDK's ABB post (test_post, an IRB 6700-155/2.85, not our preset): the joint-only parts of
    confdata, cf1/cf4/cf6 = floor(angle / 90 deg) and cfx's axis-5 bit, on the IRB 1600's identity map
    (the wrist-centre bits of cfx depend on the arm's lengths, so the 6700's cannot be checked here)."""
    conf = configurations(load_robot("irb1600"), deg(*joints), "abb")
    assert tuple(conf[:3]) == quadrants
    assert conf[3] & 1 == axis5_negative


def test_abb_cfx_counts_shoulder_elbow_wrist():
    robot = load_robot("irb1600")
    assert format_configuration("abb", configurations(robot, np.zeros(6), "abb")) == "[0,0,0,0]"
    behind = deg(0, -60, -200, 0, 30, 0)                    # axis 3 folded up and over: wrist centre behind axis 1
    sides = arm_sides(robot, behind[None])
    assert sides.behind[0]
    assert configurations(robot, behind, "abb")[3] >> 2 == 1


@pytest.mark.parametrize("angle, turns", [(400, 1), (180, 0), (181, 1), (-180, -1), (-179, 0), (0, 0), (540, 1),
                                          (541, 2), (-540, -2)])
def test_fanuc_turn_numbers_count_turns_out_of_minus_180_to_180(angle, turns):
    """(-180, 180] deg is turn 0: 180 -> 0 and -180 -> -1 (RoboDK's formula gives 1 at exactly +180)."""
    assert fanuc_turns(angle) == turns


def test_fanuc_config_of_the_lr_mate():
    robot = load_robot("lrmate200id")
    assert format_configuration("fanuc", configurations(robot, deg(0, 0, 0, 0, -90, 0), "fanuc")) == "N U T, 0, 0, 0"
    assert format_configuration("fanuc", configurations(robot, deg(0, 0, 0, 185, 30, -200), "fanuc")) == \
        "F U T, 0, 1, -1"


def test_kuka_turn_bits_of_the_sinumerik_tu_example():
    """TU = 'B010011': A1, A2 and A5 negative (bits 0, 1 and 4)."""
    conf = configurations(load_robot("arm6"), deg(-10, -20, 30, 40, -50, 60), "kuka")
    assert format_configuration("kuka", conf).endswith("T 'B010011'")
    assert conf[1] == 0b010011


def test_kuka_status_bits():
    robot = load_robot("arm6")
    assert format_configuration("kuka", configurations(robot, deg(0, 0, 0, 0, 10, 0), "kuka")) == \
        "S 'B010', T 'B000000'"                               # elbow up (the zero pose's side), A5 >= 0
    assert configurations(robot, deg(0, 0, 0, 0, -10, 0), "kuka")[0] == 0b110


def test_yaskawa_rconf_follows_the_nx100_manual():
    """Flip by the R axis (-90 < R <= 90 deg and 270 < |R| <= 360), R/T/S >= 180 as |angle| >= 180 (the
    formula: R = -280 deg is outside the GP7's +-190 deg)."""
    robot = load_robot("gp7")
    Q = np.radians([[0, 0, 0, r, 20, t] for r, t in ((0, 0), (120, 0), (-100, 0), (185, -200), (-280, 160), (80, 200))])
    rows = configurations(robot, Q, "yaskawa")
    flips, r_bits, t_bits = rows[:, 0].tolist(), rows[:, 3].tolist(), rows[:, 4].tolist()
    assert flips == [0, 1, 1, 1, 0, 0]
    assert r_bits == [0, 0, 0, 1, 1, 0]
    assert t_bits == [0, 0, 0, 1, 0, 1]
    assert format_configuration("yaskawa", configurations(robot, np.zeros(6), "yaskawa")) == "0,0,0,0,0,0"


# -- axis maps ---------------------------------------------------------------------------------------------
def test_axis_maps_per_preset():
    """The presets' maps come from their robot files' controller sections; another maker's gets the identity."""
    assert "the controller section of irb1600.yaml" in axis_map(load_robot("irb1600"), "abb").source
    assert axis_map(load_robot("lrmate200id"), "fanuc").fanuc_j3
    np.testing.assert_allclose(axis_angles(load_robot("lrmate200id"), deg(10, 20, 50, 0, -30, 90), "fanuc"),
                               [10, 20, 30, 0, -30, 90], atol=1e-12)
    other = axis_map(load_robot("gp7"), "fanuc")
    assert not other.fanuc_j3 and "no fanuc controller section" in other.source and "identity" in other.source
    assert "no kuka controller section" in axis_map(load_robot("arm6"), "kuka").source


def test_every_preset_zero_pose_is_the_front_elbow_up_pose():
    """The geometric bits take the zero pose's sides as front and elbow up: our labels agree there."""
    for name in PRESET_VENDORS:
        assert configuration_labels(load_robot(name), np.zeros(6))[0].startswith("shoulder front, elbow up")


# -- the property: pose + configuration -> the original joint values ----------------------------------------
def draws(robot, count: int, seed: int) -> np.ndarray:
    """Random in-limit configurations at least SINGULAR_MARGIN from the wrist, shoulder and elbow singular sets."""
    Q = robot.random_configurations(np.random.default_rng(seed), count)
    sides = arm_sides(robot, Q)
    keep = (np.abs(Q[:, 4]) > SINGULAR_MARGIN) & (sides.shoulder_margin > SINGULAR_MARGIN) & \
        (sides.elbow_margin > SINGULAR_MARGIN)
    return Q[keep]


def round_trip(name: str, vendor: str, count: int, seed: int) -> tuple[int, float]:
    robot = load_robot(name)
    Q = draws(robot, count, seed)
    start = time.perf_counter()
    Q_back = select_solutions(robot, robot.fk_batch(Q), configurations(robot, Q, vendor), vendor)
    elapsed = time.perf_counter() - start
    error = np.abs(Q_back - Q).max(axis=1)
    assert error.max() < 1e-6, f"{name}: a draw left its branch or 2 pi representative"
    accurate = np.abs(Q[:, 4]) >= WRIST_ACCURATE
    assert error[accurate].max() <= 1e-9, f"{name}: {np.sum(error[accurate] > 1e-9)} draws off by more than 1e-9 rad"
    return len(Q), elapsed


@pytest.mark.parametrize("name", [n if k < 1 else pytest.param(n, marks=pytest.mark.slow)
                                  for k, n in enumerate(PRESET_VENDORS)])
def test_pose_and_configuration_give_back_the_joint_values(name):
    count, _ = round_trip(name, PRESET_VENDORS[name], 10_000, 26)
    assert count > 9_900, f"{name}: only {count} draws kept"


@pytest.mark.parametrize("vendor", VENDORS)
def test_every_vendor_on_the_generic_arm(vendor):
    round_trip("arm6", vendor, 2_000, 7)


def test_a_tcp_pose_selects_the_same_joint_values():
    """The configuration is a property of q, not of the tool: a TCP pose with the robot carrying the tool
    gives back q."""
    robot = load_robot("gp7")
    tool = np.eye(4)
    tool[:3, 3] = [0.03, -0.02, 0.15]
    with_tool = robot_with_tool(robot, tool)
    Q = draws(robot, 500, 3)
    np.testing.assert_array_equal(configurations(with_tool, Q, "yaskawa"), configurations(robot, Q, "yaskawa"))
    Q_back = select_solutions(with_tool, with_tool.fk_batch(Q), configurations(robot, Q, "yaskawa"), "yaskawa")
    assert np.abs(Q_back - Q).max() < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("name", list(PRESET_VENDORS))
def test_pose_and_configuration_give_back_the_joint_values_10_5(name):
    count, _ = round_trip(name, PRESET_VENDORS[name], 100_000, 2026)
    assert count > 99_000


# -- text and bad input -------------------------------------------------------------------------------------
@pytest.mark.parametrize("vendor, text, fields", [
    ("abb", "[0,0,-1,1]", (0, 0, -1, 1)),
    ("fanuc", "'N U T, 0, 0, 1'", (0, 1, 1, 0, 0, 1)),
    ("yaskawa", "///RCONF 0,0,0,0,1,0,0,0", (0, 0, 0, 0, 1, 0)),
    ("kuka", "S 'B110', T 'B010011'", (6, 19)),
    ("kuka", "S 6 T 19", (6, 19)),
])
def test_text_reads_back(vendor, text, fields):
    assert parse_configuration(vendor, text) == fields
    assert parse_configuration(vendor, format_configuration(vendor, fields)) == fields


@pytest.mark.parametrize("vendor, value, words", [
    ("staubli", [0, 0, 0, 0], "unknown controller vendor"),
    ("abb", [0, 0, 0], "4 integers"),
    ("abb", [0, 0, 0, 9], "cfx"),
    ("abb", [0, 0.5, 0, 0], "cf4 must be an integer"),
    ("fanuc", "X U T, 0, 0, 0", "not a fanuc configuration"),
    ("yaskawa", "0,0,2,0,0,0", "not a yaskawa configuration"),
    ("kuka", (8, 0), "field S"),
])
def test_malformed_configurations_are_typed_errors(vendor, value, words):
    with pytest.raises(VendorConfigurationError, match=words):
        parse_configuration(vendor, value)


def test_no_matching_solution_names_pose_request_and_what_exists():
    robot = load_robot("irb1600")
    q = deg(10, 20, -30, 40, 50, 60)
    X = robot.fk(q)
    np.testing.assert_allclose(select_solution(robot, X, configurations(robot, q, "abb"), "abb"), q, atol=1e-9)
    with pytest.raises(ConfigurationNotFoundError) as caught:
        select_solution(robot, X, [3, 3, 3, 0], "abb")
    error = caught.value
    assert error.requested == "[3,3,3,0]" and "[0,0,0,0]" in error.available
    assert "mm with rotation" in str(error) and "no in-limit IK solution has it" in str(error)
    assert isinstance(error, ConfigurationError)


def test_an_unreachable_pose_and_mismatched_counts_are_typed_errors():
    robot = load_robot("gp7")
    X = np.eye(4)
    X[0, 3] = 5.0                                           # 5 m away: out of reach
    with pytest.raises(ConfigurationNotFoundError, match="none"):
        select_solution(robot, X, "0,0,0,0,0,0", "yaskawa")
    with pytest.raises(VendorConfigurationError, match="2 poses but 1 configurations"):
        select_solutions(robot, np.stack([X, X]), ["0,0,0,0,0,0"], "yaskawa")
    with pytest.raises(VendorConfigurationError, match="unknown controller vendor"):
        axis_angles(robot, np.zeros(6), "comau")


def test_a_configuration_that_leaves_two_variants_is_refused():
    """KUKA's Turn bits cannot tell axis 6 = 30 deg from 390 deg (the IRB 1600's axis 6 has +-400 deg)."""
    robot = load_robot("irb1600")
    q = deg(10, 20, -30, 40, 50, 30)
    with pytest.raises(ConfigurationNotFoundError, match="2 different in-limit solutions"):
        select_solution(robot, robot.fk(q), configurations(robot, q, "kuka"), "kuka")


def test_an_arm_without_a_spherical_wrist_is_refused():
    ur5 = import_urdf(DATA_DIR / "urdf" / "ur5.urdf").robot
    with pytest.raises(VendorConfigurationError, match="spherical"):
        configurations(ur5, np.zeros(6), "kuka")


def test_an_axis_on_a_boundary_by_round_off_takes_either_side():
    """Axis 1 at 4e-9 rad (an IK answer for a target at y = 0, bench cycle's shelf): a RAPID writer may write cf1 = -1
    (the side its rounded robtarget selects) and the lint takes it; 1e-4 rad is no longer on the boundary."""
    robot = load_robot("gp7")
    q = np.radians([0.0, 8.26, -62.58, 100.0, -56.84, -27.7])
    q[0] = 4e-9
    fields = configurations(robot, q, "abb")
    other = fields.copy()
    other[0] = -1
    assert fields[0] == 0 and mismatched_field(robot, q, "abb", other) is None
    q[0] = 1e-4
    assert mismatched_field(robot, q, "abb", other) == 0
