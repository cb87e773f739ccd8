"""What a controller reads from an entry: a :class:`Sample` at one time, a :class:`Window` over an
MPC horizon, and the :class:`Channels` that name their columns."""

# No postponed annotations here: pdoc (make docs) resolves a NamedTuple's field types only when
# they are evaluated at class creation.

from math import isfinite
from typing import Any, NamedTuple

import numpy as np
from skatelib.library import schema

WINDOW_MAX_N = 10_000  # the most steps one window() call returns (beyond the entry's own knots)
# The longest step of a window [s]: a minute, beyond any entry (seconds long; past its end the reference
# holds its last state). Far larger steps overflow the index arithmetic (dt = 1e308: NaN indices).
WINDOW_MAX_DT_S = 60.0


def real(value: Any) -> bool:
    """True for one finite real number: not a bool, a string or an array of several values."""
    if type(value) is float:  # the controller's usual time: one test
        return isfinite(value)
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating)) and isfinite(value)


def check_window(t0: float, n: int, dt: float, knots: int) -> None:
    """The arguments of ``Entry.window`` (and ``array_window``) for an entry of ``knots`` knots.

    Raises:
        TypeError: When ``n`` is not an integer.
        ValueError: When ``t0`` or ``dt`` is not finite, ``dt`` is not in (0, 60] s, ``n < 1`` or
            ``n`` is beyond the bound (naming the argument and its range).
    """
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool):
        raise TypeError(f"window(t0, n, dt): n must be an integer count of steps, got {n!r}")
    if n > WINDOW_MAX_N and n > knots:
        raise ValueError(f"window(t0, n, dt): n = {n} steps is beyond the bound of {WINDOW_MAX_N} "
                         "(skatelib.runtime.entry.WINDOW_MAX_N); sample a longer span in several windows")
    if not real(t0):
        raise ValueError(f"window(t0, n, dt): t0 must be a finite time in seconds, got {t0!r}")
    if not (real(dt) and 0.0 < dt <= WINDOW_MAX_DT_S):
        raise ValueError(f"window(t0, n, dt): dt must be a step in seconds in (0, {WINDOW_MAX_DT_S:g}] "
                         f"(skatelib.runtime.entry.WINDOW_MAX_DT_S), got {dt!r}")
    if n < 1:
        raise ValueError(f"window(t0, n, dt): n must be at least 1, got {n!r}")


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

    __iter__ = None  # not a sequence of rows: index a channel by name, or take .state, .control, .contact

    def __getitem__(self, name: str) -> np.ndarray:
        return self.get(name)

    def unit(self, name: str) -> str:
        self.channels.locate(name)
        return self.channels.units[name]

    def __repr__(self) -> str:
        return f"Window(t0={self._t0}, n={len(self.state)}, dt={self._dt})"
