"""The ur5e preset's dynamics against three references that share none of its code.

1. A hand computation here: UR's DH table, link masses and centres of mass as UR's article "DH Parameters for
   calculations of kinematics and dynamics" prints them (the centre of mass of link i in DH frame i), the static
   torque of joint j the sum over the links beyond it of ``-(z_j x (c_i - o_j)) . (m_i g)``.
2. Pinocchio 4.1.0's ``computeGeneralizedGravity`` on the URDF generated from UR's ROS2 description (commit 2221ec0f),
   as recorded in research40/gravity_check_output.txt (printed to 1e-3 N m).
3. Drake's inverse dynamics of a plant parsed from that URDF (tests/ur5e_urdf.py), the payload a body welded to tool0:
   within 1e-9 relative once the URDF's rounded joint origins (pi/2 written 1.570796327) are made exact, within 1e-7 as
   UR wrote it (the rounding alone moves the torques by ~1e-8 relative).

The gravity table (research40/FACTS.md section 4b) is at five configurations, without and with a 5 kg point payload
0.05 m along the flange's z.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.files.arrays import inertia_matrix
from pipeline.model.chain.drake_model import build_drake_robot
from pipeline.model.robot import load_robot
from pipeline.program.payload import Payload
from tests.ur5e_urdf import UrdfArm

PI = np.pi
G = 9.81                                                  # m/s^2, along -z of the base (Drake's default)
# UR's article (primary), UR5e rows: a, d [m], alpha [rad], link mass [kg], centre of mass in DH frame i [m].
A = [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0]
D = [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996]
ALPHA = [PI / 2, 0.0, 0.0, PI / 2, -PI / 2, 0.0]
MASS = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]
COM = [[0, -0.02561, 0.00193], [0.2125, 0, 0.11336], [0.15, 0.0, 0.0265],
       [0, -0.0018, 0.01634], [0, 0.0018, 0.01634], [0, 0, -0.001159]]

CONFIGS = {
    "zero": [0, 0, 0, 0, 0, 0],
    "upright": [0, -PI / 2, 0, -PI / 2, 0, 0],
    "elbow_up": [0, -PI / 2, PI / 2, -PI / 2, -PI / 2, 0],
    "reach_forward": [0, -PI / 4, -PI / 4, -PI / 2, PI / 2, 0],
    "mixed": [0.5, -1.2, 1.4, -1.8, -1.57, 0.3],
}
PAYLOAD_5KG = Payload(5.0, np.array([0.0, 0.0, 0.05]), source="5 kg point mass 0.05 m along the flange's z")
# Pinocchio 4.1.0 on UR's URDF [N m], J1..J6: research40/gravity_check_output.txt (check_gravity.py), printed to 1e-3.
PINOCCHIO = {
    (None, "zero"): [0.000, -59.756, -18.439, -0.000, 0.000, 0.000],
    (None, "upright"): [-0.000, -0.000, -0.000, -0.000, 0.000, 0.000],
    (None, "elbow_up"): [0.000, -20.264, -20.264, -1.825, -0.000, 0.000],
    (None, "reach_forward"): [0.000, -28.655, 0.561, 0.561, -0.000, 0.000],
    (None, "mixed"): [0.000, -34.884, -19.912, -1.841, 0.000, 0.000],
    ("5kg", "zero"): [0.000, -99.840, -37.677, -0.000, 0.000, -0.000],
    ("5kg", "upright"): [0.000, -0.000, -0.000, -0.000, 0.000, 0.000],
    ("5kg", "elbow_up"): [0.000, -44.392, -44.392, -6.715, -0.000, -0.000],
    ("5kg", "reach_forward"): [0.000, -36.057, 7.899, 7.899, -0.000, 0.000],
    ("5kg", "mixed"): [0.000, -66.394, -43.869, -6.943, 0.006, 0.000],
}
PRINTED = 0.5e-3 + 1e-9                                   # half the last printed digit [N m]
PAYLOADS = {None: None, "5kg": PAYLOAD_5KG}


def dh(a, d, alpha, theta) -> np.ndarray:
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]])


def hand_gravity_torque(q, payload: Payload | None) -> np.ndarray:
    """(6,) [N m] the torques holding the arm at rest at ``q``: per joint the moments about its axis of the weights of
    the links (and the payload) beyond it."""
    frames = [np.eye(4)]
    for i in range(6):
        frames.append(frames[-1] @ dh(A[i], D[i], ALPHA[i], q[i]))
    masses = list(MASS)
    centres = [(frames[i + 1] @ np.r_[COM[i], 1.0])[:3] for i in range(6)]
    if payload is not None:
        masses.append(payload.mass)
        centres.append((frames[6] @ np.r_[payload.com, 1.0])[:3])
    weight = np.array([0.0, 0.0, -G])
    tau = np.zeros(6)
    for j in range(6):
        z, origin = frames[j][:3, 2], frames[j][:3, 3]
        tau[j] = -sum(np.cross(z, c - origin) @ (m * weight) for m, c in zip(masses[j:], centres[j:]))
    return tau


@pytest.fixture(scope="module")
def ur5e():
    return build_drake_robot(load_robot("ur5e").spec)


@pytest.fixture(scope="module")
def urdf_arms():
    """UR's URDF as written, and with its rounded joint origins exact (tests/ur5e_urdf.py, ROUNDED)."""
    return {"as_written": UrdfArm(), "exact": UrdfArm(exact=True)}


def test_preset_rows_are_urs_published_numbers():
    spec = load_robot("ur5e").spec
    for i, joint in enumerate(spec.joints):
        assert (joint.a, joint.d, joint.alpha) == pytest.approx((A[i], D[i], ALPHA[i]), abs=1e-15)
        assert joint.inertia.mass == MASS[i]
        np.testing.assert_allclose(joint.inertia.p_LoLcm, COM[i], atol=1e-15, rtol=0)
    assert [j.tau_max for j in spec.joints] == [150, 150, 150, 28, 28, 28]


@pytest.mark.parametrize("load", list(PAYLOADS))
@pytest.mark.parametrize("config", list(CONFIGS))
def test_gravity_torque_equals_hand_computation_and_pinocchio(ur5e, config, load):
    q = np.array(CONFIGS[config], dtype=float)
    zero = np.zeros(6)
    tau = ur5e.inverse_dynamics(q, zero, zero, PAYLOADS[load])[0]
    np.testing.assert_allclose(tau, hand_gravity_torque(q, PAYLOADS[load]), atol=1e-9, rtol=0)
    np.testing.assert_allclose(tau, PINOCCHIO[(load, config)], atol=PRINTED, rtol=0)


def test_hand_computation_checks_itself():
    """At q = 0 the flange is 0.425 + 0.3922 m out horizontally: 5 kg there adds 5 g 0.8172 N m to joint 2."""
    zero = np.zeros(6)
    added = hand_gravity_torque(zero, PAYLOAD_5KG) - hand_gravity_torque(zero, None)
    assert added[1] == pytest.approx(-5.0 * G * 0.8172, abs=1e-12)


#: How far each URDF's tool0 [m] and torques (relative to max(|tau|, 1 N m) per joint) may be from the preset's: the
#: URDF as written rounds pi/2 to 1.570796327 (2.1e-10 rad off), which tilts the arm beyond and moves the torques by
#: up to ~1.2e-8 of the larger of a torque and 1 N m (measured); with those origins exact, only rounding is left.
TOLERANCES = {"as_written": (1e-9, 1e-7), "exact": (1e-14, 1e-9)}


@pytest.mark.parametrize("urdf", list(TOLERANCES))
def test_tool0_is_the_end_frame(ur5e, urdf_arms, urdf, rng):
    for q in rng.uniform(-PI, PI, (100, 6)):
        np.testing.assert_allclose(ur5e.fk(q), urdf_arms[urdf].tool0(q), atol=TOLERANCES[urdf][0], rtol=0)


@pytest.mark.parametrize("urdf", list(TOLERANCES))
def test_inverse_dynamics_with_payload_equals_drake_on_urs_urdf(ur5e, urdf_arms, urdf, rng):
    """100 random (q, qd, qdd) within the preset's limits, a payload with a non-diagonal inertia welded to tool0."""
    payload = Payload(2.5, np.array([0.01, -0.02, 0.08]), inertia_matrix([0.012, 0.010, 0.006, 0.001, -0.0015, 0.0008]),
                      "test load")
    limits = load_robot("ur5e").limits
    for _ in range(100):
        q = rng.uniform(-PI, PI, 6)
        qd = rng.uniform(-1.0, 1.0, 6) * limits.qd_max
        qdd = rng.uniform(-1.0, 1.0, 6) * limits.qdd_max
        expected = urdf_arms[urdf].inverse_dynamics(q, qd, qdd, payload)
        tau = ur5e.inverse_dynamics(q, qd, qdd, payload)[0]
        assert np.all(np.abs(tau - expected) <= TOLERANCES[urdf][1] * np.maximum(np.abs(expected), 1.0))
