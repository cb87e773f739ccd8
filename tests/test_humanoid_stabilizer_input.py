"""The humanoid stabilizer and its reference refuse input they cannot act on, with an error that
names it, instead of NaN or silently wrong joint targets: a tick period that is not a finite
positive number of seconds, gains out of their ranges or a mode that is not one, an IMU attitude
that is no unit quaternion (on the C and the Python path, before anything of the stabilizer's state
changes), a time that is not a number, an entry that is not a humanoid's whole body; and a joint
reading given as a list is read as the array it spells."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from skatelib.control import humanoid_native
from skatelib.control.feedback import StateError
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference
from skatelib.control.humanoid_stabilizer import LipStabilizer, StabilizerGains
from skatelib.library import schema
from skatelib.runtime import MotionLibrary
from skatelib.runtime.entry import Entry

PATHS = [pytest.param(True, marks=pytest.mark.skipif(humanoid_native.tick_library() is None, reason="no C compiler"),
                      id="C"), pytest.param(False, id="python")]
QUADRUPED = Path(__file__).parent / "data" / "tiny-reference.h5"
WEIGHT_N = 58 * 9.81  # the walk robot standing on both soles
FORCE, TORQUE = np.array([[0.0, 0.0, WEIGHT_N / 2]] * 2), np.zeros((2, 3))
# Chosen apart from the implementation, by how the tick uses each figure: these divide (a damping,
# a time constant) or set a rate without which the stabilizer does not stabilize or estimate.
MUST_BE_POSITIVE = {"dcm_gain_per_s", "velocity_cutoff_hz", "ankle_damping_Nms_per_rad", "ankle_return_s",
                    "swing_return_s"}
FLOAT_FIELDS = [f.name for f in dataclasses.fields(StabilizerGains) if type(f.default) is float]


@pytest.fixture(scope="module")
def walk(hrp2_walk_path):
    """The walk library, its first entry's reference and the kinematics of its joints."""
    lib = MotionLibrary.open(hrp2_walk_path)
    e = next(e for e in lib if e.success)
    return lib, e, HumanoidReference(e, lib.humanoid_model), e.columns[schema.D_JOINTS]


def _stabilizer(lib: MotionLibrary, joints: tuple[str, ...], compiled: bool = True, dt: float = 0.002
                ) -> LipStabilizer:
    return LipStabilizer(HumanoidKinematics(lib.urdf, tuple(joints)), dt, StabilizerGains(compiled=compiled))


def _pitched(rad: float) -> np.ndarray:
    """A unit quaternion (x, y, z, w) pitched by ``rad`` about y."""
    return np.array([0.0, math.sin(rad / 2), 0.0, math.cos(rad / 2)])


@pytest.mark.parametrize("dt", [0.0, -0.002, math.nan, math.inf, 10.0, "0.002", True])
def test_a_period_that_is_not_a_small_positive_time_is_refused(walk, dt):
    """0, negative, NaN, infinite, beyond the gains' time constants, a string or a bool: a
    ValueError naming ``dt`` at construction (0 made the second tick NaN, NaN the first)."""
    lib, _, _, joints = walk
    with pytest.raises(ValueError, match=r"LipStabilizer\(dt="):
        _stabilizer(lib, joints, dt=dt)
    assert _stabilizer(lib, joints, dt=0.002).dt == 0.002


def test_a_com_mode_that_is_not_one_is_refused_naming_the_modes():
    """``"LIP"`` (only ``"lip"`` selects it; it ran the velocity mode): a ValueError listing both."""
    with pytest.raises(ValueError, match=r"com_mode='LIP'.*'velocity', 'lip'"):
        StabilizerGains(com_mode="LIP")
    assert StabilizerGains(com_mode="lip").com_mode == "lip"


@pytest.mark.parametrize("name", FLOAT_FIELDS)
def test_each_gain_is_refused_out_of_its_range(name):
    """Every figure: negative, NaN, infinite or a string refused naming it; 0 refused exactly for
    those that divide or set a needed rate (``ankle_damping_Nms_per_rad=0`` divided by zero)."""
    for bad in (-1.0, math.nan, math.inf, "1"):
        with pytest.raises(ValueError, match=rf"StabilizerGains\({name}="):
            StabilizerGains(**{name: bad})
    if name in MUST_BE_POSITIVE:
        with pytest.raises(ValueError, match=rf"StabilizerGains\({name}=0.*above 0"):
            StabilizerGains(**{name: 0.0})
    else:
        assert getattr(StabilizerGains(**{name: 0.0}), name) == 0.0
    assert getattr(StabilizerGains(**{name: 2}), name) == 2  # an int is a number


def test_a_switch_that_is_not_a_bool_is_refused():
    """``enabled="no"`` (truthy: the stabilizer would run) is refused naming it."""
    with pytest.raises(ValueError, match=r"StabilizerGains\(enabled='no'\): True or False"):
        StabilizerGains(enabled="no")  # type: ignore[arg-type]


@pytest.mark.parametrize("compiled", PATHS)
@pytest.mark.parametrize("scale", [0.0, 3.0, 0.3, 1.01, 0.998])
def test_an_attitude_off_unit_length_is_refused_and_changes_nothing(walk, compiled, scale):
    """A pitched attitude scaled by 0 (read as upright), 3 (a COM estimate 0.36 m off instead of
    0.04 m), 0.3, 1.01 or 0.998: a StateError naming ``sensors.quat_xyzw`` on either path, and the
    next good tick gives what it gives had the bad reading never come."""
    lib, _, ref, joints = walk
    stab, clean = _stabilizer(lib, joints, compiled), _stabilizer(lib, joints, compiled)
    assert (stab.native is not None) == compiled
    quat = _pitched(0.05)
    for k in range(3):
        r = ref.sample(0.5 + 0.002 * k)
        with pytest.raises(StateError, match=r"sensors\.quat_xyzw is not a unit quaternion"):
            stab.tick(r, r.q, scale * quat, FORCE, TORQUE)
        a, b = stab.tick(r, r.q, quat, FORCE, TORQUE), clean.tick(r, r.q, quat, FORCE, TORQUE)
        for x, y in zip(dataclasses.astuple(a), dataclasses.astuple(b), strict=True):
            np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("compiled", PATHS)
def test_an_attitude_within_the_tolerance_is_taken_as_its_unit_quaternion(walk, compiled):
    """A pitched attitude 5e-4 longer than unit: the estimate (COM, DCM) and the targets are the
    unit attitude's (unnormalized, the COM estimate moved some 1e-4 m)."""
    lib, _, ref, joints = walk
    a, b = _stabilizer(lib, joints, compiled), _stabilizer(lib, joints, compiled)
    r, quat = ref.sample(0.5), _pitched(0.05)
    oa, ob = a.tick(r, r.q, quat, FORCE, TORQUE), b.tick(r, r.q, (1 + 5e-4) * quat, FORCE, TORQUE)
    for x, y in zip(dataclasses.astuple(oa), dataclasses.astuple(ob), strict=True):
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", PATHS)
def test_sensors_given_as_lists_are_read_as_arrays(walk, compiled):
    """Joint angles, attitude and wrenches as lists of the right lengths: the targets the arrays
    give (a list was refused as "shape (12,), (12,) expected"); a list of the wrong length names its
    shape."""
    lib, _, ref, joints = walk
    a, b = _stabilizer(lib, joints, compiled), _stabilizer(lib, joints, compiled)
    r = ref.sample(0.5)
    oa = a.tick(r, r.q, r.base_quat_xyzw, FORCE, TORQUE)
    ob = b.tick(r, r.q.tolist(), r.base_quat_xyzw.tolist(), FORCE.tolist(), TORQUE.tolist())
    for x, y in zip(dataclasses.astuple(oa), dataclasses.astuple(ob), strict=True):
        np.testing.assert_array_equal(x, y)
    with pytest.raises(StateError, match=r"sensors\.q: shape \(5,\), \(12,\) expected"):
        b.tick(r, r.q.tolist()[:5], r.base_quat_xyzw, FORCE, TORQUE)


@pytest.mark.parametrize("t", ["1", None, np.array(1.0), True])
def test_a_reference_time_that_is_not_a_number_is_refused_naming_t(walk, t):
    """A string, None, an array or a bool: the ValueError naming ``t`` that ``Entry.sample`` raises
    (a string raised a bare TypeError); a numpy float is a time."""
    ref = walk[2]
    with pytest.raises(ValueError, match=r"sample\(t\): t must be a finite time in seconds"):
        ref.sample(t)
    np.testing.assert_array_equal(ref.sample(np.float64(0.5)).q, ref.sample(0.5).q)


def test_a_quadruped_entry_is_refused_as_not_a_humanoids(walk):
    """A quadruped library's entry (it raised a bare KeyError 'joints'): a ValueError naming the
    entry, saying it is a quadruped's and what it lacks."""
    lib = walk[0]
    quadruped = MotionLibrary.open(QUADRUPED)
    e = next(iter(quadruped))
    with pytest.raises(ValueError, match=rf"{e.key!r} is a quadruped's entry, not a humanoid's: it has no joints"):
        HumanoidReference(e, lib.humanoid_model)


def test_a_humanoid_entry_without_its_whole_body_is_refused(walk):
    """The walk's entry without its joint angles (as a humanoid entry whose COM motion failed): a
    ValueError naming the entry and the missing array."""
    lib, e, _, _ = walk
    arrays = {k: v for k, v in e.arrays.items() if k != schema.D_JOINTS}
    bare = Entry(e.key, e.attrs, arrays, e.columns, e.units)
    with pytest.raises(ValueError, match=rf"{e.key!r} is a humanoid entry without its whole body.*no joints;"):
        HumanoidReference(bare, lib.humanoid_model)
