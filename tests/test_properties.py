"""Property-based checks (Hypothesis, derandomised): whatever a robot file, a job file, a YAML document
(the reader cell files will use) or an array handed to the public API holds, the package either
succeeds or raises an error of its own hierarchy, within 5 s, and writes nothing when it fails.

``make test`` runs each property on a bounded number of examples; the ``slow`` variants (CI's slow
run) run many more.
"""

from __future__ import annotations

import copy
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pipeline import load_robot
from pipeline.errors import FileFormatError, PipelineError
from pipeline.files.choices import PATH_SHAPES, TIMING_METHODS
from pipeline.files.poses import check_pose, pose_to_quaternion_position, quaternion_position_to_pose
from pipeline.files.robot_spec import load_robot_spec
from pipeline.files.schema import load_document
from pipeline.model.chain.singularity import compute_singularity
from pipeline.program.job import load_job
from pipeline.runner import run_job

#: The longest any single call may take [s].
CALL_LIMIT_S = 5.0
#: The sample limit of the jobs run here: writing the default limit's CSV alone takes seconds.
MAX_SAMPLES = 20_000
QUICK, LONG = 60, 300

ROBOT_DOC = {
    "name": "fuzz_arm", "convention": "standard", "length_unit": "mm", "angle_unit": "deg",
    "base": {"xyz": [0, 0, 100], "rpy": [0, 0, 0]}, "tool": {"xyz": [0, 0, 50], "rpy": [0, 0, 0]},
    "joints": [
        {"a": 50, "alpha": -90, "d": 300, "q_min": -170, "q_max": 170, "qd_max": 200, "qdd_max": 800},
        {"a": 400, "alpha": 0, "d": 0, "theta_offset": -90, "q_min": -90, "q_max": 150, "qd_max": 200,
         "qdd_max": 800},
        {"type": "prismatic", "a": 0, "alpha": 0, "d": 50, "sign": -1, "q_min": 0, "q_max": 200, "qd_max": 500,
         "qdd_max": 2000, "inertia": {"mass": 2.0, "com": [0, 0, 10], "I": [0.01, 0.01, 0.01, 0, 0, 0]}},
    ],
}
JOINT_JOB = {"robot": "arm6", "angle_unit": "rad", "timing": "toppra", "speed_scale": 0.5, "dt": 0.01,
             "waypoints": [[0, 0, 0, 0, 0, 0], [0.3, -0.2, 0.4, 0.1, 0.2, 0.3], [0.5, 0.1, 0.2, 0, 0, 0]],
             "outputs": ["csv", "json"]}
POSE_JOB = {"robot": "gp7", "length_unit": "mm", "angle_unit": "deg", "timing": "ruckig", "ik": "analytic",
            "speed_scale": 0.5, "dt": 0.01, "start": [0, 0, 0, 0, -90, 0],
            "waypoints": [{"xyz": [560, 0, 600], "rpy": [180, 0, 0]},
                          {"xyz": [500, 300, 450], "quaternion": [0, 0.9537, 0.3007, 0]}],
            "outputs": ["json"]}

NASTY_NUMBERS = st.sampled_from([0, -0.0, 1e-7, 8e3, 5e-324, 1e308, -1e308, 1.7e308, 10**40, -(10**60),
                                 float("nan"), float("inf"), 170.5, -1, 1, 2, 720, 1e-300])
SCALARS = st.one_of(st.none(), st.booleans(), NASTY_NUMBERS, st.integers(-(10**6), 10**6),
                    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
VALUES = st.recursive(SCALARS, lambda inner: st.one_of(st.lists(inner, max_size=7),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                      max_leaves=20)


def _paths(value, prefix=()):
    """Every path (tuple of keys and indices) into a nested document."""
    yield prefix
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, child in items:
        yield from _paths(child, (*prefix, key))


@st.composite
def mutated(draw, base: dict, edits: int = 3):
    """``base`` with up to ``edits`` random edits: a value replaced, a key deleted or added."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, edits))):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = draw(VALUES)
        elif action == "delete":
            del parent[path[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = draw(VALUES)
    return doc


@st.composite
def corrupted_text(draw, base: dict):
    """The YAML text of ``base`` with random bytes inserted, deleted or replaced."""
    data = bytearray(yaml.safe_dump(base).encode())
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(data)))
        action = draw(st.sampled_from(["insert", "delete", "replace"]))
        chunk = draw(st.binary(min_size=1, max_size=6))
        if action == "insert":
            data[at:at] = chunk
        elif action == "delete":
            del data[at:at + len(chunk)]
        else:
            data[at:at + len(chunk)] = chunk
    return bytes(data)


def timed(call, *args, **kwargs):
    """Run ``call``: its result, or None after an error of ours; never slower than CALL_LIMIT_S."""
    start = time.perf_counter()
    try:
        return call(*args, **kwargs)
    except PipelineError:
        return None
    finally:
        elapsed = time.perf_counter() - start
        assert elapsed < CALL_LIMIT_S, f"{getattr(call, '__name__', call)} took {elapsed:.1f} s"


def fuzz(examples: int):
    return settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def both(property_function, strategy, quick=QUICK, long=LONG):
    """(quick test, slow test) of one property."""
    quick_test = fuzz(quick)(given(strategy)(property_function))
    long_test = pytest.mark.slow(fuzz(long)(given(strategy)(property_function)))
    return quick_test, long_test


# -- files --------------------------------------------------------------------------------------
def check_robot_file(content) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "robot.yaml"
        path.write_bytes(content if isinstance(content, bytes) else yaml.safe_dump(content).encode())
        spec = timed(load_robot_spec, path)
        if spec is not None:
            robot = load_robot(path)
            timed(robot.fk, np.zeros(robot.dof))


ROBOT_FILES = st.one_of(mutated(ROBOT_DOC), corrupted_text(ROBOT_DOC))
test_robot_files, test_robot_files_long = both(check_robot_file, ROBOT_FILES)


def check_job_file(content) -> None:
    """A job file loads or fails typed; a job that loads runs (csv, json only) or fails typed, and a
    failed run leaves nothing in the output folder's parent."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "job.yaml"
        path.write_bytes(content if isinstance(content, bytes) else yaml.safe_dump(content).encode())
        job = timed(load_job, path)
        if job is None:
            return
        out = Path(folder) / "out" / "job"
        outcome = timed(run_job, dataclasses.replace(job, outputs=("csv", "json")), out, max_samples=MAX_SAMPLES)
        if outcome is None:
            assert not out.exists() and (not out.parent.exists() or not any(out.parent.iterdir()))
        else:
            assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["profile.csv",
                                                                                           "report.json"]


JOB_FILES = st.one_of(mutated(JOINT_JOB), mutated(POSE_JOB), corrupted_text(JOINT_JOB), corrupted_text(POSE_JOB))
test_job_files, test_job_files_long = both(check_job_file, JOB_FILES, quick=40, long=300)


@st.composite
def plausible_jobs(draw):
    """Valid-looking joint jobs that reach the IK-free part of the runner: random waypoints, methods,
    shapes, speed scales down to 1e-3 and sample times down to 1e-4 s (the size guard's territory)."""
    timing = draw(st.sampled_from(TIMING_METHODS))
    doc = {"robot": draw(st.sampled_from(["arm6", "irb1600", "arm5"])), "angle_unit": "deg", "timing": timing,
           "speed_scale": draw(st.one_of(st.floats(1e-3, 1.0), st.sampled_from([1e-3, 0.01, 1.0]))),
           "dt": draw(st.one_of(st.floats(1e-4, 0.1), st.sampled_from([1e-4, 0.1]))), "outputs": ["csv"]}
    dof = 5 if doc["robot"] == "arm5" else 6
    doc["waypoints"] = draw(st.lists(st.lists(st.floats(-60, 60), min_size=dof, max_size=dof), min_size=2,
                                     max_size=6))
    if timing != "ruckig":
        doc["path"] = draw(st.sampled_from(PATH_SHAPES))
    return doc


test_plausible_jobs, test_plausible_jobs_long = both(check_job_file, plausible_jobs(), quick=12, long=100)


def check_document(content: bytes) -> None:
    """Any bytes: a Document of plain data, or a typed error; the way cell files will be read."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "cell.yaml"
        path.write_bytes(content)
        start = time.perf_counter()
        try:
            document = load_document(path, FileFormatError)
        except FileFormatError:
            return
        finally:
            assert time.perf_counter() - start < CALL_LIMIT_S
        assert isinstance(document.data, (dict, list, str, int, float, bool, type(None)))


DOCUMENTS = st.one_of(st.binary(max_size=300), st.text(max_size=300).map(str.encode),
                      VALUES.map(lambda v: yaml.safe_dump(v).encode()), corrupted_text(ROBOT_DOC))
test_documents, test_documents_long = both(check_document, DOCUMENTS, quick=150, long=1000)


# -- arrays handed to the public API ------------------------------------------------------------
ARRAYS = st.one_of(
    hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=3, max_side=7),
               elements=st.one_of(st.floats(-4, 4), NASTY_NUMBERS.filter(lambda x: isinstance(x, float)))),
    hnp.arrays(np.float64, st.sampled_from([(6,), (4, 4), (3, 6), (3, 4, 4), (6, 6)]),
               elements=st.floats(allow_nan=True, allow_infinity=True)),
    VALUES,
    st.sampled_from(["q", {"x": 1}, [[1, 2], [3]], None, object()]),
)
ROBOT = load_robot("gp7")


def check_api_array(value) -> None:
    for call in (ROBOT.fk, ROBOT.jacobian, ROBOT.fk_batch, ROBOT.fk_all, compute_singularity, check_pose,
                 pose_to_quaternion_position):
        timed(call, value)
    for method in ("analytic", "jacobian"):
        timed(ROBOT.ik, value, method=method)
    timed(ROBOT.ik, np.eye(4), q_seed=value, method="jacobian")
    timed(ROBOT.ik_batch, value, method="analytic")
    timed(ROBOT.joint_velocities, np.zeros(6), value)
    timed(quaternion_position_to_pose, value, [0.0, 0.0, 0.0])


test_api_arrays, test_api_arrays_long = both(check_api_array, ARRAYS, quick=80, long=500)


@st.composite
def far_poses(draw):
    """Poses with finite but absurd or borderline coordinates."""
    X = np.eye(4)
    X[:3, 3] = draw(st.lists(st.sampled_from([0.0, 0.5, 1e3, 1.7e308, -1e308, 1e-300]), min_size=3, max_size=3))
    return X


def check_far_pose(X) -> None:
    for method in ("auto", "analytic", "jacobian"):
        result = timed(ROBOT.ik, X, method=method)
        assert result is None or result.success in (True, False)


test_far_poses, test_far_poses_long = both(check_far_pose, far_poses(), quick=20, long=200)
