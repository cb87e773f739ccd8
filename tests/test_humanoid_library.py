"""A humanoid library's whole body: what the walking build stores (joints with the URDF's names,
waist pose, feet, the filtered COM and ZMP, the URDF in /model), what the runtime serves of it,
and `skatelib validate`'s whole-body checks, each failing on a doctored copy."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.reader import read_library
from skatelib.library.writer import write_library
from skatelib.runtime import MotionLibrary

CLI = [sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()"]


@pytest.fixture(scope="module")
def walk(hrp2_walk_path):
    """The session's walk library (tests/conftest.py); the tests below read it and doctor copies."""
    return hrp2_walk_path


def _validate(path) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, "validate", str(path)], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "COLUMNS": "200"})


def test_the_walk_stores_its_whole_body(walk):
    """Joints (K, 12) named as the URDF's joints, in rad; the filter's figures: the multibody ZMP's
    RMS error after the filter below its error before; the URDF in the file; validate passes."""
    lib = MotionLibrary.open(walk)
    e = lib["walk_v0.375_n6"]
    K = len(e.t)
    assert e.arrays[schema.D_JOINTS].shape == (K, 12) and e.units[schema.D_JOINTS] == ("rad",) * 12
    assert e.columns[schema.D_JOINTS][3] == "L_knee" and "<robot name=\"hrp2_class\">" in lib.urdf
    assert e.arrays[schema.D_FEET].shape == (K, 10) and e.arrays[schema.D_BASE_POSE].shape == (K, 7)
    figures = json.loads(e.attrs[schema.A_WHOLEBODY])
    assert figures["zmp_rms_m"] < 0.5 * figures["zmp_rms_unfiltered_m"]
    assert figures["com_error_max_m"] < 1e-6 and figures["feet_error_max_m"] < 1e-6
    r = _validate(walk)
    assert r.returncode == 0 and "all entries valid" in r.stdout, r.stdout + r.stderr
    info = subprocess.run([*CLI, "info", str(walk), "--json"], capture_output=True, text=True, timeout=120)
    assert json.loads(info.stdout)["entries"][0]["wholebody"] == figures  # info shows them too


def test_the_runtime_serves_joints_by_name_and_time(walk):
    e = MotionLibrary.open(walk)["walk_v0.375_n6"]
    q = e.arrays[schema.D_JOINTS]
    np.testing.assert_array_equal(e.channel("R_knee"), q[:, 9])
    np.testing.assert_array_equal(e.channel("joint_velocities.R_knee"), e.arrays[schema.D_JOINT_VELOCITIES][:, 9])
    t = 1.234
    k = int(np.searchsorted(e.t, t)) - 1
    a = (t - e.t[k]) / (e.t[k + 1] - e.t[k])
    np.testing.assert_allclose(e.array_at("joints", t), q[k] + a * (q[k + 1] - q[k]), atol=1e-15)
    np.testing.assert_array_equal(e.array_at("joints", 99.0), q[-1])
    with pytest.raises(KeyError, match="joints"):
        e.array_at("nodes_t", 1.0)
    w = e.array_window("joints", 1.0, 7, 0.013)
    assert w.shape == (7, 12) and not w.flags.writeable
    for k in range(7):
        np.testing.assert_allclose(w[k], e.array_at("joints", 1.0 + 0.013 * k), atol=1e-15)
    with pytest.raises(TypeError):
        e.array_window("joints", 1.0, 2.5, 0.01)


def _doctored(walk, tmp_path, name, change):
    data = read_library(walk)
    (rec,) = data.entries.values()
    arrays = {**rec.arrays, name: change(np.array(rec.arrays[name]))}
    moved = type(rec)(rec.key, rec.attrs, arrays, rec.columns, rec.units)
    keep = {k: v for k, v in data.attrs.items() if k not in ("format", "format_version", "content_sha256")}
    return write_library(tmp_path / f"{name}.h5", keep, data.model_attrs, data.model_arrays, data.model_text, [moved])


@pytest.mark.parametrize(("name", "change", "words"), [
    (schema.D_FEET, lambda a: a + np.r_[0.005, 0, 0, 0, 0, 0, 0, 0, 0, 0], "miss the body's targets"),
    (schema.D_FEET, lambda a: a + np.r_[0, 0, 0, 0, 0.05, 0, 0, 0, 0, 0], "miss the body's targets"),
    (schema.D_JOINTS, lambda a: np.where(np.arange(12) == 3, -0.01, a), "beyond its limit"),
    (schema.D_JOINT_VELOCITIES, lambda a: 2.0 * a, "faster than its limit"),
    (schema.D_ZMP_WHOLEBODY, lambda a: a + np.r_[0.2, 0.0], "outside the support polygon"),
])
def test_validate_catches_a_doctored_whole_body(walk, tmp_path, name, change, words):
    """A sole moved 5 mm from where the joints put it, or stored pitched 0.05 rad from the joints'
    sole (5 mm at its toe), a knee bent past its limit, joint rates doubled (the walk's fastest,
    3.9 rad/s, past the 6 rad/s limit), the multibody ZMP moved 20 cm: validate exits 1 naming what
    is wrong (the untouched file passes above)."""
    r = _validate(_doctored(walk, tmp_path, name, change))
    assert r.returncode == 1 and words in r.stdout, r.stdout + r.stderr
