"""retime(): certified toppra profiles, the robustness suite (tests/data/robustness.yaml), limits,
speed scale, the sample limit, the attached certificate and typed details, and bad input."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import yaml

from pipeline.errors import ConfigurationError, PipelineError, ProfileSizeError
from pipeline.files.choices import DEFAULT_PATH_SHAPE, PATH_SHAPES
from pipeline.model.robot import load_robot
from pipeline.timing import retime
from pipeline.timing.profile import CERTIFY_TOLERANCE, certify

from ..conftest import DATA_DIR

SUITE = yaml.safe_load((DATA_DIR / "robustness.yaml").read_text())
ROBOTS = {}


def robot_named(name):
    if name not in ROBOTS:
        ROBOTS[name] = load_robot(name)
    return ROBOTS[name]


def case_waypoints(case, robot):
    if "random" in case:
        spec = case["random"]
        return robot.random_configurations(np.random.default_rng(spec["seed"]), spec["count"], spec["margin"])
    return np.radians(np.array(case["waypoints"], dtype=float))


def assert_certified_from_to(profile, waypoints):
    """The profile passed certification, runs from the first to the last waypoint, rests at both ends."""
    report = certify(profile)
    assert report.passed, str(report)
    for name in ("q", "qd", "qdd", "qddd"):
        if name in report.ratios:
            assert report.max_ratio(name) <= 1 + CERTIFY_TOLERANCE
    np.testing.assert_allclose(profile.q[0], waypoints[0], atol=1e-9)
    np.testing.assert_allclose(profile.q[-1], waypoints[-1], atol=1e-9)
    np.testing.assert_allclose(profile.qd[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(profile.qd[-1], 0.0, atol=1e-9)
    assert np.all(np.diff(profile.t) > 0)


CASES = [(case, method) for case in SUITE["cases"] for method in case.get("methods", SUITE["methods"])]


@pytest.mark.parametrize("case, method", CASES, ids=[f"{c['name']}-{m}" for c, m in CASES])
def test_robustness_suite(case, method):
    robot = robot_named(case["robot"])
    waypoints = case_waypoints(case, robot)
    shape = case.get("shape", DEFAULT_PATH_SHAPE)
    if case["expect"] == "ok":
        profile = retime(robot, waypoints, method=method, shape=shape)
        assert_certified_from_to(profile, waypoints)
    else:
        with pytest.raises(PipelineError, match=case["match"]):
            retime(robot, waypoints, method=method, shape=shape)


#: The first paths of the suite each method takes (the robots take turns, so every count is a multiple of
#: their number): Ruckig ~5 ms a path takes all of them; toppra ~10-50 ms a path TOPPRA_COUNT in the
#: default run (test_timing_fuzz times thousands more in the slow run); topp3 ~0.1-0.3 s a path SLOW_COUNT in
#: the slow run only (the default run times topp3 in test_topp3 and test_timing_fuzz).
TOPPRA_COUNT = 20
SLOW_COUNT = 50
RANDOM_RUNS = [
    pytest.param(method, shape, count, id=f"{method}-{shape}-{count}",
                 marks=[pytest.mark.slow] if method in ("topp3", "ruckig") else [])
    for method, shapes in (("toppra", PATH_SHAPES), ("ruckig", ("monotone",)), ("topp3", ("monotone", "spline")))
    for shape in shapes
    for count in ({"topp3": SLOW_COUNT, "toppra": TOPPRA_COUNT}.get(method, SUITE["random_paths"]["count"]),)
]


@pytest.mark.parametrize("method, shape, count", RANDOM_RUNS)
def test_random_paths_zero_violations(method, shape, count):
    """The suite's seeded random paths over every robot: zero violations, no crashes. Random
    waypoints over 80 % of each range often make the C2 spline overshoot a limit: that is a typed
    error naming the waypoints, never a bad profile; the monotone and linear shapes never fail."""
    spec = SUITE["random_paths"]
    rng = np.random.default_rng(spec["seed"])
    robots = [robot_named(name) for name in spec["robots"]]
    failures = 0
    for k in range(count):
        robot = robots[k % len(robots)]
        waypoints = robot.random_configurations(rng, spec["waypoints"], spec["margin"])
        try:
            profile = retime(robot, waypoints, method=method, dt=0.01, shape=shape)
        except PipelineError as exc:
            assert shape == "spline" and "leaves the limits" in str(exc) and "between waypoints" in str(exc), str(exc)
            failures += 1
            continue
        assert certify(profile).passed
        np.testing.assert_allclose(profile.q[-1], waypoints[-1], atol=1e-9)
    assert failures < count * (0.8 if shape == "spline" else 1e-9)


def test_toppra_is_near_optimal_and_reports_what_it_changed():
    robot = load_robot("gp7")
    waypoints = robot.random_configurations(np.random.default_rng(3), 6, 0.2)
    profile = retime(robot, waypoints, method="toppra", dt=0.002)
    details = profile.details
    assert details.gridpoints >= 1000 and details.time_stretch >= 1.0 and details.compute_s > 0
    assert details.retried_gridpoints == () and not details.jerk_exact
    # the dense optimum (the toppra library on 10,000 points) is at most 0.3 % shorter
    from pipeline.timing.joint_path import make_path
    from pipeline.timing.toppra_backend import ScaledPath, toppra_instance

    path = make_path(waypoints, robot.limits.q_min, robot.limits.q_max)
    view = ScaledPath(path, path.length, cap=False)
    dense = toppra_instance(view, view.limits(robot.limits, 1.0), np.linspace(0.0, 1.0, 10_000))
    optimum = dense.compute_trajectory(0.0, 0.0).duration
    assert optimum <= profile.duration <= optimum * 1.003
    # at least one limit is active somewhere: a time-optimal profile saturates qd or qdd
    report = certify(profile)
    assert max(report.max_ratio("qd"), report.max_ratio("qdd")) > 0.99


@pytest.mark.parametrize("robot_name", ["gp7", "arm2_dynamics.yaml"])
def test_compiled_passes_give_toppra_libraries_answer(robot_name):
    """The compiled TOPP-RA passes on toppra's own constraint objects (joint speeds, accelerations at both
    ends of each interval; torques on the two-joint arm) give the toppra library's path speeds on its grid."""
    import toppra.algorithm
    import toppra.constraint

    from pipeline.timing.joint_path import make_path
    from pipeline.timing.reachability import canonical_rows, solve_rows
    from pipeline.timing.toppra_backend import ScaledPath, _toppra_path

    robot = load_robot(robot_name if robot_name == "gp7" else DATA_DIR / robot_name)
    waypoints = robot.random_configurations(np.random.default_rng(5), 5, 0.2)
    path = make_path(waypoints, robot.limits.q_min, robot.limits.q_max)
    view = ScaledPath(path, path.length, cap=False)
    limits = view.limits(robot.limits, 1.0)
    interpolated = toppra.constraint.DiscretizationType.Interpolation
    constraints = [toppra.constraint.JointVelocityConstraint(np.stack([-limits.qd_max, limits.qd_max], axis=1)),
                   toppra.constraint.JointAccelerationConstraint(np.stack([-limits.qdd_max, limits.qdd_max], axis=1),
                                                                 discretization_scheme=interpolated)]
    if robot_name != "gp7":
        from pipeline.model.chain.drake_model import build_drake_robot
        from pipeline.timing.toppra_backend import scaled_inverse_dynamics

        torques = scaled_inverse_dynamics(build_drake_robot(robot.spec).inverse_dynamics, view, 1.0)
        constraints.append(toppra.constraint.JointTorqueConstraint(
            torques, np.stack([-robot.limits.tau_max, robot.limits.tau_max], axis=1), np.zeros(robot.dof),
            discretization_scheme=interpolated))
    grid = np.linspace(0.0, 1.0, 301)
    _, sd_toppra, _, _ = toppra.algorithm.TOPPRA(constraints, _toppra_path(view), gridpoints=grid
                                                 ).compute_parameterization(0.0, 0.0, return_data=True)
    rows, x_lo, x_hi = [], np.zeros(len(grid)), np.full(len(grid), np.inf)
    for constraint in constraints:
        stage_rows, xbound = canonical_rows(constraint, _toppra_path(view), grid)
        rows += [stage_rows] if stage_rows is not None else []
        if xbound is not None:
            x_lo, x_hi = np.maximum(x_lo, xbound[:, 0]), np.minimum(x_hi, xbound[:, 1])
    x, failed = solve_rows(grid, *(np.hstack([r[k] for r in rows]) for k in range(3)), x_lo, x_hi)
    assert failed == -1
    np.testing.assert_allclose(np.sqrt(x), sd_toppra, rtol=1e-6, atol=1e-8 * sd_toppra.max())


def test_compiled_passes_name_the_stage_no_timing_meets():
    """A stage whose rows leave no x (here: x <= -1 at stage 3) is reported, not papered over."""
    from pipeline.timing.reachability import solve_rows

    grid = np.linspace(0.0, 1.0, 6)
    alpha, beta, gamma = np.ones((5, 2)) * [1.0, -1.0], np.zeros((5, 2)), np.ones((5, 2))
    beta[3], gamma[3] = 1.0, -1.0                                     # u + x <= -1 and -u + x <= -1: x <= -1
    x, failed = solve_rows(grid, alpha, beta, gamma, np.zeros(6), np.full(6, 10.0))
    assert x is None and failed == 3
    gamma[3] = 1.0
    x, failed = solve_rows(grid, alpha, beta, gamma, np.zeros(6), np.full(6, 10.0))
    assert failed == -1 and x[0] == x[-1] == 0.0 and np.all(x[1:-1] > 0.0)


def test_speed_scale_slows_and_custom_limits_apply():
    robot = load_robot("irb1600")
    waypoints = robot.random_configurations(np.random.default_rng(4), 4, 0.2)
    full = retime(robot, waypoints)
    half = retime(robot, waypoints, speed_scale=0.5)
    assert half.duration == pytest.approx(2 * full.duration, rel=2e-3)
    np.testing.assert_allclose(half.limits.qd_max, robot.limits.qd_max * 0.5)
    assert certify(half, robot.limits).max_ratio("qd") <= 0.5 + 1e-6


@pytest.mark.parametrize("kwargs, error", [
    ({"method": "bang-bang"}, ConfigurationError),
    ({"speed_scale": -1.0}, ConfigurationError),
    ({"speed_scale": 0.0}, ConfigurationError),
    ({"speed_scale": 1.5}, ConfigurationError),
    ({"speed_scale": float("nan")}, ConfigurationError),
    ({"dt": 0.0}, ConfigurationError),
])
def test_bad_arguments_are_typed_errors(kwargs, error):
    robot = load_robot("gp7")
    with pytest.raises(error):
        retime(robot, np.zeros((2, 6)) + [[0.0] * 6, [0.1] * 6], **kwargs)


def test_torque_limits_through_drake_inverse_dynamics():
    """A robot file with inertias and tau_max: toppra limits the torques, certify() judges them."""
    robot = load_robot(DATA_DIR / "arm2_dynamics.yaml")
    waypoints = np.radians([[-60.0, 30.0], [40.0, -50.0], [100.0, 20.0]])
    profile = retime(robot, waypoints, method="toppra", dt=0.002)
    report = certify(profile)
    assert report.passed and "tau" in report.ratios
    assert 0.98 < report.max_ratio("tau") <= 1 + CERTIFY_TOLERANCE          # the torque limit is active
    # the same path without torque limits is faster, and would exceed them
    from pipeline.files.robot_spec import Limits
    from pipeline.model.chain.drake_model import build_drake_robot

    limits = robot.limits
    free = retime(robot, waypoints, method="toppra", dt=0.002,
                  limits=Limits(limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max, None))
    assert free.duration < profile.duration
    tau_free = build_drake_robot(robot.spec).inverse_dynamics(free.q, free.qd, free.qdd)
    assert np.max(np.abs(tau_free) / limits.tau_max) > 1.05


def test_holding_torque_over_the_limit_is_a_typed_error():
    from pipeline.errors import TimingError
    from pipeline.files.robot_spec import Limits

    robot = load_robot(DATA_DIR / "arm2_dynamics.yaml")
    limits = robot.limits
    weak = Limits(limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max, None, limits.tau_max / 10)
    with pytest.raises(TimingError, match="just to hold the path"):
        retime(robot, np.radians([[0.0, 0.0], [10.0, 10.0]]), limits=weak)


@pytest.mark.parametrize("method", ["toppra", "ruckig", "topp3"])
def test_an_oversized_profile_is_refused_before_it_is_made(method):
    """speed_scale 0.001 and dt 0.1 ms: tens of millions of samples. Each back end refuses as soon as it
    knows the duration (today's measurement: 0.01-0.3 s), naming duration, dt, count and limit."""
    robot = robot_named("gp7")
    waypoints = robot.random_configurations(np.random.default_rng(1), 4, 0.2)
    with pytest.raises(ProfileSizeError) as error:
        retime(robot, waypoints, method=method, speed_scale=0.001, dt=1e-4)
    match = re.fullmatch(r"the profile.* would last ([\d.]+) s; sampled every dt = 0.0001 s that is ([\d,]+) "
                         r"samples, above the limit of 500,000: raise the limit \(--max-samples.*", str(error.value))
    assert match and float(match.group(1)) > 1000.0
    assert int(match.group(2).replace(",", "")) == pytest.approx(float(match.group(1)) / 1e-4, rel=1e-5)


@pytest.mark.parametrize("method", ["toppra", "ruckig", "topp3"])
def test_max_samples_bounds_the_sample_count(method):
    """Refused below the profile's own count; allowed from that count plus the check's round-up (2)."""
    robot = robot_named("gp7")
    waypoints = robot.random_configurations(np.random.default_rng(2), 3, 0.2)
    profile = retime(robot, waypoints, method=method, dt=0.002)
    with pytest.raises(ProfileSizeError):
        retime(robot, waypoints, method=method, dt=0.002, max_samples=len(profile.t) - 1)
    assert len(retime(robot, waypoints, method=method, dt=0.002, max_samples=len(profile.t) + 2).t) == len(profile.t)


@pytest.mark.parametrize("bad", [0, 1, -5, 2.5, True, "100"])
def test_max_samples_must_be_an_integer_of_at_least_2(bad):
    with pytest.raises(ConfigurationError, match="max_samples"):
        retime(robot_named("gp7"), [[0.0] * 6, [0.1] * 6], max_samples=bad)


@pytest.mark.parametrize("method", ["toppra", "ruckig", "topp3"])
def test_the_profile_carries_its_certificate_and_typed_details(method):
    robot = robot_named("gp7")
    profile = retime(robot, robot.random_configurations(np.random.default_rng(5), 3, 0.2), method=method)
    assert profile.certificate.passed and profile.certificate.to_dict() == certify(profile).to_dict()
    details = profile.details.to_dict()
    assert json.loads(json.dumps(details)) == {k: list(v) if isinstance(v, tuple) else v for k, v in details.items()}
    values = [x for v in details.values() for x in (v if isinstance(v, tuple) else [v])]
    assert all(isinstance(x, (bool, int, float)) for x in values), details


def sine_on_j1(count: int) -> np.ndarray:
    """``count`` arm6 waypoints (count, 6) [rad]: one period of a sine of 1 rad on J1, the other joints still,
    rounded to 1e-6 rad as a job file writes them (so near the crests the steps shrink to 1e-6 rad)."""
    waypoints = np.tile([0.0, 0.5, 0.5, 0.0, 0.5, 0.0], (count, 1))
    waypoints[:, 0] = np.round(np.sin(2.0 * np.pi * np.linspace(0.0, 1.0, count)), 6)
    return waypoints


@pytest.mark.slow
def test_a_long_joint_path_is_certified_like_a_short_one():
    """4,000 waypoints of a sine on J1, linear path (issue 39): at a crest the steps are 1e-6 rad and the
    corner blends' ends 5e-8 apart in s. The grid dropped such breakpoints (closer than MIN_GRID_GAP to the
    point before), so one grid interval held J1's reversal: toppra ran through it at full speed and the
    profile failed its certificate (q against qd between two samples: 0.0106 rad, 4.2e-5 allowed). Every
    breakpoint is a grid point now, and the profile is certified and lasts as long as 1,000 waypoints of
    the same sine take."""
    from pipeline.timing.joint_path import make_path
    from pipeline.timing.toppra_backend import GRIDPOINTS, grid_for

    robot = robot_named("arm6")
    path = make_path(sine_on_j1(4000), robot.limits.q_min, robot.limits.q_max, "linear")
    assert np.isin(path.breakpoints, grid_for(path, GRIDPOINTS)).all()
    profile = retime(robot, path)
    assert profile.certificate.passed, str(profile.certificate)
    assert profile.duration == pytest.approx(retime(robot, sine_on_j1(1000), shape="linear").duration, rel=1e-4)


@pytest.mark.parametrize("method", ["toppra", "ruckig", "topp3"])
def test_waypoints_a_hair_apart_are_no_motion(method):
    # found by the slow property run: ruckig timed a 7e-90 rad move as a zero-length profile
    robot = load_robot("arm6")
    waypoints = np.zeros((2, 6))
    waypoints[1, 5] = 7.455748874786169e-90
    with pytest.raises(PipelineError, match="same configuration"):
        retime(robot, waypoints, method=method)
