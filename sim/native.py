"""The twins' physics steps and readouts compiled (``twin_tick.c``): the rolling torques before each
physics step (and the humanoid's shove), :meth:`skatelib.sim.plant.TwinPlant.state`'s readout and
the humanoid's ground truth (:meth:`skatelib.sim.humanoid.plant.HumanoidPlant.truth`), the same
MuJoCo calls and arithmetic as the Python path (:mod:`skatelib.sim.rolling`,
:mod:`skatelib.sim.contacts`, the plants' own), one ctypes call each per tick. Built against the
MuJoCo package's own headers and library, on the bindings' model and data, and kept as the
controller's C code is (:mod:`skatelib.library.native_code`). Without a C compiler, or a MuJoCo
package without its C headers, the Python path runs (a warning says why); both give the same
states to the bit.
"""

from __future__ import annotations

import ctypes
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import native_code
from skatelib.sim.twin_state import TwinState

ADVICE = "point SKATELIB_CACHE_DIR to a folder of your own, or build the twin with TwinPlant(compiled=False)"
# twin_tick.c's readout layout
S_T, S_TRUNK_POS, S_TRUNK_R, S_TRUNK_V, S_TRUNK_W, S_Q, S_QD = 0, 1, 4, 13, 16, 19, 31
S_DECK_POS, S_DECK_R, S_DECK_V, S_DECK_W, S_CENTRES, S_FOOT_V, S_SPINS, S_POINTS = 43, 46, 55, 58, 61, 73, 85, 97
S_FOOT_LOAD, S_WHEEL_LOAD, S_WHEEL_FORCE, S_SYSTEM_V, S_TOUCH, S_N_STRAY, S_STRAY = 109, 113, 117, 120, 123, 127, 128
N_STRAY, S_N = 8, 136
# twin_tick.c's humanoid truth layout (the joint torques after H_N)
H_T, H_COM, H_COM_V, H_BASE_POS, H_BASE_R, H_FORCE, H_SOLE_ZMP, H_ZMP = 0, 1, 4, 7, 10, 19, 25, 29
H_SOLE_POS, H_YAW, H_SOLE_V, H_WZ, H_DECK_POS, H_DECK_R, H_DECK_V, H_N_STRAY, H_STRAY, H_N = (
    31, 37, 39, 45, 47, 50, 59, 62, 63, 71)

_I, _D = ctypes.c_int, ctypes.c_double
_P = ctypes.c_void_p


class RollingTables(ctypes.Structure):
    """twin_tick.c's ``rolling_t``: the wheels (geoms, hinges, torque actuators, radii), the
    rolling resistance's coefficient and smoothing speed, the floor."""

    _fields_ = [("wheel_geom", _I * 4), ("wheel_dof", _I * 4), ("wheel_act", _I * 4), ("radius", _D * 4),
                ("coefficient", _D), ("smoothing", _D), ("floor", _I)]


class TwinTables(ctypes.Structure):
    """twin_tick.c's ``twin_t``, field for field: the rolling resistance's tables, the twin's
    actuators, feet, bodies and joints and the contact tables."""

    _fields_ = [("roll", RollingTables), ("robot_act", _I * 12), ("deck_geom", _I), ("feet", _I * 4),
                ("foot_radius", _D), ("trunk", _I), ("deck", _I), ("trunk_q", _I), ("trunk_v", _I), ("deck_v", _I),
                ("qadr", _I * 12), ("dadr", _I * 12), ("foot_of", ctypes.c_void_p), ("planned", ctypes.c_void_p)]


class HumanoidTables(ctypes.Structure):
    """twin_tick.c's ``hum_t``: the humanoid twin's root and deck bodies, the floor, the joint
    actuators, the soles' bodies and geoms, half a sole's thickness, the geoms planned on the floor."""

    _fields_ = [("root", _I), ("deck", _I), ("floor", _I), ("n_act", _I), ("feet", _I * 2), ("soles", _I * 2),
                ("half_sole", _D), ("act", ctypes.c_void_p), ("on_floor", ctypes.c_void_p)]


def rolling_tables(r: Any) -> RollingTables:
    """The C tables of a :class:`skatelib.sim.rolling.RollingResistance`."""
    from skatelib.sim.rolling import SMOOTHING_MPS

    t = RollingTables()
    for name, values in (("wheel_geom", r.geoms), ("wheel_dof", r.dofs), ("wheel_act", r.actuators)):
        getattr(t, name)[:] = [int(v) for v in values]
    t.radius[:] = [float(v) for v in r.radius]
    t.coefficient, t.smoothing, t.floor = float(r.coefficient), SMOOTHING_MPS, int(r.floor)
    return t


_LIB: list[ctypes.CDLL | None] = []


def mujoco_build() -> tuple[list[str], str]:
    """The compiler's arguments for the MuJoCo package's headers and library (its version among
    them, so that another MuJoCo compiles anew), or [] and why they are not there."""
    import mujoco

    root = Path(mujoco.__file__).parent
    libraries = sorted(root.glob("libmujoco.so*")) + sorted(root.glob("libmujoco*.dylib"))
    if not (root / "include" / "mujoco" / "mujoco.h").is_file() or not libraries:
        return [], f"the mujoco package in {root} has no C headers or no libmujoco"
    return ["-I", str(root / "include"), f"-DSKATELIB_MUJOCO={mujoco.__version__}", str(libraries[0]),
            f"-Wl,-rpath,{root}"], ""


def twin_library() -> ctypes.CDLL | None:
    """The compiled steps and readouts (built on first use, then loaded from the cache), or None
    (the Python path then runs; a warning says why)."""
    if not _LIB:
        extra, why = mujoco_build()
        if not extra:
            warnings.warn(f"the twin's C code is not available ({why}): its Python path runs", RuntimeWarning,
                          stacklevel=2)
            _LIB.append(None)
        else:
            native_code.load_once(_LIB, ("skatelib.sim", "twin_tick.c", "twin_tick"), ADVICE,
                                  {"twin_step": [_P] * 4 + [ctypes.c_int, _P],
                                   "twin_state": [_P] * 4,
                                   "rolling_steps": [_P] * 3 + [ctypes.c_int, _P, ctypes.c_int, _P],
                                   "humanoid_truth": [_P] * 3 + [_D, _P],
                                   "humanoid_sense": [_P, ctypes.c_int] + [_P] * 4},
                                  "the twin's C code is not available: its Python path runs, its rides about a "
                                  "third slower", extra=extra)
    return _LIB[0]


class CompiledTwin:
    """A plant's (:class:`skatelib.sim.plant.TwinPlant`) step and readout in C, on its
    ``MjModel`` and ``MjData``."""

    def __init__(self, lib: ctypes.CDLL, plant: Any):
        self.lib, t = lib, TwinTables()
        t.roll = rolling_tables(plant.rolling)
        for name, values in (("robot_act", plant.robot_actuators), ("feet", plant.feet), ("qadr", plant.qadr),
                             ("dadr", plant.dadr)):
            getattr(t, name)[:] = [int(v) for v in values]
        t.foot_radius, t.deck_geom = float(plant.f.foot_radius_m), plant.deck_geom
        t.trunk, t.deck = plant.trunk, plant.deck
        t.trunk_q, t.trunk_v, t.deck_v = int(plant.trunk_q), int(plant.trunk_v), int(plant.deck_v)
        self._foot_of = np.ascontiguousarray(plant.contacts.foot_of, dtype=np.intc)
        self._planned = np.ascontiguousarray(plant.contacts.planned, dtype=np.uint8)
        t.foot_of, t.planned = self._foot_of.ctypes.data, self._planned.ctypes.data
        self.tables = t
        self._tau, self._loads = np.zeros(12), np.zeros(4)
        self._md = (ctypes.c_void_p(plant.m._address), ctypes.c_void_p(plant.d._address), ctypes.addressof(t))

    def step(self, tau: np.ndarray, n: int, loads: np.ndarray | None) -> None:
        """``n`` physics steps with the joint torques ``tau``, the rolling torques before each
        (``loads``: the wheels' loads for the first, read from the contacts as they are)."""
        self._tau[:] = tau
        given = None
        if loads is not None:
            self._loads[:] = loads
            given = self._loads.ctypes.data
        self.lib.twin_step(*self._md, self._tau.ctypes.data, n, given)

    def state(self) -> np.ndarray:
        """The readout (a fresh vector, the ``S_`` layout)."""
        s = np.empty(S_N)
        self.lib.twin_state(*self._md, s.ctypes.data)
        return s


class CompiledSteps:
    """Physics steps in C with a board's rolling torques before each (``rolling``: a
    :class:`skatelib.sim.rolling.RollingResistance`, or None without a board) and a shove
    (``shove``: the body, the force along y [N], its start and length [s]; None: no shove)."""

    def __init__(self, lib: ctypes.CDLL, m: Any, d: Any, rolling: Any | None,
                 shove: tuple[int, float, float, float] | None):
        self.lib = lib
        self.tables = rolling_tables(rolling) if rolling is not None else None
        self._shove = np.array(shove[1:] if shove is not None else (0.0, 0.0, 0.0), dtype=np.float64)
        self._args = (ctypes.c_void_p(m._address), ctypes.c_void_p(d._address),
                      ctypes.addressof(self.tables) if self.tables is not None else None)
        self._after = (None, shove[0] if shove is not None else -1, self._shove.ctypes.data)

    def __call__(self, n: int) -> None:
        """``n`` physics steps."""
        self.lib.rolling_steps(*self._args, n, *self._after)


class CompiledTruth:
    """The humanoid twin's truth (:meth:`skatelib.sim.humanoid.plant.HumanoidPlant.truth`) read in C."""

    def __init__(self, lib: ctypes.CDLL, plant: Any, half_sole_m: float):
        self.lib, t = lib, HumanoidTables()
        t.root, t.deck, t.floor, t.n_act = int(plant.root), int(plant.deck), int(plant.floor), len(plant.act)
        t.feet[:] = [int(b) for b in plant.feet]
        t.soles[:] = [int(g) for g in plant.soles]
        t.half_sole = half_sole_m
        self._act = np.ascontiguousarray(plant.act, dtype=np.intc)
        self._on_floor = np.ascontiguousarray(plant.on_floor, dtype=np.uint8)
        t.act, t.on_floor = self._act.ctypes.data, self._on_floor.ctypes.data
        self.tables, self.size = t, H_N + len(plant.act)
        self._args = (ctypes.c_void_p(plant.m._address), ctypes.c_void_p(plant.d._address), ctypes.addressof(t))

    def __call__(self, plane_z: float) -> np.ndarray:
        """The readout (a fresh vector, the ``H_`` layout; what the C leaves, a walk's deck, zeros)."""
        s = np.zeros(self.size)
        self.lib.humanoid_truth(*self._args, plane_z, s.ctypes.data)
        return s


class CompiledSense:
    """The humanoid's sensors read in C (:meth:`skatelib.sim.humanoid.plant.HumanoidPlant.readings`):
    element i of the readout is ``kind[i]``'s source (0 sensordata, 1 minus sensordata, 2 qpos,
    3 qvel) at ``idx[i]``, plus the noise's element i; the first four, the IMU's quaternion, unit."""

    def __init__(self, lib: ctypes.CDLL, d: Any, kind: np.ndarray, idx: np.ndarray):
        self.lib = lib
        self._kind = np.ascontiguousarray(kind, dtype=np.intc)
        self._idx = np.ascontiguousarray(idx, dtype=np.intc)
        self.size = len(self._kind)
        self._args = (ctypes.c_void_p(d._address), self.size, self._kind.ctypes.data, self._idx.ctypes.data)

    def __call__(self, noise: np.ndarray) -> np.ndarray:
        """The readout (a fresh vector) with ``noise`` (float64, contiguous, as long)."""
        out = np.empty(self.size)
        self.lib.humanoid_sense(*self._args, noise.ctypes.data, out.ctypes.data)
        return out


def stray_geoms(s: np.ndarray, at: int, on_overflow: Callable[[], Any]) -> Any:
    """The ids of the geoms on the floor that a readout ``s`` holds at ``at`` (their count, then
    the ids: ``S_N_STRAY`` or ``H_N_STRAY``), or ``on_overflow()`` where it holds more than it
    has room for."""
    k = int(s[at])
    return s[at + 1:at + 1 + k].astype(int) if k <= N_STRAY else on_overflow()


def readout(s: np.ndarray, system_mass_kg: float, floor_touches: tuple[str, ...]) -> TwinState:
    """A :class:`TwinState` of views of the readout ``s`` (the ``S_`` layout)."""

    def grid(at: int) -> np.ndarray:
        return s[at:at + 12].reshape(3, 4)

    return TwinState(
        t=float(s[S_T]), trunk_pos=s[S_TRUNK_POS:S_TRUNK_POS + 3], trunk_R=s[S_TRUNK_R:S_TRUNK_R + 9].reshape(3, 3),
        trunk_v=s[S_TRUNK_V:S_TRUNK_V + 3], trunk_omega=s[S_TRUNK_W:S_TRUNK_W + 3], q=s[S_Q:S_Q + 12],
        qd=s[S_QD:S_QD + 12], deck_pos=s[S_DECK_POS:S_DECK_POS + 3], deck_R=s[S_DECK_R:S_DECK_R + 9].reshape(3, 3),
        deck_v=s[S_DECK_V:S_DECK_V + 3], deck_omega=s[S_DECK_W:S_DECK_W + 3], foot_centres=grid(S_CENTRES),
        foot_velocities=grid(S_FOOT_V), foot_touch=s[S_TOUCH:S_TOUCH + 4].astype(np.int8),
        contact_points=grid(S_POINTS), foot_spins=grid(S_SPINS), foot_load_N=s[S_FOOT_LOAD:S_FOOT_LOAD + 4],
        wheel_load_N=s[S_WHEEL_LOAD:S_WHEEL_LOAD + 4], wheel_force_N=s[S_WHEEL_FORCE:S_WHEEL_FORCE + 3],
        system_v=s[S_SYSTEM_V:S_SYSTEM_V + 3], system_mass_kg=system_mass_kg, floor_touches=floor_touches)
