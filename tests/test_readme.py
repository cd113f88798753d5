"""The README's Python example runs as pasted (from a folder holding the repository's trajectories/
and models/, as a user's checkout does), writing only into that folder."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)


def test_the_readme_example_runs_as_pasted(tmp_path):
    blocks = python_blocks()
    assert blocks, "the README has no Python example"
    (tmp_path / "trajectories").mkdir()     # a real folder: only the job files are the repository's
    (tmp_path / "trajectories" / "jobs").symlink_to(ROOT / "trajectories" / "jobs")
    (tmp_path / "models").symlink_to(ROOT / "models")      # the demo cells (and the job's path to them)
    jobs_before = sorted(p.name for p in (ROOT / "trajectories" / "jobs").iterdir())
    for k, code in enumerate(blocks):
        script = tmp_path / f"block{k}.py"
        script.write_text(code)
        result = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                                timeout=300)
        assert result.returncode == 0, result.stderr[-2000:]
    out = tmp_path / "out" / "gp7"
    assert (out / "report.json").is_file() and (out / "profile.csv").is_file()
    assert "PASS" in result.stdout
    assert sorted(p.name for p in (ROOT / "trajectories" / "jobs").iterdir()) == jobs_before
