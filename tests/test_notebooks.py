"""The notebooks in notebooks/: one per seed paper and one per topic (TOPICS: work cells and planning),
committed without outputs, on the public API (``import pipeline``) and without asserts of their own,
executed headless, and their key numbers checked here against expectations derived here (the seed
papers, models/SOURCES.md, our own FK, the demo cell): the notebooks explain, this file checks.

Each notebook runs in a fresh ``python3`` kernel of *this* interpreter (a kernel spec written into a
temporary JUPYTER_PATH, so no other installed kernel is picked up), with the repository first on
PYTHONPATH, in a temporary working directory, under a time-out, with ``MPLBACKEND=Agg`` and
``PIPELINE_NOTEBOOK_TEST=1`` (the notebooks then skip only the inline display of their Meshcat HTML).
Its last code cell, tagged ``key-numbers``, prints a JSON dict; ``CHECKS`` below judges it.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import pipeline
from pipeline import load_robot

from .model.test_seed_papers import SEED000_FIGURE15

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOK_DIR = ROOT / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
SEEDS = ("seed000", "seed001", "seed002", "seed003", "seed004")
#: Notebooks that follow a feature rather than a paper (their first cell is a "# title").
TOPICS = ("cells_and_planning", "reachability_irb1600")
#: Notebooks whose run takes long enough (a Dask map, 15 s; seed 003's three timings of its paths, 7 s)
#: to run in the slow suite only.
SLOW_NOTEBOOKS = ("reachability_irb1600", "seed003_irb1600_ik_velocity_trajectories", "cells_and_planning",
                  "seed004_arm6_standard_vs_modified", "seed000_gp7_jacobian_and_ik", "seed002_arm5_jacobian",
                  "seed001_gp7_dh_to_drake")
KEY_TAG = "key-numbers"
#: Per cell; the slowest cell (three timings of one path) takes a few seconds [s].
CELL_TIMEOUT_S = 300
KERNEL_STARTUP_TIMEOUT_S = 120

EXACT = 1e-12               # NumPy vs Drake, standard vs modified, paper formulas [m, rad, 1]
FINITE_DIFFERENCE = 1e-6    # vs central finite differences [m/rad, 1]
IK_RESIDUAL = 1e-5          # max |FK(q_ik) - X_target| entry, for methods verified at 1e-6 m / 1e-6 rad
RATIO_LIMIT = 1.0 + 1e-6    # certify()'s peak/limit ratio bound
MM = 1e-3
#: Joint axes at q = 0 of the GP7 and the LR Mate 200iD (models/SOURCES.md): J1 +z, J2 +y, J3 -y, J4 -x, J5 -y, J6 -x.
YASKAWA_FANUC_AXES = [[0, 0, 1], [0, 1, 0], [0, -1, 0], [-1, 0, 0], [0, -1, 0], [-1, 0, 0]]


def notebook_key(path: Path) -> str:
    """What a notebook's checks are filed under: ``seedNNN`` for a seed paper's, else its stem (a topic)."""
    return path.name[:7] if path.name.startswith("seed") else path.stem


# -- committed state ---------------------------------------------------------------------------------
def test_one_notebook_per_seed_paper_and_topic():
    seeds = [p.name[:7] for p in NOTEBOOKS if p.name.startswith("seed")]
    topics = [p.stem for p in NOTEBOOKS if not p.name.startswith("seed")]
    assert seeds == list(SEEDS) and topics == sorted(TOPICS), [p.name for p in NOTEBOOKS]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_committed_notebook_has_no_outputs(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    assert nb["metadata"]["kernelspec"]["name"] == "python3"
    assert (nb["nbformat"], nb["nbformat_minor"]) >= (4, 5) and all("id" in cell for cell in nb["cells"])
    first = nb["cells"][0]
    title = "".join(first["source"])
    assert first["cell_type"] == "markdown"
    assert f"Seed {path.name[4:7]}" in title if path.name.startswith("seed") else title.startswith("# ")
    for k, cell in enumerate(nb["cells"]):
        if cell["cell_type"] == "code":
            assert cell["outputs"] == [], f"{path.name}: cell {k} has outputs (clear them before committing)"
            assert cell["execution_count"] is None, f"{path.name}: cell {k} has an execution count"
    tagged = [c for c in nb["cells"] if KEY_TAG in c.get("metadata", {}).get("tags", [])]
    assert len(tagged) == 1 and tagged[0] is nb["cells"][-1], f"{path.name}: the last cell must be the one tagged {KEY_TAG}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_teaches_the_public_api_and_leaves_the_checks_here(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    for k, cell in enumerate(nb["cells"]):
        if cell["cell_type"] == "code":
            code = "".join(cell["source"])
            assert "from pipeline." not in code and "import pipeline." not in code, f"{path.name}: cell {k}"
            assert not re.search(r"^\s*assert\b|np\.testing\.assert", code, re.M), f"{path.name}: cell {k} asserts"
            used = set(re.findall(r"\bpipeline\.(\w+)", code)) - {"__file__"}
            assert used <= set(pipeline.__all__), f"{path.name}: cell {k} uses {used - set(pipeline.__all__)}"


# -- execution ---------------------------------------------------------------------------------------
@pytest.fixture
def kernel_env(tmp_path, monkeypatch):
    """A ``python3`` kernel spec for this interpreter, first on JUPYTER_PATH; the repository first on
    PYTHONPATH; Agg; the test flag; the system temp folder inside tmp_path."""
    spec_dir = tmp_path / "jupyter" / "kernels" / "python3"
    spec_dir.mkdir(parents=True)
    (spec_dir / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (this interpreter)", "language": "python",
    }))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PIPELINE_NOTEBOOK_TEST", "1")
    (tmp_path / "tmp").mkdir()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))     # the notebooks' scratch folders end with the test
    work = tmp_path / "work"
    work.mkdir()
    return work


def execute(path: Path, work: Path):
    """Run every cell of the notebook in a new kernel in ``work``; returns the executed notebook, with a
    last cell added that reports the kernel's interpreter and where it imported ``pipeline`` from."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(path, as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(
        "import json as _json, sys as _sys, pipeline as _pipeline\n"
        "print(_json.dumps({'executable': _sys.executable, 'pipeline': _pipeline.__file__}))"))
    client = nbclient.NotebookClient(nb, timeout=CELL_TIMEOUT_S, startup_timeout=KERNEL_STARTUP_TIMEOUT_S,
                                     kernel_name="python3", resources={"metadata": {"path": str(work)}})
    client.execute()
    return nb


def stdout_json(cell) -> dict:
    text = "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream" and o.name == "stdout")
    return json.loads(text)


@pytest.mark.parametrize("path", [pytest.param(p, id=p.stem, marks=[pytest.mark.slow] if p.stem in SLOW_NOTEBOOKS
                                                else []) for p in NOTEBOOKS])
def test_notebook_runs_and_its_key_numbers_hold(path, kernel_env):
    nb = execute(path, kernel_env)
    kernel = stdout_json(nb.cells[-1])
    assert kernel["executable"] == sys.executable
    assert Path(kernel["pipeline"]).resolve().is_relative_to(ROOT)
    assert not list(kernel_env.iterdir()), "a notebook wrote into its working directory"
    (tagged,) = [c for c in nb.cells if KEY_TAG in c.metadata.get("tags", [])]
    CHECKS[notebook_key(path)](stdout_json(tagged))


# -- independent expectations ------------------------------------------------------------------------
def check_comparisons(check: dict, passed) -> None:
    """Jacobian-check worst errors: analytic vs Drake to round-off, both vs finite differences."""
    assert passed is True or all(passed.values())
    assert check["analytic vs Drake"] <= EXACT
    assert check["analytic vs finite diff"] <= FINITE_DIFFERENCE
    assert check["Drake vs finite diff"] <= FINITE_DIFFERENCE


def check_ik(name: str, numbers: dict) -> None:
    """Every method succeeded; every closed-form solution, re-checked here by FK, reaches the target
    inside the limits, the solutions are distinct, and the true configuration is among them."""
    robot = load_robot(name)
    q_true = np.radians(numbers["ik_target_q_deg"])
    X_target = robot.fk(q_true)
    assert all(numbers["ik_success"].values()) and set(numbers["ik_success"]) == {"analytic", "jacobian", "drake"}
    assert max(numbers["ik_fk_residual_m"].values()) <= IK_RESIDUAL
    Q = np.radians(numbers["ik_analytic_solutions_deg"])
    for q in Q:
        np.testing.assert_allclose(robot.fk(q), X_target, atol=1e-9)
        assert np.all(q >= robot.limits.q_min - 1e-12) and np.all(q <= robot.limits.q_max + 1e-12)
    gaps = [np.abs(Q[i] - Q[j]).max() for i in range(len(Q)) for j in range(i)]
    assert min(gaps, default=1.0) > 1e-6
    assert np.abs(Q - q_true).max(axis=1).min() < 1e-9


def check_profile(timing: dict, waypoints, jerk_limited: bool) -> None:
    """Certified: every peak/limit ratio <= 1 (+1e-6), at rest at both ends, on the first and last waypoint."""
    assert timing["passed"] is True and timing["duration_s"] > 0.0
    ratios = timing["max_ratio"]
    assert {"q", "qd", "qdd"} <= set(ratios) and ("qddd" in ratios) == jerk_limited
    assert max(ratios.values()) <= RATIO_LIMIT
    np.testing.assert_allclose(timing["start_q"], waypoints[0], atol=1e-9)
    np.testing.assert_allclose(timing["end_q"], waypoints[-1], atol=1e-9)
    assert timing["end_qd_max"] <= 1e-9


def check_seed000(n: dict) -> None:
    np.testing.assert_allclose(n["gp7_flange_at_zero_mm"], [560, 0, 815], atol=1e-9)
    np.testing.assert_allclose(n["gp7_flange_z_x_at_zero"], [[1, 0, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(n["lrmate_flange_at_zero_mm"], [465, 0, 695], atol=1e-9)
    np.testing.assert_allclose(n["gp7_joint_axes_at_zero"], YASKAWA_FANUC_AXES, atol=1e-12)
    np.testing.assert_allclose(n["lrmate_joint_axes_at_zero"], YASKAWA_FANUC_AXES, atol=1e-12)
    # Figure 13 is what Figure 12's rows give; Figure 15 is their element-wise product, not a Jacobian.
    np.testing.assert_allclose(n["figure13_position_mm"], [-485, -40, 770], atol=1e-9)
    np.testing.assert_allclose(n["elementwise_product_mm"], SEED000_FIGURE15, atol=1e-9)
    v_dot_w = np.einsum("ij,ij->j", SEED000_FIGURE15[:3], SEED000_FIGURE15[3:])
    np.testing.assert_allclose(n["figure15_v_dot_w_mm"], v_dot_w)
    assert np.count_nonzero(v_dot_w) == 5                      # five columns impossible for a revolute joint
    assert n["gp7_max_v_dot_w_m"] < 1e-14                      # ours: v is always perpendicular to w
    for name in ("gp7", "lrmate200id"):
        check_comparisons(n["check"][name], n["check_passed"][name])
    assert n["gp7_rank_at_zero"] == 5                          # wrist singular at q5 = 0
    check_ik("gp7", n)
    assert n["ik_analytic_branches_reachable"] == 8
    for name in ("gp7", "lrmate200id"):
        successes = n["ik_batch_successes_of_20"][name]
        assert successes["analytic"] == 20 and successes["jacobian"] == 20
        assert successes["drake"] >= 18                        # Drake's solve may miss one: reported, not wrong


def check_seed001(n: dict) -> None:
    assert n["fk_standard_vs_modified_max"] <= EXACT
    assert n["jacobian_standard_vs_modified_max"] <= EXACT
    # Modified row i carries standard row i-1's a, alpha (GP7: a 40, 445, 40, 0, 0, 0; alpha -90, 0, -90, -90, 90, 0).
    np.testing.assert_allclose(n["modified_a_prev_mm"], [0, 40, 445, 40, 0, 0], atol=1e-9)
    np.testing.assert_allclose(n["modified_alpha_prev_deg"], [0, -90, 0, -90, -90, 90], atol=1e-9)
    for pose in (*n["flange_at_zero_mm"].values(), *n["drake_flange_at_zero_mm"].values()):
        np.testing.assert_allclose(pose, [560, 0, 815], atol=1e-9)
    np.testing.assert_allclose(n["joint_axes_at_zero"], YASKAWA_FANUC_AXES, atol=1e-12)
    assert n["drake_positions"] == 6 and n["drake_bodies"] == 8   # the world, six links and the payload body
    np.testing.assert_allclose(n["drake_position_limits_deg"],
                               [[-170, -65, -70, -190, -135, -360], [170, 145, 190, 190, 135, 360]], atol=1e-9)
    np.testing.assert_allclose(n["drake_velocity_limits_deg_s"], [375, 315, 410, 550, 550, 1000], atol=1e-9)
    for name in ("standard", "modified"):
        check_comparisons(n["check"][name], n["check_passed"][name])
    for pose in n["paper_table2_end_mm"].values():               # Table 2 as printed gives neither pose
        assert np.linalg.norm(np.subtract(pose, [40, -400, 330])) > 100
        assert np.linalg.norm(np.subtract(pose, [560, 0, 815])) > 100


def check_seed002(n: dict) -> None:
    a2, a3, d5_dE = 450 * MM, 350 * MM, 80 * MM
    np.testing.assert_allclose(n["end_at_zero_mm"], [450, 0, 300 - 350 - 80], atol=1e-9)
    linear = np.array([[0, a2, 0], [a3 + d5_dE, 0, a2], [a3 + d5_dE, 0, 0], [d5_dE, 0, 0], [0, 0, 0]]).T  # eqs. 46-50
    angular = np.array([[0, 0, 1], [0, -1, 0], [0, -1, 0], [0, -1, 0], [0, 0, -1]]).T                    # eqs. 51-53
    np.testing.assert_allclose(n["jacobian_at_zero"], np.vstack([linear, angular]), atol=1e-15)
    assert n["rank_at_zero"] == 5
    # Eqs. 36 and 38 (wrist point), written out here from the paper.
    q1, q2, q3, q4, _ = n["wrist_q_rad"]
    s1, c1, s2, c2, s23, c23 = math.sin(q1), math.cos(q1), math.sin(q2), math.cos(q2), math.sin(q2 + q3), math.cos(q2 + q3)
    reach = c2 * a2 + s23 * a3
    eq36 = [[-s1 * reach, c1 * (c23 * a3 - s2 * a2), c1 * c23 * a3, 0, 0],
            [c1 * reach, s1 * (c23 * a3 - s2 * a2), s1 * c23 * a3, 0, 0],
            [0, reach, s23 * a3, 0, 0]]
    plus, minus = q1 + q2 + q3 + q4, q2 - q1 + q3 + q4
    eq38 = [[0, s1, s1, s1, (math.sin(plus) + math.sin(minus)) / 2],
            [0, -c1, -c1, -c1, (math.cos(minus) - math.cos(plus)) / 2],
            [1, 0, 0, 0, -math.cos(q2 + q3 + q4)]]                # eq. 40 prints 0 here
    np.testing.assert_allclose(n["wrist_jacobian"], np.vstack([eq36, eq38]), atol=EXACT)
    assert abs(n["wrist_jacobian"][5][4]) > 0.5
    assert n["wrist_vs_eq36_max"] <= EXACT and n["wrist_vs_eq38_max"] <= EXACT
    assert n["finite_difference_at_q_max"] <= FINITE_DIFFERENCE
    check_comparisons(n["check"], n["check_passed"])


def check_seed003(n: dict) -> None:
    np.testing.assert_allclose(n["flange_at_zero_mm"], [815, 0, 961.5], atol=1e-9)
    # z_flange = +x_base, x_flange = -z_base: +90 deg about y, [w, x, y, z].
    np.testing.assert_allclose(n["quaternion_at_zero"], [math.sqrt(0.5), 0, math.sqrt(0.5), 0], atol=1e-12)
    assert n["quaternion_round_trip_error"] <= EXACT
    assert n["equation_12_max_error"] > 0.1                      # eq. 12 as printed has two sign errors
    assert n["max_speeds_deg_s"] == pytest.approx([150, 160, 170, 320, 400, 450])
    assert 180 not in [round(v) for v in n["max_speeds_deg_s"]]  # the paper's "180 deg/s"
    # Reach at the wrist centre from axis 1: a1 + a2 + d4 stretched; "about 1.2 m" (the paper; models/SOURCES.md).
    assert n["reach_wrist_centre_stretched_m"] == pytest.approx(0.150 + 0.475 + 0.600, abs=1e-12)
    assert 1.1 <= n["reach_wrist_centre_stretched_m"] <= 1.3
    assert 1.2 <= n["reach_wrist_centre_sampled_m"] <= n["reach_wrist_centre_stretched_m"] + 1e-12
    check_ik("irb1600", n)
    assert n["ik_analytic_branches_reachable"] == 4               # shoulder back is out of reach for this pose
    assert all(label.startswith("shoulder front") for label in n["ik_analytic_branch_labels"])
    assert len(n["ik_analytic_branch_labels"]) == 4
    assert n["ik_batch_successes_of_20"] == 20
    assert n["inverse_velocity_vs_inverse_jacobian_max"] <= EXACT and n["inverse_velocity_residual"] <= EXACT
    assert n["inverse_velocity_near_singular"] == {"regular": False, "zero": True}
    assert n["dependent_joints_at_zero"] == [[3, 5]]             # J4 and J6 aligned at q5 = 0
    waypoints = n["waypoints_rad"]
    assert set(n["timing"]) == {"toppra", "ruckig", "topp3"}
    check_profile(n["timing"]["toppra"], waypoints, jerk_limited=False)
    check_profile(n["timing"]["ruckig"], waypoints, jerk_limited=True)
    check_profile(n["timing"]["topp3"], waypoints, jerk_limited=True)
    assert n["topp3_path_deviation"] == 0.0 and n["jerk_reversals_per_s"]["topp3"] <= 5.0
    assert n["html_bytes"] > 10_000
    tool = n["tool_moves"]                                       # the demo job irb1600_tool_moves
    assert tool["passed"] and max(tool["max_ratio"].values()) <= RATIO_LIMIT
    assert tool["tcp_speed_max_m_s"] == pytest.approx(0.4) and tool["tcp_accel_max_m_s2"] == pytest.approx(2.0)
    assert tool["peak_tcp_speed_m_s"] >= 0.99 * tool["tcp_speed_max_m_s"]   # it cruises at the TCP limit
    assert tool["top_edge_samples"] > 50 and tool["top_edge_error_mm"] <= 0.1   # on the line between the zones
    assert tool["max_path_error_m"] <= 1e-4
    assert tool["stretches"] == 2 and tool["tracks"] == 2       # stops at waypoint 4 (the rectangle) and at the end


def check_seed004(n: dict) -> None:
    np.testing.assert_allclose(n["flange_at_zero_m"], [0.22, 0, 0.305 - 0.352 - 0.1315], atol=1e-12)
    assert n["fk_standard_vs_modified_max"] <= EXACT and n["jacobian_standard_vs_modified_max"] <= EXACT
    np.testing.assert_allclose(n["modified_a_prev_m"], [0, 0, 0.22, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(n["modified_alpha_prev_deg"], [0, 90, 0, 90, 90, -90], atol=1e-9)
    assert n["drake_bodies"] == 8 and n["drake_joint_names"] == ["J1", "J2", "J3", "J4", "J5", "J6"]
    for name in ("standard", "modified"):
        check_comparisons(n["check"][name], n["check_passed"][name])
    assert n["wrist_axis_miss_m"] <= EXACT
    check_ik("arm6", n)
    assert n["ik_analytic_branches_reachable"] == 8 and len(n["ik_analytic_branch_labels"]) == 8
    # Eq. 8 (theta1 from the flange position) misses q1 for a general pose.
    robot = load_robot("arm6")
    p = robot.fk(np.radians(n["ik_target_q_deg"]))[:3, 3]
    assert n["equation_8_theta1_deg"] == pytest.approx(math.degrees(math.atan(p[1] / p[0])), abs=1e-9)
    assert abs(n["equation_8_theta1_deg"] - n["ik_target_q_deg"][0]) > 1.0
    check_profile(n["timing"], n["waypoints_rad"], jerk_limited=True)
    assert n["html_bytes"] > 10_000


def _tcp_pointing_down(yaw_deg: float, xyz_mm) -> np.ndarray:
    """The pose rpy (180, 0, yaw) deg at xyz [mm], written out: R = Rz(yaw) Rx(180 deg)."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    X = np.eye(4)
    X[:3, :3] = [[c, s, 0], [s, -c, 0], [0, 0, -1]]
    X[:3, 3] = np.asarray(xyz_mm) * MM
    return X


def check_cells_and_planning(n: dict) -> None:
    """The demo wall cell as its file says; the IK answers reach the demo job's poses above the pick and
    the place (TCP 120 mm out of the flange) and are free; the direct move between them is refused for
    the wall; the planned path runs from the one to the other along edges this test's own collision model
    finds free; its profile is certified, within the limits, at rest at both ends, and keeps the clearance
    on every sample. The demo job's program: both joint moves planned by the detour over the wall, from
    and to their waypoints along free edges; stops only where the job has no zone; its cycle report adds
    up to its certified profile, above the lower bound, and the transfer never rests; the run of the same
    job gives the same duration, program and verdicts."""
    cell = pipeline.load_cell(ROOT / "models" / "cells" / "gp7_wall_cell.yaml")
    robot = cell.load_robot()
    model = pipeline.CollisionModel(robot, cell)
    clearance = 10 * MM
    assert n["cell"] == "gp7_wall_cell" and n["robot"] == "gp7" and n["clearance_m"] == pytest.approx(clearance)
    assert n["objects"] == ["table", "wall", "floor"] and n["home_free"] is True
    assert ["link1", "floor"] in n["filtered_pairs"] and ["link4", "link6"] in n["filtered_pairs"]
    # The poses of the demo job's waypoints 0 and 3 and its tool.
    np.testing.assert_allclose(n["tool_xyz_m"], [0, 0, 120 * MM], atol=1e-15)
    np.testing.assert_allclose(n["targets"]["pick"], _tcp_pointing_down(30, [550, 300, 400]), atol=1e-12)
    np.testing.assert_allclose(n["targets"]["place"], _tcp_pointing_down(-30, [550, -300, 400]), atol=1e-12)
    X_ET = np.eye(4)
    X_ET[:3, 3] = n["tool_xyz_m"]
    tcp = pipeline.robot_with_tool(robot, X_ET)
    q_pick, q_place = np.array(n["q_pick_rad"]), np.array(n["q_place_rad"])
    for q, X in ((q_pick, n["targets"]["pick"]), (q_place, n["targets"]["place"])):
        np.testing.assert_allclose(tcp.fk(q), X, atol=1e-9)
        assert np.all(q >= robot.limits.q_min) and np.all(q <= robot.limits.q_max) and model.is_free(q)
    for counts in n["ik_counts"].values():
        assert 1 <= counts["free"] <= counts["all"]
    # The direct move: refused for the wall, and it does go into it.
    direct = n["direct"]
    assert direct["passed"] is False and direct["clearance_passed"] is False and "wall" in direct["pair"]
    assert direct["within_limits"] is True and direct["failed_at_s"] is not None   # refused for the wall alone
    assert direct["plain_min_distance_m"] < clearance and not model.edge_is_free(q_pick, q_place)
    # The planned path: from the pick to the place exactly, every edge free here too.
    plan = n["plan"]
    vertices = np.array(plan["vertices_rad"])
    assert plan["planner"] == "detour" and len(vertices) >= 3           # over the wall, found before any search
    check_planned_vertices(model, vertices, q_pick, q_place)
    length = float(np.linalg.norm(np.diff(vertices, axis=0), axis=1).sum())
    assert plan["length_after_rad"] == pytest.approx(length, rel=1e-12) == plan["length_before_rad"]
    assert np.linalg.norm(q_place - q_pick) < plan["length_after_rad"]
    # Its profile.
    planned = n["planned"]
    assert planned["passed"] is True and planned["clearance"]["passed"] is True and planned["duration_s"] > 0
    assert planned["clearance"]["min_distance_m"] >= clearance and planned["plain_min_distance_m"] >= clearance
    assert planned["clearance"]["pair"][1] in n["objects"] and planned["clearance"]["self_min_distance_m"] > 0
    assert max(planned["max_ratio"].values()) <= RATIO_LIMIT
    np.testing.assert_allclose(planned["start_q"], q_pick, atol=1e-9)
    np.testing.assert_allclose(planned["end_q"], q_place, atol=1e-9)
    assert planned["end_qd_max"] <= 1e-9
    check_demo_program(model, n["program"])
    # The demo job, run in the notebook: the same program, duration and verdicts.
    job, program = n["job"], n["program"]
    assert job["passed"] is True and max(job["max_ratio"].values()) <= RATIO_LIMIT
    assert job["duration_s"] == program["duration_s"] == job["cycle"]["cycle_s"]
    assert job["cycle"] == program["cycle"]
    assert [p and (p["planner"], p["vertices"]) for p in job["planned"]] == [
        p and (p["planner"], len(p["vertices_rad"])) for p in program["planned"]]
    for mine, theirs in zip(program["planned"], job["planned"]):
        if mine is not None:
            np.testing.assert_allclose(theirs["vertices_q"], mine["vertices_rad"], rtol=0, atol=1e-12)
    section = job["cell"]
    assert section["name"] == "gp7_wall_cell" and section["plan"] == "collision_free"
    assert Path(section["file"]).resolve() == (ROOT / "models" / "cells" / "gp7_wall_cell.yaml").resolve()
    assert section["clearance"]["passed"] is True and section["clearance"]["min_distance_m"] >= clearance
    assert section["clearance"]["clearance_m"] == pytest.approx(clearance)
    assert "report.json" in job["files"] and "profile.csv" in job["files"]


def check_planned_vertices(model, vertices: np.ndarray, q_from, q_to) -> None:
    """A planned path from ``q_from`` to ``q_to`` exactly, every edge free in the test's own model."""
    np.testing.assert_array_equal(vertices[[0, -1]], [q_from, q_to])
    assert all(model.edge_is_free(a, b) for a, b in zip(vertices[:-1], vertices[1:]))


def check_demo_program(model, program: dict) -> None:
    """The demo job gp7_cell_pick_place as a program: tool moves at the pick and the place, the two joint
    moves over the wall planned by the detour, stops at the pick, the place and the ends only (the 75 mm
    zones); certified; the cycle report's moves add up to the profile, above the bound; the transfer
    over the wall (zones at both its ends) never at rest."""
    assert program["kinds"] == ["linear", "linear", "joint", "linear", "linear", "joint"]
    assert program["stops"] == [0, 1, 4, 6]
    targets = np.array(program["targets_rad"])
    planners = [p and p["planner"] for p in program["planned"]]
    assert planners == [None, None, "detour", None, None, "detour"]
    for k, planned in enumerate(program["planned"]):
        if planned is not None:
            vertices = np.array(planned["vertices_rad"])
            assert len(vertices) >= 3
            check_planned_vertices(model, vertices, targets[k], targets[k + 1])
    assert program["passed"] is True and max(program["max_ratio"].values()) <= RATIO_LIMIT
    cycle = program["cycle"]
    assert cycle["cycle_s"] == program["duration_s"] and cycle["lower_bound_s"] == program["lower_bound_s"]
    assert [(m["from"], m["to"], m["kind"]) for m in cycle["moves"]] == [
        (k, k + 1, kind) for k, kind in enumerate(program["kinds"])]
    assert sum(m["duration_s"] for m in cycle["moves"]) == pytest.approx(cycle["cycle_s"], abs=1e-9)
    assert all(m["duration_s"] > 0 and m["binding"] for m in cycle["moves"])
    assert 0 < program["lower_bound_s"] < cycle["cycle_s"]
    assert cycle["ratio"] == pytest.approx(cycle["cycle_s"] / cycle["lower_bound_s"], rel=1e-12)
    assert program["transfer_min_speed_rad_s"] > 0.1          # no stop over the wall [rad/s]


def check_reachability_irb1600(n: dict) -> None:
    """The IRB 1600's map on 2 Dask workers: its wrist centre's reach is the datasheet's 1.2 m to 2 % and
    to its rounding, never beyond the stretched arm's a1 + a2 + d4 (models/SOURCES.md), short of it by
    less than a voxel diagonal; the flange reaches farther, by at most d6; the files are all there."""
    stretched = (150 + 475 + 600) * MM
    assert n["robot"] == "irb1600" and n["workers"] == n["flange_workers"] == 2 and n["orientations"] == 8
    assert n["poses"] > 100_000
    assert n["stretched_m"] == pytest.approx(stretched, abs=1e-12) and n["datasheet_reach_m"] == 1.2
    reach = n["wrist_reach_m"]
    assert stretched - n["step_m"] * math.sqrt(3) <= reach <= stretched + 1e-9
    assert abs(reach - 1.2) <= 0.02 * 1.2 and round(reach, 1) == 1.2
    assert reach < n["flange_reach_m"] <= stretched + 65 * MM + 1e-9
    assert n["fraction_range"] == [0.0, 1.0]
    volumes = list(n["volume_m3"].values())
    assert volumes == sorted(volumes, reverse=True) and volumes[0] > 1.0
    assert n["files"] == ["map.html", "map.npz", "slices.png", "summary.json"]
    assert n["npz_fraction_equal"] is True and n["npz_x_unit"] == "m"


CHECKS = {"seed000": check_seed000, "seed001": check_seed001, "seed002": check_seed002,
          "seed003": check_seed003, "seed004": check_seed004, "cells_and_planning": check_cells_and_planning,
          "reachability_irb1600": check_reachability_irb1600}
