"""What every benchmark report shares: goals with their verdicts, and how a report prints and serialises them."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass(frozen=True)
class Goal:
    """One goal of an issue: the measured value (None when nothing could be measured), the bound it
    must satisfy, and the verdict."""

    name: str
    value: float | None
    bound: str
    passed: bool


def fmt(value: float | None, spec: str) -> str:
    """``value`` formatted by ``spec``, or "-" when there is none."""
    return "-" if value is None else format(value, spec)


def goal_lines(title: str, goals, versions: dict[str, str]) -> list[str]:
    """The closing lines of a report: a blank line, ``title``, a PASS/FAIL line per goal, the versions."""
    lines = ["", title]
    lines += [f"  {'PASS' if goal.passed else 'FAIL'}  {goal.name}: {fmt(goal.value, '.4g')} ({goal.bound})"
              for goal in goals]
    lines.append("versions: " + ", ".join(f"{k} {v}" for k, v in versions.items()))
    return lines


class GoalReport:
    """Base of a benchmark report dataclass with ``goals``: its verdict over them and its JSON form."""

    @property
    def passed(self) -> bool:
        return all(goal.passed for goal in self.goals)

    def to_dict(self) -> dict:
        """The report as JSON-serialisable builtins (None where a value does not exist), with ``passed``."""
        data = dataclasses.asdict(self)
        data["passed"] = self.passed
        return data
