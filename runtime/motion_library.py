"""Serve a motion library to a controller: numpy and h5py only, for the robot's computer.

Times outside an entry clamp to its ends: before the start the first state and control, after
the end the last state and the last control. States are interpolated linearly between knots;
controls are held (control k acts on [t_k, t_{k+1}), as the optimization used them). Every
array handed out is read-only.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import BOARD, GROUND
from skatelib.library.errors import SkatelibError
from skatelib.library.reader import EntryRecord, LibraryData, read_library


class Sample(NamedTuple):
    """The reference at one time: state (28,), control (24,), contact codes (4,)."""

    state: np.ndarray
    control: np.ndarray
    contact: np.ndarray


@dataclass(frozen=True)
class BlendCheck:
    """Margins of a blended entry: smallest friction margin [N] and joint-limit slack [rad]."""

    min_friction_margin_N: float
    min_joint_limit_slack_rad: float

    @property
    def ok(self) -> bool:
        return self.min_friction_margin_N >= -1e-6 and self.min_joint_limit_slack_rad >= -1e-9


class EntryNotFound(SkatelibError):
    """No entry matches a key or a request."""


class Entry:
    """One trajectory of a library (read-only arrays)."""

    def __init__(self, key: str, attrs: dict[str, Any], arrays: dict[str, np.ndarray],
                 columns: dict[str, tuple[str, ...]], check: BlendCheck | None = None):
        self.key = key
        self.attrs = attrs
        self.columns = columns
        self.check = check
        self.arrays = {k: _ro(v) for k, v in arrays.items()}  # every dataset of the entry, read-only
        self.t = _ro(arrays[schema.D_T])
        self.state = _ro(arrays[schema.D_STATE])
        self.control = _ro(arrays[schema.D_CONTROL])
        self.contact = _ro(arrays[schema.D_CONTACT]) if schema.D_CONTACT in arrays else None
        self.foot_pos = _ro(arrays[schema.D_FOOT_POS]) if schema.D_FOOT_POS in arrays else None
        self.board_pos = _ro(arrays[schema.D_BOARD_POS]) if schema.D_BOARD_POS in arrays else None
        self._t0, self._tend, self._n = float(self.t[0]), float(self.t[-1]), len(self.t)
        self._last = max(self._n - 2, 0)  # interval index; the last knot is reached with fraction 1
        self._no_contact = _ro(np.zeros(4, dtype=np.int8))
        self._ready = False

    def _prepare(self) -> None:
        """Interpolation tables, built on first use so that opening a library stays cheap."""
        dt = np.diff(self.t)
        self._uniform = bool(len(dt) and np.allclose(dt, dt[0], rtol=1e-9, atol=1e-12))
        self._inv_dt = 1.0 / float(dt[0]) if len(dt) else 0.0
        self._tlist = self.t.tolist()
        # Slopes between knots, so an interpolated sample is one multiply-add; per-row lists
        # because indexing a list is cheaper than making an ndarray view.
        self._dstate = _ro(np.diff(self.state, axis=0)) if self._n > 1 else _ro(np.zeros_like(self.state))
        self._rows = list(self.state)
        self._drows = list(self._dstate)
        self._urows = list(self.control) if len(self.control) else [self.control]
        self._crows = list(self.contact) if self.contact is not None else None
        self._ar = np.arange(1024, dtype=float)
        nx = self.state.shape[1]
        # One table [state_k, slope_k, control_k] per interval: a window is a single take.
        self._cols = (nx, 2 * nx)
        if self._n > 1:
            self._table = np.hstack([self.state[:-1], self._dstate, self.control])
        else:
            self._table = np.hstack([self.state, self._dstate, np.zeros((1, self.control.shape[-1]))])
        self._ready = True

    @property
    def target_velocity_mps(self) -> float:
        return float(self.attrs["target_velocity_mps"])

    @property
    def n_strides(self) -> int:
        return int(self.attrs["n_strides"])

    @property
    def success(self) -> bool:
        return bool(self.attrs["success"])

    @property
    def duration_s(self) -> float:
        return self._tend - self._t0

    def channel(self, name: str) -> np.ndarray:
        """One named state or control channel over the knots (read-only)."""
        for d, arr in ((schema.D_STATE, self.state), (schema.D_CONTROL, self.control)):
            if name in self.columns[d]:
                return arr[:, self.columns[d].index(name)]
        raise KeyError(f"no channel {name!r}; state: {', '.join(self.columns[schema.D_STATE])}; "
                       f"control: {', '.join(self.columns[schema.D_CONTROL])}")

    def _locate(self, t: float) -> tuple[int, float]:
        """Interval index i <= K-2 and fraction a in [0, 1] of ``t``, clamped to the entry."""
        if not self._ready:
            self._prepare()
        if t <= self._t0 or self._n < 2:
            return 0, 0.0
        if t >= self._tend:
            return self._last, 1.0
        if self._uniform:
            u = (t - self._t0) * self._inv_dt
            i = int(u)
            return (i, u - i) if i <= self._last else (self._last, 1.0)
        i = min(bisect.bisect_right(self._tlist, t) - 1, self._last)
        return i, (t - self._tlist[i]) / (self._tlist[i + 1] - self._tlist[i])

    def sample(self, t: float) -> Sample:
        """State (linear), control (held) and contacts at time ``t`` [s], clamped to the entry.

        At or after the end, the state is the last knot's and the control the last one.
        """
        i, a = self._locate(t)
        x = self._rows[i] + a * self._drows[i]
        x.flags.writeable = False
        # Contacts hold like controls: the last knot's code from the end on.
        c = self._crows[i + 1 if a >= 1.0 else i] if self._crows is not None else self._no_contact
        return Sample(x, self._urows[i], c)

    def window(self, t0: float, n: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Reference arrays for an MPC horizon: states (n, 28) and controls (n, 24) at t0 + k dt."""
        if not self._ready:
            self._prepare()
        if self._uniform and self._n >= 2:
            ar = self._ar[:n] if n <= len(self._ar) else np.arange(n, dtype=float)
            u = ar * (dt * self._inv_dt)
            u += (t0 - self._t0) * self._inv_dt
            if u[0] < 0.0 or u[-1] > self._n - 1.0:  # clamping is rare; skip it when in range
                np.clip(u, 0.0, self._n - 1.0, out=u)
        else:
            tc = np.clip(t0 + dt * np.arange(n), self._t0, self._tend)
            j = np.clip(np.searchsorted(self.t, tc, side="right") - 1, 0, self._last)
            span = self.t[j + 1] - self.t[j] if self._n >= 2 else np.ones(n)
            u = j + (tc - self.t[j]) / span
        i = u.astype(np.intp)
        np.minimum(i, self._last, out=i)
        u -= i
        rows = np.take(self._table, i, axis=0)
        a, b = self._cols
        slope = rows[:, a:b]
        slope *= u.reshape(-1, 1)
        state = rows[:, :a]
        state += slope
        rows.flags.writeable = False  # views made from here on are read-only too
        return rows[:, :a], rows[:, b:]

    def __repr__(self) -> str:
        return (f"Entry({self.key!r}, v={self.target_velocity_mps} m/s, strides={self.n_strides}, "
                f"success={self.success}, {self._n} knots over {self.duration_s:.2f} s)")


class MotionLibrary:
    """A motion library loaded into memory (``MotionLibrary.open(path)``)."""

    def __init__(self, data: LibraryData):
        self.path = data.path
        self.attrs = data.attrs
        self.model = data.model_attrs
        self.model_arrays = data.model_arrays
        self.urdf = data.model_text.get(schema.D_ROBOT_URDF, "")
        self._entries = {k: _entry(r) for k, r in data.entries.items()}

    @classmethod
    def open(cls, path: Path | str) -> MotionLibrary:
        """Load and verify a library file (see :func:`skatelib.library.reader.read_library`)."""
        return cls(read_library(path))

    @property
    def kind(self) -> str:
        return str(self.attrs[schema.A_KIND])

    def keys(self) -> list[str]:
        return list(self._entries)

    def __getitem__(self, key: str) -> Entry:
        try:
            return self._entries[key]
        except KeyError:
            raise EntryNotFound(f"{self.path}: no entry {key!r}; entries: {', '.join(self._entries)}") from None

    def __iter__(self) -> Iterator[Entry]:
        return iter(self._entries.values())

    def __len__(self) -> int:
        return len(self._entries)

    def _candidates(self, strides: int | None) -> list[Entry]:
        c = [e for e in self if e.success and (strides is None or e.n_strides == strides)]
        if not c:
            have = sorted({e.n_strides for e in self if e.success})
            raise EntryNotFound(f"{self.path}: no successful entry with strides={strides}; strides available: {have}")
        return c

    def select(self, velocity: float, strides: int | None = None) -> Entry:
        """The successful entry whose target speed is nearest ``velocity`` (fewest strides on ties)."""
        return min(self._candidates(strides), key=lambda e: (abs(e.target_velocity_mps - velocity), e.n_strides))

    def blend(self, velocity: float, strides: int, strict: bool = True) -> Entry:
        """Linear blend of the two successful entries around ``velocity`` with the same strides.

        Both entries share the contact schedule (same period and duty), so phases align knot by
        knot. The blend is checked against friction cones and joint limits (``Entry.check``).

        Raises:
            EntryNotFound: When ``velocity`` is outside the stored range for ``strides``.
            SkatelibError: When ``strict`` and the blend violates friction or joint limits.
        """
        c = sorted(self._candidates(strides), key=lambda e: e.target_velocity_mps)
        lo = [e for e in c if e.target_velocity_mps <= velocity]
        hi = [e for e in c if e.target_velocity_mps >= velocity]
        if not lo or not hi:
            raise EntryNotFound(f"{velocity} m/s is outside the {strides}-stride range "
                                f"[{c[0].target_velocity_mps}, {c[-1].target_velocity_mps}] m/s")
        a, b = lo[-1], hi[0]
        w = 0.0 if b is a else (velocity - a.target_velocity_mps) / (b.target_velocity_mps - a.target_velocity_mps)
        if a.contact is not None and b.contact is not None and not np.array_equal(a.contact, b.contact):
            raise SkatelibError(f"entries {a.key} and {b.key} have different contact schedules; cannot blend")
        arrays = {schema.D_T: a.t}
        for name in (schema.D_STATE, schema.D_CONTROL, schema.D_FOOT_POS, schema.D_BOARD_POS):
            xa, xb = getattr(a, name), getattr(b, name)
            if xa is not None and xb is not None:
                arrays[name] = (1 - w) * xa + w * xb
        if a.contact is not None:
            arrays[schema.D_CONTACT] = a.contact
        check = self._check(arrays)
        attrs = {**a.attrs, "target_velocity_mps": velocity, "status": f"blend of {a.key} and {b.key} (w={w:.3f})"}
        e = Entry(f"blend_v{velocity:.3f}_s{strides}", attrs, arrays, a.columns, check)
        if strict and not check.ok:
            raise SkatelibError(f"blend at {velocity} m/s violates limits: {check}")
        return e

    def _check(self, arrays: dict[str, np.ndarray]) -> BlendCheck:
        mu = float(self.model["friction_mu"])
        state, control = arrays[schema.D_STATE], arrays[schema.D_CONTROL]
        contact = arrays.get(schema.D_CONTACT)
        margin = np.inf
        if contact is not None:
            for k in range(len(control)):
                yaw, roll = state[k, 5], state[k, 26]
                cy, sy, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(roll), np.sin(roll)
                R_B = np.array([[cy, -sy * cr, sy * sr], [sy, cy * cr, -cy * sr], [0.0, sr, cr]])
                for i in range(4):
                    if contact[k, i] in (BOARD, GROUND):
                        f = control[k, 3 * i: 3 * i + 3]
                        fl = R_B.T @ f if contact[k, i] == BOARD else f
                        margin = min(margin, mu * fl[2] - abs(fl[0]), mu * fl[2] - abs(fl[1]))
        q = state[:, 12:24]
        lo = self.model_arrays.get(schema.D_JOINT_LOWER)
        hi = self.model_arrays.get(schema.D_JOINT_UPPER)
        slack = np.inf if lo is None or hi is None else float(min(np.min(q - lo), np.min(hi - q)))
        return BlendCheck(min_friction_margin_N=float(margin), min_joint_limit_slack_rad=slack)


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.flags.writeable:
        a = a.copy() if a.base is not None else a
        a.flags.writeable = False
    return a


def _entry(r: EntryRecord) -> Entry:
    return Entry(r.key, r.attrs, r.arrays, r.columns)
