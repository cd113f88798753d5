"""The page's motion program: the waypoints a user adds by jogging the arm, the job file they become, and
"plan and time".

A ``PageProgram`` holds each waypoint as the joint values the arm had when it was added (so its IK branch
is known) and writes the job document the pipeline reads (``to_document``; ``trajectories/README.md``): mm
and deg, the first waypoint and every joint move as joint values, linear and circular moves as TCP poses
with ``config:`` naming the branch the arm was on (and ``via:`` for circular moves). Every check is the job
reader's own: ``edit`` parses the candidate document and refuses with the reader's typed error naming the
field as a file would (``waypoints[3].zone``); ``plan_and_time`` parses the document and runs it as
``python -m pipeline run`` does, so the saved file run from the command line gives equal samples.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation, Slerp

from ..cell.cell_file import resolve_cell_path
from ..errors import ConfigurationError
from ..files.arrays import float_array
from ..files.atomic import WRITTEN_BY, write_text_atomic
from ..files.branch_names import label_parts
from ..files.choices import MOVES
from ..files.poses import check_pose, make_pose, rotation_to_rpy
from ..files.units import ANGLE_UNITS, LENGTH_UNITS
from ..model.ik.branches import choose_solution, configuration_labels
from ..model.robot import Robot, load_robot, robot_with_tool
from ..program.compile import solve_waypoints
from ..program.job import Job, JointWaypoint, load_job, parse_job
from ..runner import JobOutcome, collision_model, reported_program, run_job

#: The file's units: every document the page writes is in mm and deg.
MM, DEG = LENGTH_UNITS["mm"], ANGLE_UNITS["deg"]
#: The speed of tool moves that give none [m/s] (the job's ``tcp_speed_max``) in a new program.
DEFAULT_TCP_SPEED = 0.25
#: What a page program writes when run from the command line: the report and the profile's exact samples.
DEFAULT_OUTPUTS = ("json", "npz")
#: Job keys a page program carries besides its waypoints, robot, cell and tool: key -> the SI factor of
#: its file unit (None: no unit). Read from a loaded job, written back in mm and deg.
SETTINGS = {"description": None, "ik": None, "timing": None, "path": None, "speed_scale": None, "dt": None,
            "allow_branch_change": None, "singularity": None, "tcp_speed_max": MM, "tcp_accel_max": MM,
            "tcp_speed_limit": MM, "plan": None, "planner": None, "plan_time_budget": None,
            "plan_tilt_max": DEG, "outputs": None}
#: The fields ``edit`` changes, and the unit a user types each in (joint move, tool move).
EDITABLE = {"move": ("", ""), "speed": ("%", "mm/s"), "zone": ("mm", "mm")}


@dataclass(frozen=True, eq=False)
class PageWaypoint:
    """A waypoint as the page holds it: ``move`` (joint, linear, circular; the first waypoint is the start,
    always written as joints), ``q`` (dof,) [rad or m] the joint values the arm had when it was added (its
    branch), ``via_q`` (dof,) or None the joint values at a circular move's via point (written only for
    circular moves), ``speed`` (joint moves: a fraction in (0, 1] of the joint speed limits; tool moves:
    the TCP speed [m/s]; None: the job's default) and ``zone`` [m] (0: a stop)."""

    move: str
    q: np.ndarray
    via_q: np.ndarray | None = None
    speed: float | None = None
    zone: float = 0.0


class PageProgram:
    """The page's program (module docstring). ``robot_reference``: a preset name or robot file path as a
    job file names it; ``cell_reference``: a demo cell's name or a cell file path (None: no cell; with
    one, joint moves are planned around its obstacles, ``plan: collision_free``); ``tool``: X_FT (4, 4) [m] or None; ``name``: the
    job's name. ``settings``: the other job keys, in SI (``SETTINGS``), e.g. ``tcp_speed_max`` [m/s]. ``payload``: the
    tool's load (``pipeline.program.payload.Payload``; None: none), kept from the job file and written back."""

    def __init__(self, robot_reference: str, cell_reference: str | None = None, tool: np.ndarray | None = None,
                 name: str = "page_program"):
        self.robot_reference = _absolute_if_file(robot_reference, is_file=Path(str(robot_reference)).suffix
                                                 in (".yaml", ".yml"))
        self.cell_reference = None if cell_reference is None else \
            _absolute_if_file(cell_reference, is_file=Path(str(cell_reference)).is_file())
        if self.cell_reference is not None:
            resolve_cell_path(self.cell_reference)              # a CellFileError names an unknown cell now
        self.tool = None if tool is None else np.array(check_pose(tool, "tool X_FT"))
        self.name = name
        robot = load_robot(self.robot_reference)
        self.robot: Robot = robot if self.tool is None else robot_with_tool(robot, self.tool)
        self.waypoints: list[PageWaypoint] = []
        self.settings: dict = {"tcp_speed_max": DEFAULT_TCP_SPEED, "outputs": DEFAULT_OUTPUTS}
        self.payload = None
        if self.cell_reference is not None:
            self.settings["plan"] = "collision_free"

    # -- building -------------------------------------------------------------------------------
    def add(self, q, move: str = "joint", speed: float | None = None, zone: float = 0.0) -> int:
        """Append a waypoint at joint values ``q`` (dof,) [rad or m] reached by ``move`` at ``speed`` (as
        PageWaypoint) with ``zone`` [m]; returns its index. The first waypoint is the start: its move is
        joint, without speed or zone."""
        if move not in MOVES:
            raise ConfigurationError(f"move must be one of {', '.join(MOVES)}, got {move!r}")
        if speed is not None and not (_is_number(speed) and math.isfinite(speed) and speed > 0.0):
            raise ConfigurationError(f"speed must be a positive number or None (the job's default), got {speed!r}")
        if not (_is_number(zone) and math.isfinite(zone) and zone >= 0.0):
            raise ConfigurationError(f"zone must be a finite number >= 0 [m], got {zone!r}")
        self.waypoints.append(PageWaypoint(move, self._joints(q, "q"), None, speed, float(zone)))
        self._start_at_rest()
        return len(self.waypoints) - 1

    def set_via(self, index: int, q) -> None:
        """The via point of the circular move to waypoint ``index``: the joint values ``q`` (dof,) the arm
        has there (its TCP position is written as ``via``)."""
        self._check_index(index)
        self.waypoints[index] = replace(self.waypoints[index], via_q=self._joints(q, "via q"))

    def move_to(self, index: int, new_index: int) -> None:
        """Move waypoint ``index`` to position ``new_index`` (the one then first becomes the start)."""
        self._check_index(index)
        self._check_index(new_index)
        self.waypoints.insert(new_index, self.waypoints.pop(index))
        self._start_at_rest()

    def delete(self, index: int) -> None:
        """Remove waypoint ``index`` (the one then first becomes the start)."""
        self._check_index(index)
        del self.waypoints[index]
        self._start_at_rest()

    def add_typed(self, q, move: str = "joint", speed_text: str = "", zone_text: str = "") -> int:
        """``add`` with the speed and zone as a user types them on the page (as ``edit``), checked as the
        corner into the next move the user is about to add (so a zone is allowed on it while it is the
        last waypoint; ``edit`` refuses that). A refused value raises the reader's error naming the field
        (``waypoints[3].zone``) and adds nothing."""
        if move not in MOVES:
            raise ConfigurationError(f"move must be one of {', '.join(MOVES)}, got {move!r}")
        index = len(self.waypoints)
        rows = [*self.waypoints, PageWaypoint("joint" if index == 0 else move, self._joints(q, "q"))]
        for field, text in (("speed", speed_text), ("zone", zone_text)):
            if str(text).strip():
                rows = self._edited(rows, index, field, text, open_end=True)
        self.waypoints = rows
        return index

    def edit(self, index: int, field: str, text: str) -> None:
        """Set ``field`` (move, speed, zone) of waypoint ``index`` from ``text`` as a user types it in the
        page's units (speed: % for joint moves, mm/s for tool moves; zone: mm; empty: the job's default
        speed, no zone). A value the job reader refuses (not a number, a negative zone, a speed above 100 %
        or any arm's TCP speed, a circular move without via, a zone on the first or last waypoint, ...)
        raises its typed error (JobFileError) naming the field as a file would (``waypoints[3].zone``) and
        changes nothing. A change between a joint and a tool move resets the speed to the job's default
        (the units differ)."""
        self._check_index(index)
        self.waypoints = self._edited(self.waypoints, index, field, text, open_end=False)

    def _edited(self, rows: list[PageWaypoint], index: int, field: str, text: str,
                open_end: bool) -> list[PageWaypoint]:
        """``rows`` with ``field`` of waypoint ``index`` set from ``text`` (``edit``), checked by the job
        reader; ``open_end``: a next waypoint is to come (``add_typed``)."""
        if field not in EDITABLE:
            raise ConfigurationError(f"field must be one of {', '.join(EDITABLE)}, got {field!r}")
        waypoint = rows[index]
        unit = EDITABLE[field][waypoint.move != "joint"]
        text = str(text).strip()
        if unit and text.endswith(unit):
            text = text[: -len(unit)].strip()
        written = text if field == "move" else _typed(text)
        candidate = list(rows)
        if field == "move":
            kind_changed = (written == "joint") != (waypoint.move == "joint")
            candidate[index] = replace(waypoint, move=written, speed=None if kind_changed else waypoint.speed)
        document = self._document(candidate, check=(index, field), open_end=open_end)
        if field != "move":
            entry = document["waypoints"][index]
            if isinstance(entry, list):
                entry = document["waypoints"][index] = {"joints": entry}
            entry.pop(field, None)
            if written is not None:
                entry[field] = written
        read = parse_job(document, source=f"<page {self.name}>", name=self.name).waypoints[index]
        if field != "move":
            candidate[index] = replace(waypoint, **{field: getattr(read, field)})
        return candidate

    # -- the job file ---------------------------------------------------------------------------
    def to_document(self, relative_to: str | Path | None = None) -> dict:
        """The job file as a dict (what ``yaml.safe_dump`` writes): mm and deg, numbers that read back to
        the same values. Robot and cell files are named by absolute paths, or relative to the folder
        ``relative_to`` (where the file will be)."""
        return self._document(self.waypoints, relative_to=relative_to)

    def save(self, path: str | Path, replace: bool = False) -> Path:
        """Write the job file to ``path`` (YAML, atomically); robot and cell files named relative to it. A file
        the package did not write is replaced only with ``replace`` (OutputError naming it otherwise)."""
        path = Path(path)
        text = yaml.safe_dump(self.to_document(relative_to=path.absolute().parent), sort_keys=False,
                              default_flow_style=None, width=120)
        return write_text_atomic(path, f"# {self.name}: a job file written by {WRITTEN_BY}'s page\n{text}", replace)

    @classmethod
    def from_job_file(cls, path: str | Path) -> PageProgram:
        """A page program from a job file: its waypoints solved to joint values as the runner solves them
        (IK, branch rule, the cell's collisions), a circular move's via point by IK of its position with
        the orientation halfway between the move's ends. Refused with a JobFileError naming the field:
        pose targets other than the full pose, ``controller_config`` (the page names branches with
        ``config``) and actions (``do``: the page does not hold them, and would drop them on saving)."""
        job = load_job(path)
        for k, waypoint in enumerate(job.waypoints):
            if waypoint.actions:
                raise job.error(("waypoints", k, "do"), "the page holds motion only: it cannot show or save a "
                                "waypoint's actions (edit them in the job file)", str(waypoint.actions[0]))
            if isinstance(waypoint, JointWaypoint):
                continue
            if waypoint.target != "pose":
                raise job.error(("waypoints", k, "target"), "the page holds full TCP poses: a target of "
                                f"{waypoint.target} cannot be shown or saved by it", waypoint.target)
            if waypoint.controller_config is not None:
                raise job.error(("waypoints", k, "controller_config"), "the page names IK branches with config: "
                                "it cannot keep a controller's configuration data", waypoint.controller_config[0])
        document = job.document.data
        base = Path(path).absolute().parent
        cell = None if "cell" not in document else _reference(document["cell"], base)
        robot = _reference(document["robot"], base) if "robot" in document else job.cell.robot
        program = cls(str(robot), cell, job.tool, job.name)
        program.settings = {key: getattr(job, key) for key in SETTINGS
                            if key in document and getattr(job, key) is not None}
        program.payload = job.payload
        solved = [s.q for s in solve_waypoints(job, collision_model(job))]
        for k, (waypoint, q) in enumerate(zip(job.waypoints, solved)):
            via_q = None
            if waypoint.move == "circular":
                via_q = _via_joints(job, k, solved[k - 1], q)
            program.waypoints.append(PageWaypoint(waypoint.move, q, via_q, waypoint.speed, waypoint.zone))
        return program

    def plan_and_time(self, out_dir: str | Path | None = None) -> JobOutcome:
        """Parse ``to_document()`` and run it as ``python -m pipeline run`` does (``run_job``): the certified
        profile, the report and, with ``out_dir``, the job's output files written there (without: none,
        ``files`` empty). Errors are the job's own (JobFileError naming the field, PlanningError, ...)."""
        job = self.job()
        if out_dir is not None:
            return run_job(job, out_dir)
        program, profile, report = reported_program(job)
        return JobOutcome(job, profile, (), report, program)

    def job(self) -> Job:
        """The validated Job of ``to_document()``."""
        return parse_job(self.to_document(), source=f"<page {self.name}>", name=self.name)

    # -- helpers ----------------------------------------------------------------------------------
    def _document(self, waypoints: list[PageWaypoint], relative_to=None, check: tuple[int, str] | None = None,
                  open_end: bool = False) -> dict:
        """The job document of ``waypoints``. ``check``: (index, field) of a field being edited; the
        program's unfinished parts elsewhere (a circular move without via, a zone on the last waypoint, a
        single waypoint) are left out so that only the edit's own problems show; ``open_end``: a joint
        waypoint stands in for the next one to come."""
        rows = list(waypoints)
        if check is not None:
            last = len(rows) - 1
            rows = [replace(w, move="linear" if w.move == "circular" and w.via_q is None and (k, "move") != check
                            else w.move, zone=0.0 if k == last else w.zone) for k, w in enumerate(rows)]
            if len(rows) == 1 or open_end:
                rows.append(PageWaypoint("joint", rows[-1].q))
        document = {"description": f"{self.name}: built on the page"}
        document["robot"] = _written_reference(self.robot_reference, relative_to)
        if self.cell_reference is not None:
            document["cell"] = _written_reference(self.cell_reference, relative_to)
        document.update(length_unit="mm", angle_unit="deg")
        if self.tool is not None:
            document["tool"] = self._pose_entry(self.tool)
        if self.payload is not None:
            document["payload"] = self.payload.to_document(MM)
        document["waypoints"] = [self._waypoint_entry(w, rows[k - 1] if k else None) for k, w in enumerate(rows)]
        tool_moves = any(w.move != "joint" for w in rows)
        for key, scale in SETTINGS.items():
            value = self.settings.get(key)
            if value is None or (key in ("tcp_speed_max", "tcp_accel_max") and not tool_moves):
                continue
            if key == "outputs":
                value = [kind for kind in value if kind != "tcp_png" or tool_moves
                         or self.settings.get("tcp_speed_limit") is not None]
            document[key] = _file_number(value, scale) if scale is not None else \
                list(value) if isinstance(value, tuple) else value
        return document

    def _waypoint_entry(self, waypoint: PageWaypoint, before: PageWaypoint | None):
        """One waypoint as a job file writes it: joint values (a list, or a mapping with speed and zone),
        or a TCP pose with its move, config, via, speed and zone."""
        zone = {} if waypoint.zone == 0.0 else {"zone": _file_number(waypoint.zone, MM)}
        if waypoint.move == "joint":
            joints = self._joints_entry(waypoint.q)
            speed = {} if waypoint.speed is None else {"speed": _file_number(waypoint.speed, None)}
            return {"joints": joints, **speed, **zone} if speed or zone else joints
        entry = {**self._pose_entry(self.robot.fk(waypoint.q)), "move": waypoint.move}
        branch = label_parts(_labels(self.robot, waypoint.q))
        if branch:
            entry["config"] = branch
        if waypoint.move == "circular" and waypoint.via_q is not None:
            entry["via"] = {"xyz": _file_number(self.robot.fk(waypoint.via_q)[:3, 3], MM)}
        if waypoint.speed is not None:
            entry["speed"] = _file_number(waypoint.speed, MM)
        return {**entry, **zone}

    def _joints_entry(self, q: np.ndarray) -> list[float]:
        """Joint values in the file's units: deg, mm for prismatic joints."""
        return [_file_number(value, DEG if joint.is_revolute else MM) for value, joint in zip(q, self.robot.spec.joints)]

    @staticmethod
    def _pose_entry(X: np.ndarray) -> dict:
        """A pose as ``{xyz: [mm], rpy: [deg]}``."""
        return {"xyz": _file_number(X[:3, 3], MM), "rpy": _file_number(rotation_to_rpy(X[:3, :3]), DEG)}

    def _joints(self, q, what: str) -> np.ndarray:
        """``q`` as a read-only (dof,) float array (ConfigurationError naming ``what`` otherwise)."""
        q = float_array(q, what, (self.robot.dof,)).copy()
        q.setflags(write=False)
        return q

    def _check_index(self, index: int) -> None:
        if not (isinstance(index, int) and 0 <= index < len(self.waypoints)):
            raise ConfigurationError(f"waypoint index must be in [0, {len(self.waypoints) - 1}], got {index!r}")

    def _start_at_rest(self) -> None:
        """The first waypoint is where the motion starts: no move into it, so no speed, via or zone."""
        if self.waypoints:
            self.waypoints[0] = replace(self.waypoints[0], move="joint", via_q=None, speed=None, zone=0.0)


def _labels(robot: Robot, q: np.ndarray) -> str:
    """The IK branch label of ``q`` ("" for arms without named branches)."""
    return configuration_labels(robot, q[None])[0]


def _via_joints(job: Job, k: int, q_before: np.ndarray, q_end: np.ndarray) -> np.ndarray:
    """Joint values at the via point of the circular move to waypoint ``k``: IK of the via position with
    the orientation halfway (slerp) between the move's ends, on the branch of ``q_end``, nearest to it."""
    robot = job.robot
    X_before, X_end = robot.fk(q_before), robot.fk(q_end)
    rotations = Rotation.from_matrix(np.array([X_before[:3, :3], X_end[:3, :3]]))
    X_via = make_pose(Slerp([0.0, 1.0], rotations)(0.5).as_matrix(), job.waypoints[k].via)
    result = robot.ik(X_via, q_seed=q_end, method=job.ik)
    branch = _labels(robot, q_end)
    choice = choose_solution(robot, result, q_end, branch, label_parts(branch) or None) if result.success else None
    if choice is None or choice.q is None:
        reason = result.reason if choice is None else choice.reason
        raise job.error(("waypoints", k, "via"), f"the page shows the arm at the via point and found no IK solution "
                        f"there (orientation halfway between the move's ends): {reason}")
    return choice.q


def _typed(text: str):
    """A field's text as YAML would read it: a number where it is one, else the text (the reader then
    says what it must be); empty: None."""
    if not text:
        return None
    try:
        return float(text)
    except ValueError:
        return text


def _file_number(value, scale: float | None):
    """SI ``value`` (a number or an array) in a file unit of ``scale`` SI per unit (None: a percentage,
    which the reader divides by 100): for each number, the shortest decimal d that the reader converts
    back to ``value`` exactly, so the file shows 40, not 40.00000000000001; where no number converts back
    exactly (about 1 in 11 angles in degrees), ``value / scale``, within a unit in the last place. A list
    for an array."""
    if np.ndim(value):
        return [_file_number(v, scale) for v in np.asarray(value, dtype=float)]
    value = float(value)
    to_si = (lambda d: d / 100.0) if scale is None else (lambda d: d * scale)
    written = value * 100.0 if scale is None else value / scale
    for digits in range(1, 18):
        shorter = float(f"{written:.{digits}g}")
        if to_si(shorter) == value:
            return shorter
    return written


def _absolute_if_file(reference, is_file: bool) -> str:
    """A file reference as an absolute path; a preset or demo cell name as given."""
    return os.path.normpath(Path(reference).absolute()) if is_file else str(reference)


def _reference(value: str, base: Path) -> str:
    """A job file's robot or cell reference, a path taken relative to the file's folder ``base``."""
    candidate = Path(value)
    if candidate.suffix in (".yaml", ".yml"):
        return os.path.normpath(candidate if candidate.is_absolute() else base / candidate)
    return value


def _written_reference(reference: str, relative_to) -> str:
    """A reference as the document names it: a file path relative to the folder ``relative_to`` when they
    share a folder below the root (else, and when None, absolute); a name as given."""
    if relative_to is None or not os.path.isabs(reference):
        return reference
    shared = os.path.commonpath([reference, os.path.abspath(relative_to)])
    return reference if shared == os.path.dirname(shared) else os.path.relpath(reference, relative_to)


def _is_number(value) -> bool:
    """A real number handed to the API (int, float or a NumPy scalar; not a bool, not text)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
