"""One trajectory of a motion library, sampled for a controller.

Times outside an entry clamp to its ends: before the start the first state and control, after
the end the last state and the last control. States are interpolated linearly between knots;
controls are held (control k acts on [t_k, t_{k+1}), as the optimization used them). Every
array handed out is read-only.
"""

from __future__ import annotations

import bisect
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.errors import SkatelibError
from skatelib.runtime.blend import BlendCheck
from skatelib.runtime.references import WINDOW_MAX_DT_S as WINDOW_MAX_DT_S  # the window's bounds, named here too
from skatelib.runtime.references import WINDOW_MAX_N as WINDOW_MAX_N
from skatelib.runtime.references import Channels, Sample, Window, check_window, real


class EntryNotFound(SkatelibError):
    """No entry matches a key or a request (the message lists what exists)."""


class Entry:
    """One trajectory of a library (read-only arrays)."""

    def __init__(self, key: str, attrs: dict[str, Any], arrays: dict[str, np.ndarray],
                 columns: dict[str, tuple[str, ...]], units: dict[str, tuple[str, ...]] | None = None,
                 check: BlendCheck | None = None):
        self.key = key
        self.attrs = attrs
        self.columns = columns
        self.units = units or {}
        self.channels = Channels(columns, self.units)
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
        self._ready = False

    def ready(self) -> Entry:
        """Build the interpolation tables and run one window and one sample (numpy's first call of an operation is
        slower than the next ones): a controller's first call costs what the later ones do. ``lib[key]``,
        ``select``, ``route`` and ``blend`` call it."""
        if self._ready:
            return self
        dt = np.diff(self.t)
        self._uniform = bool(len(dt) and float(np.max(np.abs(dt - dt[0]))) <= 1e-12 + 1e-9 * abs(float(dt[0])))
        self._inv_dt = 1.0 / float(dt[0]) if len(dt) else 0.0
        self._tlist = self.t.tolist()
        # Slopes between knots (a sample is one multiply-add), per-row lists (cheaper to index than an array)
        self._dstate = _ro(np.diff(self.state, axis=0)) if self._n > 1 else _ro(np.zeros_like(self.state))
        self._rows = list(self.state)
        self._drows = list(self._dstate)
        self._urows = list(self.control) if len(self.control) else [self.control]
        self._crows = list(self.contact) if self.contact is not None else None
        self._ctable = np.ascontiguousarray(self.contact) if self.contact is not None else None
        self._ar = np.arange(1024, dtype=float)
        nx = self.state.shape[1]
        self._cols = (nx, 2 * nx)  # one table [state_k, slope_k, control_k] per interval: a window is one take
        if self._n > 1:
            self._table = np.hstack([self.state[:-1], self._dstate, self.control])
        else:
            self._table = np.hstack([self.state, self._dstate, np.zeros((1, self.control.shape[-1]))])
        self._ready = True
        self.window(self._t0, 2, 1.0)
        self.sample(self._t0)
        return self

    @property
    def target_velocity_mps(self) -> float:
        return float(self.attrs[schema.A_TARGET_VELOCITY])

    @property
    def from_velocity_mps(self) -> float:
        """The speed the entry starts riding at; 0 for a start-up from rest (and every entry of a
        library before format 1.4) [m/s]."""
        return float(self.attrs.get(schema.A_FROM_VELOCITY, 0.0))

    @property
    def n_strides(self) -> int:
        return int(self.attrs[schema.A_N_STRIDES])

    @property
    def success(self) -> bool:
        return bool(self.attrs[schema.A_SUCCESS])

    @property
    def duration_s(self) -> float:
        return self._tend - self._t0

    def channel(self, name: str) -> np.ndarray:
        """One named channel over the knots: of the state or control, else of another array with
        named columns (a humanoid's ``joints``, ``feet``...; ``ARRAY.COLUMN`` names one array's,
        ``joint_velocities.R_knee``; a bare name that two arrays share is the positions', ``joints``
        before ``joint_velocities``); read-only; KeyError lists the names."""
        if name not in self.channels:
            array, _, column = name.rpartition(".")
            for k in ([array] if array else sorted(self.columns, key=lambda a: (a.endswith("velocities"), a))):
                cols = list(self.columns.get(k, ()))
                if k not in (schema.D_STATE, schema.D_CONTROL) and (column in cols):
                    return self.arrays[k][:, cols.index(column)]
        which, j = self.channels.locate(name)
        return (self.control if which else self.state)[:, j]

    def array_at(self, name: str, t: float) -> np.ndarray:
        """The row of a per-knot array (``joints``, ``joint_velocities``, ``base_pose``, ``feet``...)
        at time ``t`` [s], linear between knots and clamped to the entry (a quaternion in it is
        interpolated by its components: renormalize it); an array of integers (``contact`` codes,
        ``step_index``) holds each knot's value until the next knot, as :meth:`sample`'s contacts do,
        never half a code. Allocates one row.

        Raises:
            KeyError: Naming the arrays with a row per knot.
        """
        a = self.arrays.get(name)
        if a is None or a.ndim < 1 or len(a) != self._n:
            names = [k for k, v in self.arrays.items() if v.ndim >= 1 and len(v) == self._n and k != schema.D_T]
            raise KeyError(f"no per-knot array {name!r}; arrays: {', '.join(names)}")
        if not real(t):
            raise ValueError(f"array_at(name, t): t must be a finite time in seconds, got {t!r}")
        i, f = self._locate(t)
        if a.dtype.kind in "biu":  # codes and indices hold
            row = np.array(a[i + 1 if f >= 1.0 else i])
        else:
            row = np.array(a[i] + f * (a[min(i + 1, self._n - 1)] - a[i]))
        row.flags.writeable = False
        return row

    def array_window(self, name: str, t0: float, n: int, dt: float) -> np.ndarray:
        """The rows of a per-knot array at ``t0 + k dt``, k = 0..n-1, as :meth:`array_at` (n, ...);
        ``n`` bounded as in :meth:`window`."""
        self.array_at(name, t0)  # KeyError naming the per-knot arrays
        check_window(t0, n, dt, len(self.t))  # the same argument checks and bound as window()
        a = self.arrays[name]
        tc = np.clip(t0 + dt * np.arange(n), self._t0, self._tend)
        if a.dtype.kind in "biu":  # codes and indices hold: the knot at or before each time
            held = a[np.clip(np.searchsorted(self.t, tc, side="right") - 1, 0, self._n - 1)]
            held.flags.writeable = False
            return held
        j = np.clip(np.searchsorted(self.t, tc, side="right") - 1, 0, self._last)
        span = self.t[j + 1] - self.t[j] if self._n >= 2 else np.ones(n)
        f = ((tc - self.t[j]) / span).reshape(-1, *([1] * (a.ndim - 1)))
        out = a[j] + f * (a[np.minimum(j + 1, self._n - 1)] - a[j])
        out.flags.writeable = False
        return out

    def unit(self, name: str) -> str:
        """The unit of a state or control channel, as stored in the file."""
        self.channels.locate(name)
        return self.channels.units[name]

    def _locate(self, t: float) -> tuple[int, float]:
        """Interval index i <= K-2 and fraction a in [0, 1] of ``t``, clamped to the entry."""
        self._ready or self.ready()
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

        Raises:
            ValueError: When ``t`` is NaN or infinite.
        """
        if not real(t):
            raise ValueError(f"sample(t): t must be a finite time in seconds, got {t!r}")
        i, a = self._locate(t)
        x = self._rows[i] + a * self._drows[i]
        x.flags.writeable = False
        # Contacts hold like controls: the last knot's code from the end on.
        c = self._crows[i + 1 if a >= 1.0 else i] if self._crows is not None else None
        return Sample(x, self._urows[i], c, t, self.channels)

    def window(self, t0: float, n: int, dt: float) -> Window:
        """References for an MPC horizon at ``t0 + k dt``, k = 0..n-1: states (n, 28), controls
        (n, 24), contact codes (n, 4) and times (n,). Clamped to the entry like :meth:`sample`.

        ``n`` is at most :data:`WINDOW_MAX_N` (10 000: any controller's horizon, and a bound on what
        one call allocates, about 7 MB), or the entry's own knot count if that is larger; ``dt`` is
        at most :data:`WINDOW_MAX_DT_S` (60 s).

        Raises:
            TypeError: When ``n`` is not an integer.
            ValueError: When ``t0`` or ``dt`` is not finite, ``dt`` is not in (0, 60] s, ``n < 1`` or
                ``n`` is beyond the bound (naming the argument and its range).
        """
        check_window(t0, n, dt, len(self.t))
        if not self._ready:
            self.ready()
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
        # Contacts hold like controls, the last knot's code at the end (index K-1 before clamping).
        contact_idx = i.copy() if self._ctable is not None else i
        np.minimum(i, self._last, out=i)
        u -= i
        rows = np.take(self._table, i, axis=0)
        a, b = self._cols
        slope = rows[:, a:b]
        slope *= u.reshape(-1, 1)
        state = rows[:, :a]
        state += slope
        rows.flags.writeable = False  # views made from here on are read-only too
        return Window((t0, dt), rows[:, :a], rows[:, b:], contact_idx, self._ctable, self.channels)

    def __repr__(self) -> str:
        return (f"Entry({self.key!r}, v={self.target_velocity_mps} m/s, strides={self.n_strides}, "
                f"success={self.success}, {self._n} knots over {self.duration_s:.2f} s)")


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.flags.writeable:
        a = a.copy() if a.base is not None else a
        a.flags.writeable = False
    return a
