"""The sweep's entry cache: keyed on what determines a solution, checksummed, never stale."""

from __future__ import annotations

import dataclasses
import os

import pytest
from skatelib.library import trust
from skatelib.pipeline.build import sweep
from skatelib.pipeline.config import load_config
from skatelib.pipeline.ocp.stagewise import c_compiler
from skatelib.pipeline.quadruped import tasks
from skatelib.pipeline.quadruped.problem import costs as pushoff_costs
from skatelib.pipeline.quadruped.problem import pushoff

from tests.helpers import TINY, run_cli


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(pushoff, "_PROBLEMS", {})  # no problem built with other code survives a test
    return tmp_path / "cache"


def _chain(compiled: bool = True) -> tasks.BuildTask:
    cfg = load_config(TINY)
    if not compiled:  # code changed in a test is another model: interpreted, it needs no compile of its own
        cfg = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))
    return tasks.BuildTask(cfg, 1, (0.3,))


def test_key_ignores_name_sweep_list_compile_and_checkout_path(tmp_path):
    """Renaming the library, changing the sweep list or the compile switches (native or portable
    code), or moving the config and URDF to another folder keeps the problem (and so the cache
    key's config part) the same."""
    cfg = load_config(TINY)
    other = dataclasses.replace(
        cfg, meta=dataclasses.replace(cfg.meta, name="renamed"),
        sweep=dataclasses.replace(cfg.sweep, velocities_mps=(0.9,), strides=(7,)),
        optimization=dataclasses.replace(cfg.optimization, compile=False, compile_native=False))
    assert other.problem_json() == cfg.problem_json()
    moved = tmp_path / "robot.urdf"
    moved.write_bytes(cfg.urdf_path.read_bytes())
    relocated = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, urdf=str(moved)))
    assert relocated.problem_json() == cfg.problem_json()
    moved.write_bytes(cfg.urdf_path.read_bytes().replace(b"<robot", b"<robot ", 1))
    assert relocated.problem_json() != cfg.problem_json()  # the URDF's bytes count


@pytest.mark.slow
def test_a_changed_cost_term_misses_the_cache(cache, monkeypatch):
    """A second run is served from the cache; after a cost weight changes in code it is solved again."""
    first = sweep.run_task(_chain(compiled=False))
    again = sweep.run_task(_chain(compiled=False))
    assert not first[0].cached and again[0].cached
    assert again[0].cache_key == first[0].cache_key

    original = pushoff_costs.EffortCost.cost
    monkeypatch.setattr(pushoff_costs.EffortCost, "cost", lambda self, s: 2.0 * original(self, s))
    monkeypatch.setattr(pushoff, "_PROBLEMS", {})
    changed = sweep.run_task(_chain(compiled=False))
    assert not changed[0].cached
    assert changed[0].cache_key != first[0].cache_key


@pytest.mark.slow
def test_a_damaged_cache_entry_is_solved_again_with_a_note(cache):
    """One flipped bit in a cached entry's payload is caught by its checksum: the entry is solved
    again, the user is told, and the cache is repaired."""
    first = sweep.run_task(_chain())
    path = cache / "entries" / f"{first[0].cache_key}.entry"
    blob = bytearray(path.read_bytes())
    blob[len(blob) // 2] ^= 0x04
    path.write_bytes(bytes(blob))
    again = sweep.run_task(_chain())
    assert not again[0].cached
    assert "damaged" in again[0].note and str(path) in again[0].note
    assert sweep.run_task(_chain())[0].cached


@pytest.mark.skipif(c_compiler() is None, reason="no C compiler: nothing is compiled")
def test_compiled_code_is_kept_apart_from_the_entries(tmp_path, monkeypatch):
    """With SKATELIB_COMPILE_DIR set (the suite sets it), a build keeps its entries in the cache
    folder and loads its compiled stage functions from the folder of compiled code: no compiled
    code in the cache folder. Unset, the folder of compiled code is the cache folder."""
    compiled = trust.compile_dir()
    assert os.environ.get(trust.COMPILE_ENV) == str(compiled)
    cache = tmp_path / "cache"
    r = run_cli(["build", str(TINY), "-o", str(tmp_path / "x.h5"), "--no-progress"],
                env={**os.environ, "COLUMNS": "200", trust.CACHE_ENV: str(cache)})
    assert r.returncode == 0, r.stdout + r.stderr
    assert len(list((cache / "entries").glob("*.entry"))) == 2
    assert not [p.name for p in cache.iterdir() if p.name != "entries"]
    assert list(compiled.glob("stage_*.so"))
    monkeypatch.delenv(trust.COMPILE_ENV)
    monkeypatch.setenv(trust.CACHE_ENV, str(cache))
    assert trust.compile_dir() == cache
