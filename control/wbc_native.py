"""The whole-body tick compiled: :class:`skatelib.control.wbc_targets.TargetMaker`'s targets and
:class:`skatelib.control.wbc.WholeBodyController`'s assembly of its QP from the default tasks and
constraints, in C (``wbc_tick.c``: the same equations in the same order; the Python modules
document them), built and kept as the controller's C code is (:mod:`skatelib.library.native_code`)
and called through ctypes, one call each per tick. Pinocchio's terms before them and the QP's
backend after them are compiled code already; what the C replaces is some hundred small numpy
operations, whose calls cost more than their arithmetic.

Not bit-identical to the Python path (its products of matrices go through BLAS, which sums in its
own order): tests hold the two to 1e-12 of each other, and the rides of the default library pass
on either (``WbcSettings(compiled=False)`` keeps the Python path).
"""

from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING, Any

import numpy as np
from skatelib.control.wbc_settings import NV, WbcSettings
from skatelib.library import native_code

if TYPE_CHECKING:
    from skatelib.control.params import SkateParams

ADVICE = "point SKATELIB_CACHE_DIR to a folder of your own, or set WbcSettings(compiled=False)"
TARGETS_IN, TARGETS_OUT, ASSEMBLY_IN = 180, 50, 695  # wbc_tick.c's T_IN, T_OUT, A_IN

_D = ctypes.c_double
_FIELDS: list[tuple[str, Any]] = [
    *((name, _D) for name in ("kp_com", "kd_com", "kp_att", "kd_att", "kp_swing", "kd_swing", "kp_post", "kd_post",
                              "stance_gain", "mass", "gravity", "axis_depth", "reach", "sw_com", "sw_swing", "w_att",
                              "w_post", "w_force")),
    ("q_diag", _D * NV), ("coef", _D * 15), ("per_leg", _D), ("joints", _D * 12)]


class WbcParams(ctypes.Structure):
    """wbc_tick.c's ``wbc_t``, field for field: gains, figures, weights, the cost's fixed diagonal,
    a stance foot's surface rows and the joints' columns of qdd."""

    _fields_ = _FIELDS


_LIB: list[ctypes.CDLL | None] = []


def wbc_library() -> ctypes.CDLL | None:
    """The compiled whole-body tick (built on first use, then loaded from the cache), or None
    without a C compiler or when it fails to build or load (the Python path then runs; a warning
    says why)."""
    return native_code.load_once(_LIB, ("skatelib.control", "wbc_tick.c", "wbc_tick"), ADVICE,
                                 {"wbc_targets": [ctypes.c_void_p] * 3,
                                  "wbc_assemble": [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                                   *[ctypes.c_void_p] * 6]},
                                 "the whole-body tick's C code is not available: its Python path runs, about twice "
                                 "as slow")


class CompiledTargets:
    """:class:`~skatelib.control.wbc_targets.TargetMaker`'s arithmetic in C: its inputs packed into
    one vector (wbc_tick.c's ``T_`` layout), its outputs read from another (``O_``)."""

    def __init__(self, lib: ctypes.CDLL, p: SkateParams, g: WbcSettings, reach_m: float):
        self.lib, self.s = lib, WbcParams()
        for name, value in (("kp_com", g.kp_com), ("kd_com", g.kd_com), ("kp_att", g.kp_attitude),
                            ("kd_att", g.kd_attitude), ("kp_swing", g.kp_swing), ("kd_swing", g.kd_swing),
                            ("kp_post", g.kp_posture), ("kd_post", g.kd_posture), ("stance_gain", g.stance_gain),
                            ("mass", p.mass_kg), ("gravity", p.gravity_mps2), ("axis_depth", p.roll_axis_depth_m),
                            ("reach", reach_m)):
            setattr(self.s, name, float(value))
        self.inp, self.out = np.zeros(TARGETS_IN), np.zeros(TARGETS_OUT)
        self._ptrs = (ctypes.addressof(self.s), self.inp.ctypes.data, self.out.ctypes.data)

    def __call__(self, arrays: tuple[Any, ...]) -> np.ndarray:
        """The outputs (a fresh vector) of one tick's inputs, in the ``T_`` layout's order."""
        np.concatenate(arrays, out=self.inp)
        self.lib.wbc_targets(*self._ptrs)
        return self.out.copy()


class CompiledAssembly:
    """:class:`~skatelib.control.wbc.WholeBodyController`'s assembly of the default tasks and
    constraints in C (wbc_tick.c's ``A_`` layout)."""

    def __init__(self, lib: ctypes.CDLL, g: WbcSettings, q_diag: np.ndarray, coefficients: np.ndarray,
                 joints: np.ndarray):
        self.lib, self.s = lib, WbcParams()
        for name, value in (("sw_com", np.sqrt(g.w_com)), ("sw_swing", np.sqrt(g.w_swing)), ("w_att", g.w_attitude),
                            ("w_post", g.w_posture), ("w_force", g.w_force), ("per_leg", len(coefficients))):
            setattr(self.s, name, float(value))
        native_code.set_field(self.s, "q_diag", q_diag)
        coef = np.zeros((5, 3))
        coef[:len(coefficients)] = coefficients
        native_code.set_field(self.s, "coef", coef)
        native_code.set_field(self.s, "joints", joints)
        self.inp = np.zeros(ASSEMBLY_IN)
        self._s, self._in = ctypes.addressof(self.s), self.inp.ctypes.data

    def __call__(self, arrays: tuple[Any, ...], legs: Any, n_legs: int, outputs: tuple[int, ...]) -> None:
        """Fill the QP's arrays (``outputs``: the addresses of H, g, rows, lo, up) from one tick's
        inputs (``A_`` layout) for the stance feet ``legs`` (the address of n_legs int32s)."""
        np.concatenate(arrays, out=self.inp)
        self.lib.wbc_assemble(self._s, legs, n_legs, self._in, *outputs)
