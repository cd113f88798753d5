"""Zones capped by both neighbouring moves, as a controller shrinks them (``compile.with_capped_zones``): a
zone next to a move of no length rounds nothing, zones that take half of the same move meet in its middle,
and ``run`` and ``program`` time and write the same zones."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.outputs.controllers.lint import LANGUAGES, lint
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job
from pipeline.program.timing import time_program

from .test_job_moves import gp7_job

ROOT = Path(__file__).resolve().parents[2]
#: How close the sampled profile comes to a waypoint it passes exactly [rad] (the samples' spacing).
PASSED_RAD = 1e-3


def closest_approach(profile, q: np.ndarray) -> float:
    return float(np.abs(profile.q - q).max(axis=1).min())


def test_a_zone_between_moves_of_no_length_rounds_nothing(caplog):
    """Three waypoints at the same joint values, the middle one with zone: 100 (mm): the path passed the two
    around it 3.8 deg off, silently (the zone took half of the move before them)."""
    same = [30, 10, 0, 0, -90, 0]
    job = parse_job(gp7_job([[0, 0, 0, 0, -90, 0], same, {"joints": same, "zone": 100}, same,
                             [0, 0, 0, 0, -90, 0]], tcp_speed_max=None))
    with caplog.at_level(logging.WARNING):
        program = compile_job(job)
    assert [m.zone for m in program.moves] == [0.0, 0.0, 0.0, 0.0]
    assert "waypoints[2].zone: zone 100 mm is more than half of a neighbouring move (0 mm long)" in caplog.text
    profile = time_program(program)
    assert closest_approach(profile, np.radians(same)) < PASSED_RAD


def test_zones_that_take_half_of_a_move_each_meet_in_its_middle():
    """150 mm zones on every corner of the IRB 1600 demo rectangle (300 mm sides): the zones of each side meet
    (an internal error, 'x must be strictly increasing', before), timed and certified, and every language
    writes them as timed."""
    document = yaml.safe_load((ROOT / "trajectories" / "jobs" / "irb1600_tool_moves.yaml").read_text())
    for waypoint in document["waypoints"][1:5]:
        waypoint["zone"] = 150
    job = parse_job(document, name="rectangle")
    program = compile_job(job)
    assert [m.zone for m in program.moves[:4]] == pytest.approx([0.15] * 4)
    assert time_program(program).certificate.passed
    for language in LANGUAGES:
        lint(program, language, "RECT")


def test_a_zone_larger_than_its_move_is_shrunk_in_run_and_program_alike(caplog):
    """A 200 mm zone between a 130 mm move and the next is 65 mm in the program (it passed run at 200 mm and
    was refused by program)."""
    document = yaml.safe_load((ROOT / "trajectories" / "jobs" / "gp7_pick_place.yaml").read_text())
    document["waypoints"][3]["zone"] = 200                 # the retreat (130 mm) into the arc
    job = parse_job(document, name="big_zone")
    with caplog.at_level(logging.WARNING):
        program = compile_job(job)
    assert program.moves[2].zone == pytest.approx(0.065)
    assert "waypoints[3].zone: zone 200 mm is more than half of a neighbouring move (130 mm long)" in caplog.text
    for language in LANGUAGES:
        lint(program, language, "BIGZONE")
