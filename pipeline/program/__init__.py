"""Motion programs: a job compiled into typed moves (``compile_job``), timed and certified once
(``time_program``), with its lower bound (``lower_bound``) and cycle-time report (``cycle_report``)."""

from .bound import LowerBound, lower_bound
from .compile import compile_job, solve_waypoints
from .model import Move, Program, ToolTrack, WaypointSolution
from .report import cycle_lines, cycle_report
from .timing import time_program

__all__ = ["LowerBound", "Move", "Program", "ToolTrack", "WaypointSolution", "compile_job", "cycle_lines",
           "cycle_report", "lower_bound", "solve_waypoints", "time_program"]
