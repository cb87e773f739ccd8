"""The C++ reader (runtime/cpp) agrees with the Python runtime: samples at 1,000 random times per
entry (plus every knot and both ends) and random windows, to 1e-12, on uniform and non-uniform
time grids; it refuses a newer major format version. Skipped, saying why, where CMake, a C++
compiler, HDF5 or nlohmann/json are missing (`make cpp` installs them).

``SKATELIB_CPP_LIB=out/cyberdog2-default.h5`` runs the comparison on that library instead of the
synthetic one."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.channels import CONTROL_NAMES, LEGS, STATE_NAMES
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.runtime import MotionLibrary

pytestmark = pytest.mark.slow  # make test-fast leaves this module out

SOURCE = Path(__file__).resolve().parent.parent / "runtime" / "cpp"


@pytest.fixture(scope="module")
def dump(tmp_path_factory) -> Path:
    if shutil.which("cmake") is None or (shutil.which("c++") or shutil.which("g++")) is None:
        pytest.skip("C++ reader not checked: cmake or a C++ compiler is missing (run `make cpp`)")
    build = tmp_path_factory.mktemp("cpp")
    conf = subprocess.run(["cmake", "-S", str(SOURCE), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release"],
                          capture_output=True, text=True)
    if conf.returncode != 0:
        why = [ln for ln in conf.stderr.splitlines() if ln.strip()][:3]
        pytest.skip(f"C++ reader not checked: HDF5 or nlohmann/json not found (run `make cpp`): {' '.join(why)}")
    subprocess.run(["cmake", "--build", str(build), "-j2"], check=True, capture_output=True)
    return build / "skatelib_dump"


def _entry(v: float, seed: int, uniform: bool) -> EntryRecord:
    rng = np.random.default_rng(seed)
    K = 61
    t = np.arange(K) * 0.03 if uniform else np.cumsum(np.r_[0.0, rng.uniform(0.01, 0.05, K - 1)])
    attrs = dict(zip(schema.ENTRY_ATTRS, (v, 2, True, "Solve_Succeeded", 10, 0.1, 1.0, 1e-9), strict=True))
    return EntryRecord(key=schema.entry_key(v, 2), attrs=attrs,
                     arrays={"t": t, "state": rng.normal(size=(K, 28)), "control": rng.normal(size=(K - 1, 24)),
                             "contact": rng.integers(0, 3, (K, 4)).astype(np.int8),
                             "foot_pos": rng.normal(size=(K, 4, 3)), "board_pos": rng.normal(size=(K, 4))},
                     columns={"state": STATE_NAMES, "control": CONTROL_NAMES, "contact": LEGS})


def _root() -> dict:
    return {schema.A_KIND: "quadruped", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "x",
            schema.A_GIT_COMMIT: "x", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "", schema.A_CASADI: "x",
            schema.A_IPOPT: "x", schema.A_PINOCCHIO: "x"}


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> Path:
    if os.environ.get("SKATELIB_CPP_LIB"):
        return Path(os.environ["SKATELIB_CPP_LIB"])
    p = tmp_path_factory.mktemp("lib") / "lib.h5"
    entries = [_entry(0.3, 1, True), _entry(0.5, 2, False), _entry(0.7, 3, True)]
    return write_library(p, _root(), dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0), {}, {}, entries)


def _run(dump: Path, lib: Path, queries: list[str]) -> list[str]:
    r = subprocess.run([str(dump), str(lib)], input="\n".join(queries) + "\n", capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def _parse(line: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    state, control, contact = line.split("|")
    return (np.array(state.split()[1:], float), np.array(control.split(), float), np.array(contact.split(), int))


def test_samples_agree_with_the_python_runtime(dump, library):
    """1,000 random times per entry, every knot and both ends: equal to 1e-12, contacts equal."""
    lib = MotionLibrary.open(library)
    rng = np.random.default_rng(0)
    for e in lib:
        times = np.r_[rng.uniform(e.t[0] - 0.2, e.t[-1] + 0.2, 1000), e.t, e.t[0], e.t[-1]]
        out = _run(dump, library, [f"S {e.key} {float(t)!r}" for t in times])
        assert len(out) == len(times)
        for t, line in zip(times, out, strict=True):
            x, u, c = _parse(line)
            s = e.sample(float(t))
            assert np.abs(x - s.state).max() <= 1e-12 and np.abs(u - s.control).max() <= 1e-12, (e.key, t)
            assert np.array_equal(c, s.contact), (e.key, t)


def test_windows_agree_with_the_python_runtime(dump, library):
    """Random MPC windows (inside, across and past the ends): states, controls, contacts, times."""
    lib = MotionLibrary.open(library)
    rng = np.random.default_rng(1)
    for e in lib:
        specs = [(float(rng.uniform(e.t[0] - 0.3, e.t[-1])), int(rng.integers(1, 15)), float(rng.uniform(0.005, 0.1)))
                 for _ in range(40)]
        out = _run(dump, library, [f"W {e.key} {t0!r} {n} {dt!r}" for t0, n, dt in specs])
        rows = iter(out)
        for t0, n, dt in specs:
            w = e.window(t0, n, dt)
            for k in range(n):
                line = next(rows)
                x, u, c = _parse(line)
                assert abs(float(line.split()[1]) - w.t[k]) <= 1e-12
                assert np.abs(x[1:] - w.state[k]).max() <= 1e-12 and np.abs(u - w.control[k]).max() <= 1e-12
                assert np.array_equal(c, w.contact[k])


def test_a_newer_major_version_is_refused(dump, library, tmp_path):
    """A file claiming format 2.0 is refused with the field named and what to do."""
    newer = tmp_path / "newer.h5"
    shutil.copy(library, newer)
    with h5py.File(newer, "r+") as f:
        f.attrs[schema.A_FORMAT_VERSION] = "2.0"
    r = subprocess.run([str(dump), str(newer)], input="K\n", capture_output=True, text=True)
    assert r.returncode == 3 and "/@format_version" in r.stderr and "update skatelib" in r.stderr
