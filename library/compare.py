"""What changed between two motion libraries (``skatelib diff``, ``skatelib build --check``), from
the files alone (numpy and h5py).

Two libraries are *equal* when they hold the same entries with the same outcome (success,
status), the same arrays within the tolerances (``|a - b| <= atol + rtol |b|``, element by element,
NaN equal to NaN, an infinity to itself), the same label-level figures within the same tolerances
(scalar attributes and the numbers of ``physics_json`` and the closed-loop verdicts) and the same
model. What differs
between two builds of one problem anyway (creation time, solve times, cache keys) is left out;
provenance (code commit, package and solver versions, solver options, the config's keys) and
solver effort (iterations, attempts; a humanoid's stage times; the controller's solve times in the
closed-loop verdicts) are reported but do not make two libraries differ. Arrays are compared column
by column under their names; their column names and units are compared too, and an integer array
(contact codes, a humanoid's step index) exactly, whatever the tolerance. Libraries of two kinds are
not compared (:class:`KindsDiffer`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.attributes import EFFORT, PROVENANCE, VOLATILE, expand, json_figures, split
from skatelib.library.certificate import certificate_figures
from skatelib.library.channel_diff import EXACT, ChannelChange, Tolerance, ValueChange, by_name, deviations
from skatelib.library.channel_diff import channels as column_changes
from skatelib.library.reader import LibraryData, read_library
from skatelib.library.records import EntryRecord, jsonable

__all__ = ["ChannelChange", "EntryChange", "KindsDiffer", "LibraryDiff", "Tolerance", "ValueChange", "compare",
           "compare_files"]

CONFIG = "config_resolved_json"
CERTIFICATE = schema.A_CERTIFICATE


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
        """The comparison as plain data; each changed entry says whether it ``differs`` (an entry
        whose solver effort alone changed does not)."""
        doc = {"equal": self.equal, **asdict(self)}
        for entry, change in zip(doc["changed"], self.changed, strict=True):
            entry["differs"] = change.differs
        return doc


def compare_files(a: Path | str, b: Path | str, tolerance: Tolerance = EXACT,
                  keys: list[str] | None = None) -> LibraryDiff:
    """Compare the libraries at ``a`` and ``b`` (both verified first); ``keys`` restricts the
    entries compared.

    Raises:
        LibraryFormatError: Either file is missing, damaged or of another major version.
    """
    return compare(read_library(a), read_library(b), tolerance, keys)


class KindsDiffer(ValueError):
    """Two libraries of different kinds (a quadruped's and a humanoid's): nothing to compare."""

    def __init__(self, A: LibraryData, B: LibraryData):
        super().__init__(f"{A.path} is a {A.kind} library and {B.path} a {B.kind} one: only libraries of one kind "
                         "can be compared")


def compare(A: LibraryData, B: LibraryData, tol: Tolerance = EXACT, keys: list[str] | None = None) -> LibraryDiff:
    """Compare two read libraries (module docstring).

    Raises:
        KindsDiffer: One is a quadruped's library and the other a humanoid's.
    """
    if A.kind != B.kind:
        raise KindsDiffer(A, B)
    ka, kb = set(A.entries), set(B.entries)
    if keys:
        ka, kb = ka & set(keys), kb & set(keys)
    changed = [c for k in sorted(ka & kb) if (c := _entry(A.entries[k], B.entries[k], tol)) is not None]
    model = _values(A.model_attrs, B.model_attrs, tol) + _arrays_equal(A.model_arrays, B.model_arrays, tol)
    model += [_first_line_unlike(k, A.model_text.get(k), B.model_text.get(k))
              for k in sorted(set(A.model_text) | set(B.model_text)) if A.model_text.get(k) != B.model_text.get(k)]
    config = _values(json_figures(A.attrs.get(CONFIG)), json_figures(B.attrs.get(CONFIG)), EXACT)
    prov = _values({k: v for k, v in A.attrs.items() if k in PROVENANCE},
                   {k: v for k, v in B.attrs.items() if k in PROVENANCE}, EXACT)
    other = {k for k in set(A.attrs) | set(B.attrs) if k not in PROVENANCE | VOLATILE | {CONFIG, CERTIFICATE}}
    prov += _values({k: A.attrs[k] for k in other if k in A.attrs}, {k: B.attrs[k] for k in other if k in B.attrs},
                    tol)
    cert = _values(certificate_figures(A.attrs.get(CERTIFICATE)), certificate_figures(B.attrs.get(CERTIFICATE)),
                   EXACT)
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
            if name == "t" and x is not None and y is not None and np.size(x) and np.size(y):  # how long each lasts
                shapes.append(ValueChange("duration [s]", float(np.asarray(x)[-1] - np.asarray(x)[0]),
                                          float(np.asarray(y)[-1] - np.asarray(y)[0])))
            continue
        x, layout = by_name(name, np.asarray(x), a, b)
        shapes += layout
        channels += column_changes(name, x, np.asarray(y), b, t, tol)
    attrs_a = {k: v for k, v in a.attrs.items() if k not in VOLATILE | EFFORT | PROVENANCE}
    attrs_b = {k: v for k, v in b.attrs.items() if k not in VOLATILE | EFFORT | PROVENANCE}
    (fig_a, effort_a), (fig_b, effort_b) = split(expand(attrs_a)), split(expand(attrs_b))
    figures = _values(fig_a, fig_b, tol)
    effort = _values({**{k: v for k, v in a.attrs.items() if k in EFFORT}, **effort_a},
                     {**{k: v for k, v in b.attrs.items() if k in EFFORT}, **effort_b}, EXACT)
    if not (channels or shapes or figures or effort):
        return None
    return EntryChange(a.key, tuple(channels), tuple(shapes), tuple(figures), tuple(effort))


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
    """The model's arrays that differ: where the largest deviation is, and both values there (the
    shapes, where they differ)."""
    out = []
    for k in sorted(set(a) | set(b)):
        x, y = a.get(k), b.get(k)
        if x is None or y is None or np.shape(x) != np.shape(y):
            out.append(ValueChange(f"{k} shape", None if x is None else list(np.shape(x)),
                                   None if y is None else list(np.shape(y))))
        elif (bad := tol.exceeded(x, y)).any():
            at = np.unravel_index(int(np.argmax(deviations(x, y, bad)[1])), np.shape(x))
            where = "[" + ", ".join(str(int(i)) for i in at) + "]" if np.ndim(x) else ""
            out.append(ValueChange(f"{k}{where}", jsonable(np.asarray(x)[at]), jsonable(np.asarray(y)[at])))
    return out


def _first_line_unlike(name: str, a: str | None, b: str | None) -> ValueChange:
    """A text of the model (the URDF) that differs: its first line that does, on each side."""
    lines_a, lines_b = (a or "").splitlines(), (b or "").splitlines()
    for i in range(max(len(lines_a), len(lines_b))):
        x = lines_a[i].strip() if i < len(lines_a) else None
        y = lines_b[i].strip() if i < len(lines_b) else None
        if x != y:
            return ValueChange(f"{name} line {i + 1}", x if a is not None else None, y if b is not None else None)
    return ValueChange(name, a, b)  # the same lines, other line ends
