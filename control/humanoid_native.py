"""The humanoid stabilizer's tick compiled: :class:`skatelib.control.humanoid_stabilizer.LipStabilizer`'s
arithmetic after its kinematics (the estimate, the offset observer, the DCM feedback and the
support polygon, the COM command, the ankles, the swing soles and the correction's solve) in C
(``humanoid_tick.c``: the same equations in the same order; the Python module documents them),
built and kept as the controller's C code is (:mod:`skatelib.library.native_code`) and called
through ctypes once per tick. Pinocchio's kinematics before it are compiled code already; what the
C replaces is some hundred small numpy operations, whose calls cost more than their arithmetic
(about 0.5 ms a tick on the 2-core x86 VM of the benchmarks, a quarter of a 500 Hz cycle).

Not bit-identical to the Python path (numpy's dot products and LAPACK's solve sum in their own
order): tests hold the two to 1e-9 of each other over a run's ticks, and the twin's runs pass on
either (``StabilizerGains(compiled=False)`` keeps the Python path).
"""

from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING, Any

import numpy as np
from skatelib.library import native_code

if TYPE_CHECKING:
    from skatelib.control.humanoid_reference import ReferenceSample

ADVICE = "point SKATELIB_CACHE_DIR to a folder of your own, or set StabilizerGains(compiled=False)"
IN_FIXED, STATE, OUT_FIXED = 95, 28, 12  # humanoid_tick.c's I_A, S_N, O_DQ
O_COM, O_XI, O_ZMP, O_PD, O_DC, O_SINGULAR = 0, 3, 5, 7, 9, 11
S_DC, S_OFFSET, S_TILT, S_LIFT = 0, 6, 8, 12

_FIELDS: list[tuple[str, Any]] = [
    *((name, ctypes.c_double) for name in (
        "dt", "dcm_gain", "velocity_cutoff_hz", "offset_rate", "polygon_margin", "ankle_damping", "ankle_return",
        "ankle_tilt_max", "com_shift_max", "lip", "com_velocity_gain", "swing_height_gain", "swing_return", "enabled",
        "min_load", "toe_off")),
    ("nv", ctypes.c_int)]


class TickParams(ctypes.Structure):
    """humanoid_tick.c's ``hs_params``, field for field."""

    _fields_ = _FIELDS


_LIB: list[ctypes.CDLL | None] = []


def tick_library() -> ctypes.CDLL | None:
    """The compiled tick (built on first use, then loaded from the cache), or None without a C
    compiler or when it fails to build or load (the Python path then runs; a warning says why)."""
    return native_code.load_once(_LIB, ("skatelib.control", "humanoid_tick.c", "humanoid_tick"), ADVICE,
                                 {"humanoid_tick": [ctypes.c_void_p] * 4},
                                 "the humanoid stabilizer's C code is not available: its Python path runs, about "
                                 "four times as slow")


class CompiledTick:
    """One stabilizer's state and its tick in C: the inputs packed into one vector (the ``I_``
    layout), the state kept in another (``S_``), the outputs read from a third (``O_``)."""

    def __init__(self, lib: ctypes.CDLL, params: dict[str, float], nv: int):
        """``params``: every field of ``hs_params`` but ``nv`` (the stabilizer's gains, its period,
        the sensors' least load and the toe-off pitch)."""
        if nv > 64:
            raise ValueError(f"the compiled stabilizer takes at most 64 degrees of freedom, not {nv}")
        self.lib, self.p, self.nv = lib, TickParams(), nv
        missing = {name for name, _ in _FIELDS} - set(params) - {"nv"}
        if missing:
            raise ValueError(f"the compiled stabilizer misses {sorted(missing)}")
        for name, value in params.items():
            setattr(self.p, name, float(value))
        self.p.nv = nv
        self.state = np.zeros(STATE)
        self.inp, self.out = np.zeros(IN_FIXED + nv * nv), np.zeros(OUT_FIXED + nv)
        self._zeros = np.zeros(nv * nv)
        self._ptrs = (ctypes.addressof(self.p), self.inp.ctypes.data, self.state.ctypes.data, self.out.ctypes.data)

    def __call__(self, r: ReferenceSample, measured: tuple[np.ndarray, ...], force: np.ndarray, torque: np.ndarray,
                 rows: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """The outputs (the ``O_`` layout, a fresh vector) of one tick: the reference sample ``r``
        (after the landing detection), the measured kinematics (COM, soles, sensor points and
        rotations), the ankle sensors' ``force`` and ``torque`` and the correction's ``rows`` (None
        with the stabilizer off)."""
        c, soles, pts, rots = measured
        A, R = rows if rows is not None else (self._zeros, np.zeros(18))
        np.concatenate((r.soles.ravel(), r.sole_yaw, r.support, r.anchors, r.sole_vel.ravel(), r.com, r.com_vel,
                        r.zmp, (r.gravity, r.ground_z), r.sole_pitch, c, soles.ravel(), pts.ravel(), rots.ravel(),
                        force.ravel(), torque.ravel(), R.ravel(), r.sole_size, A.ravel()), out=self.inp)
        self.lib.humanoid_tick(*self._ptrs)
        return self.out.copy()
