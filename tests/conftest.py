"""Shared fixtures: every robot file in models/ is tested automatically.

``pytest --regen-golden`` rewrites the golden profiles in tests/golden/ from the demo jobs: the only
run in which a test writes into the repository.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.files.robot_spec import preset_names
from pipeline.model.robot import load_robot

DATA_DIR = Path(__file__).parent / "data"
PRESETS = preset_names()


def pytest_addoption(parser):
    parser.addoption("--regen-golden", action="store_true", default=False,
                     help="rewrite tests/golden/*.npz from the demo jobs in trajectories/jobs/")


@pytest.fixture
def regen_golden(request) -> bool:
    """True when the run was asked to rewrite the golden profiles (--regen-golden)."""
    return request.config.getoption("--regen-golden")


@pytest.fixture(params=PRESETS)
def robot(request):
    """Each preset robot in turn."""
    return load_robot(request.param)


@pytest.fixture(scope="session")
def drake_robots():
    """Drake models built once per session, by preset name."""
    from pipeline.model.chain.drake_model import build_drake_robot

    return {name: build_drake_robot(load_robot(name).spec) for name in PRESETS}


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
