"""The compiled kinematics (pipeline.model.chain.compiled, used by Robot) against the NumPy oracle
(pipeline.model.chain.kinematics.DhKinematics) and Drake: presets on 10,000 random configurations, random DH
tables (standard and modified, prismatic joints, base and tool transforms), and bad inputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pipeline.errors import ConfigurationError
from pipeline.files.robot_spec import parse_robot_spec
from pipeline.model.chain.kinematics import DhKinematics
from pipeline.model.robot import Robot, load_robot

PRESETS = ["gp7", "lrmate200id", "irb1600", "arm5", "arm6"]
TOLERANCE = 1e-12


def _agree(robot: Robot, Q: np.ndarray) -> None:
    oracle = DhKinematics(robot.spec)
    np.testing.assert_allclose(robot.fk_batch(Q), oracle.fk_batch(Q), rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(robot.jacobian_batch(Q), oracle.jacobian_batch(Q), rtol=0, atol=TOLERANCE)
    for q in Q[:50]:
        np.testing.assert_allclose(robot.fk(q), oracle.fk(q), rtol=0, atol=TOLERANCE)
        np.testing.assert_allclose(robot.jacobian(q), oracle.jacobian(q), rtol=0, atol=TOLERANCE)
        X, J = robot.fk_and_jacobian(q)
        np.testing.assert_allclose(X, oracle.fk(q), rtol=0, atol=TOLERANCE)
        np.testing.assert_allclose(J, oracle.jacobian(q), rtol=0, atol=TOLERANCE)


@pytest.mark.parametrize("name", PRESETS)
def test_presets_agree_with_the_numpy_oracle_on_10000_configurations(name):
    robot = load_robot(name)
    _agree(robot, robot.random_configurations(np.random.default_rng(7), 10_000))


def random_robot(rng: np.random.Generator, convention: str) -> Robot:
    """A random chain of 2-7 joints, some prismatic, with offsets, signs, a base and a tool."""
    dof = int(rng.integers(2, 8))
    joints = []
    for i in range(dof):
        prismatic = rng.random() < 0.3
        joint = {"name": f"J{i + 1}", "a": float(rng.uniform(-0.5, 0.5)), "alpha": float(rng.uniform(-180, 180)),
                 "d": float(rng.uniform(-0.5, 0.5)), "theta_offset": float(rng.uniform(-180, 180)),
                 "sign": int(rng.choice([-1, 1])), "qd_max": 100}
        if prismatic:
            joint.update(type="prismatic", q_min=-0.3, q_max=0.4)
        else:
            joint.update(q_min=-170, q_max=170)
        joints.append(joint)
    doc = {"name": f"random_{convention}_{dof}", "convention": convention, "length_unit": "m", "angle_unit": "deg",
           "base": {"xyz": rng.uniform(-0.3, 0.3, 3).tolist(),
                    "rpy": rng.uniform(-180, 180, 3).tolist()},
           "tool": {"xyz": rng.uniform(-0.2, 0.2, 3).tolist(), "rpy": rng.uniform(-180, 180, 3).tolist()},
           "joints": joints}
    return Robot(parse_robot_spec(doc))


@pytest.mark.parametrize("convention", ["standard", pytest.param("modified", marks=pytest.mark.slow)])
def test_random_dh_tables_agree_with_the_numpy_oracle(convention):
    rng = np.random.default_rng(11 if convention == "standard" else 12)
    for _ in range(40):
        robot = random_robot(rng, convention)
        _agree(robot, robot.random_configurations(rng, 200))


def test_presets_agree_with_drake():
    from pipeline.model.chain.drake_model import build_drake_robot

    for name in PRESETS:
        robot = load_robot(name)
        drake = build_drake_robot(robot.spec)
        for q in robot.random_configurations(np.random.default_rng(3), 20):
            np.testing.assert_allclose(robot.fk(q), drake.fk(q), rtol=0, atol=TOLERANCE)
            np.testing.assert_allclose(robot.jacobian(q), drake.jacobian(q), rtol=0, atol=TOLERANCE)


@pytest.mark.parametrize("bad, message", [
    (np.zeros(5), r"shape \(6,\)"), (np.full(6, np.nan), "non-finite"), (np.full(6, 1e300), "beyond"),
    ("abc", "numbers"), ([0, 0, 0, 0, 0, 0, 0], r"shape \(6,\)"), (np.zeros((2, 6)), r"shape \(6,\)"),
])
def test_bad_configurations_get_the_typed_errors(bad, message):
    robot = load_robot("gp7")
    for call in (robot.fk, robot.jacobian, robot.fk_and_jacobian):
        with pytest.raises(ConfigurationError, match=message):
            call(bad)


def test_bad_batches_get_the_typed_errors():
    robot = load_robot("gp7")
    Q = np.zeros((3, 6))
    Q[1, 2] = np.inf
    for call in (robot.fk_batch, robot.jacobian_batch):
        with pytest.raises(ConfigurationError, match="non-finite"):
            call(Q)
        with pytest.raises(ConfigurationError, match=r"shape \(N, 6\)"):
            call(np.zeros((3, 5)))


def test_lists_integers_and_strided_arrays_are_accepted():
    robot = load_robot("gp7")
    wide = np.zeros((6, 2))
    np.testing.assert_allclose(robot.fk([0, 0, 0, 0, 0, 0]), robot.fk(np.zeros(6, dtype=int)), atol=0)
    np.testing.assert_allclose(robot.fk(wide[:, 0]), robot.fk(np.zeros(6)), atol=0)


# -- the compiled closed form (pipeline.model.ik.closed_form) -------------------------------------------------------
def test_the_closed_form_accepts_solutions_exactly_on_a_limit():
    """U at exactly -70 deg (its lower limit): limits are inclusive."""
    robot = load_robot("gp7")
    rng = np.random.default_rng(4)
    for q in robot.random_configurations(rng, 200):
        q[2] = robot.limits.q_min[2]
        result = robot.ik(robot.fk(q), robot.random_configurations(rng, 1)[0], method="analytic")
        assert result.success, result.reason
        assert min(np.abs(s.q - q).max() for s in result.solutions) < 1e-6


def shoulder_singular_configuration(robot):
    """A configuration of arm6 whose wrist centre lies on axis 1 (q1 = 2 rad is then free)."""
    from scipy.optimize import brentq

    from pipeline.model.ik import closed_form
    from pipeline.model.ik.analytic import analytic_solver_for

    solver = analytic_solver_for(robot)

    def reach(q3):
        X = robot.fk(np.array([2.0, -1.5, q3, 0.0, 1.0, 0.0]))
        return np.array(closed_form.wrist_centre(solver.geometry, X))[:2] @ [np.cos(2.0), np.sin(2.0)]

    return np.array([2.0, -1.5, brentq(reach, -2.0, -1.2), 0.0, 1.0, 0.0])


def test_at_a_shoulder_singularity_the_closed_form_tries_the_q1_values_the_limits_allow():
    robot = load_robot("arm6")
    q = shoulder_singular_configuration(robot)
    X = robot.fk(q)
    for seed in (None, np.zeros(6), np.array([-2.5, 0, 0, 0, 0, 0])):
        result = robot.ik(X, seed, method="analytic")
        assert result.success, result.reason
        q1_values = {round(s.q[0], 6) for s in result.solutions}
        assert len(q1_values) > 10
        for solution in result.solutions[:20]:
            assert np.abs(robot.fk(solution.q) - X).max() < 1e-9


def with_position_limits(robot: Robot, q_min: np.ndarray, q_max: np.ndarray) -> Robot:
    """The robot with other position limits [rad]."""
    joints = tuple(dataclasses.replace(j, q_min=float(lo), q_max=float(hi))
                   for j, lo, hi in zip(robot.spec.joints, q_min, q_max))
    return Robot(dataclasses.replace(robot.spec, joints=joints))


def test_the_failure_reason_gives_the_true_smallest_violation_and_counts_joints():
    from pipeline.model.ik.analytic import analytic_solver_for

    robot = load_robot("gp7")
    X = robot.fk(np.radians([10, 30, 20, 40, 50, 60]))
    free = with_position_limits(robot, np.full(6, -np.pi), np.full(6, np.pi))
    branches = np.array([s.q for s in free.ik(X, method="analytic").solutions])
    window = np.radians(-60.0)                               # L only in [-60, -59] deg: no branch has it
    assert np.abs(branches[:, 1] - window).min() > 0.2
    q_min, q_max = robot.limits.q_min.copy(), robot.limits.q_max.copy()
    q_min[1], q_max[1] = window, window + np.radians(1.0)
    narrowed = with_position_limits(robot, q_min, q_max)
    result = narrowed.ik(X, method="analytic")
    assert not result.success
    reported = float(result.reason.split(" by ")[1].split(" rad")[0])
    below, above = q_min - branches, branches - q_max                # no 2 pi shift helps within [-pi, pi]
    expected = np.maximum(np.maximum(below, above), 0.0).max(axis=1).min()
    assert reported == pytest.approx(expected, rel=1e-3)
    assert "has 5 joints" in analytic_solver_for(load_robot("arm5")).reason


def test_very_wide_limits_give_one_representative_and_bounded_memory():
    """+-1e6 rad on every joint: one 2 pi variant per branch (nearest the seed), counted not listed."""
    import tracemalloc

    huge = with_position_limits(load_robot("arm6"), np.full(6, -1e6), np.full(6, 1e6))
    q = np.array([0.3, -0.4, 0.5, 0.6, 0.7, 0.8])
    seed = q + 2.0 * np.pi * np.array([3, 0, -2, 5, 1, -7]) + 0.01
    tracemalloc.start()
    result = huge.ik(huge.fk(q), seed, method="analytic")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert result.success and len(result.solutions) <= 8 and peak < 5e6
    assert np.abs(result.q - (q + 2.0 * np.pi * np.array([3, 0, -2, 5, 1, -7]))).max() < 1e-6
    assert result.solutions.variants[0] > 1e30
    gp7 = load_robot("gp7")                     # narrower joints: every variant listed, and counted as listed
    listed = gp7.ik(gp7.fk(q), method="analytic").solutions
    labels = [solution.branch for solution in listed]
    assert len(listed) > 8 and listed.variants == [labels.count(label) for label in labels]


def test_ik_without_a_seed_works_with_continuous_joints():
    """The default seed is the middle of each range, 0 for a continuous joint (not inf - inf)."""
    robot = load_robot("arm6")
    joints = tuple(dataclasses.replace(j, q_min=-np.inf, q_max=np.inf) if i in (3, 5) else j
                   for i, j in enumerate(robot.spec.joints))
    endless = Robot(dataclasses.replace(robot.spec, joints=joints))
    X = endless.fk(np.array([0.3, -0.4, 0.5, 0.6, 0.7, 0.8]))
    for method in ("analytic", "jacobian", "auto"):
        result = endless.ik(X, method=method)
        assert result.success, (method, result.reason)
        assert np.all(np.isfinite(result.q))


def _sincos_errors(angles: np.ndarray) -> tuple[float, float]:
    from numba import njit

    from pipeline.model.chain.compiled import sincos

    @njit
    def errors(angles):
        worst_sin = worst_cos = 0.0
        for angle in angles:
            s, c = sincos(angle)
            worst_sin = max(worst_sin, abs(s - np.sin(angle)))
            worst_cos = max(worst_cos, abs(c - np.cos(angle)))
        return worst_sin, worst_cos

    return errors(angles)


@pytest.mark.parametrize("scale", [1.0, 4.0, 100.0, 1e5, 1e6, 1e9])
def test_sincos_is_within_one_ulp_of_the_c_library(scale):
    """Our fdlibm sincos against math.sin / math.cos: random angles, exact multiples of pi/4 (where the
    reduction cancels most) and their neighbours, beyond SINCOS_RANGE too (the C library takes over)."""
    rng = np.random.default_rng(11)
    quarter_turns = np.arange(-4000, 4001) * np.pi / 4 * (scale / 1e3)
    angles = np.concatenate([rng.uniform(-scale, scale, 200_000), quarter_turns, np.nextafter(quarter_turns, np.inf),
                             [0.0, -0.0, 5e-324, np.pi / 4, -np.pi / 4]])
    assert max(_sincos_errors(angles)) <= np.finfo(float).eps / 2


def test_sincos_of_nan_and_infinity_is_nan():
    from numba import njit

    from pipeline.model.chain.compiled import sincos

    @njit
    def of(angle):
        return sincos(angle)

    for angle in (np.nan, np.inf, -np.inf):
        assert all(np.isnan(value) for value in of(angle))


# -- array layouts and what compiles (issue 39) ------------------------------------------------------------------------
def test_a_fortran_ordered_pose_takes_the_compiled_fast_path_with_the_same_answer(monkeypatch):
    """A pose from Drake's GetAsMatrix4() is Fortran-ordered: the closed form's kernel takes it as it is (one
    specialisation, no re-typing), not the checked slow path."""
    import pipeline.model.ik as ik
    from pipeline.model.ik import closed_form

    robot = load_robot("gp7")
    rng = np.random.default_rng(5)
    poses = robot.fk_batch(robot.random_configurations(rng, 20))
    expected = [robot.ik(X) for X in poses]

    def slow_path(*args, **kws):
        raise AssertionError("the pose went to the checked slow path")

    monkeypatch.setattr(ik, "make_target", slow_path)
    for X, result in zip(poses, expected):
        fortran = np.asfortranarray(X)
        assert not fortran.flags.c_contiguous
        answer = robot.ik(fortran)
        assert answer.success and np.array_equal(answer.q, result.q)
        assert [s.q.tolist() for s in answer.solutions] == [s.q.tolist() for s in result.solutions]
    assert len(closed_form.solve_one.overloads) == _just_in_time_specialisations()


def _just_in_time_specialisations() -> int:
    """How many specialisations an IK kernel Python has called gets: none while the prebuilt ones serve, else one."""
    from pipeline.model.ik.prebuilt import prebuilt_status

    return 0 if prebuilt_status().module is not None else 1


def test_fk_and_the_jacobian_take_strided_joint_vectors_as_they_are(monkeypatch):
    """Strided and Fortran-ordered joint values enter the compiled kernels without a copy (no ``_checked``), one
    specialisation each, with the answers of C-ordered ones."""
    from pipeline.model.chain import compiled

    robot = load_robot("gp7")
    Q = robot.random_configurations(np.random.default_rng(6), 20)
    expected = [(robot.fk(q), robot.jacobian(q), *robot.fk_and_jacobian(q)) for q in Q]
    expected_batches = robot.fk_batch(Q), robot.jacobian_batch(Q)

    def copy(*args, **kws):
        raise AssertionError("the joint values were copied before the kernel took them")

    monkeypatch.setattr(Robot, "_checked", copy)
    strided = np.asfortranarray(Q)
    for q, (X, J, X_both, J_both) in zip(strided, expected):
        assert not q.flags.c_contiguous
        assert np.array_equal(robot.fk(q), X) and np.array_equal(robot.jacobian(q), J)
        assert all(np.array_equal(a, b) for a, b in zip(robot.fk_and_jacobian(q), (X_both, J_both)))
    assert np.array_equal(robot.fk_batch(strided), expected_batches[0])
    assert np.array_equal(robot.jacobian_batch(strided), expected_batches[1])
    for kernel in (compiled.fk_into, compiled.jacobian_into, compiled.fk_and_jacobian_into, compiled.fk_batch_into,
                   compiled.jacobian_batch_into):
        assert len(kernel.overloads) == 1, kernel


def test_damped_least_squares_takes_any_layout_and_read_only_arrays_in_one_specialisation():
    from pipeline.model.ik import descent

    robot = load_robot("gp7")
    rng = np.random.default_rng(8)
    poses = robot.fk_batch(robot.random_configurations(rng, 5))
    seeds = robot.random_configurations(rng, 5)
    for X, seed in zip(poses, seeds):
        expected = robot.ik(X, seed, method="jacobian")
        read_only = seed.copy()
        read_only.flags.writeable = False
        answer = robot.ik(np.asfortranarray(X), read_only, method="jacobian")
        assert answer.success and np.array_equal(answer.q, expected.q)
    assert len(descent.descend.overloads) == _just_in_time_specialisations()


def test_inner_functions_refuse_python_calls():
    """A function compiled for kernels only has no entry point for Python: a TypeError, not a crash."""
    from pipeline.model.chain import compiled

    with pytest.raises(TypeError, match="compiled for kernels only"):
        compiled.cross((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


#: Which kernels a fresh process has compiled (or loaded from its cache), as JSON: after importing the IK, and
#: (argument "ik") after load_robot('gp7') and one robot.ik(pose), with the specialisations of some functions the
#: closed form calls.
_COMPILED_SCRIPT = """
import json, sys
import numpy as np
from pipeline.model.chain import compiled
from pipeline.model.ik import closed_form, descent, three_parallel
from pipeline import load_robot

kernels = {"fk_into": compiled.fk_into, "fk_batch_into": compiled.fk_batch_into,
           "jacobian_into": compiled.jacobian_into, "jacobian_batch_into": compiled.jacobian_batch_into,
           "fk_and_jacobian_into": compiled.fk_and_jacobian_into, "solve_one": closed_form.solve_one,
           "solve_batch": closed_form.solve_batch, "ur_solve_one": three_parallel.solve_one,
           "ur_solve_batch": three_parallel.solve_batch, "descend": descent.descend}
inner = {"relative": compiled._relative, "moved": compiled._moved, "write_variants": closed_form._write_variants,
         "sort_distinct": closed_form._sort_distinct, "finish": closed_form.finish}
report = {"imported": {name: len(kernel.overloads) for name, kernel in kernels.items()}}
if sys.argv[1:] == ["ik"]:
    X = np.array([[0.0, 0.0, 1.0, 0.5], [0.0, 1.0, 0.0, 0.1], [-1.0, 0.0, 0.0, 0.4], [0.0, 0.0, 0.0, 1.0]])
    assert load_robot("gp7").ik(X).success
    report["after_ik"] = {name: len(kernel.overloads) for name, kernel in kernels.items()}
    report["inner"] = {name: len(function.overloads) for name, function in inner.items()}
print(json.dumps(report))
"""


def _compiled_in_a_fresh_process(cache, *arguments: str) -> dict:
    import json
    import os
    import subprocess
    import sys

    from pipeline.model.ik.prebuilt import SWITCH

    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PIPELINE_PROGRESS": "0", SWITCH: "0"}   # just in time
    done = subprocess.run([sys.executable, "-c", _COMPILED_SCRIPT, *arguments], env=env, capture_output=True,
                          text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_importing_the_kinematics_and_ik_compiles_nothing(tmp_path):
    """No kernel compiles (or loads from the cache) on import: only when a call needs it."""
    assert set(_compiled_in_a_fresh_process(tmp_path)["imported"].values()) == {0}


@pytest.mark.slow
def test_the_first_closed_form_call_compiles_only_the_kernel_it_uses(tmp_path):
    """The first IK call of a GP7 (an empty Numba cache) compiles the spherical wrist's single-call kernel, once,
    and none of FK, the batches, the UR family's or damped least squares'; its helpers once each (a constant
    argument is no specialisation of its own). A second process loads the kernel from the cache."""
    first = _compiled_in_a_fresh_process(tmp_path, "ik")
    assert {name for name, count in first["after_ik"].items() if count} == {"solve_one"}
    assert first["after_ik"]["solve_one"] == 1
    assert set(first["inner"].values()) == {1}
    cached = _compiled_in_a_fresh_process(tmp_path, "ik")
    assert cached["after_ik"] == first["after_ik"] and set(cached["inner"].values()) == {0}
