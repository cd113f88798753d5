"""URDF out and in, checked against parsers that are not ours (Drake's, yourdfpy's).

Out: every preset -> URDF -> Drake's parser (strict: a warning fails) -> FK at tool0 equal to ours.
In: URDFs written from the ROS-Industrial support packages (tests/data/urdf, sources in their headers)
-> robot file -> FK equal to the URDF's own (Drake) at tool0; random chains with parallel,
intersecting, prismatic and fixed joints; typed errors for what DH cannot be.
"""

from __future__ import annotations

import logging
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from pipeline import load_robot
from pipeline.errors import UrdfChainError, UrdfFileError
from pipeline.files.robot_spec import preset_names
from pipeline.model.chain.drake_model import build_plant
from pipeline.model.chain.kinematics import rotation_log
from pipeline.urdf import import_urdf, urdf_text, write_urdf

from ..conftest import DATA_DIR

URDF_DIR = DATA_DIR / "urdf"
CONFIGURATIONS = 500
FK_TOLERANCE = 1e-12


class UrdfPlant:
    """A URDF parsed by Drake (strict parsing: any warning is an error), its root link welded to the
    world unless it is Drake's ``world``; FK of ``tip`` in ``base``."""

    def __init__(self, text: str, joint_names: list[str], base: str = "base_link", tip: str = "tool0",
                 root: str | None = "base_link"):
        self.plant = MultibodyPlant(0.0)
        parser = Parser(self.plant)
        parser.SetStrictParsing()
        parser.AddModelsFromString(text, "urdf")
        if root is not None:
            self.plant.WeldFrames(self.plant.world_frame(), self.plant.GetFrameByName(root))
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.joints = [self.plant.GetJointByName(name) for name in joint_names]
        self.base, self.tip = self.plant.GetFrameByName(base), self.plant.GetFrameByName(tip)

    def set(self, q) -> None:
        for joint, value in zip(self.joints, q):
            (joint.set_angle if hasattr(joint, "set_angle") else joint.set_translation)(self.context, value)

    def fk(self, q) -> np.ndarray:
        self.set(q)
        return self.tip.CalcPose(self.context, self.base).GetAsMatrix4()

    def mass_matrix(self, q) -> np.ndarray:
        self.set(q)
        return self.plant.CalcMassMatrix(self.context)


def worst_fk_difference(robot, plant: UrdfPlant, count: int = CONFIGURATIONS, seed: int = 0) -> float:
    Q = robot.random_configurations(np.random.default_rng(seed), count)
    return max(float(np.abs(robot.fk(q) - plant.fk(q)).max()) for q in Q)


# -- out ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", preset_names())
def test_exported_urdf_parses_in_drake_with_our_fk(name):
    robot = load_robot(name)
    plant = UrdfPlant(urdf_text(robot.spec), robot.joint_names)
    assert worst_fk_difference(robot, plant) < FK_TOLERANCE


@pytest.mark.parametrize("name", preset_names())
def test_exported_urdf_carries_names_limits_and_ros_frames(name, tmp_path):
    robot = load_robot(name)
    path = write_urdf(robot, tmp_path / f"{name}.urdf")
    plant = UrdfPlant(path.read_text(), robot.joint_names).plant
    for joint, spec in zip((plant.GetJointByName(n) for n in robot.joint_names), robot.spec.joints):
        assert joint.position_lower_limits()[0] == spec.q_min and joint.position_upper_limits()[0] == spec.q_max
        assert joint.velocity_upper_limits()[0] == spec.qd_max
    assert plant.HasFrameNamed("base_link") and plant.HasFrameNamed("tool0")


@pytest.mark.parametrize("name", preset_names())
def test_exported_urdf_loads_in_yourdfpy_without_a_warning_and_agrees(name, tmp_path, caplog):
    yourdfpy = pytest.importorskip("yourdfpy")
    robot = load_robot(name)
    path = write_urdf(robot, tmp_path / f"{name}.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with caplog.at_level(logging.WARNING):
            model = yourdfpy.URDF.load(str(path))
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert model.validate()
    for q in robot.random_configurations(np.random.default_rng(1), 50):
        model.update_cfg(dict(zip(robot.joint_names, q)))
        assert np.abs(model.get_transform("tool0", "base_link") - robot.fk(q)).max() < FK_TOLERANCE


def test_exported_inertias_give_drakes_mass_matrix_of_our_plant():
    robot = load_robot(DATA_DIR / "arm2_dynamics.yaml")
    exported = UrdfPlant(urdf_text(robot.spec), robot.joint_names)
    ours = build_plant(robot.spec)
    context = ours.CreateDefaultContext()
    for q in robot.random_configurations(np.random.default_rng(2), 20):
        ours.SetPositions(context, q)
        assert np.allclose(exported.mass_matrix(q), ours.CalcMassMatrix(context), rtol=1e-12, atol=1e-12)


# -- round trip ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("name", preset_names())
def test_robot_file_to_urdf_to_robot_file_keeps_the_fk(name, convention, tmp_path):
    robot = load_robot(name)
    path = write_urdf(robot, tmp_path / f"{name}.urdf")
    imported = import_urdf(path, convention=convention)
    written = load_robot(imported.write(tmp_path / f"{name}.yaml"))
    assert written.spec.convention == convention and written.joint_names == robot.joint_names
    Q = robot.random_configurations(np.random.default_rng(3), CONFIGURATIONS)
    assert max(float(np.abs(written.fk(q) - robot.fk(q)).max()) for q in Q) < FK_TOLERANCE
    assert np.allclose(written.limits.q_min, robot.limits.q_min, rtol=0, atol=1e-13)
    assert np.allclose(written.limits.qd_max, robot.limits.qd_max, rtol=1e-14)


# -- in: ROS-Industrial descriptions ----------------------------------------------------------------------
#: From the manufacturers' zero poses as the ROS-Industrial descriptions define them (models/SOURCES.md):
#: joint axes at q = 0 in the base frame, flange origin [m], flange z and x axes.
ROS_FACTS = {
    "motoman_gp7": dict(preset="gp7", axes=[[0, 0, 1], [0, 1, 0], [0, -1, 0], [-1, 0, 0], [0, -1, 0], [-1, 0, 0]],
                        flange=[0.560, 0.0, 0.815], z=[1, 0, 0], x=[0, 0, 1]),
    "abb_irb1600_6_12": dict(preset="irb1600", axes=[[0, 0, 1], [0, 1, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0]],
                             flange=[0.815, 0.0, 0.9615], z=[1, 0, 0], x=[0, 0, -1]),
}


@pytest.mark.parametrize("name", ["motoman_gp7", "abb_irb1600_6_12", "ur5"])
def test_imported_ros_industrial_urdf_has_the_urdfs_own_fk(name, tmp_path):
    path = URDF_DIR / f"{name}.urdf"
    imported = import_urdf(path)
    robot = load_robot(imported.write(tmp_path / f"{name}.yaml"))
    plant = UrdfPlant(path.read_text(), robot.joint_names)
    assert worst_fk_difference(robot, plant) < FK_TOLERANCE
    assert imported.max_fk_error_m < FK_TOLERANCE


@pytest.mark.parametrize("name", sorted(ROS_FACTS))
def test_imported_ros_industrial_robot_meets_the_published_facts_and_our_preset(name):
    facts = ROS_FACTS[name]
    robot = import_urdf(URDF_DIR / f"{name}.urdf").robot
    joint_frames, X_BE = robot.joint_frames(np.zeros((1, robot.dof)))
    assert np.allclose(joint_frames[0, :, :3, 2], facts["axes"], atol=1e-12)   # z of each joint frame = its axis
    assert np.allclose(X_BE[0, :3, 3], facts["flange"], atol=1e-12)
    assert np.allclose(X_BE[0, :3, 2], facts["z"], atol=1e-5)   # the URDFs write pi/2 as 1.570796 or 1.57079
    assert np.allclose(X_BE[0, :3, 0], facts["x"], atol=1e-5)
    preset = load_robot(facts["preset"])
    for q in preset.random_configurations(np.random.default_rng(4), 200):
        ours, theirs = preset.fk(q), robot.fk(q)
        assert np.abs(ours[:3, 3] - theirs[:3, 3]).max() < 1e-12
        assert np.linalg.norm(rotation_log(ours[:3, :3].T @ theirs[:3, :3])) < 1e-5


def test_ur5_parallel_axes_get_the_conventional_rows_and_its_inertias():
    imported = import_urdf(URDF_DIR / "ur5.urdf")
    rows = imported.document["joints"]
    assert [rows[i]["alpha"] for i in (1, 2)] == [0.0, 0.0]            # joints 2-4 parallel
    assert [rows[i]["d"] for i in (1, 2)] == [0.0, 0.0]                # normal through the previous origin
    assert [rows[i]["a"] for i in (1, 2)] == [425.0, 392.25]
    assert rows[0]["d"] == 89.159 and rows[3]["d"] == 109.15 and rows[4]["d"] == 94.65 and rows[5]["d"] == 82.3
    assert [row["tau_max"] for row in rows] == [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]
    robot = imported.robot
    urdf = UrdfPlant((URDF_DIR / "ur5.urdf").read_text(), robot.joint_names)
    ours = build_plant(robot.spec)
    context = ours.CreateDefaultContext()
    for q in robot.random_configurations(np.random.default_rng(5), 20):
        ours.SetPositions(context, q)
        assert np.allclose(ours.CalcMassMatrix(context), urdf.mass_matrix(q), rtol=1e-12, atol=1e-12)


def test_gp7_wrist_axes_intersect_and_fixed_side_frames_are_ignored():
    imported = import_urdf(URDF_DIR / "motoman_gp7.urdf")
    rows = imported.document["joints"]
    assert [rows[i]["a"] for i in (3, 4)] == [0.0, 0.0] and rows[4]["d"] == 0.0      # one wrist centre
    assert imported.chain.base == "base_link" and imported.chain.tip == "tool0" and imported.chain.ignored == ()
    assert any("tau_max" in note for note in imported.document["assumptions"])          # efforts, no inertias


# -- in: random chains ----------------------------------------------------------------------------------
def random_chain_urdf(rng: np.random.Generator, dof: int) -> str:
    """A serial URDF under a ``world`` root: joints of random kind, origin and axis, drawn so that
    parallel, intersecting and collinear axes occur often; fixed joints between some of them."""
    def pose():
        if rng.random() < 0.75:         # right angles and round offsets: parallel and intersecting axes
            xyz = rng.choice([0.0, 0.0, 0.1, -0.25, 0.4], size=3)
            rpy = rng.choice([0.0, np.pi / 2, -np.pi / 2, np.pi], size=3)
        else:
            xyz, rpy = rng.uniform(-0.4, 0.4, 3), rng.uniform(-np.pi, np.pi, 3)
        return " ".join(repr(float(v)) for v in xyz), " ".join(repr(float(v)) for v in rpy)

    lines = ['<robot name="random">', '<link name="world"/>', '<link name="base_link"/>',
             '<joint name="mount" type="fixed"><parent link="world"/><child link="base_link"/>'
             '<origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/></joint>']
    parent = "base_link"
    for i in range(dof):
        if rng.random() < 0.3:
            xyz, rpy = pose()
            lines += [f'<link name="spacer{i}"/>', f'<joint name="fixed{i}" type="fixed"><parent link="{parent}"/>'
                      f'<child link="spacer{i}"/><origin xyz="{xyz}" rpy="{rpy}"/></joint>']
            parent = f"spacer{i}"
        kind = "prismatic" if rng.random() < 0.2 else "revolute"
        axis = rng.choice(["1 0 0", "0 1 0", "0 0 1", "0 0 -1", "0 2 0"]) if rng.random() < 0.8 else \
            " ".join(repr(float(v)) for v in rng.normal(size=3))
        xyz, rpy = pose()
        low, high = (-0.3, 0.3) if kind == "prismatic" else (-3.0, 3.0)
        lines += [f'<link name="l{i}"/>', f'<joint name="j{i}" type="{kind}"><parent link="{parent}"/>'
                  f'<child link="l{i}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
                  f'<limit lower="{low}" upper="{high}" effort="10" velocity="1"/></joint>']
        parent = f"l{i}"
    xyz, rpy = pose()
    lines += ['<link name="tool0"/>', f'<joint name="flange" type="fixed"><parent link="{parent}"/>'
              f'<child link="tool0"/><origin xyz="{xyz}" rpy="{rpy}"/></joint>', "</robot>"]
    return "\n".join(lines)


@pytest.mark.slow
@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_random_chains_import_with_the_urdfs_fk(convention, tmp_path):
    rng = np.random.default_rng(6)
    for k in range(100):
        text = random_chain_urdf(rng, dof=int(rng.integers(1, 8)))
        path = tmp_path / f"chain{k}.urdf"
        path.write_text(text)
        imported = import_urdf(path, convention=convention)
        robot = load_robot(imported.write(tmp_path / f"chain{k}.yaml"))
        plant = UrdfPlant(text, robot.joint_names, root=None)
        assert worst_fk_difference(robot, plant, count=50, seed=k) < FK_TOLERANCE, text


# -- in: what DH cannot be ---------------------------------------------------------------------------------
def two_finger_urdf(mimic: bool = False, second_kind: str = "prismatic") -> str:
    mimic_tag = '<mimic joint="left"/>' if mimic else ""
    return f"""<robot name="gripper_arm">
  <link name="base_link"/><link name="arm"/><link name="palm"/><link name="left_finger"/><link name="right_finger"/>
  <joint name="shoulder" type="revolute"><parent link="base_link"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="arm"/><child link="palm"/><origin xyz="0.3 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="left" type="prismatic"><parent link="palm"/><child link="left_finger"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="1" velocity="0.1"/></joint>
  <joint name="right" type="{second_kind}"><parent link="palm"/><child link="right_finger"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="1" velocity="0.1"/>{mimic_tag}</joint>
</robot>"""


def write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_a_fork_of_moving_joints_is_a_typed_error_naming_them_and_a_tip_picks_one(tmp_path):
    path = write(tmp_path, two_finger_urdf())
    with pytest.raises(UrdfChainError, match=r"link\[palm\].*left, right.*--tip"):
        import_urdf(path)
    imported = import_urdf(path, tip="left_finger")
    assert imported.robot.joint_names == ["shoulder", "wrist", "left"] and imported.chain.ignored == ("right",)
    assert any("right" in note for note in imported.document["assumptions"])


@pytest.mark.parametrize("text, field", [
    (two_finger_urdf(mimic=True), r"joint\[right\]\.mimic"),
    (two_finger_urdf(second_kind="floating"), r"joint\[right\]\.type"),
    (two_finger_urdf(second_kind="planar"), r"joint\[right\]\.type"),
])
def test_mimic_floating_and_planar_joints_on_the_chain_are_typed_errors(tmp_path, text, field):
    with pytest.raises(UrdfChainError, match=field):
        import_urdf(write(tmp_path, text), tip="right_finger")


@pytest.mark.parametrize("change, field", [
    (('velocity="1"/></joint>\n  <joint name="wrist"', 'velocity="0"/></joint>\n  <joint name="wrist"'),
     r"joint\[shoulder\]\.limit\.velocity"),
    (('lower="-1" upper="1" effort="1" velocity="1"/></joint>\n  <joint name="wrist"',
      'effort="1" velocity="1"/></joint>\n  <joint name="wrist"'), r"joint\[shoulder\]\.limit\.lower"),
    (('<axis xyz="0 0 1"/>', '<axis xyz="0 0 x"/>'), r"joint\[shoulder\]\.axis\.xyz"),
    (('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>'), r"joint\[shoulder\]\.axis\.xyz"),
    (('<child link="arm"/>', '<child link="nowhere"/>'), r"joint\[shoulder\]\.child\.link"),
    (('type="revolute"', 'type="hinge"'), r"joint\[shoulder\]\.type"),
    (("</robot>", "</robt>"), r"document: is not well-formed XML"),
    (('<robot name="gripper_arm">', '<robot name="arm" xmlns:xacro="http://ros.org/wiki/xacro"><xacro:property '
      'name="l" value="0.3"/>'), r"document: is a xacro file: expand it first"),
    (('<origin xyz="0.3 0 0"/>', '<origin xyz="${l} 0 0"/>'), r"document: is a xacro file"),
])
def test_bad_urdfs_get_typed_errors_naming_the_element(tmp_path, change, field):
    text = two_finger_urdf()
    assert change[0] in text
    with pytest.raises(UrdfFileError, match=field):
        import_urdf(write(tmp_path, text.replace(change[0], change[1], 1)), tip="left_finger")


def test_unknown_links_and_files_are_typed_errors(tmp_path):
    path = write(tmp_path, two_finger_urdf())
    with pytest.raises(UrdfChainError, match=r"link\[hand\]"):
        import_urdf(path, tip="hand")
    with pytest.raises(UrdfChainError, match=r"link\[arm\]: is not below the base link 'palm'"):
        import_urdf(path, base="palm", tip="arm")
    with pytest.raises(UrdfFileError, match="cannot be read"):
        import_urdf(tmp_path / "missing.urdf")


def test_a_continuous_joint_stays_continuous_without_an_assumption(tmp_path):
    text = two_finger_urdf().replace('name="shoulder" type="revolute"', 'name="shoulder" type="continuous"', 1)
    imported = import_urdf(write(tmp_path, text), tip="left_finger")
    row = imported.document["joints"][0]
    assert row["continuous"] is True and "q_min" not in row and "q_max" not in row
    assert imported.robot.spec.joints[0].is_continuous
    assert not any("continuous" in note for note in imported.document["assumptions"])


# -- the command line ---------------------------------------------------------------------------------------
def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "pipeline", *args], capture_output=True, text=True, cwd=cwd)


@pytest.mark.slow                                   # some 4 s (two CLI runs); export and import by the API stay in make test
def test_cli_export_then_import_round_trip(tmp_path):
    exported = run_cli("export", "irb1600", "--urdf", str(tmp_path / "irb1600.urdf"), cwd=tmp_path)
    assert exported.returncode == 0, exported.stderr
    imported = run_cli("import-urdf", str(tmp_path / "irb1600.urdf"), "--out", str(tmp_path / "irb1600.yaml"),
                       "--convention", "modified", cwd=tmp_path)
    assert imported.returncode == 0, imported.stderr
    assert "largest difference" in imported.stdout
    document = yaml.safe_load((tmp_path / "irb1600.yaml").read_text())
    assert document["convention"] == "modified" and document["length_unit"] == "mm"
    assert "irb1600.urdf" in document["provenance"]["source"]
    robot, preset = load_robot(tmp_path / "irb1600.yaml"), load_robot("irb1600")
    q = preset.random_configurations(np.random.default_rng(7), 1)[0]
    assert np.abs(robot.fk(q) - preset.fk(q)).max() < FK_TOLERANCE


@pytest.mark.slow
def test_cli_import_of_a_fork_fails_in_one_line_and_writes_nothing(tmp_path):
    path = write(tmp_path, two_finger_urdf())
    result = run_cli("import-urdf", str(path), "--out", str(tmp_path / "out.yaml"), cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "chain forks" in result.stderr and "left, right" in result.stderr
    assert not (tmp_path / "out.yaml").exists()


def _imported_ur5_jobs(tmp_path: Path, *options: str) -> Path:
    """The UR5 imported with ``options`` into tmp_path/ur5.yaml and a joint job on it; the job's path."""
    from pipeline.__main__ import main

    assert main(["import-urdf", str(URDF_DIR / "ur5.urdf"), "--out", str(tmp_path / "ur5.yaml"), *options]) == 0
    job = {"robot": "ur5.yaml", "angle_unit": "deg", "waypoints": [[0, -90, 90, 0, 90, 0], [45, -60, 60, 10, 80, 30]],
           "outputs": ["json"]}
    (tmp_path / "job.yaml").write_text(yaml.safe_dump(job))
    return tmp_path / "job.yaml"


def test_a_urdf_import_without_acceleration_limits_is_named_by_the_first_job(tmp_path):
    """A URDF has no acceleration limits: the first job names the robot file's joint row, not the job."""
    from pipeline.errors import RobotFileError
    from pipeline.runner import run_job_file

    job = _imported_ur5_jobs(tmp_path)
    with pytest.raises(RobotFileError) as error:
        run_job_file(job, tmp_path / "out")
    assert (error.value.source, error.value.field) == (str(tmp_path / "ur5.yaml"), "joints[0].qdd_max")
    assert error.value.line > 1 and "--time-to-full-speed" in str(error.value) and not (tmp_path / "out").exists()


def test_time_to_full_speed_fills_the_acceleration_limits_and_records_them(tmp_path):
    _imported_ur5_jobs(tmp_path, "--time-to-full-speed", "0.25")
    document = yaml.safe_load((tmp_path / "ur5.yaml").read_text())
    assert all(row["qdd_max"] == pytest.approx(row["qd_max"] / 0.25, rel=1e-12) for row in document["joints"])
    assert "--time-to-full-speed 0.25" in document["provenance"]["qdd_max"]
    assert any("qd_max / 0.25 s" in line for line in document["assumptions"])


@pytest.mark.slow
def test_an_imported_ur5_with_a_time_to_full_speed_runs_a_job(tmp_path):
    """The issue's new user: an imported UR5 (torque limits, inertias) and --time-to-full-speed runs a job
    (about 8 s: the torque-limited timing)."""
    from pipeline.runner import run_job_file

    outcome = run_job_file(_imported_ur5_jobs(tmp_path, "--time-to-full-speed", "0.25"), tmp_path / "out")
    assert outcome.limit_report.passed and outcome.limit_report.max_ratio("qdd") <= 1.0 + 1e-6


# -- fuzz findings 2 and 7 of issue 22: overflow, the FK self-check, bounded sizes and counts --------------
def chain_urdf(moving: int, fixed_between: int = 0, fixed_beside: int = 0, axis: str = "0 0 1", extra: str = "",
               inertial: str = "") -> str:
    """A serial URDF: ``moving`` revolute joints 0.1 m apart (joint 0's axis ``axis``, the others y), each
    after ``fixed_between`` fixed links; ``fixed_beside`` fixed links hung on the last link; ``inertial``
    in every moving link; ``extra`` XML before ``</robot>``."""
    lines, parent = ['<robot name="r">', '<link name="base_link"/>'], "base_link"
    for i in range(moving):
        for k in range(fixed_between):
            lines += [f'<link name="s{i}_{k}"/><joint name="f{i}_{k}" type="fixed"><parent link="{parent}"/>'
                      f'<child link="s{i}_{k}"/><origin xyz="0 0 0.001"/></joint>']
            parent = f"s{i}_{k}"
        lines += [f'<link name="l{i}">{inertial}</link><joint name="j{i}" type="revolute"><parent link="{parent}"/>'
                  f'<child link="l{i}"/><origin xyz="0 0 0.1"/><axis xyz="{axis if i == 0 else "0 1 0"}"/>'
                  '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>']
        parent = f"l{i}"
    lines += [f'<link name="b{k}"/><joint name="b{k}" type="fixed"><parent link="{parent}"/><child link="b{k}"/>'
              '</joint>' for k in range(fixed_beside)]
    return "\n".join([*lines, extra, "</robot>"])


def test_a_huge_axis_is_normalised_without_overflow_and_imports_exactly(tmp_path):
    """Finding 2: ``<axis xyz="1e308 1e308 0"/>`` overflowed the norm (to a zero axis: FK 4.2 m off, and
    written); it is a direction like any other."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")                  # numpy's overflow warning fails the test
        imported = import_urdf(write(tmp_path, chain_urdf(3, axis="1e308 1e308 0")))
    np.testing.assert_allclose(imported.chain.joints[0].joint.axis, np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0),
                               atol=1e-15)
    assert imported.max_fk_error_m < FK_TOLERANCE


def test_an_import_whose_own_fk_check_fails_is_an_error_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """Finding 2: the import printed its own FK check "largest difference 4.2 m" and wrote the file (exit
    0). A DH table that differs from the URDF (here one row's d moved by 1 mm) is refused with the
    difference and the tolerance."""
    import dataclasses

    from pipeline.__main__ import main
    from pipeline.urdf import importer

    def one_row_off(*args):
        geometry = dh_from_axes(*args)
        rows = (dataclasses.replace(geometry.rows[0], d=geometry.rows[0].d + 1e-3), *geometry.rows[1:])
        return dataclasses.replace(geometry, rows=rows)

    dh_from_axes = importer.dh_from_axes
    monkeypatch.setattr(importer, "dh_from_axes", one_row_off)
    path, out = write(tmp_path, chain_urdf(3)), tmp_path / "out.yaml"
    with pytest.raises(UrdfChainError, match=r"link\[l2\]: .*differs .* by 0.001 m .*tolerance 1e-06 m"):
        import_urdf(path)
    assert main(["import-urdf", str(path), "--out", str(out)]) == 2
    assert "nothing written" in capsys.readouterr().err and not out.exists()


@pytest.mark.parametrize("change, field", [
    (('<mass value="1"/>', '<mass value="1e308"/>'), r"link\[l0\]\.inertial\.mass\.value: is implausible"),
    (('ixx="0.1"', 'ixx="1e308"'), r"link\[l0\]\.inertial\.inertia\.ixx: is implausible"),
    (('<origin xyz="0 0 0.1"/>', '<origin xyz="0 0 1e300"/>'), r"joint\[j0\]\.origin\.xyz: is implausible"),
    (('upper="1"', 'upper="1e308"'), r"joint\[j0\]\.limit\.upper: is implausible"),
    (('effort="1"', 'effort="1e308"'), r"joint\[j0\]\.limit\.effort: is implausible"),
])
def test_numbers_too_large_for_a_robot_are_typed_errors_naming_the_element(tmp_path, change, field):
    """Finding 7: masses of 1e308 ended in an OverflowError (robot_file._significant)."""
    inertial = '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>'
    text = chain_urdf(2, inertial=inertial)
    assert change[0] in text
    with pytest.raises(UrdfFileError, match=field):
        import_urdf(write(tmp_path, text.replace(change[0], change[1], 1)))


def test_rounding_an_infinite_inertia_does_not_overflow():
    from pipeline.files.robot_writer import _significant

    assert _significant(float("inf"), float("inf")) == float("inf")
    assert _significant(0.12345678901234567, 1.0) == 0.123456789012346


def test_a_kinematic_loop_is_a_typed_error_naming_its_joints(tmp_path):
    """Finding 7: a loop of links beside the tree ended in a RecursionError."""
    loop = ('<link name="a"/><link name="b"/><joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
            '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>')
    with pytest.raises(UrdfChainError, match=r"joint\[ab\]: lies on a kinematic loop") as error:
        import_urdf(write(tmp_path, chain_urdf(2, extra=loop)), base="a")
    assert error.value.value == ["ab", "ba"]


def test_long_chains_take_linear_time_and_too_many_moving_joints_are_refused(tmp_path):
    """Finding 7: a 2000-joint chain ended in a RecursionError (every walk over the tree recursed)."""
    from pipeline.urdf.chain import MAX_CHAIN_JOINTS

    deep = import_urdf(write(tmp_path, chain_urdf(2, fixed_between=600), "deep.urdf"))    # 1200 deep: > recursion limit
    assert deep.robot.dof == 2 and deep.max_fk_error_m < FK_TOLERANCE
    with pytest.raises(UrdfChainError, match=rf"joint\[j{MAX_CHAIN_JOINTS}\]: .*at most {MAX_CHAIN_JOINTS}"):
        import_urdf(write(tmp_path, chain_urdf(MAX_CHAIN_JOINTS + 5), "long.urdf"))


def test_too_many_links_and_too_large_files_are_refused_before_any_work(tmp_path, monkeypatch):
    """Finding 7: 100,000 fixed links gave no answer in 60 s (the limit, scaled down here; a real one
    is parsed in ~0.2 ms per link, and the tree is walked in linear time)."""
    from pipeline.urdf import reader

    monkeypatch.setattr(reader, "MAX_URDF_LINKS", 100)
    with pytest.raises(UrdfFileError, match=r"document: has 102 <link> elements, more than 100"):
        import_urdf(write(tmp_path, chain_urdf(2, fixed_beside=99)))
    monkeypatch.setattr(reader, "MAX_URDF_BYTES", 2**20)
    big = write(tmp_path, chain_urdf(2, extra="<!--" + "x" * 2**20 + "-->"), "big.urdf")
    with pytest.raises(UrdfFileError, match=r"document: is larger than 1 MiB"):
        import_urdf(big)


def test_a_device_is_refused_by_its_kind_without_reading_it():
    """Finding 7: /dev/zero reports size 0, so the size check passed and reading ended in a MemoryError
    after 11 s; only the path's kind is looked at (os.stat), nothing is read."""
    with pytest.raises(UrdfFileError, match=r"/dev/zero: document: is a character device, not a URDF file"):
        import_urdf("/dev/zero")
