"""The humanoid stabilizer's C tick (``skatelib.control.humanoid_native``) against its Python path
on every tick of the twin's runs (a walk and the 1.0 m/s skate under the default errors, the
stabilizer and the landing detection on and off), the singular correction's least-norm fallback,
a changed gain seen (the negative control of the comparison) and a compiler that fails leaving the
Python path; and the verdict's support margins, computed apart from the controller's hull, against
the controller's polygon and analytic cases."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from skatelib.control import humanoid_native
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference, ReferenceSample, polygon_margin
from skatelib.control.humanoid_stabilizer import LipStabilizer, StabilizerGains
from skatelib.library import trust
from skatelib.proving.humanoid import support
from skatelib.proving.humanoid.loop import STEPS_PER_TICK, figures_for
from skatelib.runtime import MotionLibrary
from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION, parse_humanoid_perturbation
from skatelib.sim.humanoid.plant import HumanoidPlant

pytest.importorskip("mujoco")
compiled = pytest.mark.skipif(humanoid_native.tick_library() is None, reason="no C compiler")
TOL = 1e-9


def _pair(lib: MotionLibrary, key: str, gains: StabilizerGains):
    f = figures_for(lib, key)
    kin = (HumanoidKinematics(lib.urdf, f.joint_names), HumanoidKinematics(lib.urdf, f.joint_names))
    dt = STEPS_PER_TICK * 0.001
    c, py = LipStabilizer(kin[0], dt, gains), LipStabilizer(kin[1], dt, dataclasses.replace(gains, compiled=False))
    assert c.native is not None and py.native is None
    return f, c, py


def _worst(lib: MotionLibrary, key: str, gains: StabilizerGains, ticks: int, c_gains: StabilizerGains | None = None
           ) -> float:
    """The largest difference of the two paths' outputs over ``ticks`` ticks of a run on the twin
    (default errors) driven by the Python path; the compiled one with ``c_gains`` when given."""
    f, c, py = _pair(lib, key, gains)
    if c_gains is not None:
        c = LipStabilizer(c.kin, c.dt, c_gains)
    plant = HumanoidPlant(f, parse_humanoid_perturbation(DEFAULT_HUMANOID_PERTURBATION))
    ref = HumanoidReference(lib[key], lib.humanoid_model)
    worst = 0.0
    for _ in range(ticks):
        r = plant.readings()
        s = ref.sample(r.t)
        args = (s, r.q, r.imu_quat_wxyz[[1, 2, 3, 0]], r.ft_force, r.ft_torque)
        a, b = py.tick(*args), c.tick(*args)
        for x, y in zip(dataclasses.astuple(a), dataclasses.astuple(b), strict=True):
            assert np.array_equal(np.isnan(x), np.isnan(y))
            worst = max(worst, float(np.nanmax(np.abs(np.asarray(x, float) - np.asarray(y, float)), initial=0.0)))
        plant.step(a.q_target, STEPS_PER_TICK)
    return worst


@compiled
@pytest.mark.parametrize("gains", [StabilizerGains(), StabilizerGains(landing=False),
                                   StabilizerGains(com_mode="lip"), StabilizerGains(enabled=False)],
                         ids=["default", "no-landing", "lip", "off"])
def test_the_compiled_tick_is_the_python_tick_along_a_walk(hrp2_walk_path, gains):
    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    assert _worst(lib, key, gains, 1200) <= TOL


@compiled
def test_the_compiled_tick_is_the_python_tick_along_the_skate(hrp2_skate_v100):
    """The push (a sole on the ground, one on the rolling deck: the anchors, the deck's speed),
    the slide and the stop's start."""
    lib = MotionLibrary.open(hrp2_skate_v100)
    assert _worst(lib, next(iter(lib)).key, StabilizerGains(), 1500) <= TOL


@compiled
def test_the_comparison_sees_a_changed_gain(hrp2_walk_path):
    """The negative control: the compiled tick with another DCM gain differs beyond the tolerance."""
    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    assert _worst(lib, key, StabilizerGains(), 300, StabilizerGains(dcm_gain_per_s=3.3)) > 1e3 * TOL


@compiled
def test_a_singular_correction_takes_the_least_norm_change(hrp2_walk_path, monkeypatch):
    """Rows that LU cannot solve (two equal): the C tick says so and the stabilizer takes the
    least-norm change, as its Python path does."""
    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    f, c, py = _pair(lib, key, StabilizerGains())
    for stab in (c, py):
        rows = stab.kin.rows

        def singular(qfull, rows=rows):
            A, R = rows(qfull)
            A = A.copy()
            A[17] = A[16]
            return A, R

        monkeypatch.setattr(stab.kin, "rows", singular)
    plant = HumanoidPlant(f)
    ref = HumanoidReference(lib[key], lib.humanoid_model)
    for _ in range(50):
        r = plant.readings()
        s = ref.sample(r.t)
        args = (s, r.q, r.imu_quat_wxyz[[1, 2, 3, 0]], r.ft_force, r.ft_torque)
        a, b = py.tick(*args), c.tick(*args)
        assert np.all(np.isfinite(b.q_target)) and np.allclose(a.q_target, b.q_target, atol=TOL, rtol=0)
        plant.step(a.q_target, STEPS_PER_TICK)
    assert c.native is not None and c.native.out[humanoid_native.O_SINGULAR] == 1.0


@compiled
@pytest.mark.parametrize("sensor", ["torque", "force", "q"])
def test_a_sensor_reading_nan_is_refused_by_both_paths_and_changes_nothing(hrp2_walk_path, sensor):
    """A NaN ankle torque, ankle force or joint angle: both paths refuse the tick (a StateError
    naming the sensor; it made every later joint target NaN), and the next good tick gives on each
    path what it gives had the bad reading never come."""
    from skatelib.control.feedback import StateError

    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    f, c, py = _pair(lib, key, StabilizerGains())
    _, c_clean, py_clean = _pair(lib, key, StabilizerGains())
    plant = HumanoidPlant(f)
    plant.step(f.q0_rad, 200)  # standing, both soles loaded
    ref = HumanoidReference(lib[key], lib.humanoid_model)
    r = plant.readings()
    s = ref.sample(0.0)
    good = {"q": r.q, "quat_xyzw": r.imu_quat_wxyz[[1, 2, 3, 0]], "force": r.ft_force, "torque": r.ft_torque}
    bad = dict(good, **{sensor: good[sensor].copy()})
    bad[sensor].flat[0] = np.nan
    for stab, clean in ((c, c_clean), (py, py_clean)):
        stab.tick(s, *good.values())
        clean.tick(s, *good.values())
        with pytest.raises(StateError, match=f"sensors.{sensor}"):
            stab.tick(s, *bad.values())
        a, b = stab.tick(s, *good.values()), clean.tick(s, *good.values())
        assert np.isfinite(a.q_target).all()
        for x, y in zip(dataclasses.astuple(a), dataclasses.astuple(b), strict=True):
            np.testing.assert_array_equal(np.asarray(x, float), np.asarray(y, float))


def test_a_compiler_that_fails_leaves_the_python_tick(monkeypatch, tmp_path, hrp2_walk_path):
    monkeypatch.setattr(humanoid_native, "_LIB", [])
    monkeypatch.setenv("CC", "false")
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)
    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    f = figures_for(lib, key)
    with pytest.warns(RuntimeWarning, match=r"false failed on humanoid_tick.c.*Python path runs"):
        stab = LipStabilizer(HumanoidKinematics(lib.urdf, f.joint_names), 0.002)
    assert stab.native is None and not list(tmp_path.rglob("*.so"))


def _sample(centres: np.ndarray, yaw: np.ndarray, on: np.ndarray, size: tuple[float, float]) -> ReferenceSample:
    z = np.zeros(3)
    return ReferenceSample(q=z, base_pos=z, base_quat_xyzw=np.array([0.0, 0, 0, 1]),
                           soles=np.column_stack([centres, np.zeros(2)]), sole_yaw=yaw, support=on, com=z, com_vel=z,
                           com_acc=z, zmp=z[0:2], gravity=9.81, sole_size=size)


def test_the_verdicts_support_margins_are_the_controllers_polygon():
    """Random soles (places, yaws, which support) and points in and around them: the margins
    computed from the supporting lines are the controller's hull's (rounded to 1e-12 there)."""
    rng = np.random.default_rng(3)
    n, size = 400, (0.24, 0.14)
    centres = rng.uniform(-0.3, 0.3, (n, 2, 2))
    centres[: n // 4, 1] = centres[: n // 4, 0] + [0.0, 0.2]  # side by side, parallel: collinear edges
    yaw = rng.uniform(-0.6, 0.6, (n, 2))
    yaw[: n // 4] = 0.0
    on = rng.random((n, 2)) < 0.8
    zmp = centres.mean(axis=1) + rng.normal(0.0, 0.15, (n, 2))
    got = support.margins(centres, yaw, on, size, zmp)
    for k in range(n):
        poly = _sample(centres[k], yaw[k], on[k], size).polygon()
        assert got[k] == pytest.approx(polygon_margin(poly, zmp[k]), abs=1e-11), k


def test_support_margins_by_hand():
    """One sole at the origin, 0.24 x 0.14 m: its centre 7 cm inside, 1 cm beyond its toe 1 cm
    outside; two soles side by side, 6 cm apart: the point between them inside by half a sole's
    length (the hull spans the gap); no contact (the ZMP NaN) -inf; no support sole inf."""
    size = (0.24, 0.14)
    c = np.array([[[0.0, 0.0], [5.0, 5.0]]] * 2 + [[[0.0, -0.1], [0.0, 0.1]]] * 3)
    on = np.array([[True, False]] * 2 + [[True, True], [True, True], [False, False]])
    zmp = np.array([[0.0, 0.0], [0.13, 0.0], [0.0, 0.0], [np.nan, 0.0], [0.0, 0.0]])
    got = support.margins(c, np.zeros((5, 2)), on, size, zmp)
    assert got[0:3] == pytest.approx([0.07, -0.01, 0.12])
    assert got[3] == -np.inf and got[4] == np.inf
