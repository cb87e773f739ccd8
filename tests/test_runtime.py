"""Runtime loader: interpolation against np.interp, clamping, windows, selection, blending, and
that it imports nothing but numpy and h5py."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.library import schema
from skatelib.library.channels import CONTROL_NAMES, LEGS, STATE_NAMES
from skatelib.library.writer import EntryData, write_library
from skatelib.runtime import EntryNotFound, MotionLibrary

K = 41


def _entry(v: float, strides: int = 1, seed: int = 0) -> EntryData:
    rng = np.random.default_rng(seed)
    t = np.arange(K) * 0.03
    state = rng.normal(size=(K, 28)) + v
    state[:, 12:24] = rng.uniform(-0.3, 0.3, (K, 12))  # inside every joint's limits
    state[:, 3:6] = state[:, 26] = 0.0  # level trunk and deck: forces below stay inside their cones
    control = np.zeros((K - 1, 24))
    control[:, 2::3] = 20.0  # vertical forces: deep inside the cones
    contact = np.ones((K, 4), dtype=np.int8)
    attrs = dict(zip(schema.ENTRY_ATTRS, (v, strides, True, "Solve_Succeeded", 10, 0.1, 1.0, 1e-9), strict=True))
    return EntryData(key=schema.entry_key(v, strides), attrs=attrs,
                     arrays={"t": t, "state": state, "control": control, "contact": contact,
                             "foot_pos": rng.normal(size=(K, 4, 3)), "board_pos": rng.normal(size=(K, 4))},
                     columns={"state": STATE_NAMES, "control": CONTROL_NAMES, "contact": LEGS})


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    p = tmp_path_factory.mktemp("rt") / "lib.h5"
    root = {schema.A_KIND: "quadruped", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "x",
            schema.A_GIT_COMMIT: "x", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "", schema.A_CASADI: "x",
            schema.A_IPOPT: "x", schema.A_PINOCCHIO: "x"}
    model = dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0) | {"friction_mu": 0.6}
    arrays = {schema.D_JOINT_LOWER: np.full(12, -0.5), schema.D_JOINT_UPPER: np.full(12, 0.5)}
    write_library(p, root, model, arrays, {}, [_entry(0.3, seed=1), _entry(0.5, seed=2), _entry(0.5, 2, seed=3)])
    return MotionLibrary.open(p)


@settings(max_examples=200, deadline=None)
@given(t=st.floats(-1.0, 2.0, allow_nan=False))
def test_sample_matches_np_interp_and_holds_controls(lib, t):
    """State = np.interp per channel (clamped); control = the one acting on [t_k, t_k+1)."""
    e = lib["v0.30_s1"]
    s = e.sample(t)
    expected = np.array([np.interp(t, e.t, e.state[:, j]) for j in range(28)])
    assert np.allclose(s.state, expected, atol=1e-12)
    k = int(np.clip(np.searchsorted(e.t, t, side="right") - 1, 0, K - 2))
    assert np.array_equal(s.control, e.control[k])


def test_window_equals_samples(lib):
    """window(t0, n, dt) stacks the samples at t0 + k dt, clamping past the end."""
    e = lib["v0.50_s1"]
    xs, us = e.window(1.05, 12, 1 / 30)
    for k in range(12):
        s = e.sample(1.05 + k / 30)
        assert np.allclose(xs[k], s.state, atol=1e-12) and np.array_equal(us[k], s.control)


def test_arrays_are_read_only(lib):
    """Arrays handed out cannot be written."""
    e = lib["v0.50_s1"]
    for a in (e.state, e.control, e.sample(0.1).state, e.window(0, 3, 0.01)[0]):
        with pytest.raises(ValueError):
            a[0] = 1.0


def test_select_picks_nearest_velocity_and_strides(lib):
    """select finds the nearest target speed, filtered by strides; unknown strides are named."""
    assert lib.select(0.36).key == "v0.30_s1"
    assert lib.select(0.46).key == "v0.50_s1"
    assert lib.select(0.3, strides=2).key == "v0.50_s2"
    with pytest.raises(EntryNotFound, match="strides available"):
        lib.select(0.3, strides=7)


def test_blend_is_the_linear_mix_and_checked(lib):
    """blend(0.35) = 3/4 of the 0.3 entry + 1/4 of the 0.5 entry, with margins reported."""
    b = lib.blend(0.35, 1)
    a, c = lib["v0.30_s1"], lib["v0.50_s1"]
    assert np.allclose(b.state, 0.75 * a.state + 0.25 * c.state)
    assert b.check is not None and b.check.ok
    assert b.check.min_friction_margin_N == pytest.approx(0.6 * 20.0)
    with pytest.raises(EntryNotFound, match="outside"):
        lib.blend(0.9, 1)


def test_runtime_imports_only_numpy_and_h5py():
    """Importing skatelib.runtime and opening nothing pulls in none of the pipeline's packages."""
    code = ("import sys, skatelib.runtime; bad = [m for m in ('casadi', 'pinocchio', 'rerun', 'joblib', 'typer', "
            "'scipy', 'rich') if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
