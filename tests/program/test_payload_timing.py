"""A part the robot carries changes the timing where, and only where, the torque limits bind.

The job tests/data/ur5e_payload_pick_place.yaml (the ur5e preset: UR's published masses and torque limits, a 1 kg
gripper, a 3 kg part gripped at waypoint 1 and released at waypoint 3): stretch 1 swings the arm reaching out half a
turn about joint 1 (torque-bound with the part, bound by the acceleration limit without it), stretch 2 turns the part half a turn about joint 6 (bound by joint
speed and acceleration). The same job without the grip and the release (the same waypoints and waits) is the baseline.
The certified profile's torques are recomputed by Drake on UR's own URDF (tests/ur5e_urdf.py), each load a body welded
to tool0, sample by sample with the load ``profile.details.loads_s`` says is carried there.
"""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from pipeline.errors import TimingError
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.report import cycle_report
from pipeline.program.timing import time_program
from tests.conftest import DATA_DIR
from tests.ur5e_urdf import UrdfArm

JOB = DATA_DIR / "ur5e_payload_pick_place.yaml"
#: Stretches (indices into ``details.stretches``): the swing about joint 1, the turn about joint 6.
SWING, TURN = 1, 2
#: Torques equal to this fraction of max(|tau|, 1 N m) per joint (UR's URDF rounds pi/2 to 1.570796327, which alone
#: moves them by ~1e-8 of that: tests/model/test_ur5e_dynamics.py).
TORQUE_AGREEMENT = 1e-6


def timed(path):
    program = compile_job(load_job(path))
    return program, time_program(program)


@pytest.fixture(scope="module")
def with_part():
    return timed(JOB)


@pytest.fixture(scope="module")
def without_part(tmp_path_factory):
    """The same job without the grip and the release (every wait kept, so the same stops)."""
    text = JOB.read_text(encoding="utf-8")
    for action in (", {grip: part}", ", {release: part}"):
        assert text.count(action) == 1
        text = text.replace(action, "")
    path = tmp_path_factory.mktemp("no_part") / JOB.name
    path.write_text(text, encoding="utf-8")
    return timed(path)


def loads_at(program, profile) -> list[tuple]:
    """Per sample, the loads carried (``details.loads_s``: a sample at a piece's first time belongs to the piece
    before it), as the job's own loads: the tool's and each part named (``tool + part``)."""
    pieces = profile.details.loads_s
    starts = np.array([piece["from_s"] for piece in pieces])
    index = np.maximum(np.searchsorted(starts, profile.t, side="left") - 1, 0)
    named = {"tool": program.payload, **program.parts}
    return [tuple(named[name] for name in pieces[k]["load"].split(" + ")) for k in index]


def stretch_samples(profile, k: int) -> np.ndarray:
    """Indices of the samples of stretch k: after it leaves its first waypoint (passage and rest) up to its last."""
    details = profile.details
    stretch = details.stretches[k]
    start = details.passages_s[stretch["first"]] + details.rests_s[stretch["first"]]
    end = details.passages_s[stretch["last"]]
    return np.flatnonzero((profile.t > start) & (profile.t <= end))


def torque_ratios(program, profile, k: int) -> np.ndarray:
    """(dof,) the largest |tau| / tau_max of each joint on stretch k."""
    return np.abs(profile.tau[stretch_samples(profile, k)]).max(axis=0) / program.limits.tau_max


@pytest.mark.slow
def test_every_samples_torque_is_drakes_on_urs_urdf_with_the_load_carried_there(with_part):
    program, profile = with_part
    assert [piece["load"] for piece in profile.details.loads_s] == ["tool", "tool + part", "tool + part",
                                                                     "tool + part", "tool + part", "tool"]
    arm = UrdfArm()
    worst = 0.0
    for q, qd, qdd, tau, loads in zip(profile.q, profile.qd, profile.qdd, profile.tau, loads_at(program, profile)):
        expected = arm.inverse_dynamics(q, qd, qdd, *loads)
        worst = max(worst, float(np.max(np.abs(tau - expected) / np.maximum(np.abs(expected), 1.0))))
    assert worst <= TORQUE_AGREEMENT, worst


def test_the_certificates_torque_ratios_are_at_most_one(with_part):
    _, profile = with_part
    assert profile.certificate.passed
    assert np.all(profile.certificate.ratios["tau"] <= 1.0), profile.certificate.ratios["tau"]


@pytest.mark.slow
def test_the_part_slows_the_torque_bound_swing_and_not_the_speed_bound_turn(with_part, without_part):
    (program, profile), (bare_program, bare) = with_part, without_part
    assert bare.details.loads_s[1]["load"] == "tool"
    durations = [[p.details.stretches[k]["duration_s"] for k in (SWING, TURN)] for p in (profile, bare)]
    swing, bare_swing = torque_ratios(program, profile, SWING), torque_ratios(bare_program, bare, SWING)
    assert swing[0] == pytest.approx(1.0, abs=1e-3)          # joint 1's torque binds carrying the part
    assert bare_swing[0] < 0.99                               # without it, the acceleration limit does
    assert durations[0][0] > durations[1][0] + 5e-3
    for ratios in (torque_ratios(program, profile, TURN), torque_ratios(bare_program, bare, TURN)):
        assert np.all(ratios < 0.9)
    assert durations[0][1] == pytest.approx(durations[1][1], abs=1e-6)


def test_the_cycle_report_names_the_torque_where_it_binds_and_only_there(with_part):
    program, profile = with_part
    moves = cycle_report(program, profile)["moves"]
    assert "joint shoulder_pan torque at its limit" in moves[SWING]["binding"]
    assert "torque" not in moves[TURN]["binding"] and "torque" not in moves[0]["binding"]


def test_a_load_too_heavy_to_hold_names_the_moves_and_the_load():
    document = yaml.safe_load(JOB.read_text(encoding="utf-8"))
    document["parts"]["part"].update(mass=3.9, com=[0, 600, 190])    # within 5 kg, 0.6 m off the wrist's axis
    program = compile_job(parse_job(document, source="heavy.yaml"))
    with pytest.raises(TimingError, match=r"the moves from waypoint 2 to 3 carrying tool \+ part \(4\.9 kg\): joint 4 needs .* N m just to "
                                          r"hold the path"):
        time_program(program)
