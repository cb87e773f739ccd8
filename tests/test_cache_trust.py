"""The cache runs nothing it did not write: payloads that cannot execute code when read (no pickle),
cache folders no one else can write, compiled libraries checked against the SHA-256 recorded when
they were built."""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest
from skatelib.library import trust
from skatelib.library.errors import OutputError
from skatelib.pipeline.build import cache as entry_cache
from skatelib.pipeline.build import codec, sweep
from skatelib.pipeline.build.preflight import check_cache_dir
from skatelib.pipeline.config import load_config
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.stagewise import CompileTarget, c_compiler, compiled_stage_functions
from skatelib.pipeline.quadruped import tasks
from skatelib.pipeline.quadruped.problem import pushoff

from tests.helpers import CLI, TINY

ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


class _Planted:
    """Unpickling this writes a marker file: proof that a reader ran code from the cache."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv(trust.TRUSTED_ENV, raising=False)
    monkeypatch.setattr(pushoff, "_PROBLEMS", {})
    return tmp_path / "cache"


def _chain() -> tasks.BuildTask:
    return tasks.BuildTask(load_config(TINY), 1, (0.3,))


def _framed(payload: bytes) -> bytes:
    """A blob with a valid header and checksum around ``payload``: what someone who can write the
    cache and recompute checksums would plant."""
    return entry_cache._MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + b"-" * 8 + b"\n" + payload


@pytest.mark.slow
def test_a_planted_pickle_is_neither_run_nor_trusted(cache, tmp_path):
    """A payload whose unpickling would write a marker file sits where the entry's cache file goes,
    with a valid checksum, and as an old-style ``.pkl`` beside it: the build solves the entry
    again, says why, and the marker never appears."""
    first = sweep.run_task(_chain())
    key = first[0].cache_key
    marker = tmp_path / "ran"
    evil = pickle.dumps({"result": _Planted(str(marker)), "attempts": 1})
    (cache / "entries" / f"{key}.pkl").write_bytes(_framed(evil))
    (cache / "entries" / f"{key}.entry").write_bytes(_framed(evil))
    again = sweep.run_task(_chain())
    assert not marker.exists()
    assert not again[0].cached and "cannot be loaded" in again[0].note
    assert np.array_equal(again[0].result.state, first[0].result.state)
    assert sweep.run_task(_chain())[0].cached  # repaired


@pytest.mark.slow
def test_an_entry_served_from_the_cache_equals_the_solved_one(cache):
    """Every array and figure of an entry read back from the new cache format is bit-identical
    with the one the solve returned."""
    first = sweep.run_task(_chain())[0].result
    again = sweep.run_task(_chain())[0]
    assert again.cached
    for name in ("t", "state", "control", "contact", "foot_pos", "board_pos"):
        a, b = getattr(first, name), getattr(again.result, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    for name in ("success", "status", "iterations", "objective", "max_constraint_violation", "final_velocity_mps",
                 "ipopt_options"):
        assert getattr(first, name) == getattr(again.result, name), name


def test_the_codec_refuses_what_it_does_not_know():
    """Object arrays and unregistered classes are not written; a manifest naming an unregistered
    type, or bytes that are not such a payload, are not read."""
    with pytest.raises(codec.PayloadError, match="object array"):
        codec.encode({"a": np.array([object()])})
    with pytest.raises(codec.PayloadError, match="cannot be cached"):
        codec.encode({"a": _Planted("x")})
    blob = codec.encode({"x": (1, 2.5, "s", None, np.arange(3), np.float32(1.5))})
    out = codec.decode(blob)
    assert out["x"][:4] == (1, 2.5, "s", None) and np.array_equal(out["x"][4], np.arange(3))
    assert out["x"][5].dtype == np.float32
    buf = io.BytesIO()
    manifest = json.dumps({"$c": "os.system", "f": {"command": "touch ran"}}).encode()
    np.savez(buf, manifest=np.frombuffer(manifest, dtype=np.uint8))
    with pytest.raises(codec.PayloadError, match=r"not registered: 'os\.system'"):
        codec.decode(buf.getvalue())
    with pytest.raises(codec.PayloadError):
        codec.decode(blob[:-7])  # truncated
    with pytest.raises(codec.PayloadError):
        codec.decode(pickle.dumps({"x": 1}))


def test_a_cache_folder_others_can_write_is_refused_before_any_solve(cache, tmp_path):
    """Group- or world-writable: the preflight refuses it naming the folder and what to do, and
    ``skatelib build`` exits 2 without solving."""
    cache.mkdir(parents=True)
    cache.chmod(0o777)
    with pytest.raises(OutputError, match="can be written by others") as e:
        check_cache_dir()
    assert str(cache) in str(e.value) and "chmod go-w" in str(e.value) and "--no-cache" in str(e.value)
    out = tmp_path / "lib.h5"
    env = {**os.environ, "SKATELIB_CACHE_DIR": str(cache)}
    run = subprocess.run([*CLI, "build", str(TINY), "-o", str(out), "--no-progress"], capture_output=True,
                         text=True, env=env, timeout=120)
    assert run.returncode == 2, run.stderr
    assert "can be written by others" in run.stderr and not out.exists()
    assert not list((cache / "entries").glob("*")) if (cache / "entries").exists() else True
    cache.chmod(0o700)
    check_cache_dir()


def test_a_writable_shared_cache_is_refused(cache, tmp_path, monkeypatch):
    """A folder named in SKATELIB_TRUSTED_CACHE that its users can write is no trusted cache."""
    shared = tmp_path / "shared"
    shared.mkdir()
    monkeypatch.setenv(trust.TRUSTED_ENV, str(shared))
    with pytest.raises(OutputError, match=trust.TRUSTED_ENV):
        check_cache_dir()


@pytest.mark.skipif(ROOT, reason="root can write every file: no folder is read-only to it")
def test_a_read_only_shared_cache_serves_entries(cache, tmp_path, monkeypatch):
    """Entries solved into one cache, made read-only and named as the shared cache, serve a user
    whose own cache is empty; nothing is written to the shared one."""
    sweep.run_task(_chain())
    shared = tmp_path / "shared"
    cache.rename(shared)
    for p in sorted(shared.rglob("*"), reverse=True):
        p.chmod(0o555 if p.is_dir() else 0o444)
    shared.chmod(0o555)
    monkeypatch.setenv(trust.TRUSTED_ENV, str(shared))
    check_cache_dir()
    again = sweep.run_task(_chain())
    assert again[0].cached


def _tiny_stage() -> StageExpressions:
    z, p = ca.SX.sym("z", 2), ca.SX.sym("p", 1)
    return StageExpressions(z, p, (z[0] - p[0]) ** 2 + z[1] ** 2, ca.vertcat(z[0] * z[1]))


@pytest.mark.skipif(c_compiler() is None, reason="no C compiler")
def test_a_compiled_library_changed_after_it_was_built_is_compiled_again(tmp_path):
    """The library's SHA-256 is recorded when it is built; a library whose bytes changed since is
    not loaded: a note names it and it is compiled again (and then matches its record)."""
    folder = tmp_path / "cc"
    folder.mkdir(mode=0o700)
    fns = compiled_stage_functions(_tiny_stage(), CompileTarget(folder, ("-O0",)))
    (lib,) = folder.glob("stage_*.so")
    record = trust.digest_record(lib)
    assert record.read_text().strip() == trust.sha256_of(lib)
    assert float(fns.value(ca.DM([1.0, 2.0]), ca.DM([0.5]))[0]) == pytest.approx(4.25)
    with open(lib, "ab") as f:
        f.write(b"\0")  # another library's bytes, as far as the record can tell
    with pytest.warns(trust.CacheNote, match="changed after it was built"):
        again = compiled_stage_functions(_tiny_stage(), CompileTarget(folder, ("-O0",)))
    assert record.read_text().strip() == trust.sha256_of(lib)
    assert float(again.value(ca.DM([1.0, 2.0]), ca.DM([0.5]))[0]) == pytest.approx(4.25)
    lib.chmod(0o666)  # a library others could replace is not loaded either
    with pytest.warns(trust.CacheNote, match="can be written by others"):
        compiled_stage_functions(_tiny_stage(), CompileTarget(folder, ("-O0",)))
    with warnings.catch_warnings():
        warnings.simplefilter("error", trust.CacheNote)  # as built and private: loaded without a note
        compiled_stage_functions(_tiny_stage(), CompileTarget(folder, ("-O0",)))


def test_a_tls_scheduler_needs_dask_tls_settings():
    """A tls:// address is accepted with dask's TLS settings (CA file, client certificate) and
    refused, naming them, without; the reachability check follows."""
    pytest.importorskip("distributed")
    import dask
    from skatelib.library.errors import ConfigError
    from skatelib.pipeline.build.preflight import check_scheduler

    unset = {"distributed.comm.tls.ca-file": None, "distributed.comm.tls.client.cert": None}
    with dask.config.set(unset), pytest.raises(ConfigError, match=r"distributed\.comm\.tls\.ca-file"):
        check_scheduler("tls://127.0.0.1:1")
    settings = {"distributed.comm.tls.ca-file": "ca.pem", "distributed.comm.tls.client.cert": "c.pem",
                "distributed.comm.tls.client.key": "c.key"}
    with dask.config.set(settings), pytest.raises(ConfigError, match="no dask scheduler answers"):
        check_scheduler("tls://127.0.0.1:1", timeout_s=0.5)
