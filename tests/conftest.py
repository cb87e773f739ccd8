"""Shared fixtures, each made once per test run: the default config and the system built from it,
and the libraries several test modules read (a solve or a build costs seconds to minutes; the
modules that read one open it, and copy it before they change it)."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import NamedTuple

import pytest
from skatelib.pipeline.config import CONFIG_DIR, load_config
from skatelib.pipeline.quadruped.model.system import SkateSystem

from tests.helpers import TINY, run_cli


class CliBuild(NamedTuple):
    """A library written by ``skatelib build`` or ``skatelib solve`` in a subprocess, with an entry
    cache of its own (a later command pointed at it is served from it)."""

    path: Path
    stdout: str
    cache: Path


def _cli_build(folder: Path, config: Path, *args: str) -> CliBuild:
    out, cache = folder / "lib.h5", folder / "cache"
    r = run_cli(["build", str(config), "-o", str(out), "--no-progress", *args], timeout=900,
                env={**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(cache)})
    assert r.returncode == 0, r.stdout + r.stderr
    return CliBuild(out, r.stdout, cache)


def _cli_solve(folder: Path, velocity: float, strides: int) -> CliBuild:
    out, cache = folder / "lib.h5", folder / "cache"
    r = run_cli(["solve", "--config", str(TINY), "--velocity", str(velocity), "--strides", str(strides), "-o",
                 str(out)], timeout=900, env={**os.environ, "COLUMNS": "200", "SKATELIB_CACHE_DIR": str(cache)})
    assert r.returncode == 0, r.stdout + r.stderr
    return CliBuild(out, r.stdout, cache)


@pytest.fixture(scope="session")
def cfg():
    return load_config()


@pytest.fixture(scope="session")
def system(cfg):
    return SkateSystem.from_config(cfg)


@pytest.fixture(scope="session")
def small_cfg(cfg):
    """The default config with the stage functions interpreted (no C compilation)."""
    return dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))


@pytest.fixture(scope="session")
def pushoff_0p3(small_cfg):
    """The one-stride 0.3 m/s push-off of ``small_cfg``, solved cold in this process (the problem of
    ``tests/configs/tiny.toml``'s first entry)."""
    from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, solve

    r = solve(PushoffSpec(small_cfg, 0.3, 1))
    assert r.success, r.status
    return r


@pytest.fixture(scope="session")
def shove_0p3(small_cfg):
    """The same push-off solved the old way: only the board's final speed constrained, no riding end
    state (the terminal shove the physics checks and the twin must refuse)."""
    import numpy as np
    from skatelib.pipeline.quadruped.problem import problem, pushoff
    from skatelib.pipeline.quadruped.problem.bounds import bound_terms
    from skatelib.pipeline.quadruped.problem.end_terms import FinalSpeed, RidingEnd

    def board_only(self, n):
        lo, hi = np.full((n, 4), -np.inf), np.full((n, 4), np.inf)
        lo[-1, 0], hi[-1, 0] = -self.rel_tol, self.rel_tol
        return lo, hi

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(FinalSpeed, "bounds", board_only)
        mp.setattr(RidingEnd, "bounds", lambda self, n: (np.full((n, 2), -np.inf), np.full((n, 2), np.inf)))
        mp.setattr(problem, "bound_terms", lambda *a: [t for t in bound_terms(*a) if not t.name.startswith("end_")])
        mp.setattr(pushoff, "_PROBLEMS", {})
        return pushoff.solve(pushoff.PushoffSpec(small_cfg, 0.3, 1))


@pytest.fixture(scope="session")
def tiny_build(tmp_path_factory) -> CliBuild:
    """``skatelib build tests/configs/tiny.toml --jobs 2 --profile``: 0.3 and 0.4 m/s, one stride each;
    its profile is ``profile.json`` beside the library."""
    folder = tmp_path_factory.mktemp("tiny_build")
    return _cli_build(folder, TINY, "--jobs", "2", "--profile", str(folder / "profile.json"))


@pytest.fixture(scope="session")
def tiny_v03(tmp_path_factory) -> CliBuild:
    """``skatelib solve -V 0.3 -s 1 --config tests/configs/tiny.toml``: a library of one solved entry."""
    return _cli_solve(tmp_path_factory.mktemp("tiny_v03"), 0.3, 1)


@pytest.fixture(scope="session")
def tiny_v04(tmp_path_factory) -> CliBuild:
    """``skatelib solve -V 0.4 -s 1 --config tests/configs/tiny.toml``: a library of one solved entry,
    the one the controller and the twin ride."""
    return _cli_solve(tmp_path_factory.mktemp("tiny_v04"), 0.4, 1)


@pytest.fixture(scope="session")
def hrp2_walk_path(tmp_path_factory):
    """The HRP-2 walk library (``configs/hrp2_walk.toml``), built once per session."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library

    out = tmp_path_factory.mktemp("hrp2_walk") / "walk.h5"
    rep = build_library(load_config(CONFIG_DIR / "hrp2_walk.toml"), out, BuildOptions(jobs=1, cache=False))
    assert not rep.failed
    return out


@pytest.fixture(scope="session")
def hrp2_walk_motion():
    """The HRP-2 walk's motion at 0.375 m/s (six steps), solved in this process: its config and motion."""
    from skatelib.pipeline.humanoid.motion import solve_motion

    c = load_config(CONFIG_DIR / "hrp2_walk.toml")
    return c, solve_motion(c, 0.375)


@pytest.fixture(scope="session")
def hrp2_skate_build(tmp_path_factory) -> CliBuild:
    """``skatelib build configs/hrp2_skate.toml -j 2`` (0.5, 0.75 and 1.0 m/s) from an empty cache."""
    return _cli_build(tmp_path_factory.mktemp("hrp2_skate"), CONFIG_DIR / "hrp2_skate.toml", "-j", "2")


@pytest.fixture(scope="session")
def hrp2_skate_v100(tmp_path_factory) -> Path:
    """The shipped skate config's 1.0 m/s entry alone, as a library (built without the cache)."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library

    folder = tmp_path_factory.mktemp("hrp2_skate_v100")
    cfg = folder / "skate.toml"
    cfg.write_text(f'extends = "{(CONFIG_DIR / "hrp2_skate.toml").as_posix()}"\n[sweep]\nvelocities_mps = [1.0]\n')
    out = folder / "skate.h5"
    assert not build_library(load_config(cfg), out, BuildOptions(jobs=1, cache=False)).failed
    return out

