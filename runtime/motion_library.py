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
from math import isfinite
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import S_Q
from skatelib.library.errors import SkatelibError
from skatelib.library.margins import friction_margins, friction_use
from skatelib.library.reader import EntryRecord, LibraryData, read_library


class Channels:
    """Names and units of an entry's state and control columns, looked up by name."""

    __slots__ = ("_at", "units")

    def __init__(self, columns: dict[str, tuple[str, ...]], units: dict[str, tuple[str, ...]]):
        self._at: dict[str, tuple[int, int]] = {}
        self.units: dict[str, str] = {}
        for which, d in enumerate((schema.D_STATE, schema.D_CONTROL)):
            for j, name in enumerate(columns.get(d, ())):
                self._at[name] = (which, j)
                u = units.get(d, ())
                self.units[name] = u[j] if j < len(u) else ""

    def locate(self, name: str) -> tuple[int, int]:
        """(0 for state or 1 for control, column) of a channel.

        Raises:
            KeyError: Naming the valid channels when ``name`` is unknown.
        """
        try:
            return self._at[name]
        except KeyError:
            raise KeyError(f"no channel {name!r}; channels: {', '.join(self._at)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._at

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._at)


class Sample(NamedTuple):
    """The reference at one time: ``state`` (28,), ``control`` (24,), ``contact`` codes (4,) per leg
    (0 swing, 1 board, 2 ground; ``None`` for entries without a contact plan), the time ``t`` [s].
    ``sample["board_vx"]`` reads a channel by name; ``sample.unit("board_vx")`` its unit."""

    state: np.ndarray
    control: np.ndarray
    contact: np.ndarray | None
    t: float
    channels: Channels

    def get(self, name: str) -> float:
        """One state or control channel by name (KeyError lists the valid names)."""
        which, j = self.channels.locate(name)
        return float((self.control if which else self.state)[j])

    def unit(self, name: str) -> str:
        self.channels.locate(name)
        return self.channels.units[name]

    def __getitem__(self, key: Any) -> Any:
        return self.get(key) if isinstance(key, str) else tuple.__getitem__(self, key)


class Window:
    """References over an MPC horizon at ``t[k] = t0 + k dt``: ``state`` (n, 28), ``control`` (n, 24),
    ``contact`` (n, 4) codes per step and leg (held like controls; ``None`` without a contact plan),
    ``t`` (n,) [s]. ``window["board_vx"]`` is that channel over the horizon, (n,). ``t`` and
    ``contact`` are made on first access, so a caller pays only for what it reads."""

    __slots__ = ("_contact", "_ctable", "_dt", "_idx", "_t", "_t0", "channels", "control", "state")

    def __init__(self, grid: tuple[float, float], state: np.ndarray, control: np.ndarray, idx: np.ndarray,
                 ctable: np.ndarray | None, channels: Channels):
        """``grid``: (t0, dt) of the horizon; ``idx`` into ``ctable``, the contact table."""
        (self._t0, self._dt), self._idx, self._ctable = grid, idx, ctable
        self._t: np.ndarray | None = None
        self._contact: np.ndarray | None = None
        self.state, self.control, self.channels = state, control, channels

    @property
    def t(self) -> np.ndarray:
        if self._t is None:
            self._t = self._t0 + self._dt * np.arange(len(self.state), dtype=float)
            self._t.flags.writeable = False
        return self._t

    @property
    def contact(self) -> np.ndarray | None:
        if self._contact is None and self._ctable is not None:
            self._contact = np.take(self._ctable, self._idx, axis=0)
            self._contact.flags.writeable = False
        return self._contact

    def __len__(self) -> int:
        return len(self.state)

    def get(self, name: str) -> np.ndarray:
        """One state or control channel over the horizon by name (KeyError lists the valid names)."""
        which, j = self.channels.locate(name)
        return (self.control if which else self.state)[:, j]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.get(name)

    def unit(self, name: str) -> str:
        self.channels.locate(name)
        return self.channels.units[name]

    def __repr__(self) -> str:
        return f"Window(t0={self._t0}, n={len(self.state)}, dt={self._dt})"


@dataclass(frozen=True)
class BlendMargin:
    """What a blended entry must keep (``MotionLibrary.blend``).

    Attributes:
        friction_fraction: Every contact force within ``(1 - friction_fraction) mu`` of its normal
            force: ``|f_t| <= (1 - friction_fraction) mu f_n`` [-]. Relative, because an absolute
            margin cannot hold where a foot touches down or lifts off with a tiny normal force.
        joint_rad: Every joint angle at least this far inside its limits [rad].
    """

    friction_fraction: float = 0.01
    joint_rad: float = 0.01


@dataclass(frozen=True)
class BlendCheck:
    """Margins of a blended entry and the ones asked for.

    Attributes:
        min_friction_margin_N: Smallest Coulomb margin mu f_n - |f_t| [N].
        max_friction_use: Largest |f_t| / (mu f_n) [-] (1: on the cone).
        min_joint_limit_slack_rad: Smallest distance of a joint angle from its limits [rad].
        required: The margins asked for.
    """

    min_friction_margin_N: float
    max_friction_use: float
    min_joint_limit_slack_rad: float
    required: BlendMargin = BlendMargin()

    @property
    def ok(self) -> bool:
        return (self.max_friction_use <= 1.0 - self.required.friction_fraction
                and self.min_joint_limit_slack_rad >= self.required.joint_rad)


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
        self._ctable = np.ascontiguousarray(self.contact) if self.contact is not None else None
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
        """One named state or control channel over the knots (read-only; KeyError lists the names)."""
        which, j = self.channels.locate(name)
        return (self.control if which else self.state)[:, j]

    def unit(self, name: str) -> str:
        """The unit of a state or control channel, as stored in the file."""
        self.channels.locate(name)
        return self.channels.units[name]

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

        Raises:
            ValueError: When ``t`` is NaN or infinite.
        """
        if not isfinite(t):
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

        Raises:
            ValueError: When ``t0`` or ``dt`` is not finite, ``dt <= 0`` or ``n < 1``.
        """
        if not isfinite(t0):
            raise ValueError(f"window(t0, n, dt): t0 must be a finite time in seconds, got {t0!r}")
        if not (isfinite(dt) and dt > 0.0):
            raise ValueError(f"window(t0, n, dt): dt must be a positive, finite step in seconds, got {dt!r}")
        if n < 1:
            raise ValueError(f"window(t0, n, dt): n must be at least 1, got {n!r}")
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


class MotionLibrary:
    """A motion library loaded into memory (``MotionLibrary.open(path)``).

    ``key in lib``, ``lib[key]``, ``lib.keys()`` and ``len(lib)`` work on entry keys; iterating
    yields the :class:`Entry` objects in file order (strides, then speed).
    """

    def __init__(self, data: LibraryData):
        self.path = data.path
        self.attrs = data.attrs
        self.model = data.model_attrs
        self.model_arrays = data.model_arrays
        self.urdf = data.model_text.get(schema.D_ROBOT_URDF, "")
        self.content_sha256 = data.content_sha256  # the file's verified SHA-256 (format doc, Integrity)
        self._entries = {k: _entry(r) for k, r in data.entries.items()}

    @classmethod
    def open(cls, path: Path | str) -> MotionLibrary:
        """Load and verify a library file (see :func:`skatelib.library.reader.read_library`).

        Raises:
            LibraryFormatError: When the file is missing, corrupt, incomplete or of another major version.
        """
        return cls(read_library(path))

    @property
    def kind(self) -> str:
        return str(self.attrs[schema.A_KIND])

    def keys(self) -> list[str]:
        return list(self._entries)

    def __contains__(self, key: object) -> bool:
        return key in self._entries

    def __getitem__(self, key: str) -> Entry:
        """The entry named ``key``.

        Raises:
            EntryNotFound: Listing the keys that exist.
        """
        try:
            return self._entries[key]
        except KeyError:
            raise EntryNotFound(f"{self.path}: no entry {key!r}; entries: {', '.join(self._entries)}") from None

    def __iter__(self) -> Iterator[Entry]:
        return iter(self._entries.values())

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        ok = sum(e.success for e in self)
        return (f"MotionLibrary({str(self.path)!r}, kind={self.kind!r}, {len(self)} entries, {ok} successful, "
                f"speeds {self.speeds()} m/s)")

    def speeds(self, strides: int | None = None) -> list[float]:
        """Target speeds of the successful entries (with ``strides`` strides, when given) [m/s]."""
        return sorted({e.target_velocity_mps for e in self
                       if e.success and (strides is None or e.n_strides == strides)})

    def _candidates(self, strides: int | None) -> list[Entry]:
        c = [e for e in self if e.success and (strides is None or e.n_strides == strides)]
        if not c:
            have = sorted({e.n_strides for e in self if e.success})
            raise EntryNotFound(f"{self.path}: no successful entry with strides={strides}; strides available: {have}")
        return c

    def select(self, velocity: float, strides: int | None = None, clamp: bool = False) -> Entry:
        """The successful entry whose target speed is nearest ``velocity`` [m/s] (fewest strides on ties).

        Raises:
            ValueError: When ``velocity`` is NaN or infinite.
            EntryNotFound: When no successful entry has ``strides`` strides, or ``velocity`` lies
                outside the stored speeds and ``clamp`` is false (the message lists the speeds).
        """
        if not isfinite(velocity):
            raise ValueError(f"select(velocity): velocity must be a finite speed in m/s, got {velocity!r}")
        c = self._candidates(strides)
        speeds = sorted({e.target_velocity_mps for e in c})
        if not clamp and not speeds[0] - 1e-9 <= velocity <= speeds[-1] + 1e-9:
            which = "" if strides is None else f" for {strides} strides"
            raise EntryNotFound(f"{self.path}: {velocity} m/s is outside the stored speeds {speeds} m/s{which}; "
                                "pass clamp=True for the nearest")
        return min(c, key=lambda e: (abs(e.target_velocity_mps - velocity), e.n_strides))

    def blend(self, velocity: float, strides: int | None = None, strict: bool = True,
              margin: BlendMargin = BlendMargin()) -> Entry:
        """Linear blend of the two successful entries around ``velocity`` [m/s] with the same strides
        (the fewest strides whose entries bracket it when ``strides`` is None).

        Both entries share the contact schedule (same period and duty), so phases align knot by
        knot. The blend is checked against Coulomb cones and joint limits with ``margin``
        (``Entry.check``). Its attributes are its own: the blended speed, ``blend_sources`` and
        ``blend_weights``, and ``success`` only when both sources succeeded and the check passes.

        Raises:
            ValueError: When ``velocity`` is NaN or infinite.
            EntryNotFound: When no stride count's entries bracket ``velocity``.
            SkatelibError: When ``strict`` and the blend misses the margins.
        """
        if not isfinite(velocity):
            raise ValueError(f"blend(velocity): velocity must be a finite speed in m/s, got {velocity!r}")
        a, b = self._bracket(velocity, strides)
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
        check = self._check(arrays, margin)
        attrs = {"target_velocity_mps": float(velocity), "n_strides": a.n_strides,
                 "success": bool(a.success and b.success and check.ok),
                 "status": f"blend of {a.key} and {b.key} (weights {1 - w:.3f}, {w:.3f})",
                 "blend_sources": (a.key, b.key), "blend_weights": (1.0 - w, w)}
        e = Entry(f"blend_v{velocity:.4f}_s{a.n_strides}", attrs, arrays, a.columns, a.units, check)
        if strict and not check.ok:
            raise SkatelibError(f"blend at {velocity} m/s misses its margins: {check}")
        return e

    def _bracket(self, velocity: float, strides: int | None) -> tuple[Entry, Entry]:
        counts = [strides] if strides is not None else sorted({e.n_strides for e in self if e.success})
        for s in counts:
            c = sorted(self._candidates(s), key=lambda e: e.target_velocity_mps)
            lo = [e for e in c if e.target_velocity_mps <= velocity]
            hi = [e for e in c if e.target_velocity_mps >= velocity]
            if lo and hi:
                return lo[-1], hi[0]
        ranges = {s: self.speeds(s) for s in counts}
        raise EntryNotFound(f"{self.path}: {velocity} m/s is outside the stored speeds {ranges} (per stride count)")

    def _check(self, arrays: dict[str, np.ndarray], margin: BlendMargin) -> BlendCheck:
        mu = float(self.model["friction_mu"])
        state, control = arrays[schema.D_STATE], arrays[schema.D_CONTROL]
        contact = arrays.get(schema.D_CONTACT)
        fric, use = np.inf, 0.0
        if contact is not None:
            fric = float(friction_margins(state, control, contact, mu)[0].min(initial=np.inf))
            use = friction_use(state, control, contact, mu)
        q = state[:, S_Q]
        lo = self.model_arrays.get(schema.D_JOINT_LOWER)
        hi = self.model_arrays.get(schema.D_JOINT_UPPER)
        slack = np.inf if lo is None or hi is None else float(min(np.min(q - lo), np.min(hi - q)))
        return BlendCheck(min_friction_margin_N=fric, max_friction_use=use, min_joint_limit_slack_rad=slack,
                          required=margin)


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    if a.flags.writeable:
        a = a.copy() if a.base is not None else a
        a.flags.writeable = False
    return a


def _entry(r: EntryRecord) -> Entry:
    return Entry(r.key, dict(r.attrs), dict(r.arrays), {k: tuple(v) for k, v in r.columns.items()},
                 {k: tuple(v) for k, v in r.units.items()})
