"""What changed between two motion libraries (``skatelib diff``, ``skatelib build --check``), from
the files alone (numpy and h5py).

Two libraries are *equal* when they hold the same entries with the same outcome (success,
status), the same arrays within the tolerances (``|a - b| <= atol + rtol |b|``, element by element,
NaN equal to NaN), the same label-level figures within the same tolerances (scalar attributes and
the numbers of ``physics_json`` and the closed-loop verdicts) and the same model. What differs
between two builds of one problem anyway (creation time, solve times, cache keys) is left out;
provenance (code commit, package and solver versions, solver options, the config's keys) and
solver effort (iterations, attempts; a humanoid's stage times) are reported but do not make two
libraries differ.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.attributes import EFFORT, PROVENANCE, VOLATILE, expand, json_figures, split
from skatelib.library.certificate import certificate_figures
from skatelib.library.reader import LibraryData, read_library
from skatelib.library.records import EntryRecord, jsonable

CONFIG = "config_resolved_json"
CERTIFICATE = schema.A_CERTIFICATE


@dataclass(frozen=True)
class Tolerance:
    """Element-wise ``|a - b| <= atol + rtol |b|``; the defaults demand bit-identical numbers."""

    atol: float = 0.0
    rtol: float = 0.0

    def exceeded(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        both_nan = np.isnan(a) & np.isnan(b)
        with np.errstate(invalid="ignore"):
            return ~both_nan & ~(np.abs(a - b) <= self.atol + self.rtol * np.abs(b))


@dataclass(frozen=True)
class ChannelChange:
    """The largest deviation of one column of one array, and when it occurs."""

    array: str
    column: str
    unit: str
    max_abs: float
    at_s: float | None  # the entry's time of that row (None when the array has no row per knot)
    a: float
    b: float


@dataclass(frozen=True)
class ValueChange:
    """A scalar that differs: an attribute, a figure of a JSON attribute, a config key."""

    name: str
    a: object  # None: absent on that side
    b: object


@dataclass(frozen=True)
class EntryChange:
    key: str
    channels: tuple[ChannelChange, ...] = ()
    shapes: tuple[ValueChange, ...] = ()  # arrays whose shapes differ (knot counts, columns)
    figures: tuple[ValueChange, ...] = ()  # outcome and label-level figures
    effort: tuple[ValueChange, ...] = ()  # iterations, attempts: reported only

    @property
    def differs(self) -> bool:
        return bool(self.channels or self.shapes or self.figures)


@dataclass(frozen=True)
class LibraryDiff:
    a: str
    b: str
    tolerance: Tolerance
    added: tuple[str, ...] = ()  # in b, not in a
    removed: tuple[str, ...] = ()
    changed: tuple[EntryChange, ...] = ()  # entries that differ (and those whose effort alone differs)
    same: int = 0
    model: tuple[ValueChange, ...] = ()
    config: tuple[ValueChange, ...] = ()  # the resolved config's differing keys (dotted)
    provenance: tuple[ValueChange, ...] = field(default=())
    certificate: tuple[ValueChange, ...] = ()  # per entry rate, interval, shove margin; spec, code (not counted)

    @property
    def equal(self) -> bool:
        return not (self.added or self.removed or self.model or any(c.differs for c in self.changed))

    def as_dict(self) -> dict[str, Any]:
        return {"equal": self.equal, **asdict(self)}


def compare_files(a: Path | str, b: Path | str, tolerance: Tolerance = Tolerance(),
                  keys: list[str] | None = None) -> LibraryDiff:
    """Compare the libraries at ``a`` and ``b`` (both verified first); ``keys`` restricts the
    entries compared.

    Raises:
        LibraryFormatError: Either file is missing, damaged or of another major version.
    """
    return compare(read_library(a), read_library(b), tolerance, keys)


def compare(A: LibraryData, B: LibraryData, tol: Tolerance = Tolerance(), keys: list[str] | None = None) -> LibraryDiff:
    """Compare two read libraries (module docstring)."""
    ka, kb = set(A.entries), set(B.entries)
    if keys:
        ka, kb = ka & set(keys), kb & set(keys)
    changed = [c for k in sorted(ka & kb) if (c := _entry(A.entries[k], B.entries[k], tol)) is not None]
    model = _values(A.model_attrs, B.model_attrs, tol) + _arrays_equal(A.model_arrays, B.model_arrays, tol)
    model += [ValueChange(k, "...", "...") for k in sorted(set(A.model_text) | set(B.model_text))
              if A.model_text.get(k) != B.model_text.get(k)]
    config = _values(json_figures(A.attrs.get(CONFIG)), json_figures(B.attrs.get(CONFIG)), Tolerance())
    prov = _values({k: v for k, v in A.attrs.items() if k in PROVENANCE},
                   {k: v for k, v in B.attrs.items() if k in PROVENANCE}, Tolerance())
    other = {k for k in set(A.attrs) | set(B.attrs) if k not in PROVENANCE | VOLATILE | {CONFIG, CERTIFICATE}}
    prov += _values({k: A.attrs[k] for k in other if k in A.attrs}, {k: B.attrs[k] for k in other if k in B.attrs},
                    tol)
    cert = _values(certificate_figures(A.attrs.get(CERTIFICATE)), certificate_figures(B.attrs.get(CERTIFICATE)),
                   Tolerance())
    return LibraryDiff(str(A.path), str(B.path), tol, tuple(sorted(kb - ka)), tuple(sorted(ka - kb)), tuple(changed),
                       len(ka & kb) - sum(c.differs for c in changed), tuple(model), tuple(config), tuple(prov),
                       tuple(cert))


def _entry(a: EntryRecord, b: EntryRecord, tol: Tolerance) -> EntryChange | None:
    channels: list[ChannelChange] = []
    shapes: list[ValueChange] = []
    t = np.asarray(b.arrays.get("t", np.zeros(0)))
    for name in sorted(set(a.arrays) | set(b.arrays)):
        x, y = a.arrays.get(name), b.arrays.get(name)
        if x is None or y is None or np.shape(x) != np.shape(y):
            shapes.append(ValueChange(name, None if x is None else list(np.shape(x)),
                                      None if y is None else list(np.shape(y))))
            continue
        channels += _channels(name, np.asarray(x), np.asarray(y), b, t, tol)
    attrs_a = {k: v for k, v in a.attrs.items() if k not in VOLATILE | EFFORT | PROVENANCE}
    attrs_b = {k: v for k, v in b.attrs.items() if k not in VOLATILE | EFFORT | PROVENANCE}
    (fig_a, effort_a), (fig_b, effort_b) = split(expand(attrs_a)), split(expand(attrs_b))
    figures = _values(fig_a, fig_b, tol)
    effort = _values({**{k: v for k, v in a.attrs.items() if k in EFFORT}, **effort_a},
                     {**{k: v for k, v in b.attrs.items() if k in EFFORT}, **effort_b}, Tolerance())
    if not (channels or shapes or figures or effort):
        return None
    return EntryChange(a.key, tuple(channels), tuple(shapes), tuple(figures), tuple(effort))


def _channels(name: str, x: np.ndarray, y: np.ndarray, e: EntryRecord, t: np.ndarray,
              tol: Tolerance) -> Iterator[ChannelChange]:
    X, Y = x.reshape(len(x), -1) if x.ndim else x.reshape(1, 1), y.reshape(len(y), -1) if y.ndim else y.reshape(1, 1)
    bad = tol.exceeded(X, Y)
    if not bad.any():
        return
    names, units = column_names(name, y, e)
    with np.errstate(invalid="ignore"):
        dev = np.where(bad, np.abs(X.astype(np.float64) - Y.astype(np.float64)), -1.0)
    for j in np.nonzero(bad.any(axis=0))[0]:
        row = int(np.nanargmax(np.where(np.isnan(dev[:, j]), np.inf, dev[:, j])))
        per_knot = y.ndim and len(y) in (len(t), len(t) - 1)  # a row per knot (or per interval)
        at = float(t[row]) if per_knot else None
        yield ChannelChange(name, names[j], units[j], float(dev[row, j]), at, float(X[row, j]), float(Y[row, j]))


def column_names(name: str, y: np.ndarray, e: EntryRecord) -> tuple[list[str], list[str]]:
    """A column name and unit for each of the flattened trailing axes of array ``name``."""
    width = int(np.prod(y.shape[1:])) if y.ndim > 1 else 1
    cols, units = list(e.columns.get(name, [])), list(e.units.get(name, []))
    if y.ndim <= 1:
        return [name], [units[0] if units else ""]
    if len(cols) == width:
        return cols, units or [""] * width
    if len(cols) == y.shape[1]:  # (K, n, 3): a column per named row and axis
        inner = width // y.shape[1]
        axes = "xyz" if inner == 3 else [str(i) for i in range(inner)]
        return ([f"{c}.{ax}" for c in cols for ax in axes],
                [u for u in (units or [""] * len(cols)) for _ in range(inner)])
    return [f"{name}[{j}]" for j in range(width)], [""] * width


def _values(a: Mapping[str, Any], b: Mapping[str, Any], tol: Tolerance) -> list[ValueChange]:
    out = []
    for k in sorted(set(a) | set(b)):
        x, y = jsonable(a.get(k)), jsonable(b.get(k))
        if _same(x, y, tol):
            continue
        out.append(ValueChange(k, x, y))
    return out


def _same(x: Any, y: Any, tol: Tolerance) -> bool:
    numeric = (int, float)
    if isinstance(x, numeric) and isinstance(y, numeric) and not isinstance(x, bool) and not isinstance(y, bool):
        return not bool(tol.exceeded(np.array(x), np.array(y)))
    if isinstance(x, list) and isinstance(y, list):
        try:
            xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        except (TypeError, ValueError):
            return x == y
        return xa.shape == ya.shape and not tol.exceeded(xa, ya).any()
    return bool(x == y)


def _arrays_equal(a: Mapping[str, np.ndarray], b: Mapping[str, np.ndarray], tol: Tolerance) -> list[ValueChange]:
    out = []
    for k in sorted(set(a) | set(b)):
        x, y = a.get(k), b.get(k)
        if x is None or y is None or np.shape(x) != np.shape(y) or tol.exceeded(x, y).any():
            out.append(ValueChange(k, None if x is None else jsonable(np.asarray(x)),
                                   None if y is None else jsonable(np.asarray(y))))
    return out
