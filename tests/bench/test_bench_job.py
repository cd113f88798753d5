"""The whole-job benchmark: which jobs it times, and one real run in fresh processes (slow)."""

from __future__ import annotations

import json

import pytest

from pipeline.bench.job import COMPUTED_GOAL_S, cell_jobs, run_job_benchmark
from pipeline.errors import ConfigurationError


def test_the_demo_cell_jobs_are_timed():
    names = [path.stem for path in cell_jobs()]
    assert "gp7_cell_pick_place" in names and "gp7_pick_place" not in names


def test_no_jobs_is_a_typed_error():
    with pytest.raises(ConfigurationError, match="no job files"):
        run_job_benchmark(jobs=[])


@pytest.mark.slow
def test_one_fresh_process_run_reports_its_times_and_goal():
    report = run_job_benchmark(repeats=1)
    (job,) = [j for j in report.jobs if j.job == "gp7_cell_pick_place"]
    assert 0.0 < job.computed[0] < job.with_figures[0] and job.process[0] > job.computed[0]
    assert abs(job.duration_s - 2.26) < 0.05
    (goal,) = report.goals
    assert goal.value == max(min(j.computed) for j in report.jobs) and goal.passed == (goal.value < COMPUTED_GOAL_S)
    assert "gp7_cell_pick_place" in report.format_table() and json.loads(json.dumps(report.to_dict()))["jobs"]
