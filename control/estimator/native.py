"""The estimator's tick compiled: :class:`skatelib.control.estimator.estimator.StateEstimator`'s
``__call__`` in C (``tick.c``, the same equations in the same order on the same state), built once
and kept as the controller's C code is (:mod:`skatelib.library.native_code`), called through
ctypes: numpy and the standard library only, one call per tick.

The legs' kinematics are the model's own: each leg's three revolute joints (their placements and
axes) and its foot frame's placement are read from the pinocchio model once; the C code composes
them as pinocchio does (tested against it). A model it cannot read so (a leg not a chain of three
revolute joints) or a machine without a working C compiler keeps the Python tick (with a warning).
"""

from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING, Any

import numpy as np
from skatelib.library import native_code

if TYPE_CHECKING:
    from skatelib.control.estimator.reading import Reading
    from skatelib.control.kinematics import LegKinematics

ADVICE = "point SKATELIB_CACHE_DIR to a folder of your own, or set EstimatorSettings(compiled=False)"

_D = ctypes.c_double
# est_t of tick.c, field for field
_FIELDS: list[tuple[str, Any]] = [
           ("joint_R", _D * 108), ("joint_p", _D * 36), ("axis", _D * 36), ("foot_R", _D * 36), ("foot_p", _D * 12),
           ("rho", _D), ("g", _D), ("touch_m", _D), ("settle_s", _D), ("floor_settle_s", _D), ("deck_height", _D),
           ("axis_depth", _D), ("k_tilt", _D), ("att_gate", _D), ("att_gravity", _D), ("mount", _D * 9),
           ("gyro_bias", _D * 3), ("q_proc", _D * 10), ("foot_velocity2", _D), ("foot_height2", _D), ("gate", _D),
           ("deck_prior", _D), ("mass", _D), ("com_offset", _D * 3), ("compliance", _D), ("turn", _D),
           ("tilt_from_velocity", _D), ("moving_deck", _D), ("deck_roll_on", _D), ("has_body", _D),
           ("R", _D * 9), ("omega", _D * 3), ("accel", _D * 3), ("x", _D * 10), ("P", _D * 100), ("yaw", _D),
           ("roll", _D), ("yaw_rate", _D), ("roll_rate", _D), ("deck_pos", _D * 3), ("footholds", _D * 12),
           ("deck_R", _D * 9), ("stance", _D * 4), ("down_since", _D * 4), ("last_t", _D), ("has_last", _D),
           ("now", _D), ("used", _D * 4), ("give", _D * 4), ("accel_world", _D * 3)]
IN_N, OUT_N = 39, 52


class EstState(ctypes.Structure):
    """tick.c's ``est_t``: the legs, figures, settings and state of one estimator (all doubles)."""

    _fields_ = _FIELDS


_LIB: list[ctypes.CDLL | None] = []


def tick_library() -> ctypes.CDLL | None:
    """The compiled tick (built on first use, then loaded from the cache), or None without a C
    compiler or when it fails to build or load (the Python tick then runs; a warning says why)."""
    return native_code.load_once(
        _LIB, ("skatelib.control.estimator", "tick.c", "estimator_tick"), ADVICE,
        {"est_tick": [ctypes.c_void_p] * 3, "est_legs": [ctypes.c_void_p] * 3,
         "est_static_loads": [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_void_p]},
        "the estimator's C tick is not available: the Python tick runs, about 16 times slower")


def leg_chains(kin: LegKinematics) -> tuple[np.ndarray, ...] | None:
    """Each leg's joints' placements (R (4, 3, 3, 3), p (4, 3, 3)) and axes (4, 3, 3), and its
    foot frame's placement (R (4, 3, 3), p (4, 3)), all in their parents' frames; None when a leg
    is not a chain of three one-axis revolute joints from the trunk in channel order."""
    m = kin.model
    joint_R, joint_p, axes = np.zeros((4, 3, 3, 3)), np.zeros((4, 3, 3)), np.zeros((4, 3, 3))
    foot_R, foot_p = np.zeros((4, 3, 3)), np.zeros((4, 3))
    named = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}
    for i, f in enumerate(kin.feet):
        frame = m.frames[f]
        chain = []
        j = int(frame.parentJoint)
        while j != 0:
            chain.append(j)
            j = int(m.parents[j])
        chain.reverse()
        if len(chain) != 3:
            return None
        for k, j in enumerate(chain):
            joint = m.joints[j]
            if joint.nq != 1 or joint.idx_q != kin.q_index[3 * i + k] or joint.idx_v != kin.v_index[3 * i + k]:
                return None
            name = joint.shortname()
            if name in named:
                axes[i, k] = named[name]
            elif name == "JointModelRevoluteUnaligned":
                axes[i, k] = np.asarray(joint.extract().axis, dtype=float)
            else:
                return None
            joint_R[i, k] = m.jointPlacements[j].rotation
            joint_p[i, k] = m.jointPlacements[j].translation
        foot_R[i], foot_p[i] = frame.placement.rotation, frame.placement.translation
    if not np.allclose(foot_R, np.eye(3)):
        return None  # the foot's centre is all the tick reads of its frame; a turned frame is not expected
    return joint_R, joint_p, axes, foot_R, foot_p


def static_loads(lib: ctypes.CDLL, feet_xy: np.ndarray, com_xy: np.ndarray, weight_N: float) -> np.ndarray:
    """The C code's :func:`skatelib.control.estimator.loads.static_loads` (for tests)."""
    dx = np.ascontiguousarray(feet_xy[0] - com_xy[0], dtype=float)
    dy = np.ascontiguousarray(feet_xy[1] - com_xy[1], dtype=float)
    out = np.zeros(len(dx))
    lib.est_static_loads(dx.ctypes.data, dy.ctypes.data, len(dx), float(weight_N), out.ctypes.data)
    return out


class CompiledTick:
    """The C tick of one estimator: its figures and settings copied in at construction, its state
    at :meth:`load` (the estimator's Python state, taken at the first tick so that calibration and
    any change made before riding count), then kept in C."""

    def __init__(self, lib: ctypes.CDLL, chains: tuple[np.ndarray, ...]):
        self.lib, self.s = lib, EstState()
        self.inp, self.out = np.zeros(IN_N), np.zeros(OUT_N)
        self._ptrs = (ctypes.addressof(self.s), self.inp.ctypes.data, self.out.ctypes.data)
        joint_R, joint_p, axes, foot_R, foot_p = chains
        s = self.s
        for name, arr in (("joint_R", joint_R), ("joint_p", joint_p), ("axis", axes), ("foot_R", foot_R),
                          ("foot_p", foot_p)):
            native_code.set_field(s, name, arr)

    def load(self, scalars: dict[str, float], arrays: dict[str, np.ndarray]) -> None:
        """Figures, settings and state into C, by field name (est_t's)."""
        for name, value in scalars.items():
            setattr(self.s, name, float(value))
        for name, arr in arrays.items():
            native_code.set_field(self.s, name, arr)

    @property
    def last_t(self) -> float | None:
        """The time of the last reading it took [s] (None before the first)."""
        return float(self.s.last_t) if self.s.has_last else None

    def __call__(self, reading: Reading, plan: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        """One tick's readings and the contact codes planned now and ``liftoff_s`` ahead: the
        output vector (tick.c's OUT_ layout)."""
        np.concatenate(((reading.t,), reading.gyro, reading.accel, reading.q, reading.qd, plan, ahead), out=self.inp)
        self.lib.est_tick(*self._ptrs)
        return self.out

    def legs(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The C code's foot centres (3, 4) and linear and angular Jacobians (4, 3, 3) at ``q``
        (trunk frame; :func:`skatelib.control.estimator.legs.leg_terms`' layout)."""
        qv, out = np.ascontiguousarray(q, dtype=float), np.zeros(84)
        self.lib.est_legs(ctypes.addressof(self.s), qv.ctypes.data, out.ctypes.data)
        return out[:12].reshape(3, 4), out[12:48].reshape(4, 3, 3), out[48:].reshape(4, 3, 3)

    def view(self, name: str) -> np.ndarray:
        """A field of the C state as a numpy array (a copy)."""
        return np.array(getattr(self.s, name))
