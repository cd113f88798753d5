"""``python -m pipeline ui [ROBOT | CELL | JOB]``: the local web page (viser) to jog the arm, drag a TCP
target and see every IK branch, build a program, plan and time it, and save it as a job file.

``Page`` is the page and its API in one: every control on the page calls one of its methods
(``set_joints``, ``drag_target``, ``adopt``, ``add_waypoint``, ``plan_and_time``, ``save_job``,
``load_job`` ...), and the tests drive the same methods in-process. The server binds to 127.0.0.1 unless
``host`` says otherwise. Long work (planning and timing, the first compile of the kinematics) runs in a
background thread with a progress bar, so the page never freezes; a bad value in a field gets the typed
message a job file would get for it, next to the field.

Frames: the scene is drawn in the cell frame W (the robot's base B at the cell's X_WB; W = B without a
cell); targets are TCP poses X_WT [m]; the IK works on X_BT = inv(X_WB) X_WT.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ..cell.cell_file import cell_names, load_cell, resolve_cell_path
from ..cell.tool import Tool, rigid_inverse
from ..errors import ConfigurationError, PipelineError
from ..files.arrays import float_array
from ..files.atomic import prepare_file_target, write_text_atomic
from ..files.poses import check_pose, pose_to_quaternion_position, quaternion_position_to_pose
from ..files.units import ANGLE_UNITS, LENGTH_UNITS
from ..model.robot import load_robot
from ..outputs.views import camera_pose, scene_spheres
from ..runner import LANGUAGE_TITLES, program_name
from .branches import TargetBranches, branch_names, closest_words, pose_words, target_branches
from .program import PageProgram
from .scene import ArmScene

log = logging.getLogger(__name__)

LOCALHOST = "127.0.0.1"
DEFAULT_PORT = 8080
#: The robot a page shows when it is given nothing.
DEFAULT_ROBOT = "gp7"
#: How many drag updates the page keeps the compute time of [1].
UPDATE_HISTORY = 2000
#: Samples of the replay slider per second of profile [1/s], and the plots' points at most.
REPLAY_FPS, PLOT_POINTS = 50.0, 1500
MOVES = ("joint", "linear", "circular")


@dataclass(frozen=True)
class PageSource:
    """What the page opens: ``robot`` (end frame the TCP), its ``tool`` (a Tool), ``cell`` (or None), the
    ``program`` to edit (a PageProgram), and ``title``."""

    robot: object
    tool: Tool
    cell: object
    program: PageProgram
    title: str


def load_source(name: str | None) -> PageSource:
    """A preset or robot file, a demo cell's name or a cell file, or a job file (its program is loaded)."""
    name = DEFAULT_ROBOT if name is None else str(name)
    path = Path(name)
    keys = _yaml_keys(path) if path.suffix in (".yaml", ".yml") else set()
    if name in cell_names() or "objects" in keys:
        cell = load_cell(resolve_cell_path(name) if name in cell_names() else path)
        robot = cell.load_robot()
        program = PageProgram(str(cell.robot), name, None, f"{cell.name}_program")     # TCP: the flange
        return PageSource(robot, Tool.from_job_and_cell(None, cell, cell.name), cell, program, f"cell {cell.name}")
    if "waypoints" in keys:
        from ..program.job import load_job

        job = load_job(path)
        return PageSource(job.robot, Tool.of_job(job), job.cell, PageProgram.from_job_file(path), f"job {job.name}")
    robot = load_robot(name)
    return PageSource(robot, Tool(), None, PageProgram(name, None, None, f"{robot.name}_program"), f"robot {robot.name}")


def _yaml_keys(path: Path) -> set:
    """The top-level keys of a YAML file (empty for a missing or non-mapping file)."""
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError):
        return set()
    return set(data) if isinstance(data, dict) else set()


def pose_text(X: np.ndarray) -> str:
    """A pose (4, 4) [m] as the page shows it: position [mm], rpy [deg] and quaternion [w x y z]."""
    quaternion, _ = pose_to_quaternion_position(X)
    return f"{pose_words(X)}, quaternion [{', '.join(f'{v:.6f}' for v in quaternion)}]"


class Page:
    """The page on a viser server at ``host``:``port`` (module docstring)."""

    def __init__(self, source: PageSource, host: str = LOCALHOST, port: int = DEFAULT_PORT):
        import viser

        self.source, self.robot, self.cell = source, source.robot, source.cell
        self.program = source.program
        self.X_WB = np.eye(4) if self.cell is None else self.cell.X_WB
        self.collision = None
        if self.cell is not None:
            from ..cell.collision import CollisionModel

            self.collision = CollisionModel(self.cell.load_robot(), self.cell)
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.host, self.port = host, self.server.get_port()
        self.scene = ArmScene(self.server, self.robot, source.tool, self.cell)
        limits = self.robot.limits
        start = self.program.waypoints[0].q if self.program.waypoints else np.zeros(self.robot.dof)
        self.q = np.clip(start, limits.q_min, limits.q_max)
        self.branches: TargetBranches | None = None
        self.update_seconds: list[float] = []
        self.outcome = None
        self.plan_error: str | None = None
        self._busy = threading.Lock()
        self._worker: threading.Thread | None = None
        self._syncing = False
        self._drag_lock, self._dragging, self._pending = threading.Lock(), False, None
        self._build_gui()
        self.set_joints(self.q)
        self.place_target(self.X_WB @ self.robot.fk(self.q))
        self._frame_camera()

    # -- the arm ---------------------------------------------------------------------------------------------
    def set_joints(self, q) -> None:
        """Jog to q (dof,) [rad or m], within the joint limits (ConfigurationError naming the joint)."""
        q = float_array(q, "q", (self.robot.dof,))
        limits = self.robot.limits
        outside = np.flatnonzero((q < limits.q_min - 1e-12) | (q > limits.q_max + 1e-12))
        if len(outside):
            j = int(outside[0])
            raise ConfigurationError(f"joint {j + 1} = {self._to_file_unit(j, q[j]):g} {self._unit(j)} is outside its "
                                     f"limits [{self._to_file_unit(j, limits.q_min[j]):g}, "
                                     f"{self._to_file_unit(j, limits.q_max[j]):g}] {self._unit(j)}")
        self.q = q.copy()
        self.scene.show(self.q)
        self._syncing = True
        try:
            for j, slider in enumerate(self.sliders):
                slider.value = round(self._to_file_unit(j, q[j]), 6)
        finally:
            self._syncing = False
        self.readout.content = self.tcp_readout()

    def tcp_readout(self) -> str:
        """The TCP pose in W, our branch name and the maker's configuration of the current q (markdown)."""
        names, vendor, texts = branch_names(self.robot, self.q[None])
        branch = f"  \nbranch **{names[0]}**" if names[0] else ""
        config = f" · {vendor} {texts[0]}" if vendor is not None else ""
        return f"**TCP** {pose_text(self.X_WB @ self.robot.fk(self.q))}{branch}{config}"

    # -- the target and its branches -------------------------------------------------------------------------
    def place_target(self, X_WT: np.ndarray) -> None:
        """Move the draggable target to X_WT (4, 4) [m] without computing its branches."""
        X_WT = check_pose(X_WT, "target X_WT")
        quaternion, position = pose_to_quaternion_position(X_WT)
        self.gizmo.wxyz, self.gizmo.position = quaternion, position

    def drag_target(self, X_WT: np.ndarray) -> TargetBranches:
        """Every IK branch of the TCP target X_WT (4, 4) [m]: drawn as ghost arms coloured by state and listed
        on the page (the time it took is kept in ``update_seconds``)."""
        start = time.perf_counter()
        X_BT = rigid_inverse(self.X_WB) @ check_pose(X_WT, "target X_WT")
        self.branches = target_branches(self.robot, X_BT, self.q, self.collision)
        self.scene.ghosts.show(self.branches.branches)
        self.branch_table.content = self._branch_markdown(self.branches)
        options = tuple(self._branch_option(k, b) for k, b in enumerate(self.branches.branches)) or ("(none)",)
        self.branch_choice.options = options
        self.update_seconds = (self.update_seconds + [time.perf_counter() - start])[-UPDATE_HISTORY:]
        return self.branches

    def adopt(self, k: int) -> None:
        """Jog the arm to branch k of the last target."""
        if self.branches is None or not 0 <= k < len(self.branches.branches):
            count = 0 if self.branches is None else len(self.branches.branches)
            raise ConfigurationError(f"branch {k + 1}: the target has {count} branch(es)")
        self.set_joints(self.branches.branches[k].q)

    # -- the program -----------------------------------------------------------------------------------------
    def add_waypoint(self, move: str, speed_text: str = "", zone_text: str = "") -> int:
        """Add the arm's current joint values as a ``move`` (joint, linear, circular) with the speed (% for
        joint moves, mm/s for tool moves) and zone [mm] as typed; an error names the field."""
        index = self.program.add_typed(self.q, move, speed_text, zone_text)
        self._show_program()
        return index

    def set_via(self, index: int) -> None:
        """The current joint values as the via point of circular move ``index``."""
        self.program.set_via(index, self.q)
        self._show_program()

    def plan_and_time(self, wait: bool = False):
        """Plan and time the program in a background thread (the page keeps answering); ``wait``: join it
        and return the JobOutcome (a PipelineError is raised then, else shown on the page)."""
        if not self._busy.acquire(blocking=False):
            raise ConfigurationError("planning and timing is already running")
        self.plan_error = None
        self.progress.visible, self.progress.animated = True, True
        self.status.content = "planning and timing ..."
        self._worker = threading.Thread(target=self._plan_and_time, name="page-plan", daemon=True)
        self._worker.start()
        if wait:
            self._worker.join()
            if self.plan_error is not None:
                raise ConfigurationError(self.plan_error)
            return self.outcome
        return None

    def _plan_and_time(self) -> None:
        try:
            self.outcome = self.program.plan_and_time()
            self._show_outcome(self.outcome)
        except PipelineError as error:
            self.plan_error = str(error)
            self.status.content = f"<span style='color:#c00'>{error}</span>"
        finally:
            self.progress.visible = False
            self._busy.release()

    def show_for_screenshot(self) -> None:
        """What a picture of the page shows: a program with moves planned and timed, the arm half way
        through it, and the branches of its last waypoint's TCP pose (else of the arm's own)."""
        X_WT = self.X_WB @ self.robot.fk(self.q)
        if len(self.program.waypoints) > 1:
            self.plan_and_time(wait=True)
            self.replay.value = round(self.replay.max / 2.0, 2)
            X_WT = self.X_WB @ self.robot.fk(self.program.waypoints[-1].q)
        self.place_target(X_WT)
        self.drag_target(X_WT)

    def save_job(self, path, replace: bool = False) -> Path:
        """The program as a job file that ``python -m pipeline run`` reproduces sample for sample (a file the
        package did not write is replaced only with ``replace``)."""
        return self.program.save(_file_path(path), replace)

    def export(self, language: str, folder, replace: bool = False) -> list[Path]:
        """The planned and timed program in a controller's language (rapid, ls, jbi, krl, urscript) as files
        NAME.<suffix> in ``folder`` (``pipeline.runner.program_texts``: the files ``python -m pipeline
        program`` writes); OutputError for a language that cannot move the robot (URScript on an arm that is not
        a Universal Robots one), ConfigurationError before the program is planned and timed."""
        from ..runner import check_language_arm, program_texts

        check_language_arm(self.robot, language)
        if self.outcome is None:
            raise ConfigurationError("plan and time the program first: the export is of the certified program")
        outcome = self.outcome
        texts = program_texts(outcome.job, language, outcome.program, outcome.profile)
        name = program_name(language, outcome.job.name)
        targets = {suffix: _file_path(Path(_file_path(folder)) / f"{name}{suffix}") for suffix in texts}
        for path in targets.values():
            prepare_file_target(path, replace)
        return [write_text_atomic(targets[suffix], text, replace) for suffix, text in texts.items()]

    def load_job(self, path) -> None:
        """Edit the program of a job file of the page's robot (and cell); another is refused, naming the
        command that opens it."""
        program = PageProgram.from_job_file(_file_path(path))
        job_cell = None if program.cell_reference is None else load_cell(resolve_cell_path(program.cell_reference))
        if program.robot.spec.name != self.robot.spec.name or (job_cell is None) != (self.cell is None) or (
                job_cell is not None and job_cell.name != self.cell.name):
            where = "" if job_cell is None else f" in cell {job_cell.name}"
            raise ConfigurationError(f"{path}: a job of {program.robot.spec.name}{where}; this page shows "
                                     f"{self.source.title}: open it with python -m pipeline ui {path}")
        self.program = program
        self._show_program()

    def stop(self) -> None:
        """Stop the server (waits for a running plan)."""
        if self._worker is not None:
            self._worker.join()
        self.server.stop()

    # -- what the page shows ---------------------------------------------------------------------------------
    def _unit(self, j: int) -> str:
        spec = self.robot.spec
        return spec.angle_unit if self.robot.revolute_mask[j] else spec.length_unit

    def _to_file_unit(self, j: int, value: float) -> float:
        scale = ANGLE_UNITS[self._unit(j)] if self.robot.revolute_mask[j] else LENGTH_UNITS[self._unit(j)]
        return float(value) / scale

    def _branch_option(self, k: int, branch) -> str:
        return f"{k + 1}: {branch.name or 'solution'} ({branch.state})"

    def _branch_markdown(self, view: TargetBranches) -> str:
        if not view.branches:
            return f"no branch: {view.reason}"
        rows = ["| # | branch | config | state | σmin | closest |", "|---|---|---|---|---|---|"]
        for k, b in enumerate(view.branches):
            rows.append(f"| {k + 1} | {b.name or '-'} | {b.vendor_config or '-'} | {b.state} | {b.sigma_min:.3g} | "
                        f"{closest_words(b.clearance)} |")
        return "\n".join(rows)

    def _show_program(self) -> None:
        lines = []
        for k, w in enumerate(self.program.waypoints):
            speed = "" if w.speed is None else (f" {w.speed * 100:g} %" if w.move == "joint" else f" {w.speed * 1e3:g} mm/s")
            zone = f" zone {w.zone * 1e3:g} mm" if w.zone > 0 else ""
            via = " (via set)" if w.via_q is not None else ""
            lines.append(f"{k}. {'start' if k == 0 else w.move}{speed}{zone}{via}")
        self.program_list.content = "\n".join(lines) if lines else "(no waypoints: jog the arm, then Add)"

    def _show_outcome(self, outcome) -> None:
        profile = outcome.profile
        self.status.content = f"```\n{outcome.summary()}\n```"
        t = profile.t - profile.t[0]
        keep = np.unique(np.linspace(0, len(t) - 1, min(len(t), PLOT_POINTS)).round().astype(int))
        for name, values in (("q", profile.q), ("qd", profile.qd), ("qdd", profile.qdd), ("jerk", profile.qddd)):
            self.plots[name].data = (t[keep], *values[keep].T)
        X_BT = self.robot.fk_batch(profile.q[keep])
        speed = np.linalg.norm(np.gradient(X_BT[:, :3, 3], t[keep], axis=0), axis=1)
        self.plots["tcp"].data = (t[keep], speed)
        self.scene.show_trace(X_BT[:, :3, 3] @ self.X_WB[:3, :3].T + self.X_WB[:3, 3])
        self.replay.max = float(t[-1])
        self.replay.value = 0.0

    def _replay_at(self, seconds: float) -> None:
        """The arm (and its sliders) where the certified profile is at ``seconds`` [s] from its start."""
        if self.outcome is None:
            return
        profile = self.outcome.profile
        t = profile.t - profile.t[0]
        self.set_joints(np.array([np.interp(seconds, t, profile.q[:, j]) for j in range(profile.dof)]))

    def _frame_camera(self) -> None:
        centres, radii = scene_spheres(self.robot, self.q[None], self.cell, self.source.tool)
        centres = centres @ self.X_WB[:3, :3].T + self.X_WB[:3, 3]
        position, target = camera_pose(centres, radii)
        self.server.initial_camera.position = tuple(position)
        self.server.initial_camera.look_at = tuple(target)

    # -- the controls ----------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui, robot = self.server.gui, self.robot
        gui.configure_theme(control_width="large")
        gui.add_markdown(f"**{self.source.title}** · {robot.name}")
        self.readout = gui.add_markdown("")
        with gui.add_folder("Joints"):
            self.sliders = []
            for j in range(robot.dof):
                low, high = (self._to_file_unit(j, v) for v in (robot.limits.q_min[j], robot.limits.q_max[j]))
                slider = gui.add_slider(f"J{j + 1} [{self._unit(j)}]", min=round(low, 6), max=round(high, 6),
                                        step=0.01 if self.robot.revolute_mask[j] else 0.001,
                                        initial_value=round(min(max(0.0, low), high), 6),
                                        hint=f"limits {low:g} .. {high:g} {self._unit(j)}")
                slider.on_update(lambda _event, j=j: self._slider_moved(j))
                self.sliders.append(slider)
        self.gizmo = self.server.scene.add_transform_controls("/target", scale=0.15)
        self.gizmo.on_update(lambda event: self._gizmo_moved())
        with gui.add_folder("Target: every IK branch"):
            self.snap_button = gui.add_button("Target to the TCP")
            self.snap_button.on_click(lambda _event: self._snap_target())
            self.branch_table = gui.add_markdown("drag the gizmo: each branch is drawn as a ghost arm")
            self.branch_choice = gui.add_dropdown("Branch", ("(none)",))
            self.adopt_button = gui.add_button("Adopt this branch")
            self.adopt_button.on_click(lambda _event: self._guarded(self.branch_error, lambda: self.adopt(
                int(self.branch_choice.value.split(":")[0]) - 1)))
            self.branch_error = gui.add_markdown("")
        for k, handle in enumerate(self.scene.ghosts.handles):
            handle.on_click(lambda _event, k=k: self._guarded(self.branch_error, lambda: self.adopt(k)))
        with gui.add_folder("Program"):
            self.move_kind = gui.add_dropdown("Move", MOVES, initial_value="joint")
            self.speed_text = gui.add_text("Speed (% or mm/s)", "")
            self.zone_text = gui.add_text("Zone [mm]", "")
            self.add_button = gui.add_button("Add the current pose")
            self.add_button.on_click(lambda _event: self._guarded(self.program_error, lambda: self.add_waypoint(
                self.move_kind.value, self.speed_text.value, self.zone_text.value)))
            self.index = gui.add_number("Waypoint #", 0, min=0, step=1)
            via = gui.add_button("Current pose as its via point")
            via.on_click(lambda _event: self._guarded(self.program_error, lambda: self.set_via(int(self.index.value))))
            order = gui.add_button_group("Reorder", ("Up", "Down", "Delete"))
            order.on_click(lambda event: self._guarded(self.program_error, lambda: self._reorder(event.target.value)))
            self.program_error = gui.add_markdown("")
            self.program_list = gui.add_markdown("")
            self.plan_button = gui.add_button("Plan and time")
            self.plan_button.on_click(lambda _event: self._guarded(self.program_error, self.plan_and_time))
            self.progress = gui.add_progress_bar(100.0, animated=True, visible=False)
            self.path_text = gui.add_text("Job file", f"{self.program.name}.yaml")
            files = gui.add_button_group("File", ("Save", "Load"))
            self.replace_box = gui.add_checkbox("Replace a file not written here", False)
            files.on_click(lambda event: self._guarded(self.program_error, lambda: self._file(event.target.value)))
            self.language = gui.add_dropdown("Controller", tuple(LANGUAGE_TITLES), initial_value="rapid",
                                             hint=", ".join(f"{k}: {v}" for k, v in LANGUAGE_TITLES.items()))
            self.export_button = gui.add_button("Export the program (beside the job file)")
            self.export_button.on_click(lambda _event: self._guarded(self.program_error, self._export))
        with gui.add_folder("Result"):
            self.status = gui.add_markdown("")
            self.replay = gui.add_slider("Replay [s]", min=0.0, max=1.0, step=1.0 / REPLAY_FPS, initial_value=0.0)
            self.replay.on_update(lambda _event: self._replay_at(self.replay.value))
            self.plots = {}
            from viser import uplot

            for name, title in (("q", "q"), ("qd", "qd"), ("qdd", "qdd"), ("jerk", "jerk")):
                series = (uplot.Series(label="t [s]"),
                          *(uplot.Series(label=f"J{j + 1}", stroke=_series_colour(j)) for j in range(robot.dof)))
                self.plots[name] = gui.add_uplot((np.zeros(2),) * (robot.dof + 1), series, title=title, aspect=2.0)
            self.plots["tcp"] = gui.add_uplot((np.zeros(2), np.zeros(2)), (uplot.Series(label="t [s]"), uplot.Series(
                label="TCP speed [m/s]", stroke="#c02890")), title="TCP speed", aspect=2.0)
        self._show_program()

    def _guarded(self, field, action) -> None:
        """Run a control's action; a PipelineError is shown in ``field`` (a markdown next to the control)."""
        try:
            action()
            field.content = ""
        except PipelineError as error:
            field.content = f"<span style='color:#c00'>{error}</span>"

    def _slider_moved(self, j: int) -> None:
        if self._syncing:
            return
        q = self.q.copy()
        scale = self._to_file_unit(j, 1.0)
        q[j] = float(self.sliders[j].value) / scale
        self.set_joints(np.clip(q, self.robot.limits.q_min, self.robot.limits.q_max))

    def _gizmo_moved(self) -> None:
        """A drag event: the newest target is drawn; events that arrive while one is drawn are merged into
        the newest (the browser sends them faster than a slow machine may draw them), one drawer at a time."""
        with self._drag_lock:
            self._pending = quaternion_position_to_pose(np.asarray(self.gizmo.wxyz), np.asarray(self.gizmo.position))
            if self._dragging:
                return
            self._dragging = True
        while True:
            with self._drag_lock:
                X_WT, self._pending = self._pending, None
                if X_WT is None:
                    self._dragging = False
                    return
            self.drag_target(X_WT)

    def _snap_target(self) -> None:
        X_WT = self.X_WB @ self.robot.fk(self.q)
        self.place_target(X_WT)
        self.drag_target(X_WT)

    def _reorder(self, action: str) -> None:
        k = int(self.index.value)
        if action == "Delete":
            self.program.delete(k)
        else:
            self.program.move_to(k, k - 1 if action == "Up" else k + 1)
            self.index.value = k - 1 if action == "Up" else k + 1
        self._show_program()

    def _export(self) -> None:
        files = self.export(self.language.value, Path(self.path_text.value).parent, self.replace_box.value)
        self.status.content = "wrote " + ", ".join(str(path) for path in files)

    def _file(self, action: str) -> None:
        if action == "Save":
            self.status.content = f"saved {self.save_job(self.path_text.value, self.replace_box.value)}"
        else:
            self.load_job(self.path_text.value)


def _file_path(path) -> Path:
    """A file or folder name typed on the page or handed to its API: text without NUL (ConfigurationError)."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip() or "\0" in str(path):
        raise ConfigurationError(f"a file name must be non-empty text, got {path!r}")
    return Path(path)


def _series_colour(j: int) -> str:
    """A distinct colour per joint (matplotlib's tab10)."""
    return ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")[j % 8]


def open_page(name: str | None = None, host: str = LOCALHOST, port: int = DEFAULT_PORT) -> Page:
    """The page of ``name`` (``load_source``) served on host:port."""
    return Page(load_source(name), host, port)
