"""The names (and defaults) a job file or an API call chooses from, in one light module: readers
validate a name here without importing the algorithms behind it."""

from __future__ import annotations

#: Inverse kinematics methods (``pipeline.model.ik``).
IK_METHODS = ("auto", "analytic", "jacobian", "drake")
#: What an IK target asks for (``pipeline.model.ik``): position and full orientation (6 constraints),
#: position and the end frame's z axis (5), position only (3).
FULL_POSE = "pose"
POSITION_AND_AXIS = "position+axis"
POSITION_ONLY = "position"
TARGET_KINDS = (FULL_POSE, POSITION_AND_AXIS, POSITION_ONLY)
#: Time parameterisation methods (``pipeline.timing``).
TIMING_METHODS = ("toppra", "ruckig", "topp3")
#: Older names still accepted for a timing method -> the method they now mean.
TIMING_ALIASES = {"toppra+ruckig": "topp3"}
#: The limits each timing method needs beyond qd_max, for every joint.
TIMING_LIMITS = {"toppra": ("qdd_max",), "ruckig": ("qdd_max", "qddd_max"), "topp3": ("qdd_max", "qddd_max")}
#: Geometric joint path shapes through waypoints (``pipeline.timing.joint_path``).
PATH_SHAPES = ("monotone", "spline", "linear")
#: The path shape unless a job or call says otherwise: it never leaves the limits the waypoints keep.
DEFAULT_PATH_SHAPE = "monotone"
#: Sample time of a timed profile unless a job or call says otherwise [s].
DEFAULT_DT = 0.004
#: Most samples a profile may have unless the caller allows more (500,000 x 6 joints x 4 quantities
#: is about 100 MB of arrays) [1].
DEFAULT_MAX_SAMPLES = 500_000
#: Longest a job's moves may take at their speed limits, bounded from below before any timing, unless the
#: caller allows more [s]: 10 minutes of motion is a unit mistake (a TCP speed in m/s written under mm)
#: or a tiny speed scale, not a job's move (``pipeline.program.bound.check_duration``).
DEFAULT_MAX_DURATION_S = 600.0
#: How the TCP gets to a pose waypoint (``pipeline.program.tool_path``): joint interpolation, or a tool move, a
#: straight line or a circular arc.
TOOL_MOVES = ("linear", "circular")
MOVES = ("joint", *TOOL_MOVES)
#: What a tool move does near a singularity (``pipeline.program.tool_moves``): refuse, or slow down through it.
SINGULARITY_POLICIES = ("stop", "slow_down")
#: How a job's joint moves meet a cell (``pipeline.cell.clear_motion``): as given (and certified), or replaced by
#: a planned collision-free joint path where the direct one comes closer than the clearance.
PLAN_MODES = ("direct", "collision_free")
#: OMPL geometric planners a job or call may name (``pipeline.cell.planning``), the default, and the search
#: time one planned move gets unless told otherwise [s].
PLANNERS = ("RRTConnect", "RRT", "RRTstar", "InformedRRTstar", "SORRTstar", "AORRTC", "BITstar", "PRM", "PRMstar",
            "KPIECE1", "BKPIECE1", "LBKPIECE1", "FMT")
DEFAULT_PLANNER = "RRTConnect"
PLAN_TIME_BUDGET_S = 2.0
