"""The whole-job benchmark: which jobs it times, and one real run in fresh processes (slow)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.bench.job import (
    COMPUTED_GOAL_S,
    FIRST_IK_GOAL_S,
    LONG_GOAL_S,
    LONG_RATIO_GOAL,
    LONG_WAYPOINTS,
    FirstIkTiming,
    JobBenchReport,
    cell_jobs,
    first_ik_goal,
    long_job_text,
    run_job_benchmark,
    time_first_ik,
)
from pipeline.errors import ConfigurationError
from pipeline.files.schema import MAX_FILE_BYTES


def test_the_demo_cell_jobs_are_timed():
    names = [path.stem for path in cell_jobs()]
    assert "gp7_cell_pick_place" in names and "gp7_pick_place" not in names


def test_no_jobs_is_a_typed_error():
    with pytest.raises(ConfigurationError, match="no job files"):
        run_job_benchmark(jobs=[])


def waypoint_rows(text: str) -> np.ndarray:
    """The waypoints (K, dof) of a job file written as ``long_job_text`` writes it (a row ``- [a,b,...]`` each)."""
    rows = text.split("waypoints:\n", 1)[1].splitlines()
    return np.array([[float(v) for v in row[3:-1].split(",")] for row in rows])


def test_the_long_jobs_are_one_sine_sampled_four_times_as_densely():
    """The long joint jobs' files: within the reader's size limit, 4x the segments of the short one, the same
    sine on J1 (the short job's waypoints every 4th of the long one's); the slow test below runs them."""
    short, long = LONG_WAYPOINTS
    assert (long - 1) == 4 * (short - 1)
    text = long_job_text(long)
    assert len(text.encode()) < MAX_FILE_BYTES
    rows = waypoint_rows(text)
    assert rows.shape == (long, 6) and rows[:, 0].max() == 1.0 and rows[:, 0].min() == -1.0
    np.testing.assert_allclose(waypoint_rows(long_job_text(short)), rows[::4], atol=1e-6)


@pytest.mark.slow
def test_one_fresh_process_run_reports_its_times_and_goal():
    report = run_job_benchmark(repeats=1, long_repeats=1, first_ik_repeats=0)
    (job,) = [j for j in report.jobs if j.job == "gp7_cell_pick_place"]
    assert 0.0 < job.computed[0] < job.with_figures[0] and job.process[0] > job.computed[0]
    assert abs(job.duration_s - 2.26) < 0.05
    computed, longest, ratio = report.goals
    assert computed.value == max(min(j.computed) for j in report.jobs)
    assert computed.passed == (computed.value < COMPUTED_GOAL_S)
    short, long = report.long_jobs
    assert [short.waypoints, long.waypoints] == list(LONG_WAYPOINTS)
    assert longest.value == long.total[0] and longest.passed == (longest.value < LONG_GOAL_S)
    assert ratio.value == long.total[0] / short.total[0] and ratio.passed == (ratio.value <= LONG_RATIO_GOAL)
    assert short.duration_s == pytest.approx(long.duration_s, rel=1e-3)
    assert "gp7_cell_pick_place" in report.format_table() and json.loads(json.dumps(report.to_dict()))["long_jobs"]


def test_the_first_ik_call_is_judged_on_its_cold_median_and_reported_beside_the_warm_one():
    timing = FirstIkTiming("gp7", 3, [0.9, 1.0, 1.1], [4.0, 6.0, 4.5], [0.8, 0.9, 1.0], [0.3, 0.4, 0.5],
                           [0.9, 1.0, 1.0], [15.0, 16.0, 17.0], "used")
    goal = first_ik_goal(timing)
    assert goal.value == 4.5 and goal.passed and f"<= {FIRST_IK_GOAL_S:g} s" in goal.bound
    assert not first_ik_goal(FirstIkTiming("gp7", 1, [1.0], [5.5], [1.0], [0.4], [1.0], [16.0], "used")).passed
    assert "prebuilt IK kernels: used" in goal.name
    table = JobBenchReport((), (goal,), {}, (), timing).format_table()
    assert "first IK call: load_robot('gp7')" in table and "4.50 / 6.00" in table and "0.40 / 0.50" in table
    assert "16.00 / 17.00" in table


@pytest.mark.slow
def test_the_first_ik_call_is_timed_with_an_empty_cache_a_warm_one_and_just_in_time():
    timing = time_first_ik(1)
    assert timing.repeats == 1 and min(timing.cold + timing.warm + timing.jit) > 0.0
    assert timing.prebuilt == "used", "make builds the prebuilt IK kernels at install: " + timing.prebuilt
    assert all(seconds > 0.0 for seconds in timing.cold_import + timing.warm_import)
