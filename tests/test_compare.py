"""`skatelib diff` and `build --check`: a library equals its copy; two libraries built from configs
that differ in one cost weight differ, and the comparison names the entries, the channels and the
config key; `--json` is one parseable document; `build --check` passes on an unchanged config and
fails after a weight changes, leaving the reference as it was. The tolerance test builds its
expectation from numpy directly."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from skatelib.library.compare import Tolerance, compare_files
from skatelib.library.reader import read_library
from skatelib.library.writer import write_library

from tests.helpers import CLI, TINY, interpreted_tiny

pytestmark = pytest.mark.slow  # make test-fast leaves this module out


def _cli(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "COLUMNS": "200"})


@pytest.fixture(scope="module")
def pair(tmp_path_factory, tiny_build):
    """The tiny library (a.h5, the session's build), and the same built with the force-rate weight
    doubled (b.h5); the module's commands use the session build's entry cache."""
    d = tmp_path_factory.mktemp("diff")
    shutil.copy(tiny_build.path, d / "a.h5")
    heavier = d / "heavier.toml"
    interpreted_tiny(heavier, "[optimization.weights]\nforce_rate = 2e-3\n")  # another model
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SKATELIB_CACHE_DIR", str(tiny_build.cache))
        r = _cli(["build", str(heavier), "-o", str(d / "b.h5"), "--no-progress"])
        assert r.returncode == 0, r.stdout + r.stderr
        yield d, heavier


def test_a_copy_is_equal(pair, tmp_path):
    """diff of a library with its copy: exit 0, 'equal'."""
    d, _ = pair
    shutil.copy(d / "a.h5", tmp_path / "copy.h5")
    r = _cli(["diff", str(d / "a.h5"), str(tmp_path / "copy.h5")])
    assert r.returncode == 0 and "equal: 2 entries" in r.stdout, r.stdout + r.stderr


def test_one_weight_changed_is_named(pair):
    """Exit 1; the table names both entries, force channels with their unit, and the config key;
    --json carries the same, per channel with the time of the largest deviation."""
    d, _ = pair
    r = _cli(["diff", str(d / "a.h5"), str(d / "b.h5")])
    assert r.returncode == 1, r.stdout + r.stderr
    for words in ("v0.30_s1", "v0.40_s1", "optimization.weights.force_rate", "f_FL_z", " N ", "differ"):
        assert words in r.stdout, words
    r = _cli(["diff", str(d / "a.h5"), str(d / "b.h5"), "--json", "--entry", "v0.30_s1"])
    doc = json.loads(r.stdout)
    assert r.returncode == 1 and doc["equal"] is False and [c["key"] for c in doc["changed"]] == ["v0.30_s1"]
    assert {"name": "optimization.weights.force_rate", "a": 0.001, "b": 0.002} in doc["config"]
    channels = doc["changed"][0]["channels"]
    worst = max(channels, key=lambda c: c["max_abs"])
    lib_a, lib_b = read_library(d / "a.h5").entries["v0.30_s1"], read_library(d / "b.h5").entries["v0.30_s1"]
    j = list(lib_a.columns[worst["array"]]).index(worst["column"])
    dev = np.abs(lib_a.arrays[worst["array"]][:, j] - lib_b.arrays[worst["array"]][:, j])
    assert worst["max_abs"] == pytest.approx(dev.max()) and worst["at_s"] == lib_b.arrays["t"][np.argmax(dev)]
    r = _cli(["diff", str(d / "a.h5"), str(d / "b.h5"), "--entry", "v9.99_s1"])  # a typo is no 'equal'
    assert r.returncode == 2 and "v0.30_s1" in r.stderr, r.stdout + r.stderr


def test_tolerances_decide(pair, tmp_path):
    """A state column moved by 1e-6: differs bit for bit, equal with atol 1e-5 (and not with 1e-7);
    the reported deviation is the one planted."""
    d, _ = pair
    data = read_library(d / "a.h5")
    rec = data.entries["v0.40_s1"]
    state = np.array(rec.arrays["state"])
    state[5, 2] += 1e-6
    moved = type(rec)(rec.key, rec.attrs, {**rec.arrays, "state": state}, rec.columns, rec.units)
    out = write_library(tmp_path / "m.h5", {k: v for k, v in data.attrs.items() if k not in ("format", "format_version",
                                                                                            "content_sha256")},
                        data.model_attrs, data.model_arrays, data.model_text,
                        [data.entries["v0.30_s1"], moved])
    exact = compare_files(d / "a.h5", out)
    assert not exact.equal and [c.key for c in exact.changed if c.differs] == ["v0.40_s1"]
    (ch,) = exact.changed[0].channels
    assert (ch.array, ch.column, ch.unit) == ("state", "base_z", "m") and ch.max_abs == pytest.approx(1e-6, rel=1e-6)
    assert ch.at_s == pytest.approx(float(rec.arrays["t"][5]))
    assert compare_files(d / "a.h5", out, Tolerance(atol=1e-5)).equal
    assert not compare_files(d / "a.h5", out, Tolerance(atol=1e-7)).equal


def test_build_check_passes_unchanged_and_fails_changed(pair):
    """build --check on the config a library was built from: exit 0 (served from the entry cache);
    on the heavier-weight config: exit 1 naming the key; the reference is untouched either way."""
    d, heavier = pair
    before = (d / "a.h5").read_bytes()
    r = _cli(["build", str(TINY), "--check", str(d / "a.h5"), "--no-progress"])
    assert r.returncode == 0 and "equal" in r.stdout, r.stdout + r.stderr
    r = _cli(["build", str(heavier), "--check", str(d / "a.h5"), "--no-progress"])
    assert r.returncode == 1 and "force_rate" in r.stdout and "differs from" in r.stdout, r.stdout + r.stderr
    assert (d / "a.h5").read_bytes() == before
    r = _cli(["build", str(TINY), "--check", str(d / "missing.h5")])
    assert r.returncode == 3, r.stdout + r.stderr


def test_humanoid_libraries_compare_too(hrp2_walk_path, tmp_path):
    """A humanoid library equals its copy, and a rebuild of it (its stage times differ: reported as
    effort, not counted), and is not compared with a quadruped's (exit 2); with its COM height moved
    2 mm at one knot it differs, naming the entry, com_z, its unit and that knot's time."""
    root = TINY.parents[2]
    lib = hrp2_walk_path
    shutil.copy(lib, tmp_path / "copy.h5")
    assert _cli(["diff", str(lib), str(tmp_path / "copy.h5")]).returncode == 0
    r = _cli(["diff", str(root / "tests" / "data" / "tiny-reference.h5"), str(lib)])  # a quadruped's: usage error
    assert r.returncode == 2 and "a humanoid one: only libraries of one kind" in " ".join(r.stderr.split()), r.stderr
    r = _cli(["build", str(TINY), "--check", str(lib), "--no-progress"])  # refused before any solve
    assert r.returncode == 2 and "a humanoid library" in " ".join(r.stderr.split()), r.stdout + r.stderr
    again = tmp_path / "again.h5"
    r = _cli(["build", str(root / "configs" / "hrp2_walk.toml"), "-o", str(again), "--no-progress", "--no-cache"])
    assert r.returncode == 0, r.stdout + r.stderr
    r = _cli(["diff", str(lib), str(again), "--json"])
    doc = json.loads(r.stdout)
    assert r.returncode == 0 and doc["equal"], r.stdout
    assert {"wholebody.ik_and_filter_s"} <= {f["name"] for c in doc["changed"] for f in c["effort"]}
    data = read_library(lib)
    key, rec = next(iter(data.entries.items()))
    state = np.array(rec.arrays["state"])
    state[40, 2] += 2e-3
    moved = type(rec)(rec.key, rec.attrs, {**rec.arrays, "state": state}, rec.columns, rec.units)
    keep = {k: v for k, v in data.attrs.items() if k not in ("format", "format_version", "content_sha256")}
    other = write_library(tmp_path / "moved.h5", keep, data.model_attrs, data.model_arrays, data.model_text,
                          [moved, *(e for k, e in data.entries.items() if k != key)])
    r = _cli(["diff", str(lib), str(other), "--json"])
    doc = json.loads(r.stdout)
    assert r.returncode == 1 and [c["key"] for c in doc["changed"] if c["channels"]] == [key]
    (ch,) = doc["changed"][0]["channels"]
    assert (ch["column"], ch["unit"]) == ("com_z", "m") and ch["max_abs"] == pytest.approx(2e-3)
    assert ch["at_s"] == pytest.approx(float(rec.arrays["t"][40]))
