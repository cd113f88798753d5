"""Lint rules every controller writer applies before writing (pipeline.outputs.controllers.lint): each rule refuses
a crafted bad program with a ControllerLintError naming the move, the field and the value, and the demo
jobs pass in every language."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import OutputError, PipelineError
from pipeline.model.vendors import configurations
from pipeline.outputs.controllers.lint import (
    JBI,
    KRL,
    LANGUAGES,
    LIMITS,
    RAPID,
    URSCRIPT,
    ControllerLintError,
    check_points,
    lint,
    move_lengths,
    written_speed,
)
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job

ROOT = Path(__file__).resolve().parents[2]
JOBS = ("arm6_joint_rad", "gp7_pick_place", "irb1600_tool_moves")
FANUC_LS = "ls"


@pytest.fixture(scope="module")
def programs():
    return {name: compile_job(load_job(ROOT / "trajectories" / "jobs" / f"{name}.yaml")) for name in JOBS}


def with_move(program, index: int, **changes):
    """The program with move ``index`` changed (dataclasses.replace)."""
    moves = list(program.moves)
    moves[index] = dataclasses.replace(moves[index], **changes)
    return dataclasses.replace(program, moves=tuple(moves))


def configs(program, language):
    vendor = LIMITS[language].vendor
    return None if vendor is None else configurations(program.robot, program.targets, vendor)


@pytest.mark.parametrize("language", LANGUAGES)
@pytest.mark.parametrize("job", JOBS)
def test_the_demo_jobs_pass_in_every_language(programs, job, language):
    program = programs[job]
    lint(program, language, "DEMO1", ["a comment of at most 32 chars"], configs(program, language))


def test_every_language_states_its_limits_and_sources():
    for language in LANGUAGES:
        limits = LIMITS[language]
        assert limits.sources and limits.joint_speed.source and limits.tool_speed.source
    assert (LIMITS[RAPID].name_max, LIMITS[JBI].name_max, LIMITS[KRL].name_max, LIMITS[URSCRIPT].name_max) == \
        (32, 8, 24, None)
    assert LIMITS[JBI].comment_max == 32


def test_an_unknown_language_is_refused(programs):
    with pytest.raises(ControllerLintError) as error:
        lint(programs["gp7_pick_place"], "gcode")
    assert error.value.field == "language"


@pytest.mark.parametrize("language, name", [(RAPID, "M" * 33), (JBI, "JOB123456"), (KRL, "K" * 25),
                                            (FANUC_LS, "F" * 9), (KRL, "1ABC"), (RAPID, "my-module"),
                                            (FANUC_LS, "lower")])
def test_names_beyond_the_language_are_refused(programs, language, name):
    with pytest.raises(ControllerLintError) as error:
        lint(programs["gp7_pick_place"], language, name)
    assert (error.value.move, error.value.field, error.value.value) == (None, "name", name)
    assert isinstance(error.value, OutputError) and isinstance(error.value, PipelineError)


def test_names_at_the_limit_pass(programs):
    program = programs["gp7_pick_place"]
    for language, name in [(RAPID, "M" * 32), (JBI, "JOB12345"), (KRL, "K" * 24), (URSCRIPT, "u" * 200)]:
        lint(program, language, name)


def test_comments_beyond_the_language_are_refused(programs):
    program = programs["gp7_pick_place"]
    with pytest.raises(ControllerLintError) as error:
        lint(program, JBI, "GP7", ["c" * 33])
    assert error.value.field == "comment"
    lint(program, JBI, "GP7", ["c" * 32])
    lint(program, KRL, "GP7", ["c" * 500])
    with pytest.raises(ControllerLintError, match="line break"):
        lint(program, KRL, "GP7", ["two\nlines"])


@pytest.mark.parametrize("language, repeat, limit", [(FANUC_LS, 1429, 9999), (JBI, 14286, 100000)])
def test_too_many_points_per_file_are_refused(programs, language, repeat, limit):
    program = programs["gp7_pick_place"]
    many = dataclasses.replace(program, moves=program.moves * repeat)        # 1 + 7 x repeat targets
    assert 1 + 7 * repeat > limit
    with pytest.raises(ControllerLintError) as error:
        lint(many, language, "GP7")
    assert (error.value.move, error.value.field, error.value.value) == (None, "points", 1 + 7 * repeat)
    check_points(language, limit)                                            # the limit itself passes


def test_a_zone_over_half_of_either_neighbouring_move_is_refused(programs):
    program = programs["gp7_pick_place"]
    lengths = move_lengths(program)
    np.testing.assert_allclose(lengths[[1, 2]], [0.130, 0.130], atol=1e-9)     # the pick's approach and retreat
    # move 3 (index 2) ends where the arc begins: half of the 130 mm retreat is the bound
    with pytest.raises(ControllerLintError) as error:
        lint(with_move(program, 2, zone=0.0651), KRL, "GP7")
    assert (error.value.move, error.value.field, error.value.value) == (3, "zone", 0.0651)
    lint(with_move(program, 2, zone=0.065), KRL, "GP7")
    # the next move's length counts too: a zone at the end of the arc before the 130 mm place approach
    with pytest.raises(ControllerLintError) as error:
        lint(with_move(program, 3, zone=0.0651), KRL, "GP7")
    assert (error.value.move, error.value.field) == (4, "zone")


def test_the_arc_length_counts_for_a_circular_move(programs):
    program = programs["irb1600_tool_moves"]
    lengths = move_lengths(program)
    chord = np.linalg.norm(program.moves[4].X_BT[:3, 3] - program.moves[3].X_BT[:3, 3])
    assert lengths[4] > chord


@pytest.mark.parametrize("language, speed", [(KRL, 0.004), (FANUC_LS, 0.004), (JBI, 0.00004), (KRL, 1.5)])
def test_joint_speeds_outside_the_written_percentage_are_refused(programs, language, speed):
    program = programs["gp7_pick_place"]                          # move 1 (index 0) is a joint move
    with pytest.raises(ControllerLintError) as error:
        lint(with_move(program, 0, speed=speed), language, "GP7")
    assert (error.value.move, error.value.field, error.value.value) == (1, "speed", speed)


@pytest.mark.parametrize("language, speed", [(FANUC_LS, 2.5), (JBI, 1.6), (JBI, 0.00001)])
def test_tool_speeds_outside_the_language_are_refused(programs, language, speed):
    program = programs["gp7_pick_place"]                          # move 2 (index 1) is a linear move
    with pytest.raises(ControllerLintError) as error:
        lint(with_move(program, 1, speed=speed), language, "GP7")
    assert (error.value.move, error.value.field) == (2, "speed")


@pytest.mark.parametrize("language", [RAPID, FANUC_LS, JBI, KRL, URSCRIPT])
def test_tool_moves_faster_than_the_jobs_tcp_speed_limit_are_written_at_it(programs, language):
    """A job's tcp_speed_limit (a safety-rated reduced speed) caps its 500 mm/s tool moves: the timing runs them
    at the limit, and so does every written program (it was refused as above "the robot's TCP speed limit")."""
    program = programs["gp7_pick_place"]
    limited = dataclasses.replace(program, limits=dataclasses.replace(program.limits, tcp_speed_max=0.3))
    lint(limited, language, "GP7")
    tool_moves = [m for m in limited.moves if m.is_tool_move]
    assert tool_moves and all(m.speed == 0.5 and limited.tool_speed(m) == 0.3 for m in tool_moves)
    value, speed = written_speed(language, limited, tool_moves[0])
    assert value == pytest.approx(0.3 * speed.per_si, abs=speed.step)


@pytest.mark.parametrize("language", [RAPID, FANUC_LS, JBI, KRL])
def test_a_configuration_other_than_the_joint_values_is_refused(programs, language):
    program = programs["gp7_pick_place"]
    written = configs(program, language).copy()
    written[3, 1] = 1 - written[3, 1] if language != RAPID else written[3, 1] + 1
    with pytest.raises(ControllerLintError) as error:
        lint(program, language, "GP7", configs=written)
    field = {RAPID: "cf4", FANUC_LS: "up", JBI: "m", KRL: "T"}[language]
    assert (error.value.move, error.value.field, error.value.value) == (3, field, int(written[3, 1]))


def test_a_configuration_of_the_wrong_size_is_refused(programs):
    program = programs["gp7_pick_place"]
    with pytest.raises(ControllerLintError) as error:
        lint(program, KRL, "GP7", configs=np.zeros((3, 2), int))
    assert error.value.field == "configuration"


def test_an_axis_on_a_quadrant_boundary_may_be_written_on_either_side(programs):
    """Axis 4 at -1e-12 rad (round-off of a track that ends at 0): confdata cf4 = -1 by floor, 0 as its
    written pose selects; both pass, cf4 = 1 does not."""
    program = programs["gp7_pick_place"]
    target = program.moves[2].target.copy()
    target[3] = -1e-12
    moved = with_move(program, 2, target=target)
    written = configurations(moved.robot, moved.targets, "abb")
    assert written[3, 1] == -1
    lint(moved, RAPID, "GP7", configs=written)
    written[3, 1] = 0
    lint(moved, RAPID, "GP7", configs=written)
    written[3, 1] = 1
    with pytest.raises(ControllerLintError):
        lint(moved, RAPID, "GP7", configs=written)
