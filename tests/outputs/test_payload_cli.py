"""program -> read-program -> the job file it writes carries the same loads (the centres of mass in the job's
length unit, read_units) and the job's part names (KRL holds only the total load: the gripped mark names its parts),
through the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.__main__ import main
from pipeline.program.compile import compile_job
from pipeline.program.job import load_job

JOB = Path(__file__).resolve().parents[1] / "data" / "gp7_payload_pick_place.yaml"
PROGRAM_FILES = {"rapid": "gp7_payload_pick_place.mod", "ls": "GP7_PAYL.ls", "krl": "gp7_payload_pick_place.src"}


@pytest.mark.parametrize("language", ["ls", *(pytest.param(language, marks=pytest.mark.slow) for language in ("rapid", "krl"))])
def test_the_job_read_back_from_the_program_carries_the_same_loads(tmp_path, language):
    assert main(["program", str(JOB), "--lang", language, "--out", str(tmp_path)]) == 0
    read = tmp_path / "read.yaml"
    assert main(["read-program", str(tmp_path / PROGRAM_FILES[language]), "--robot", "gp7", "--out", str(read)]) == 0
    assert "length_unit: mm" in read.read_text()
    original, back = compile_job(load_job(JOB)), compile_job(load_job(read))
    for a, b in zip(original.loads, back.loads, strict=True):
        assert a.name == b.name and a.mass == pytest.approx(b.mass, abs=1e-9)
        assert np.allclose(a.com, b.com, atol=1e-6) and np.allclose(a.inertia, b.inertia, atol=1e-6)
    assert [[str(a) for a in actions] for actions in back.actions] == \
        [[str(a) for a in actions] for actions in original.actions]
