"""The runner: every demo job against its golden profile, IK continuity, the outputs, and nothing
written when a step fails. ``pytest --regen-golden`` rewrites tests/golden/ from the demo jobs."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import pipeline.outputs.plots
from pipeline.__main__ import main
from pipeline.errors import JobFileError
from pipeline.files.atomic import OWNER_MARKER
from pipeline.outputs.formats import profile_columns
from pipeline.program.compile import solve_waypoints
from pipeline.program.job import load_job, parse_job
from pipeline.runner import FILE_NAMES, run_job, run_job_file
from pipeline.timing.topp3_backend import SOLVER_GAP

ROOT = Path(__file__).resolve().parent.parent
JOB_FILES = sorted((ROOT / "trajectories" / "jobs").glob("*.yaml"))
GOLDEN_DIR = Path(__file__).resolve().parent / "golden"
#: Golden files keep every GOLDEN_STRIDE-th sample (more when that would exceed GOLDEN_MAX_SAMPLES) and the last.
GOLDEN_STRIDE = 10
GOLDEN_MAX_SAMPLES = 500
#: How far a rerun of a demo job may be from its golden on any CPU, BLAS kernel or compiler: the relative
#: error of the path speed sd(s), per timing method. topp3 (copp's TOPP3) stops Clarabel at a relative duality
#: gap SOLVER_GAP (its tol_gap_rel); where the objective grows quadratically away from its optimum (copp's
#: total-variation smoothing term) a gap eps leaves the solution sqrt(eps) from it [1]. toppra's compiled
#: passes and Ruckig's closed form are exact to round-off (measured 1e-10): they keep 1e-4.
PATH_SPEED_RTOL = {"topp3": math.sqrt(SOLVER_GAP)}
EXACT_PATH_SPEED_RTOL = 1e-4
#: Compared at the same share of the duration (t / T, so a uniform slow-down moves no sample): the duration,
#: the integral of ds / sd, inherits sd's relative error; qd = q'(s) sd is off by that share of qd_max; q(s)
#: by the path that error covers in the whole profile, rtol x qd_max x T [rad]; qdd = q' sdd + q'' sd^2 with
#: sdd the slope of sd^2 / 2 between stations, so sd's error is divided by the station spacing: amplified up
#: to QDD_AMPLIFICATION times, a share of qdd_max [1].
QDD_AMPLIFICATION = 60
RATIO_LIMIT = 1.0 + 1e-6


def golden_indices(count: int) -> np.ndarray:
    stride = max(GOLDEN_STRIDE, math.ceil(count / (GOLDEN_MAX_SAMPLES - 1)))
    return np.unique(np.append(np.arange(0, count, stride), count - 1))


def write_golden(path: Path, profile) -> None:
    keep = golden_indices(len(profile.t))
    np.savez(path, duration=profile.duration, method=profile.method, t=profile.t[keep],
             q=profile.q[keep], qd=profile.qd[keep], qdd=profile.qdd[keep])


def resample(t_new: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t_new, t, values[:, j]) for j in range(values.shape[1])])


def golden_mismatches(profile, golden, limit_values: dict) -> list[str]:
    """What of ``profile`` (``t``, ``q``, ``qd``, ``qdd`` [s, rad, rad/s, rad/s^2], ``duration``,
    ``method``) is out of tolerance of ``golden`` (a loaded golden file): the method, the duration, and
    q, qd, qdd on the golden's samples at the same share of the duration. ``limit_values``: the report's
    timed limits (``qd_max``, ``qdd_max``) [SI]. Empty when the profile matches its golden."""
    golden_duration = float(golden["duration"])
    if str(golden["method"]) != profile.method:
        return [f"method {profile.method}, golden {golden['method']}"]
    rtol = PATH_SPEED_RTOL.get(profile.method, EXACT_PATH_SPEED_RTOL)
    mismatches = []
    if abs(profile.duration / golden_duration - 1.0) > rtol:
        mismatches.append(f"duration {profile.duration:.9g} s, golden {golden_duration:.9g} s "
                          f"(relative tolerance {rtol:g})")
    qd_max, qdd_max = (np.asarray(limit_values[name], dtype=float) for name in ("qd_max", "qdd_max"))
    t = golden["t"] * (profile.duration / golden_duration)
    allowed = {"q": rtol * qd_max * profile.duration, "qd": rtol * qd_max, "qdd": QDD_AMPLIFICATION * rtol * qdd_max}
    for name, tolerance in allowed.items():
        excess = np.abs(resample(t, profile.t, getattr(profile, name)) - golden[name]) / tolerance
        k, j = np.unravel_index(np.argmax(excess), excess.shape)
        if excess[k, j] > 1.0:
            mismatches.append(f"{name} of joint {j + 1} at t = {golden['t'][k]:.3f} s is {excess[k, j]:.3g} x "
                              f"its tolerance {tolerance[j]:.3g} from the golden")
    return mismatches


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    """``demo_run(stem)``: (JobOutcome, output directory) of the demo job ``stem`` run once per module
    with every output it names."""
    runs = {}

    def run(stem: str):
        if stem not in runs:
            out = tmp_path_factory.mktemp(stem) / stem
            runs[stem] = run_job_file(ROOT / "trajectories" / "jobs" / f"{stem}.yaml", out), out
        return runs[stem]

    return run


#: The golden run by ``make test``; the others run in the slow run and ``make test-kernels`` (CI), to keep ``make test``
#: within its time.
FAST_GOLDEN = "gp7_pick_place"


@pytest.mark.parametrize("job_file", [p if p.stem == FAST_GOLDEN else pytest.param(p, marks=pytest.mark.slow)
                                      for p in JOB_FILES], ids=lambda p: p.stem)
def test_demo_job_matches_its_golden_profile(job_file, regen_golden, demo_run):
    """Every demo job, planned ones too (a plan is the same in any process), against its golden."""
    outcome, _ = demo_run(job_file.stem)
    profile, report = outcome.profile, outcome.report
    certificate = outcome.limit_report
    assert certificate.passed and all(certificate.max_ratio(name) <= RATIO_LIMIT for name in certificate.ratios)
    assert certificate.clearance is None or certificate.clearance.passed
    np.testing.assert_allclose(profile.qd[[0, -1]], 0.0, atol=1e-9)           # at rest at both ends
    golden_path = GOLDEN_DIR / f"{job_file.stem}.npz"
    if regen_golden:
        GOLDEN_DIR.mkdir(exist_ok=True)
        write_golden(golden_path, profile)
    assert golden_path.is_file(), f"no golden profile for {job_file.name}: run pytest --regen-golden"
    with np.load(golden_path) as golden:
        assert golden_mismatches(profile, golden, report["limits"]["timed"]["values"]) == []


def _arm5_spline_mismatches(tmp_path: Path, joint_speed_share: float = 1.0, **job_changes) -> list[str]:
    """golden_mismatches of the arm5_joint_spline demo job (its report only) run with joint 1's qd_max
    times ``joint_speed_share`` (a copy of the arm5 robot file) and ``job_changes`` to the job file."""
    robot = yaml.safe_load((ROOT / "models" / "arm5.yaml").read_text())
    robot["joints"][0]["qd_max"] *= joint_speed_share
    (tmp_path / "arm5.yaml").write_text(yaml.safe_dump(robot))
    job_file = ROOT / "trajectories" / "jobs" / "arm5_joint_spline.yaml"
    doc = {**yaml.safe_load(job_file.read_text()), "robot": str(tmp_path / "arm5.yaml"), "outputs": ["json"],
           **job_changes}
    outcome = run_job(parse_job(doc, base_dir=job_file.parent), tmp_path / "out")
    with np.load(GOLDEN_DIR / "arm5_joint_spline.npz") as golden:
        return golden_mismatches(outcome.profile, golden, outcome.report["limits"]["timed"]["values"])


def test_the_golden_comparison_reports_a_joint_speed_limit_one_percent_lower(tmp_path):
    """Joint 1 is at its speed limit in that job: 1 % less moves qd by ~1e-2 of qd_max, 100 x the tolerance."""
    mismatches = _arm5_spline_mismatches(tmp_path, joint_speed_share=0.99)
    assert [m.split(" ")[0] for m in mismatches] == ["duration", "q", "qd", "qdd"], mismatches


def test_the_golden_comparison_reports_a_coarser_toppra_grid(tmp_path, monkeypatch):
    import pipeline.timing.toppra_backend

    monkeypatch.setattr(pipeline.timing.toppra_backend, "GRIDPOINTS", 500)
    assert any(m.startswith("qd ") for m in _arm5_spline_mismatches(tmp_path))


def test_the_golden_comparison_does_not_depend_on_the_sample_rate(tmp_path):
    """Half the job's dt samples the same motion: the golden still matches (an unchanged robot file copy)."""
    assert _arm5_spline_mismatches(tmp_path, dt=0.002) == []


def test_golden_files_are_small():
    for path in GOLDEN_DIR.glob("*.npz"):
        with np.load(path) as golden:
            assert golden["t"].size <= GOLDEN_MAX_SAMPLES and golden["q"].dtype == np.float64
        assert path.stat().st_size < 100_000


def test_outputs_hold_the_profile_and_the_report(demo_run):
    outcome, out = demo_run("arm5_joint_spline")
    profile = outcome.profile
    joint_job_files = [name for kind, name in FILE_NAMES.items() if kind != "tcp_png"]   # no TCP figure: no TCP
    assert [p.name for p in outcome.files] == joint_job_files   # the job lists all the others, in this order
    assert sorted(p.name for p in out.iterdir()) == sorted([*joint_job_files, OWNER_MARKER])
    header = (out / "profile.csv").read_text().splitlines()[0]
    assert header == ",".join(profile_columns([True] * 5)) and header.startswith("t_s,q1_rad,")
    with np.load(out / "profile.npz") as data:
        np.testing.assert_array_equal(data["qdd"], profile.qdd)
        assert list(data["joint_names"]) == ["Q1", "Q2", "Q3", "Q4", "Q5"]
    report = json.loads((out / "report.json").read_text())
    assert report == json.loads(json.dumps(outcome.report))
    assert report["robot"]["name"] == "arm5" and report["duration_s"] == pytest.approx(profile.duration)
    assert report["limits"]["timed"]["passed"] and report["method"]["timing"] == "toppra"
    assert len(report["inputs_sha256"]) == 64 and report["versions"]["numpy"] == np.__version__
    assert (out / "profile.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = outcome.summary()
    assert "arm5" in summary and "toppra" in summary and f"{profile.duration:.4f} s" in summary
    assert str(out / "profile.png") in summary


def test_pose_waypoints_are_solved_in_order_and_stay_near_each_other():
    job = load_job(ROOT / "trajectories" / "jobs" / "gp7_pick_place.yaml")
    solved = solve_waypoints(job)
    for waypoint, result in zip(job.waypoints, solved):
        np.testing.assert_allclose(job.robot.fk(result.q), waypoint.X_BE, atol=1e-9)
    previous = job.start
    for k, (waypoint, result) in enumerate(zip(job.waypoints, solved)):
        every = job.robot.ik(waypoint.X_BE, q_seed=previous, method="analytic").solutions
        nearest = min(np.linalg.norm(s.q - previous) for s in every)
        assert np.linalg.norm(result.q - previous) == pytest.approx(nearest, abs=1e-12), f"waypoint {k}"
        previous = result.q


def unreachable_job(tmp_path: Path) -> Path:
    """A pose inside the reach bound (every length added up, 1.375 m) that no configuration reaches."""
    doc = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "outputs": ["csv"],
           "waypoints": [{"xyz": [560, 0, 600], "rpy": [180, 0, 0]}, {"xyz": [1200, 0, 600], "rpy": [180, 0, 0]}]}
    path = tmp_path / "unreachable.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def test_unreachable_pose_names_the_waypoint_and_the_reason(tmp_path):
    path = unreachable_job(tmp_path)
    with pytest.raises(JobFileError) as error:
        run_job_file(path, tmp_path / "out")
    message = str(error.value)
    assert message.startswith(f"{path}:{error.value.line}: waypoints[1]: pose is unreachable")
    assert len(message) > len(str(path)) + 60 and error.value.line is not None
    assert (error.value.source, error.value.field) == (str(path), "waypoints[1]")
    assert not (tmp_path / "out").exists()


def test_cli_run_exits_2_on_a_bad_job_and_0_on_a_good_one(tmp_path, capsys):
    assert main(["run", str(unreachable_job(tmp_path)), "--out", str(tmp_path / "bad")]) == 2
    assert "waypoints[1]" in capsys.readouterr().err and not (tmp_path / "bad").exists()
    job = tmp_path / "ok.yaml"
    job.write_text(yaml.safe_dump({"robot": "arm5", "angle_unit": "deg", "outputs": ["json"],
                                   "waypoints": [[0, 0, 0, 0, 0], [10, 20, 30, 40, 50]]}))
    assert main(["run", str(job), "--out", str(tmp_path / "good")]) == 0
    assert "report.json" in capsys.readouterr().out and (tmp_path / "good" / "report.json").is_file()


def test_a_failing_plot_leaves_no_output_behind(tmp_path, monkeypatch):
    def broken_plot(*args, **kwargs):
        raise RuntimeError("plot failed")

    monkeypatch.setattr(pipeline.outputs.plots, "plot_profile", broken_plot)
    job = parse_job({"robot": "arm5", "angle_unit": "deg", "waypoints": [[0, 0, 0, 0, 0], [10, 20, 30, 40, 50]]})
    with pytest.raises(RuntimeError, match="plot failed"):
        run_job(job, tmp_path / "out" / "job")
    assert list((tmp_path / "out").iterdir()) == []


def test_torque_limited_robot_writes_torques(tmp_path):
    job = tmp_path / "arm2.yaml"
    job.write_text(yaml.safe_dump({"robot": str(ROOT / "tests" / "data" / "arm2_dynamics.yaml"), "angle_unit": "deg",
                                   "waypoints": [[0, 0], [90, -60], [-30, 45]], "outputs": ["csv", "npz", "png"]}))
    outcome = run_job_file(job, tmp_path / "out")
    assert "tau" in outcome.limit_report.ratios and outcome.limit_report.max_ratio("tau") <= RATIO_LIMIT
    header = (tmp_path / "out" / "profile.csv").read_text().splitlines()[0]
    assert header.endswith("qddd2_rad_s3,tau1_N_m,tau2_N_m")
    with np.load(tmp_path / "out" / "profile.npz") as data:
        np.testing.assert_array_equal(data["tau"], outcome.profile.tau)
    assert "tau" in outcome.summary()


@pytest.mark.slow
def test_the_report_says_what_timed_the_path_and_certifies_once(tmp_path, monkeypatch):
    """ruckig times waypoint to waypoint (no path shape); the program is certified once, by time_program."""
    import pipeline.program.timing

    calls = []
    real_certify = pipeline.program.timing.certify
    monkeypatch.setattr(pipeline.program.timing, "certify",
                        lambda profile, **kw: calls.append(profile) or real_certify(profile, **kw))
    for name, timing, path in (("arm6_joint_rad", "ruckig", None), ("arm5_joint_spline", "toppra", "spline")):
        outcome = run_job_file(ROOT / "trajectories" / "jobs" / f"{name}.yaml", tmp_path / name)
        assert len(calls) == 1 and outcome.limit_report is outcome.profile.certificate
        calls.clear()
        report = json.loads((tmp_path / name / "report.json").read_text())
        assert report["method"]["timing"] == timing and report["method"]["path"] == path
        assert report["timing_details"] == json.loads(json.dumps(outcome.profile.details.to_dict()))
        assert not any(isinstance(value, str) for value in report["timing_details"].values())


BRANCH_JOB = ROOT / "tests" / "data" / "gp7_branch_change.yaml"
#: A tool job whose line passes through the base's axis, out of reach (one waypoint per line).
TOOL_MOVE_JOB = """\
robot: gp7
length_unit: mm
angle_unit: deg
tcp_speed_max: 500
allow_branch_change: true
waypoints:
  - {xyz: [300, 300, 300], rpy: [180, 0, 0]}
  - {xyz: [-300, -300, 300], rpy: [180, 0, 0], move: linear}
outputs: [json]
"""


def _line_of(text: str, start: str, occurrence: int = 0) -> int:
    """The 1-based line of the ``occurrence``-th line of ``text`` that starts (stripped) with ``start``."""
    return [i for i, line in enumerate(text.splitlines(), 1) if line.lstrip().startswith(start)][occurrence]


@pytest.mark.parametrize("change, field, words", [
    ("", "waypoints[1]", "the IK branch changes"),
    ("rpy: [8.86217177, 26.86158031, 60.80439172], config: {shoulder: front}", "waypoints[1].config",
     "no in-limit solution has the configuration"),
])
def test_errors_after_reading_name_the_line_of_their_waypoint(tmp_path, change, field, words):
    """A branch change and a configuration without a solution (IK, after reading) carry the file line."""
    text = BRANCH_JOB.read_text()
    if change:
        text = text.replace("rpy: [8.86217177, 26.86158031, 60.80439172]", change)
    path = tmp_path / "job.yaml"
    path.write_text(text)
    with pytest.raises(JobFileError) as error:
        run_job_file(path, tmp_path / "out")
    assert (error.value.field, error.value.line) == (field, _line_of(text, "- {", 1)) and words in str(error.value)
    assert str(error.value).startswith(f"{path}:{error.value.line}: {field}: ") and not (tmp_path / "out").exists()


def test_a_tool_move_error_names_the_line_of_its_waypoint(tmp_path):
    path = tmp_path / "line.yaml"
    path.write_text(TOOL_MOVE_JOB)
    with pytest.raises(JobFileError) as error:
        run_job_file(path, tmp_path / "out")
    assert (error.value.field, error.value.line) == ("waypoints[1]", _line_of(TOOL_MOVE_JOB, "- {", 1))
    assert "out of reach" in str(error.value) and not (tmp_path / "out").exists()
