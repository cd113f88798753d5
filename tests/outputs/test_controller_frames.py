"""RAPID, FANUC .ls and Yaskawa .jbi in the controller's own frames (issue 35), as KRL: targets in the robot file's
controller section's base frame, the tool on its flange frame, and ``program -> read-program -> compile`` landing
on the same joint values, for imported arms whose section has a shifted, turned base and a turned flange."""

from __future__ import annotations

import datetime as dt
import re

import numpy as np
import pytest
import yaml

from pipeline.files.poses import rotation_to_rpy, rpy_position_to_pose
from pipeline.outputs.controllers.fanuc_ls import rounding_bound, write_ls
from pipeline.outputs.controllers.rapid import write_rapid
from pipeline.outputs.controllers.read_jbi import read_jbi
from pipeline.outputs.controllers.read_ls import comment_tool, read_ls
from pipeline.outputs.controllers.read_rapid import read_rapid
from pipeline.outputs.controllers.yaskawa_jbi import write_jbi
from pipeline.program.compile import compile_job
from pipeline.program.job import parse_job
from pipeline.urdf import import_urdf

from ..conftest import DATA_DIR

WHEN = dt.datetime(2025, 1, 2, 3, 4, 5, tzinfo=dt.timezone.utc)
#: The section's frames: base 100 mm along x, -50 along y, 330 up, turned 30 deg about z; flange turned as
#: ROS-Industrial's tool0 is from a FANUC flange, 5 mm out along our end frame's z [mm, deg].
BASE = {"xyz": [100.0, -50.0, 330.0], "rpy": [0.0, 0.0, 30.0]}
FLANGE = {"xyz": [0.0, 0.0, 5.0], "rpy": [180.0, -90.0, 0.0]}
TOOL_MM = [10.0, 20.0, 120.0]
#: language -> (URDF, maker, seed [deg], writer, reader, mm step, deg step).
LANGUAGES = {
    "rapid": ("abb_irb6640_185_280.urdf", "abb", [5, 10, -10, 8, 45, 12], lambda p: write_rapid(p, "demo"),
              read_rapid, 0.001, 1e-4),
    "ls": ("fanuc_lrmate200ic.urdf", "fanuc", [10, 20, -10, 5, -60, 10], lambda p: write_ls(p, "DEMO", WHEN),
           read_ls, 0.001, 0.001),
    "jbi": ("motoman_gp8.urdf", "yaskawa", [5, 20, -10, 8, -70, 12], lambda p: write_jbi(p, "DEMO", WHEN),
            read_jbi, 0.001, 0.01),
}


def pose(frame: dict) -> np.ndarray:
    return rpy_position_to_pose(np.radians(frame["rpy"]), np.array(frame["xyz"]) / 1000.0)


@pytest.fixture(scope="module")
def programs(tmp_path_factory) -> dict:
    """language -> (robot file path, compiled program): a joint start, a joint move and two linear moves."""
    out = {}
    for language, (urdf, maker, seed, *_) in LANGUAGES.items():
        document = import_urdf(DATA_DIR / "urdf" / urdf, controller=maker, time_to_full_speed=0.3).document
        document["controller"] = {**document["controller"], "base": BASE, "flange": FLANGE}
        path = tmp_path_factory.mktemp(language) / f"{maker}.yaml"
        path.write_text(yaml.safe_dump(document, sort_keys=False))
        job = {"robot": str(path), "length_unit": "mm", "angle_unit": "deg", "outputs": ["json"], "tcp_speed_max": 250,
               "tool": {"xyz": TOOL_MM, "rpy": [0, 0, 0]}, "waypoints": [seed]}
        start = compile_job(parse_job({**job, "waypoints": [seed, [v + 1 for v in seed]]}))
        X0 = start.robot.fk(np.radians(seed))
        rpy = np.degrees(rotation_to_rpy(X0[:3, :3])).tolist()
        at = [(X0[:3, 3] * 1000 + d).tolist() for d in ([0, 0, 60], [0, 0, 0], [80, 0, 0])]
        job["waypoints"] = [seed, {"xyz": at[0], "rpy": rpy, "move": "joint"},
                            {"xyz": at[1], "rpy": rpy, "move": "linear"}, {"xyz": at[2], "rpy": rpy, "move": "linear"}]
        out[language] = str(path), compile_job(parse_job(job))
    return out


def numbers(text: str) -> np.ndarray:
    return np.array([float(v) for v in re.findall(r"-?\d+(?:\.\d+)?(?:E[-+]?\d+)?", text)])


@pytest.mark.parametrize("language", LANGUAGES)
def test_targets_are_in_the_controllers_base_and_the_tool_on_its_flange(programs, language):
    _, program = programs[language]
    text = LANGUAGES[language][3](program)
    X_base_T = np.linalg.inv(pose(BASE)) @ program.moves[-1].X_BT          # the last target, in the base frame
    X_flange_T = np.linalg.inv(pose(FLANGE)) @ program.tool.X_FT            # the tool on the controller's flange
    if language == "rapid":
        target = numbers(re.findall(r"robtarget p\d+ := \[\[([^\]]*)\]", text)[-1])
        tool = numbers(re.search(r"tooldata \w+ := \[TRUE,\[\[([^\]]*)\]", text).group(1))
    elif language == "ls":
        last = text.split("/POS")[1].split("P[")[-1]
        target = numbers(" ".join(re.findall(r"[XYZ] =\s*(-?[\d.]+)", last)))
        tool = comment_tool(re.findall(r"!(.*) ;", text))[:3, 3] * 1000
    else:
        last = [line for line in text.splitlines() if re.match(r"C\d{5}=", line)][-1]
        target = numbers(last.split("=")[1])[:3]
        tool = comment_tool(re.findall(r"^'(.*)$", text, re.MULTILINE))[:3, 3] * 1000
    np.testing.assert_allclose(target, X_base_T[:3, 3] * 1000, atol=1e-3)
    np.testing.assert_allclose(tool, X_flange_T[:3, 3] * 1000, atol=1e-3)
    comments = " ".join(re.findall(r"(?:!|^'|^\s*! ?)(.*?)(?: ;)?$", text, re.MULTILINE)).replace("  ", " ")
    assert "controller section" in comments and "xyz [100.0, -50.0, 330.0] mm" in comments, comments


@pytest.mark.parametrize("language", LANGUAGES)
def test_program_read_program_compile_lands_on_the_same_joint_values(programs, language):
    path, program = programs[language]
    _, _, _, write, read, mm_step, deg_step = LANGUAGES[language]
    reread = compile_job(parse_job(read(write(program), path)))
    np.testing.assert_allclose(reread.tool.X_FT, program.tool.X_FT, atol=1e-6)
    assert len(reread.targets) == len(program.targets)
    for q_read, q in zip(reread.targets, program.targets):
        assert np.all(np.abs(q_read - q) <= rounding_bound(program.robot, q, mm_step, deg_step) + np.radians(1e-4))
