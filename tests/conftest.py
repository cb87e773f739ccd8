"""Shared fixtures: the default config and the system built from it (built once per session)."""

from __future__ import annotations

import pytest
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.model.system import SkateSystem


@pytest.fixture(scope="session")
def cfg():
    return load_config()


@pytest.fixture(scope="session")
def system(cfg):
    return SkateSystem.from_config(cfg)
