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
from skatelib.library.channels import CONTROL_NAMES, CONTROL_UNITS, LEGS, STATE_NAMES, STATE_UNITS
from skatelib.library.errors import SkatelibError
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.runtime import BlendMargin, EntryNotFound, MotionLibrary

K = 41


def _entry(v: float, strides: int = 1, seed: int = 0) -> EntryRecord:
    rng = np.random.default_rng(seed)
    t = np.arange(K) * 0.03
    state = rng.normal(size=(K, 28)) + v
    state[:, 12:24] = rng.uniform(-0.3, 0.3, (K, 12))  # inside every joint's limits
    state[:, 3:6] = state[:, 26] = 0.0  # level trunk and deck: forces below stay inside their cones
    control = np.zeros((K - 1, 24))
    control[:, 2::3] = 20.0  # vertical forces: deep inside the cones
    contact = np.ones((K, 4), dtype=np.int8)
    attrs = dict(zip(schema.ENTRY_ATTRS, (v, strides, True, "Solve_Succeeded", 10, 0.1, 1.0, 1e-9), strict=True))
    return EntryRecord(key=schema.entry_key(v, strides), attrs=attrs,
                     arrays={"t": t, "state": state, "control": control, "contact": contact,
                             "foot_pos": rng.normal(size=(K, 4, 3)), "board_pos": rng.normal(size=(K, 4))},
                     columns={"state": STATE_NAMES, "control": CONTROL_NAMES, "contact": LEGS},
                     units={"state": STATE_UNITS, "control": CONTROL_UNITS})


_ROOT = {schema.A_KIND: "quadruped", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "x",
         schema.A_GIT_COMMIT: "x", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "", schema.A_CASADI: "x",
         schema.A_IPOPT: "x", schema.A_PINOCCHIO: "x"}
_MODEL = dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0) | {"friction_mu": 0.6}
_LIMITS = {schema.D_JOINT_LOWER: np.full(12, -0.5), schema.D_JOINT_UPPER: np.full(12, 0.5)}


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    p = tmp_path_factory.mktemp("rt") / "lib.h5"
    write_library(p, _ROOT, _MODEL, _LIMITS, {}, [_entry(0.3, seed=1), _entry(0.5, seed=2), _entry(0.5, 2, seed=3)])
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
    w = e.window(1.05, 12, 1 / 30)
    for k in range(12):
        s = e.sample(1.05 + k / 30)
        assert np.allclose(w.state[k], s.state, atol=1e-12) and np.array_equal(w.control[k], s.control)
        assert np.array_equal(w.contact[k], s.contact) and w.t[k] == pytest.approx(1.05 + k / 30)


def test_arrays_are_read_only(lib):
    """Arrays handed out cannot be written."""
    e = lib["v0.50_s1"]
    w = e.window(0, 3, 0.01)
    for a in (e.state, e.control, e.sample(0.1).state, w.state, w.control, w.contact, w.t):
        with pytest.raises(ValueError):
            a[0] = 1.0


def test_select_picks_nearest_velocity_and_strides(lib):
    """select finds the nearest target speed, filtered by strides; unknown strides are named."""
    assert lib.select(0.36).key == "v0.30_s1"
    assert lib.select(0.46).key == "v0.50_s1"
    assert lib.select(0.3, strides=2, clamp=True).key == "v0.50_s2"
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


def test_blend_picks_start_ups_whatever_strides_transitions_have(tmp_path):
    """A library of two-stride start-ups and a one-stride transition (the default library's shape):
    blend(v) without strides mixes the start-ups around v (it took the transitions' 1 stride as a
    start-up's and raised EntryNotFound 'strides=1'); a speed only a transition reaches is outside."""
    path = tmp_path / "ride.h5"
    ride = _entry(0.5, 1, seed=4)
    ride = EntryRecord(key=schema.entry_key(0.5, 1, 0.3), attrs={**ride.attrs, schema.A_FROM_VELOCITY: 0.3},
                       arrays=ride.arrays, columns=ride.columns, units=ride.units)
    write_library(path, _ROOT, _MODEL, _LIMITS, {}, [_entry(0.3, 2, seed=1), _entry(0.7, 2, seed=2), ride])
    rides = MotionLibrary.open(path)
    b = rides.blend(0.6)
    assert b.attrs["blend_sources"] == ("v0.30_s2", "v0.70_s2") and b.n_strides == 2
    a, c = rides["v0.30_s2"], rides["v0.70_s2"]
    assert np.allclose(b.state, 0.25 * a.state + 0.75 * c.state)
    with pytest.raises(EntryNotFound, match="outside"):
        rides.blend(0.8)


def test_blend_strict_rejects_a_blend_that_misses_its_margins(lib):
    """The joints of the test entries come within 0.2 rad of their limits: a margin of 0.3 rad
    rejects the blend (strict, the default), and strict=False returns it with the failed check."""
    tight = BlendMargin(joint_rad=0.3)
    with pytest.raises(SkatelibError, match="misses its margins"):
        lib.blend(0.35, 1, margin=tight)
    b = lib.blend(0.35, 1, strict=False, margin=tight)
    assert b.check is not None and not b.check.ok and b.check.min_joint_limit_slack_rad < 0.3


def test_runtime_imports_only_numpy_and_h5py():
    """Importing skatelib.runtime and opening nothing pulls in none of the pipeline's packages."""
    code = ("import sys, skatelib.runtime; bad = [m for m in ('casadi', 'pinocchio', 'rerun', 'joblib', 'typer', "
            "'scipy', 'rich') if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_membership_keys_and_repr(lib):
    """`key in lib` tests keys (it was False for every key: iteration yields entries)."""
    assert "v0.50_s1" in lib and "v9.99_s1" not in lib
    assert lib.keys() == ["v0.30_s1", "v0.50_s1", "v0.50_s2"]
    assert "3 entries" in repr(lib) and "v0.50_s1" in repr(lib["v0.50_s1"])


@pytest.mark.parametrize("args", [(0.0, -1, 0.03), (0.0, 0, 0.03), (float("nan"), 3, 0.03), (0.0, 3, 0.0),
                                  (0.0, 3, -0.03), (0.0, 3, float("nan")), (float("inf"), 3, 0.03),
                                  (0.0, 10, 1e308), (0.0, 10, 60.001)])
def test_window_refuses_bad_arguments(lib, args):
    """n < 1, a non-finite t0, dt <= 0, non-finite or absurd: a ValueError naming the argument (it
    returned 1023 rows for n = -1, raised IndexError for n = 0, a NaN t0 or dt = 1e308)."""
    with pytest.raises(ValueError, match=r"window\(t0, n, dt\): (t0|n|dt) must"):
        lib["v0.30_s1"].window(*args)
    with pytest.raises(ValueError, match=r"\): (t0|t|n|dt) must"):
        lib["v0.30_s1"].array_window("foot_pos", *args)


def test_window_takes_steps_up_to_its_bound(lib):
    """dt up to WINDOW_MAX_DT_S (a minute) clamps to the entry's ends; the refusal names the range."""
    from skatelib.runtime.entry import WINDOW_MAX_DT_S

    e = lib["v0.30_s1"]
    w = e.window(0.0, 3, WINDOW_MAX_DT_S)
    assert np.allclose(w.state[1:], e.state[-1], rtol=0, atol=1e-12) and np.array_equal(w.t, [0.0, 60.0, 120.0])
    with pytest.raises(ValueError, match=r"dt must be a step in seconds in \(0, 60\].*got 1e\+308"):
        e.window(0.0, 10, 1e308)


@pytest.mark.parametrize("t", [float("nan"), float("inf"), -float("inf")])
def test_sample_refuses_non_finite_times(lib, t):
    """sample(nan) says what is wrong (it raised 'cannot convert float NaN to integer')."""
    with pytest.raises(ValueError, match=r"sample\(t\): t must be a finite time"):
        lib["v0.30_s1"].sample(t)


def test_select_outside_the_range_raises_unless_clamped(lib):
    """select(5.0) names the stored speeds (it silently returned the fastest entry); clamp=True
    asks for the nearest; NaN is a ValueError (it returned the slowest entry)."""
    with pytest.raises(EntryNotFound, match=r"outside the stored speeds \[0.3, 0.5\]"):
        lib.select(5.0)
    assert lib.select(5.0, clamp=True).key == "v0.50_s1"
    with pytest.raises(ValueError, match="finite speed"):
        lib.select(float("nan"))


@pytest.mark.parametrize(("call", "old", "new"), [
    ("select", "velocity", "target_velocity_mps"), ("select", "v_from", "from_velocity_mps"),
    ("select", "v_to", "target_velocity_mps"), ("route", "v_to", "target_velocity_mps"),
    ("route", "v_from", "from_velocity_mps"), ("blend", "velocity", "target_velocity_mps"),
    ("speeds", "v_from", "from_velocity_mps")])
def test_an_old_speed_keyword_is_refused_naming_the_new_one(lib, call, old, new):
    """Each speed keyword the runtime renamed (one name per quantity) raises a TypeError that names
    its new keyword; the new keyword is accepted."""
    with pytest.raises(TypeError, match=f"the keyword '{old}' is now '{new}'"):
        getattr(lib, call)(**{old: 0.3})
    assert lib.select(target_velocity_mps=0.36, from_velocity_mps=0.0).key == "v0.30_s1"
    assert lib.speeds(from_velocity_mps=0.0) == [0.3, 0.5]


def test_channels_by_name_with_units(lib):
    """Samples and windows read channels by name, with the units stored in the file."""
    e = lib["v0.50_s1"]
    s, w = e.sample(0.4), e.window(0.4, 5, 0.05)
    assert s["board_vx"] == s.state[24] and s["f_RL_z"] == s.control[8]
    assert np.array_equal(w["board_vx"], w.state[:, 24]) and np.array_equal(w["qd_FL_hip"], w.control[:, 13])
    assert s.unit("board_vx") == w.unit("board_vx") == e.unit("board_vx") == "m/s" and e.unit("f_FL_x") == "N"
    with pytest.raises(KeyError, match="board_vx"):
        s["board_speed"]


def test_blend_has_its_own_attributes(lib):
    """A blend carries its own speed, sources and weights, not the lower neighbour's solve figures;
    strides may be left out as for select."""
    b = lib.blend(0.4)
    assert b.target_velocity_mps == 0.4 and b.n_strides == 1 and b.success
    assert b.attrs["blend_sources"] == ("v0.30_s1", "v0.50_s1")
    assert b.attrs["blend_weights"] == pytest.approx((0.5, 0.5))
    assert "final_velocity_mps" not in b.attrs and "iterations" not in b.attrs


def test_blend_margin_refuses_a_blend_at_the_friction_cone(tmp_path):
    """Entries whose deck feet use 99.5 % of the cone blend into one that misses the default 1 %
    friction margin: strict refuses it, non-strict marks it failed; margin 0 accepts it."""
    entries = []
    for v, seed in ((0.3, 1), (0.5, 2)):
        d = _entry(v, seed=seed)
        d.arrays["control"][:, 0::3] = 0.995 * 0.6 * 20.0  # f_x at 99.5 % of mu f_z, deck level
        entries.append(d)
    p = tmp_path / "edge.h5"
    root = {schema.A_KIND: "quadruped", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "x",
            schema.A_GIT_COMMIT: "x", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "", schema.A_CASADI: "x",
            schema.A_IPOPT: "x", schema.A_PINOCCHIO: "x"}
    model = dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0) | {"friction_mu": 0.6}
    write_library(p, root, model, {}, {}, entries)
    edge = MotionLibrary.open(p)
    with pytest.raises(SkatelibError, match="misses its margins"):
        edge.blend(0.4, 1)
    loose = edge.blend(0.4, 1, strict=False)
    assert not loose.success and loose.check is not None and loose.check.max_friction_use == pytest.approx(0.995)
    assert edge.blend(0.4, 1, margin=BlendMargin(friction_fraction=0.0)).success


def test_window_takes_an_integer_count_and_has_a_bound(lib):
    """A float n is a TypeError (it was 'slice indices must be integers'); n beyond WINDOW_MAX_N is a
    ValueError before anything is allocated (10**7 steps took 6.5 GB); at the bound it works."""
    import tracemalloc

    from skatelib.runtime.entry import WINDOW_MAX_N

    e = lib["v0.30_s1"]
    with pytest.raises(TypeError, match="n must be an integer"):
        e.window(0.0, 10.5, 0.1)
    with pytest.raises(TypeError, match="n must be an integer"):
        e.window(0.0, True, 0.1)
    tracemalloc.start()
    with pytest.raises(ValueError, match="beyond the bound"):
        e.window(0.0, 10**7, 1e-3)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 1e6
    w = e.window(0.0, WINDOW_MAX_N, 1e-3)
    assert w.state.shape[0] == WINDOW_MAX_N and e.window(0.0, np.int64(3), 0.1).state.shape[0] == 3


def test_codes_hold_and_one_dimensional_arrays_interpolate(tmp_path):
    """``array_at`` / ``array_window`` of the contact codes are :meth:`sample`'s and :meth:`window`'s
    codes (held, never half a code: a leg from ground to swing is not 'on the board' between), and a
    per-knot array of one dimension (``t``) is interpolated like the others."""
    e = _entry(0.4, seed=4)
    e.arrays["contact"] = np.random.default_rng(5).integers(0, 3, (K, 4)).astype(np.int8)
    p = tmp_path / "codes.h5"
    write_library(p, _ROOT, _MODEL, _LIMITS, {}, [e])
    entry = MotionLibrary.open(p)[e.key]
    times = np.concatenate([np.linspace(-0.1, 1.3, 701), entry.t])
    for t in times:
        got = entry.array_at("contact", float(t))
        assert got.dtype == np.int8 and np.array_equal(got, entry.sample(float(t)).contact), t
        assert float(entry.array_at("t", float(t))) == pytest.approx(min(max(t, 0.0), entry.t[-1]))
    held = entry.array_window("contact", -0.05, 200, 0.007)
    assert np.array_equal(held, entry.window(-0.05, 200, 0.007).contact)
    assert set(np.unique(held)) <= {0, 1, 2}


def test_select_clamps_far_targets_to_the_nearest_end_and_refuses_a_transition_to_its_start(lib):
    """A target so far out that every entry's distance rounds alike still gets the nearest end; a
    transition whose target is its start speed is no entry's."""
    assert lib.select(1e16, clamp=True).target_velocity_mps == 0.5
    assert lib.select(-1e16, clamp=True).target_velocity_mps == 0.3
    with pytest.raises(ValueError, match="a transition changes the speed"):
        lib.select(0.3, from_velocity_mps=0.3)


@pytest.mark.parametrize("kw", [{"friction_fraction": -0.5}, {"friction_fraction": 1.0},
                                {"friction_fraction": float("nan")}, {"joint_rad": -0.01},
                                {"joint_rad": float("inf")}])
def test_a_margin_that_is_no_margin_is_refused(lib, kw):
    """A negative margin would pass forces outside the cone or joints beyond their limits."""
    with pytest.raises(ValueError, match="BlendMargin"):
        BlendMargin(**kw)
    with pytest.raises(TypeError, match="BlendMargin"):
        lib.blend(0.4, margin=0.1)  # type: ignore[arg-type]


def test_misuses_name_what_to_do(lib):
    """The constructor given a path says to open() it; a window is not iterated row by row."""
    with pytest.raises(TypeError, match=r"MotionLibrary\.open\(path\)"):
        MotionLibrary("lib.h5")  # type: ignore[arg-type]
    w = lib["v0.30_s1"].window(0.0, 3, 0.1)
    with pytest.raises(TypeError):
        list(w)  # type: ignore[call-overload]
    assert w["board_vx"].shape == (3,)


def test_entries_of_other_knot_times_are_not_blended():
    from skatelib.runtime.blended import blend_pair
    from skatelib.runtime.motion_library import _entry as as_entry

    a, b = _entry(0.3, seed=1), _entry(0.5, seed=2)
    b.arrays.update({k: v[:-1] for k, v in b.arrays.items() if k != "control"}, control=b.arrays["control"][:-1])
    with pytest.raises(SkatelibError, match="different knot times"):
        blend_pair(as_entry(a), as_entry(b), 0.4, lambda arrays: None)  # type: ignore[arg-type,return-value]


@pytest.mark.parametrize("bad", [True, "0.4", np.array([0.1, 0.2]), None])
def test_speeds_and_times_are_one_finite_number(lib, bad):
    """A bool, a string, several values or None as a speed or a time: a ValueError that shows it,
    not a bool taken for 1 m/s or numpy's words."""
    e = lib["v0.30_s1"]
    for call in (lambda: lib.select(bad), lambda: lib.route(0.0, bad), lambda: e.sample(bad),
                 lambda: e.array_at("foot_pos", bad), lambda: e.window(bad, 3, 0.1), lambda: e.window(0.0, 3, bad)):
        with pytest.raises(ValueError, match=r"finite|a step in seconds"):
            call()
    assert e.sample(np.float32(0.3)).t == pytest.approx(0.3) and lib.select(np.float64(0.5)).target_velocity_mps == 0.5
