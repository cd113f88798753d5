"""Shared fixtures: every robot file in models/ is tested automatically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.robot import load_robot
from pipeline.robot_spec import preset_names

DATA_DIR = Path(__file__).parent / "data"
PRESETS = preset_names()


@pytest.fixture(params=PRESETS)
def robot(request):
    """Each preset robot in turn."""
    return load_robot(request.param)


@pytest.fixture(scope="session")
def drake_robots():
    """Drake models built once per session, by preset name."""
    from pipeline.drake_model import build_drake_robot

    return {name: build_drake_robot(load_robot(name).spec) for name in PRESETS}


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
