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


@pytest.fixture(scope="session")
def hrp2_walk_path(tmp_path_factory):
    """The HRP-2 walk library (``configs/hrp2_walk.toml``), built once per session."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library
    from skatelib.pipeline.config import CONFIG_DIR

    out = tmp_path_factory.mktemp("hrp2_walk") / "walk.h5"
    rep = build_library(load_config(CONFIG_DIR / "hrp2_walk.toml"), out, BuildOptions(jobs=1, cache=False))
    assert not rep.failed
    return out
