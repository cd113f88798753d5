"""The IK kernels built ahead of time (pipeline/model/ik/prebuilt.py): the machine code only ever gets arguments
of exactly its signature (anything else goes to the Numba dispatcher, which converts or refuses it), it is used
only when its record matches the sources, versions and CPU, a record the package did not write is never replaced,
and (slow: a build) the prebuilt kernels answer as the just-in-time ones do."""

from __future__ import annotations

import json
import pickle
import shutil

import numpy as np
import pytest

from pipeline import load_robot
from pipeline.errors import OutputError
from pipeline.model.chain.compiled import POSE
from pipeline.model.ik import closed_form, descent, prebuilt
from pipeline.model.ik.analytic import analytic_solver_for

from ..conftest import DATA_DIR


class _Dispatcher:
    """Stands in for a kernel's dispatcher: records that the arguments went to it."""

    def __init__(self, kernel):
        self.kernel_signature, self.py_func, self.calls = kernel.kernel_signature, kernel.py_func, 0

    def __call__(self, *args):
        self.calls += 1
        return "dispatcher"


class _Subclass(np.ndarray):
    """An ndarray subclass: not what the machine code was built for."""


def _routed(kernel, *args) -> str:
    """Where ``_guarded`` sends ``args``: "machine code" or "dispatcher"."""
    return prebuilt._guarded(lambda *_: "machine code", _Dispatcher(kernel))(*args)


def _solve_one_arguments():
    robot = load_robot("gp7")
    solver = analytic_solver_for(robot)
    X = robot.fk(np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]))
    return [solver.geometry, robot._chain, robot._limit_rows, X, np.zeros(6), np.empty((64, closed_form.SOLUTION_COLUMNS))]


def test_only_arguments_of_exactly_the_signature_reach_the_machine_code():
    args = _solve_one_arguments()
    assert _routed(closed_form.solve_one, *args) == "machine code"
    read_only = args[3].copy()
    read_only.flags.writeable = False
    good = {"Fortran-ordered pose": np.asfortranarray(args[3]), "read-only pose": read_only,
            "strided seed": np.zeros(12)[::2], "unpickled pose": pickle.loads(pickle.dumps(args[3]))}
    for name, value in good.items():
        index = 4 if "seed" in name else 3
        assert _routed(closed_form.solve_one, *args[:index], value, *args[index + 1:]) == "machine code", name
    not_contiguous_out = np.empty((64, 2 * closed_form.SOLUTION_COLUMNS))[:, ::2]
    read_only_out = np.empty((64, closed_form.SOLUTION_COLUMNS))
    read_only_out.flags.writeable = False
    bad = {3: [args[3].astype(np.float32), args[3].tolist(), args[3][None], args[3].astype(np.int64),
               args[3].view(_Subclass)],
           5: [not_contiguous_out, read_only_out],
           1: [np.asfortranarray(args[1])]}                     # the chain is a C-contiguous parameter
    for index, values in bad.items():
        for value in values:
            assert _routed(closed_form.solve_one, *args[:index], value, *args[index + 1:]) == "dispatcher", \
                (index, type(value), getattr(value, "dtype", None))
    with pytest.raises(TypeError, match="missing 1 required positional argument"):
        _routed(closed_form.solve_one, *args[:-1])
    big_endian = args[3].astype(">f8")
    assert _routed(closed_form.solve_one, *args[:3], big_endian, *args[4:]) == "dispatcher"


def test_integer_arguments_must_be_int64_values():
    robot = load_robot("lrmate200id")
    args = [robot._chain, robot.limits.q_min, robot.limits.q_max, np.eye(4), POSE, np.zeros(6), 200]
    assert _routed(descent.descend, *args) == "machine code"
    assert _routed(descent.descend, *args[:4], np.int64(POSE), *args[5:]) == "machine code"
    for kind in (True, 0.0, 2 ** 63, -2 ** 63 - 1, "0", np.int32(0)):
        assert _routed(descent.descend, *args[:4], kind, *args[5:]) == "dispatcher", kind


def _copy_sources(root):
    package = prebuilt.FOLDER.parents[1]
    for folder in prebuilt.SOURCE_FOLDERS:
        (root / folder).mkdir(parents=True)
        for source in (package / folder).glob("*.py"):
            shutil.copy(source, root / folder / source.name)


def test_the_fingerprint_changes_with_any_byte_of_the_sources(tmp_path):
    _copy_sources(tmp_path)
    assert prebuilt.fingerprint(tmp_path) == prebuilt.fingerprint()
    source = tmp_path / "model" / "ik" / "closed_form.py"
    source.write_text(source.read_text().replace("SINGULAR", "SINGULAR ", 1))
    assert prebuilt.fingerprint(tmp_path) != prebuilt.fingerprint()


def test_kernels_stay_just_in_time_without_a_matching_record(tmp_path, monkeypatch):
    assert "no prebuilt kernels in" in prebuilt.load(tmp_path).reason
    (tmp_path / prebuilt.RECORD).write_text(json.dumps({"written_by": "dh-pipeline", "fingerprint": "0" * 64,
                                                        "file": "x.so"}))
    stale = prebuilt.load(tmp_path)
    assert stale.module is None and "built from other sources, versions or CPU; rebuild it" in stale.reason
    (tmp_path / prebuilt.RECORD).write_text(json.dumps({"fingerprint": prebuilt.fingerprint(), "file": "x.so"}))
    assert "x.so: missing" in prebuilt.load(tmp_path).reason
    (tmp_path / "x.so").write_bytes(b"not an extension")
    assert "cannot be loaded" in prebuilt.load(tmp_path).reason
    monkeypatch.setenv(prebuilt.SWITCH, "0")
    assert prebuilt.load(tmp_path).reason.startswith(f"{prebuilt.SWITCH}=0")


def test_a_record_not_written_here_is_never_replaced(tmp_path):
    record = tmp_path / prebuilt.RECORD
    record.write_text('{"mine": true}\n')
    with pytest.raises(OutputError, match="not written by this package"):
        prebuilt.build(tmp_path)
    assert record.read_text() == '{"mine": true}\n' and sorted(p.name for p in tmp_path.iterdir()) == [record.name]


@pytest.mark.slow
def test_prebuilt_kernels_answer_as_the_just_in_time_ones(tmp_path):
    """Built into a temporary folder and loaded from there: the closed forms of both families (single and batch)
    and damped least squares give the just-in-time kernels' solutions on seeded random targets (to round-off:
    the kernels' own bodies are not fused into FMA instructions ahead of time)."""
    from pipeline.model.ik import three_parallel

    report = prebuilt.build(tmp_path)
    module = prebuilt.load(tmp_path).module
    assert module is not None and report.record.is_file() and json.loads(report.record.read_text())["kernels"]
    rng = np.random.default_rng(39)
    for robot, kernels in ((load_robot("gp7"), closed_form), (load_robot(DATA_DIR / "ur5.yaml"), three_parallel)):
        solver = analytic_solver_for(robot)
        Q = rng.uniform(robot.limits.q_min, robot.limits.q_max, (40, 6))
        X, seeds = robot.fk_batch(Q), rng.uniform(robot.limits.q_min, robot.limits.q_max, (40, 6))
        ahead, just_in_time = (np.empty((40, 32, closed_form.SOLUTION_COLUMNS)) for _ in range(2))
        info_ahead, info_jit = np.empty((40, closed_form.INFO)), np.empty((40, closed_form.INFO))
        prefix = "closed_form" if kernels is closed_form else "three_parallel"
        getattr(module, f"{prefix}_solve_batch")(solver.geometry, robot._chain, robot._limit_rows, X, seeds, ahead,
                                                 info_ahead)
        kernels.solve_batch(solver.geometry, robot._chain, robot._limit_rows, X, seeds, just_in_time, info_jit)
        counts = info_jit[:, closed_form.COUNT].astype(int)
        assert np.array_equal(info_ahead[:, closed_form.COUNT], info_jit[:, closed_form.COUNT]) and counts.min() > 0
        for n, count in enumerate(np.minimum(counts, 32)):
            assert np.allclose(ahead[n, :count], just_in_time[n, :count], rtol=0.0, atol=1e-9)
            one = np.empty((64, closed_form.SOLUTION_COLUMNS))
            numbers = getattr(module, f"{prefix}_solve_one")(solver.geometry, robot._chain, robot._limit_rows,
                                                              X[n], seeds[n], one)
            assert numbers[closed_form.COUNT] == count and np.allclose(one[:min(count, 32)], ahead[n, :count],
                                                                       rtol=0.0, atol=1e-9)
    robot = load_robot("lrmate200id")
    for q in rng.uniform(robot.limits.q_min, robot.limits.q_max, (20, 6)):
        args = (robot._chain, robot.limits.q_min, robot.limits.q_max, robot.fk(q), POSE,
                np.clip(q + 0.2, robot.limits.q_min, robot.limits.q_max), 200)
        q_ahead, iterations, *_, strict = module.descent_descend(*args)
        q_jit, iterations_jit, *_, strict_jit = descent.descend(*args)
        assert strict == strict_jit and abs(iterations - iterations_jit) <= 1
        assert np.allclose(q_ahead, q_jit, rtol=0.0, atol=1e-6)
