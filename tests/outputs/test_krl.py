"""KUKA KRL writer (pipeline.outputs.controllers.krl): the demo-style jobs as .src and .dat, parsed with a lark
grammar written from KUKA's expert programming documentation (pipeline/outputs/controllers/grammars/krl.lark), Status and Turn
equal to pipeline.model.vendors' values, and every E6POS re-solved with its S and T landing on the exported
joint values within the format's rounding (X, Y, Z to 0.001 mm, A, B, C and axis angles to 0.0001 deg)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from lark import Lark, Tree

from pipeline.model.ik import solve_ik_batch
from pipeline.model.ik.result import limit_variants
from pipeline.model.vendors import configurations, select_solution
from pipeline.model.vendors.configuration import mismatched_field
from pipeline.outputs.controllers.krl import kuka_abc, write_krl
from pipeline.outputs.controllers.lint import ControllerLintError
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job

ROOT = Path(__file__).resolve().parents[2]
GRAMMAR = Lark((ROOT / "pipeline" / "outputs" / "controllers" / "grammars" / "krl.lark").read_text(), parser="lalr")
JOBS = ("arm6_joint_rad", "gp7_pick_place", "irb1600_tool_moves", "lrmate200id_quaternion_poses")
#: Pose jobs; the LR Mate's poses are not round numbers, so their rounding shows (up to 4e-5 deg in the joints).
POSE_JOBS = ("gp7_pick_place", "irb1600_tool_moves", "lrmate200id_quaternion_poses")
#: Re-solving a pose written to 0.001 mm and 0.0001 deg lands within this of the exported joints [deg]
#: (the rounding moves the TCP by at most 0.0005 mm and 0.00005 deg per angle; on the demo jobs the joints
#: move by at most 2e-4 deg).
RESOLVE_TOL_DEG = 0.002


@pytest.fixture(scope="module")
def programs():
    return {name: compile_job(load_job(ROOT / "trajectories" / "jobs" / f"{name}.yaml")) for name in JOBS}


def krl_name(job: str) -> str:
    return job.upper()[:24]


def rotation(a: float, b: float, c: float) -> np.ndarray:
    """Rz(a) Ry(b) Rx(c) for angles [deg]: KUKA's A, B, C."""
    a, b, c = np.radians([a, b, c])
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rx = np.array([[1, 0, 0], [0, np.cos(c), -np.sin(c)], [0, np.sin(c), np.cos(c)]])
    return Rz @ Ry @ Rx


def declarations(dat: str) -> dict[str, tuple[str, dict[str, float]]]:
    """name -> (type, {component: value}) of every DECL of a .dat, read from its parse tree."""
    tree = GRAMMAR.parse(dat)
    out = {}
    for decl in tree.find_data("decl"):
        kind, name, aggregate = decl.children
        values = {str(c.children[0]).upper(): float(c.children[1].children[0]) for c in aggregate.children}
        out[str(name.children[0])] = (str(kind).upper(), values)
    return out


def pose(values: dict[str, float]) -> np.ndarray:
    X = np.eye(4)
    X[:3, :3] = rotation(values["A"], values["B"], values["C"])
    X[:3, 3] = np.array([values["X"], values["Y"], values["Z"]]) / 1000.0
    return X


def motions(src: str) -> list[Tree]:
    return [m.children[0] for m in GRAMMAR.parse(src).find_data("motion")]


@pytest.mark.parametrize("job", JOBS)
def test_src_and_dat_parse_with_the_grammar(programs, job):
    src, dat = write_krl(programs[job], krl_name(job))
    assert GRAMMAR.parse(src).children[0].data == "src"
    assert GRAMMAR.parse(dat).children[0].data == "dat"
    assert src.startswith(f"DEF {krl_name(job)}( )\n") and src.endswith("END\n")
    assert "velocity profile" in src and "BAS" in src            # the header: what differs, what is assumed


def test_grammar_refuses_what_krl_does_not_accept():
    for bad in ("DEF A( )\nPTP\nEND\n", "DEFDAT A\nDECL E6POS P={X 1 Y 2}\nENDDAT\n", "DEF A( )\nLIN P C_XYZ\nEND\n",
                "DEF ABCDEFGHIJKLMNOPQRSTUVWXY( )\nEND\n"):
        with pytest.raises(Exception):
            GRAMMAR.parse(bad)


def same_status_turn(robot, X: np.ndarray, status: int, turn: int) -> np.ndarray:
    """Every distinct in-limit IK solution and 2 pi variant (K, 6) [rad] of pose X with this KUKA S and T."""
    Q = np.array([s.q for s in solve_ik_batch(robot, X[None], method="analytic")[0].solutions])
    shifted, valid = limit_variants(Q, robot.revolute_mask, robot.limits.q_min, robot.limits.q_max)
    Q = shifted[valid]
    Q = Q[(configurations(robot, Q, "kuka") == (status, turn)).all(axis=1)]
    return np.unique(np.round(Q, 6), axis=0)


@pytest.mark.parametrize("job", POSE_JOBS)
def test_status_and_turn_are_the_controllers_values(programs, job):
    program = programs[job]
    _, dat = write_krl(program, krl_name(job))
    decl = declarations(dat)
    targets = program.targets
    written = [k for k in range(len(targets)) if decl[f"XP{k}"][0] == "E6POS"]
    assert written
    for k in written:
        values = decl[f"XP{k}"][1]                  # the joint values' own (an axis at 0 by round-off: either sign)
        assert mismatched_field(program.robot, targets[k], "kuka", (values["S"], values["T"])) is None


@pytest.mark.parametrize("job", POSE_JOBS)
def test_each_e6pos_resolved_with_its_status_and_turn_lands_on_the_exported_joints(programs, job):
    """A PTP's E6POS names its joints alone (select_solution); a LIN or CIRC target's S and T (which the
    controller ignores) are those of one of its solutions, the exported one: on the IRB 1600's axis 6 of
    +-400 deg two variants can share the sign bit."""
    program = programs[job]
    _, dat = write_krl(program, krl_name(job))
    decl = declarations(dat)
    for k, q in enumerate(program.targets):
        kind, values = decl[f"XP{k}"]
        if kind == "E6AXIS":
            np.testing.assert_allclose([values[f"A{i}"] for i in range(1, 7)], np.degrees(q), atol=0.5e-4 + 1e-9)
            continue
        X, status_turn = pose(values), (int(values["S"]), int(values["T"]))
        if k == 0 or program.moves[k - 1].kind == "joint":
            q_back = select_solution(program.robot, X, status_turn, "kuka")
            assert np.degrees(np.abs(q_back - q)).max() < RESOLVE_TOL_DEG, k
        else:
            Q = same_status_turn(program.robot, X, *status_turn)
            assert np.degrees(np.abs(Q - q).max(axis=1)).min() < RESOLVE_TOL_DEG, k


def test_an_ambiguous_ptp_target_is_written_as_axis_angles(programs):
    """The IRB 1600's start has axis 6 at -20.65 deg: -380.65 deg has the same Turn, so it is an E6AXIS."""
    program = programs["irb1600_tool_moves"]
    _, dat = write_krl(program, "IRB")
    assert declarations(dat)["XP0"][0] == "E6AXIS"
    X = program.robot.fk(program.targets[0])
    assert len(same_status_turn(program.robot, X, *configurations(program.robot, program.targets[0], "kuka"))) == 2


def test_joint_waypoints_are_e6axis_axis_angles(programs):
    program = programs["arm6_joint_rad"]
    _, dat = write_krl(program, "ARM6")
    decl = declarations(dat)
    for k, q in enumerate(program.targets):
        kind, values = decl[f"XP{k}"]
        assert kind == "E6AXIS"
        written = np.array([values[f"A{i}"] for i in range(1, 7)])
        np.testing.assert_allclose(written, np.degrees(q), atol=0.5e-4 + 1e-9)


def test_moves_speeds_and_zones(programs):
    program = programs["gp7_pick_place"]
    src, dat = write_krl(program, "GP7", generation="kss8")       # KSS 8: C_DIS on every move with a zone
    kinds = [m.data for m in motions(src)]
    assert kinds == ["ptp"] + [{"joint": "ptp", "linear": "lin", "circular": "circ"}[m.kind] for m in program.moves]
    lines = src.splitlines()
    motion_lines = [i for i, text in enumerate(lines) if text.split()[0] in ("PTP", "LIN", "CIRC")]
    for move, i in zip(program.moves, motion_lines[1:]):
        assert lines[i].split(",")[-1].split()[-1 if move.zone <= 0.0 else -2] == f"XP{move.end}"
        if move.zone > 0.0:
            assert lines[i].endswith(" C_DIS") and lines[i - 1] == f"$APO.CDIS = {move.zone * 1000:.3f}"
        else:
            assert "C_DIS" not in lines[i]
    assert "$VEL.CP = 0.500" in lines and "$ACC.CP = 2.500" in lines and "$VEL_AXIS[1] = 100" in lines
    assert "CIRC XA4, XP4 C_DIS" in lines
    assert declarations(dat)["XA4"][0] == "FRAME"


def test_joint_speeds_are_percent_of_the_axes_speed(programs):
    src, _ = write_krl(programs["arm6_joint_rad"], "ARM6")
    assert "$VEL_AXIS[6] = 60" in src.splitlines()                # speed 1.0 x speed_scale 0.6


def test_kuka_abc_is_zyx_euler():
    for a, b, c in [(10.0, 20.0, 30.0), (-170.0, 45.0, 179.0), (35.0, -80.0, -5.0)]:
        np.testing.assert_allclose(kuka_abc(rotation(a, b, c)), (a, b, c), atol=1e-9)


def test_a_name_over_24_characters_is_refused(programs):
    with pytest.raises(ControllerLintError) as error:
        write_krl(programs["gp7_pick_place"], "A" * 25)
    assert error.value.field == "name"


def test_a_zone_over_half_a_move_is_refused(programs):
    program = programs["gp7_pick_place"]
    moves = list(program.moves)
    moves[2] = dataclasses.replace(moves[2], zone=0.070)          # the 130 mm retreat
    with pytest.raises(ControllerLintError) as error:
        write_krl(dataclasses.replace(program, moves=tuple(moves)), "GP7")
    assert (error.value.move, error.value.field) == (3, "zone")


def test_a_ptp_target_with_an_axis_at_zero_is_written_as_axis_angles(programs):
    """The LR Mate's start has axis 6 at (a rounding error below) 0 deg: its Turn bit is not what the
    written pose re-solves to, so it is an E6AXIS; the next PTP target names its joints and stays an E6POS."""
    program = programs["lrmate200id_quaternion_poses"]
    decl = declarations(write_krl(program, "LRMATE")[1])
    assert abs(program.targets[0][5]) < 1e-9
    assert (decl["XP0"][0], decl["XP1"][0]) == ("E6AXIS", "E6POS")
