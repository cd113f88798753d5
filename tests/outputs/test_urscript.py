"""URScript programs of compiled programs (pipeline.outputs.controllers.urscript, issue 26): a UR5 job (tests/data/ur5.yaml,
UR's own DH table, so q is the controller's joint vector) with joint, linear and circular moves and a zone. Every
program parses with pipeline/outputs/controllers/grammars/urscript.lark (written from UR's Script Manual; the reader
pipeline.outputs.controllers.read_urscript uses it too); every movej goes to the program's joint values; movel/movec poses
are the program's TCP poses; the servoj replay is the certified profile at the controller's period."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.errors import OutputError
from pipeline.model.robot import Robot
from pipeline.outputs.controllers.urscript import resample, write_urscript
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job, parse_job
from pipeline.program.timing import time_program
from pipeline.runner import collision_model

lark = pytest.importorskip("lark", reason="lark (pip install lark) parses the URScript grammar")

TESTS = Path(__file__).resolve().parents[1]
GRAMMAR = TESTS.parent / "pipeline" / "outputs" / "controllers" / "grammars" / "urscript.lark"
#: Written values are rounded to 1e-6 (m, rad): half of that, and double round-off.
ROUNDING = 0.5e-6 + 1e-12
DOWN = {"rpy": [180, 0, 90]}
UR5_JOB = {
    "robot": str(TESTS / "data" / "ur5.yaml"), "length_unit": "mm", "angle_unit": "deg", "tcp_speed_max": 250,
    "tcp_accel_max": 1200, "tool": {"xyz": [0, 0, 100], "rpy": [0, 0, 0]}, "dt": 0.008, "outputs": ["json"],
    "waypoints": [
        [0, -90, 90, -90, -90, 0],
        {"joints": [30, -100, 100, -90, -90, 30], "speed": 50},                # joint move at 50 % of the limits
        {"xyz": [-303.2, -301.1, 225], "move": "linear", **DOWN},              # straight down 100 mm: stop
        {"xyz": [-403.2, -301.1, 225], "move": "linear", "zone": 20, **DOWN},
        {"xyz": [-403.2, -101.1, 225], "move": "circular", "via": {"xyz": [-453.2, -201.1, 225]}, **DOWN},
        [0, -90, 90, -90, -90, 0],
    ],
}


@pytest.fixture(scope="module")
def ur5():
    """(program, certified profile) of the UR5 job."""
    program = compile_job(parse_job(UR5_JOB, source=str(TESTS / "ur5_job.yaml")))
    return program, time_program(program)


@pytest.fixture(scope="module")
def parser():
    return lark.Lark(GRAMMAR.read_text(), parser="lalr")


def call(tree) -> tuple[str, list, dict]:
    """A parsed call as (function name, positional values, keyword values)."""
    name, arguments = tree.children
    arguments = [] if arguments is None else arguments.children
    positional = [value(a) for a in arguments if getattr(a, "data", None) != "keyword"]
    keywords = {a.children[0].value: value(a.children[1]) for a in arguments if getattr(a, "data", None) == "keyword"}
    return str(name), positional, keywords


def value(node):
    """A parsed value as Python: a number, a list of numbers, ("pose", [6 numbers]), a boolean, a name."""
    kind = node.data
    if kind == "number":
        return float(node.children[0])
    if kind == "list":
        return [value(child) for child in node.children if child is not None]
    if kind in ("numbers", "pose_numbers"):                # a list or pose of number literals: one token
        values = [float(v) for v in str(node.children[0]).lstrip("p")[1:-1].split(",")]
        return values if kind == "numbers" else ("pose", values)
    if kind == "pose":
        return ("pose", [value(child) for child in node.children[1:]])
    if kind == "boolean":
        return node.children[0].value == "True"
    return str(node.children[0])


def functions(tree) -> dict[str, dict[str, list[tuple[list, dict]]]]:
    """The calls inside each ``def`` of the program (nested defs separately), by the def's name."""
    out = {}
    for node in tree.iter_subtrees():
        if node.data in ("program", "function_def"):
            calls = out.setdefault(str(node.children[0]), {})
            for statement in node.children[-1 if node.data == "function_def" else 1].children:
                if getattr(statement, "data", None) == "expr_statement" and statement.children[0].data == "call":
                    name, positional, keywords = call(statement.children[0])
                    calls.setdefault(name, []).append((positional, keywords))
    return out


def pose_matrix(values: list[float]) -> np.ndarray:
    X = np.eye(4)
    X[:3, :3] = Rotation.from_rotvec(values[3:]).as_matrix()
    X[:3, 3] = values[:3]
    return X


def test_native_program_parses_and_movej_targets_are_the_program_joint_values(ur5, parser):
    program, _ = ur5
    calls = functions(parser.parse(write_urscript(program, "ur5_moves")))["ur5_moves"]
    movej = [args[0] for args, _ in calls["movej"]]
    expected = [program.targets[0]] + [m.target for m in program.moves if m.kind == "joint"]
    assert len(movej) == len(expected)
    for q, target in zip(movej, expected):
        assert np.abs(np.array(q) - target).max() <= ROUNDING
    assert calls["set_tcp"][0][0][0] == ("pose", [0.0, 0.0, 0.1, 0.0, 0.0, 0.0])


def test_tool_moves_are_the_program_poses_speeds_and_zones(ur5, parser):
    program, _ = ur5
    calls = functions(parser.parse(write_urscript(program, "ur5_moves")))["ur5_moves"]
    tool_moves = [m for m in program.moves if m.is_tool_move]
    written = calls["movel"] + calls["movec"]
    assert len(written) == len(tool_moves) == 3
    for move in tool_moves:
        args, keywords = calls["movec" if move.kind == "circular" else "movel"].pop(0)
        X = pose_matrix(args[-1][1])
        np.testing.assert_allclose(X[:3, 3], move.X_BT[:3, 3], atol=ROUNDING)
        np.testing.assert_allclose(X[:3, :3], move.X_BT[:3, :3], atol=4e-6)
        assert keywords["v"] == 0.25 and keywords["a"] == 1.2
        assert keywords["r"] == (0.0 if move.end in program.stops else move.zone)
        if move.kind == "circular":
            np.testing.assert_allclose(args[0][1][:3], move.via, atol=ROUNDING)
            assert keywords["mode"] == 0.0
    assert not calls["movel"] and not calls["movec"]          # every one was checked above


def test_joint_move_speed_is_its_fraction_of_the_joint_limits(ur5, parser):
    program, _ = ur5
    calls = functions(parser.parse(write_urscript(program, "ur5_moves")))["ur5_moves"]
    (_, approach), (_, half), *_, (_, full) = calls["movej"]
    assert (approach["a"], approach["v"]) == (1.4, 1.05)
    assert half["v"] == pytest.approx(0.5 * math.pi, abs=ROUNDING)           # 50 % of 180 deg/s
    assert full["v"] == pytest.approx(math.pi, abs=ROUNDING) and full["a"] == pytest.approx(math.radians(600), abs=1e-6)


@pytest.mark.parametrize("period", [0.002, 0.008])
def test_servoj_replay_is_the_certified_profile_at_the_period(ur5, parser, period):
    program, profile = ur5
    text = write_urscript(program, "ur5_replay", profile, period=period)
    defs = functions(parser.parse(text))
    servoj = defs["certified_replay"]["servoj"]
    assert len(servoj) == math.ceil(profile.duration / period - 1e-9)
    assert all(kw == {"t": period, "lookahead_time": 0.1, "gain": 300.0} for _, kw in servoj)
    Q = np.array([args[0] for args, _ in servoj])
    assert np.abs(Q[-1] - profile.q[-1]).max() <= ROUNDING
    # Where a servoj time is a profile sample time, the target is that sample.
    times = np.minimum(np.arange(1, len(Q) + 1) * period, profile.duration)
    on_sample = np.isclose(times[:, None], profile.t[None, :], atol=1e-9, rtol=0.0)
    rows, samples = np.nonzero(on_sample)
    assert len(rows) > 10
    assert np.abs(Q[rows] - profile.q[samples]).max() <= ROUNDING
    # Everywhere, the targets are within linear interpolation's error (max |qdd| dt^2 / 8) of the samples'
    # straight lines, twice that for the Hermite's own error.
    linear = np.column_stack([np.interp(times, profile.t, q) for q in profile.q.T])
    gap = np.diff(profile.t).max()
    assert np.abs(Q - linear).max() <= 2.0 * np.abs(profile.qdd).max() * gap**2 / 8.0 + ROUNDING
    assert defs["certified_replay"]["movej"][0][0][0] == pytest.approx(list(profile.q[0]), abs=ROUNDING)
    assert defs["native_moves"]["movej"] and "use_certified_replay = True" in text


def test_resample_ends_at_the_profile_end(ur5):
    _, profile = ur5
    Q = resample(profile, 0.002)
    np.testing.assert_allclose(Q[-1], profile.q[-1], atol=1e-12)


@pytest.mark.parametrize("change, match", [
    ({"name": "1bad"}, "program name"), ({"name": "end"}, "program name"), ({"period": 0.0}, "period"),
    ({"period": float("nan")}, "period"), ({"lookahead_time": 0.5}, "lookahead_time"), ({"gain": 50}, "gain"),
])
def test_bad_options_are_refused(ur5, change, match):
    program, profile = ur5
    options = {"name": "ur5_replay", "profile": profile, **change}
    with pytest.raises(OutputError, match=match):
        write_urscript(program, **options)


def test_a_profile_of_another_program_is_refused(ur5):
    profile = ur5[1]
    other = UR5_JOB | {"waypoints": [[10, -90, 90, -90, -90, 0], [30, -100, 100, -90, -90, 30]]}
    with pytest.raises(OutputError, match="not this program's profile"):
        write_urscript(compile_job(parse_job(other, source=str(TESTS / "other.yaml"))), "other", profile)


def test_an_arm_that_is_not_a_ur_one_is_refused_naming_its_maker_and_the_fix():
    """The GP7 (a yaskawa controller section) and a UR5 file without its controller section: refused."""
    gp7 = compile_job(load_job(TESTS.parent / "trajectories" / "jobs" / "gp7_pick_place.yaml"))
    with pytest.raises(OutputError, match=r"gp7: URScript runs only on .* maker yaskawa: .*controller: \{maker: ur\}"
                                          r".*--lang jbi"):
        write_urscript(gp7, "gp7")
    ur5 = compile_job(parse_job(UR5_JOB, source=str(TESTS / "ur5_job.yaml")))
    bare = dataclasses.replace(ur5, robot=Robot(dataclasses.replace(ur5.robot.spec, controller=None)))
    with pytest.raises(OutputError, match=r"ur5: .* has no controller section: .*--lang rapid/ls/jbi/krl"):
        write_urscript(bare, "ur5")


def test_grammar_rejects_what_urscript_does_not_allow(parser):
    for text in ("def a():\n  movej([0.0, 1.0)\nend\n", "def a():\n  movel(p[0.0, 1.0] a=1.2)\nend\n",
                 "def a():\nmovej([0.0])\n", "movej([0.0])\n"):
        with pytest.raises(lark.exceptions.LarkError):
            parser.parse(text)


def on_a_ur_controller(program):
    """``program`` with its robot's controller section naming the maker ur (the moves the writer makes of a
    program do not depend on the maker; the only demo job with planned moves is the GP7's)."""
    robot = program.robot
    section = dataclasses.replace(robot.spec.controller, maker="ur", X_B_base=np.eye(4), X_E_flange=np.eye(4))
    return dataclasses.replace(program, robot=Robot(dataclasses.replace(robot.spec, controller=section)))


def test_planned_moves_pass_their_vertices_with_exact_stops(parser):
    """The GP7 cell job (joint moves planned over a wall, zones of 75 mm next to them), written as if the arm were
    on a UR controller: every planner vertex is a movej with r=0, and no blend into or out of a planned move."""
    job = load_job(TESTS.parent / "trajectories" / "jobs" / "gp7_cell_pick_place.yaml")
    program = on_a_ur_controller(compile_job(job, collision_model(job)))
    calls = functions(parser.parse(write_urscript(program, "gp7_cell")))["gp7_cell"]
    expected = [program.targets[0]]
    for move in program.moves:
        if move.kind == "joint":
            expected += [*move.planned.waypoints[1:-1], move.target]
    movej = [(np.array(args[0]), kw["r"]) for args, kw in calls["movej"]]
    assert len(movej) == len(expected)
    assert all(np.abs(q - target).max() <= ROUNDING and r == 0.0 for (q, r), target in zip(movej, expected))
    assert all(kw["r"] == 0.0 for _, kw in calls["movel"])
