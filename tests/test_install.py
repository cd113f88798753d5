"""The package installed non-editable, as a user gets it from `pip install .`, works from any
directory: the presets and demo cells ship inside it, a demo job runs, the `dh-pipeline` console script
exists, and a job names a demo cell by its name.

The tracked files are copied to a temporary folder first (so no build/ or egg-info lands in the
checkout) and installed there with `pip install --no-deps` into a fresh virtual environment; the
dependencies come from this test's environment through a .pth file placed after the new environment's
own site-packages, so `pipeline` is imported from the installed copy (asserted). Everything lives in one
temporary folder, removed at the end.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def tracked_copy(destination: Path) -> Path:
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    for name in files:
        target = destination / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if (ROOT / name).is_file():
            shutil.copy2(ROOT / name, target)
    return destination


def fresh_venv(folder: Path) -> Path:
    """A virtual environment whose own site-packages comes first, then this environment's (for the
    dependencies), without this environment's editable finder for the checkout."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True)
    python = folder / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    ours = sysconfig.get_paths()["purelib"]
    (site / "zz_test_dependencies.pth").write_text(ours + "\n")   # appended after the venv's own entries
    return python


@pytest.fixture
def tmp_path():
    """A temporary folder removed when the test ends (pytest's own tmp_path keeps the last runs' folders,
    here a virtual environment and a copy of the repository)."""
    with tempfile.TemporaryDirectory(prefix="dh_pipeline_install_") as folder:
        yield Path(folder).resolve()


@pytest.mark.slow
def test_non_editable_install_works_from_another_directory(tmp_path):
    source = tracked_copy(tmp_path / "source")
    python = fresh_venv(tmp_path / "venv")
    subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps",
                    str(source)], check=True, cwd=tmp_path)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    probe = ("import json, pipeline; from pipeline import load_robot, preset_names; "
             "print(json.dumps({'file': pipeline.__file__, 'presets': preset_names(), "
             "'flange': load_robot('gp7').fk([0] * 6)[:3, 3].tolist()}))")
    result = subprocess.run([str(python), "-c", probe], cwd=elsewhere, capture_output=True, text=True, check=True)
    found = json.loads(result.stdout)
    assert found["file"].startswith(str(tmp_path / "venv")), found["file"]
    assert found["presets"] == ["arm5", "arm6", "gp7", "irb1600", "lrmate200id", "ur5e"]
    assert found["flange"] == pytest.approx([0.56, 0.0, 0.815], abs=1e-12)
    job = source / "trajectories" / "jobs" / "gp7_pick_place.yaml"
    run = subprocess.run([str(python), "-m", "pipeline", "run", str(job), "--out", str(elsewhere / "out")],
                         cwd=elsewhere, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert (elsewhere / "out" / "report.json").is_file() and (elsewhere / "out" / "profile.csv").is_file()
    assert json.loads((elsewhere / "out" / "report.json").read_text())["limits"]["timed"]["passed"] is True
    check_console_script_and_demo_cell_by_name(tmp_path / "venv" / "bin" / "dh-pipeline", elsewhere)


def check_console_script_and_demo_cell_by_name(script: Path, elsewhere: Path) -> None:
    """The console script exists and runs; a job written anywhere names a demo cell by its name."""
    assert script.is_file(), "pip install did not create the dh-pipeline console script"
    usage = subprocess.run([str(script), "--help"], cwd=elsewhere, capture_output=True, text=True)
    assert usage.returncode == 0 and usage.stdout.startswith("usage: dh-pipeline"), usage.stderr
    check = subprocess.run([str(script), "check-cell", "gp7_wall_cell"], cwd=elsewhere, capture_output=True, text=True)
    assert check.returncode == 0 and "cell gp7_wall_cell" in check.stdout, check.stderr
    (elsewhere / "cell_job.yaml").write_text("cell: gp7_wall_cell\nangle_unit: deg\noutputs: [json]\n"
                                             "waypoints: [[0, 0, 0, 0, -90, 0], [20, 10, 0, 0, -90, 0]]\n")
    run = subprocess.run([str(script), "run", "cell_job.yaml", "--out", "cell_out"], cwd=elsewhere,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    report = json.loads((elsewhere / "cell_out" / "report.json").read_text())
    assert report["cell"]["name"] == "gp7_wall_cell" and report["cell"]["clearance"]["passed"] is True
    assert Path(report["cell"]["file"]).is_relative_to(script.parent.parent)     # the installed copy


def test_every_subpackage_is_installed():
    """Each folder of ``pipeline`` with an ``__init__.py`` is listed in pyproject.toml's packages (a new
    stage folder missing there is absent from a non-editable install)."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    folders = {".".join(path.parent.relative_to(ROOT).parts) for path in (ROOT / "pipeline").rglob("__init__.py")}
    assert folders <= listed, sorted(folders - listed)
