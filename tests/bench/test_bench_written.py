"""``bench written``: as written and round trip per program and language, and its goals (issue 36)."""

from __future__ import annotations

import pytest

from pipeline.bench.cycle import DEMO_JOB_DIR
from pipeline.bench.written import ROUND_TRIP_GOAL, WrittenBenchReport, WrittenRecord, measure_job, written_goals
from pipeline.program.job import load_job


@pytest.mark.slow
@pytest.mark.parametrize("languages", [("jbi",), pytest.param(("rapid", "krl", "ls"), marks=pytest.mark.slow)])
def test_the_gp7_pick_and_place_comes_back_with_its_stops_in_every_language(languages):
    """Its retreat runs into the arc through a 60 mm zone: Yaskawa writes it as the arc's first MOVC point (reached on
    a line) with PL3; before, the arc's repeated start stopped the robot there (6 stops read back for 5)."""
    records = measure_job(load_job(DEMO_JOB_DIR / "gp7_pick_place.yaml"), languages)
    assert tuple(r.language for r in records) == languages
    for record in records:
        assert record.passed and record.error == "", record
        assert record.read_back_stops == record.job_stops == 5
    report = WrittenBenchReport(0, 0, records, written_goals(records), {}, 0.0)
    assert report.passed and "gp7_pick_place" in report.format_table()


def _record(ratio: float, **changes) -> WrittenRecord:
    fields = dict(written_s=2.0, written_passed=True, read_back_s=2.0 * ratio, read_back_passed=True, same_stops=True)
    return WrittenRecord("p", "rapid", 2.0, 3, **{**fields, **changes})


@pytest.mark.parametrize("record", [_record(1.2), _record(0.8), _record(1.0, same_stops=False),
                                    _record(1.0, read_back_passed=False), _record(1.0, written_passed=False),
                                    _record(1.0, read_back_s=None)])
def test_each_goal_can_fail(record):
    goals = written_goals([_record(1.0), record])
    assert not all(goal.passed for goal in goals) and not record.passed
    assert all(goal.passed for goal in written_goals([_record(1.0), _record(ROUND_TRIP_GOAL)]))


@pytest.mark.slow                                  # every demo job and one drawn program in four languages: ~1 min
def test_the_cli_runs_the_suite_and_writes_json(tmp_path, capsys):
    import json

    from pipeline.__main__ import main

    out = tmp_path / "written.json"
    assert main(["bench", "written", "--programs", "1", "--cells", "irb1600_wall_cell", "--out", str(out)]) in (0, 1)
    data = json.loads(out.read_text())
    names = {r["program"] for r in data["records"]}
    assert "irb1600_wall_cell_00" in names and "gp7_cell_pick_place" in names and "arm5_joint_spline" not in names
    assert len(data["records"]) == 4 * len(names) and [g["name"] for g in data["goals"]][0].startswith("written")
    assert "round trip" in capsys.readouterr().out
