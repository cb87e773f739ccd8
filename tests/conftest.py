"""Shared fixtures: the default config and the system built from it, and the libraries several test
modules read (a solve or a build costs seconds to minutes; the modules that read one open it, and
copy it before they change it). The solves and builds are made once per test run, whichever of the
pytest-xdist processes asks first (:func:`_once`); the others wait for it and read what it made."""

from __future__ import annotations

import fcntl
import os
import pickle
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import pytest
from skatelib.pipeline.config import CONFIG_DIR, load_config
from skatelib.pipeline.quadruped.model.system import SkateSystem

from tests.helpers import TINY, run_cli

# Compiles the tiny config's stage functions (the default model's: one library serves its start-ups
# and transitions) or finds them compiled; exits at once without a C compiler.
PRECOMPILE = f"""
from skatelib.pipeline.ocp.stagewise import c_compiler
if c_compiler() is not None:
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.problem.pushoff import problem_for
    problem_for(load_config({str(TINY)!r}, QuadrupedConfig), 1)
"""
_precompile: list[subprocess.Popen] = []


def pytest_configure(config: pytest.Config) -> None:
    """Compiled code (the stage functions of the tiny config's model, the estimator's tick) kept where
    a build of the developer's would keep it (``$SKATELIB_COMPILE_DIR``, else the cache folder),
    whatever entry cache a test points ``SKATELIB_CACHE_DIR`` to: compiled once per machine and
    model, not once per test (the processes a test starts inherit the variable). Where no stage
    functions are compiled yet (a fresh machine), the run's first process starts compiling them in
    the background at once (some 100 s of one core), so that the tests that do not solve
    (:data:`FIRST`) run meanwhile and the first that solves finds them compiled or waits on the
    compile's lock, instead of compiling them itself while the other worker waits; the compile is
    stopped when the run ends first."""
    from skatelib.library import trust

    os.environ[trust.COMPILE_ENV] = str(trust.compile_dir())
    compiled = list(trust.compile_dir().glob("stage_*.so"))  # any: a changed model compiles in its first test
    if not compiled and not hasattr(config, "workerinput"):  # the controller of an xdist run, or no xdist
        _precompile.append(subprocess.Popen([sys.executable, "-c", PRECOMPILE], stdout=subprocess.DEVNULL,
                                            stderr=subprocess.DEVNULL, start_new_session=True))


# Test files that neither solve nor build a quadruped entry (the humanoid's, the installs', the
# readers', the docs', the rides of tests/data's libraries): scheduled first, while the stage
# functions compile in the background. A file here that comes to need the compiled code only waits.
FIRST = ("test_certify", "test_footage", "test_video", "test_fitted", "test_track_report", "test_humanoid",
         "test_rerun_humanoid_twin", "test_controller_install", "test_runtime_install", "test_cpp_reader",
         "test_docs", "test_twin_board", "test_urdf")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The files of :data:`FIRST` first, then the others; in each part the files with more tests
    first, as pytest-xdist's loadfile orders files by default (the Makefile turns its own ordering
    off, ``--no-loadscope-reorder``, to keep this one). Each file's tests stay in their order."""
    by_file: dict[Path, list[pytest.Item]] = {}
    for item in items:
        by_file.setdefault(item.path, []).append(item)
    files = sorted(by_file, key=lambda f: (not f.name.startswith(FIRST), -len(by_file[f])))
    items[:] = [item for f in files for item in by_file[f]]


def pytest_unconfigure(config: pytest.Config) -> None:
    for process in _precompile:
        if process.poll() is None:  # its process group: the C compiler it runs too
            os.killpg(process.pid, signal.SIGTERM)
            process.wait()


class CliBuild(NamedTuple):
    """A library written by ``skatelib build`` or ``skatelib solve`` in a subprocess, with an entry
    cache of its own (a later command pointed at it is served from it)."""

    path: Path
    stdout: str
    cache: Path


def _once(tmp_path_factory: pytest.TempPathFactory, name: str, make: Callable[[Path], Any]) -> Any:
    """``make(folder)``, run once per test run and shared by the pytest-xdist processes: the first to
    ask runs it under a lock in the run's temporary folder (the workers' common parent) and pickles
    what it returns there; the others wait on the lock and unpickle it. A ``make`` that fails leaves
    nothing, so the next process to ask makes it again (and fails the same way)."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent
    folder, value = root / f"once-{name}", root / f"once-{name}.pickle"
    with open(root / f"once-{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if value.exists():
            return pickle.loads(value.read_bytes())
        if folder.exists():
            shutil.rmtree(folder)  # a make that failed
        folder.mkdir()
        made = make(folder)
        part = value.with_suffix(".part")
        part.write_bytes(pickle.dumps(made))
        part.replace(value)
        return made


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
def pushoff_0p3(tmp_path_factory, cfg):
    """The one-stride 0.3 m/s push-off of ``cfg``, solved cold in this process (the problem of
    ``tests/configs/tiny.toml``'s first entry)."""
    from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, solve

    def make(_: Path) -> Any:
        r = solve(PushoffSpec(cfg, 0.3, 1))
        assert r.success, r.status
        return r

    return _once(tmp_path_factory, "pushoff_0p3", make)


@pytest.fixture(scope="session")
def shove_0p3(tmp_path_factory, cfg):
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

    def make(_: Path) -> Any:
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(FinalSpeed, "bounds", board_only)
            mp.setattr(RidingEnd, "bounds", lambda self, n: (np.full((n, 2), -np.inf), np.full((n, 2), np.inf)))
            mp.setattr(problem, "bound_terms",
                       lambda *a: [t for t in bound_terms(*a) if not t.name.startswith("end_")])
            mp.setattr(pushoff, "_PROBLEMS", {})
            return pushoff.solve(pushoff.PushoffSpec(cfg, 0.3, 1))

    return _once(tmp_path_factory, "shove_0p3", make)


@pytest.fixture(scope="session")
def tiny_build(tmp_path_factory) -> CliBuild:
    """``skatelib build tests/configs/tiny.toml --jobs 2 --profile``: 0.3 and 0.4 m/s, one stride each;
    its profile is ``profile.json`` beside the library."""
    return _once(tmp_path_factory, "tiny_build",
                 lambda folder: _cli_build(folder, TINY, "--jobs", "2", "--profile", str(folder / "profile.json")))


@pytest.fixture(scope="session")
def tiny_v03(tmp_path_factory) -> CliBuild:
    """``skatelib solve -V 0.3 -s 1 --config tests/configs/tiny.toml``: a library of one solved entry."""
    return _once(tmp_path_factory, "tiny_v03", lambda folder: _cli_solve(folder, 0.3, 1))


@pytest.fixture(scope="session")
def tiny_v04(tmp_path_factory) -> CliBuild:
    """``skatelib solve -V 0.4 -s 1 --config tests/configs/tiny.toml``: a library of one solved entry,
    the one the controller and the twin ride."""
    return _once(tmp_path_factory, "tiny_v04", lambda folder: _cli_solve(folder, 0.4, 1))


@pytest.fixture(scope="session")
def hrp2_walk_path(tmp_path_factory):
    """The HRP-2 walk library (``configs/hrp2_walk.toml``), built once per session."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library

    def make(folder: Path) -> Path:
        out = folder / "walk.h5"
        cfg = load_config(CONFIG_DIR / "hrp2_walk.toml")
        assert not build_library(cfg, out, BuildOptions(jobs=1, cache=False)).failed
        return out

    return _once(tmp_path_factory, "hrp2_walk", make)


@pytest.fixture(scope="session")
def hrp2_walk_motion():
    """The HRP-2 walk's motion at 0.375 m/s (six steps), solved in this process: its config and motion."""
    from skatelib.pipeline.humanoid.motion import solve_motion

    c = load_config(CONFIG_DIR / "hrp2_walk.toml")
    return c, solve_motion(c, 0.375)


@pytest.fixture(scope="session")
def hrp2_skate_build(tmp_path_factory) -> CliBuild:
    """``skatelib build configs/hrp2_skate.toml -j 2`` (0.5, 0.75 and 1.0 m/s) from an empty cache."""
    return _once(tmp_path_factory, "hrp2_skate_build",
                 lambda folder: _cli_build(folder, CONFIG_DIR / "hrp2_skate.toml", "-j", "2"))


@pytest.fixture(scope="session")
def hrp2_skate_v100(tmp_path_factory) -> Path:
    """The shipped skate config's 1.0 m/s entry alone, as a library (built without the cache)."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library

    def make(folder: Path) -> Path:
        cfg = folder / "skate.toml"
        cfg.write_text(f'extends = "{(CONFIG_DIR / "hrp2_skate.toml").as_posix()}"\n[sweep]\nvelocities_mps = [1.0]\n')
        out = folder / "skate.h5"
        assert not build_library(load_config(cfg), out, BuildOptions(jobs=1, cache=False)).failed
        return out

    return _once(tmp_path_factory, "hrp2_skate_v100", make)

