"""The README's examples run as pasted: the quick start (its two YAML files and its command, in an empty
folder) and every Python block (from a folder holding the repository's trajectories/ and models/, as a
user's checkout does), writing only into their folders."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def quick_start() -> str:
    """The README's quick start section (from its heading to the user's guide)."""
    text = README.read_text()
    return text[text.index("## Quick start"):text.index("## User's guide")]


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


@pytest.mark.slow
def test_the_quick_start_comes_first_and_runs_as_pasted(tmp_path):
    text, section = README.read_text(), quick_start()
    assert re.findall(r"^## .*", text, re.M)[0] == "## Quick start"           # the first section of all
    assert "make run" in section and "make test" in section and "pip install ." in section
    files = re.findall(r"```yaml\n# (\S+\.yaml)\n(.*?)```", section, re.S)
    assert [name for name, _ in files] == ["my_arm.yaml", "my_job.yaml"]
    assert sum(body.count("\n") + 1 for _, body in files) <= 16                # a robot and a job, in a dozen lines
    for name, body in files:
        (tmp_path / name).write_text(f"# {name}\n{body}")
    (command,) = [line.split("#")[0].split() for line in re.findall(r"^dh-pipeline run .*$", section, re.M)]
    result = subprocess.run([sys.executable, "-m", "pipeline", *command[1:]], cwd=tmp_path, capture_output=True,
                            text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    out = tmp_path / command[command.index("--out") + 1]
    written = {path.name for path in out.iterdir()}
    named = set(re.findall(r"`(profile\.\w+|report\.json)`", section))
    assert named == {"profile.csv", "profile.npz", "profile.png", "report.json"} and named <= written
    assert json.loads((out / "report.json").read_text())["limits"]["timed"]["passed"] is True
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my_arm.yaml", "my_job.yaml", "out"]


@pytest.mark.slow                                  # a Dask map and a cell job: about 18 s
def test_the_readme_python_examples_run_as_pasted(tmp_path):
    """From an empty folder, as a user who installed the package runs them (demo jobs and cells by name)."""
    blocks = python_blocks()
    assert blocks, "the README has no Python example"
    assert not any(name in block for block in blocks for name in ("trajectories/", "models/"))
    jobs_before = sorted(p.name for p in (ROOT / "trajectories" / "jobs").iterdir())
    for k, code in enumerate(blocks):
        script = tmp_path / f"block{k}.py"
        script.write_text(code)
        result = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                                timeout=300)
        assert result.returncode == 0, result.stderr[-2000:]
    out = tmp_path / "out" / "gp7"
    assert (out / "report.json").is_file() and (out / "profile.csv").is_file()
    assert "PASS" in result.stdout and "FAIL" in result.stdout     # the direct move refused, the planned one not
    assert sorted(p.name for p in (ROOT / "trajectories" / "jobs").iterdir()) == jobs_before
