"""Array-level comparisons of two motion libraries' entries (:mod:`skatelib.library.compare`):
the tolerance, each column's largest deviation with its name, unit and time, and the columns'
names and units themselves (numpy only)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.library.records import EntryRecord


@dataclass(frozen=True)
class Tolerance:
    """Element-wise ``|a - b| <= atol + rtol |b|``; the defaults demand bit-identical numbers."""

    atol: float = 0.0
    rtol: float = 0.0

    def exceeded(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Where ``a`` and ``b`` differ beyond the tolerance; NaN equals NaN and an infinity the
        same infinity (``inf - inf`` is NaN: no tolerance would hold it)."""
        a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        alike = (np.isnan(a) & np.isnan(b)) | (a == b)
        with np.errstate(invalid="ignore"):
            return ~alike & ~(np.abs(a - b) <= self.atol + self.rtol * np.abs(b))


EXACT = Tolerance()  # bit for bit


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


def by_name(name: str, x: np.ndarray, a: EntryRecord, b: EntryRecord) -> tuple[np.ndarray, list[ValueChange]]:
    """Array ``name`` of entry ``a`` with its columns in ``b``'s order where both name the same
    columns in another order (so that each channel is compared with the channel of its name), and
    the differences of the two arrays' column names and units (counted: a reader that takes a
    channel by its name or position gets another one)."""
    cols_a, cols_b = list(a.columns.get(name, [])), list(b.columns.get(name, []))
    units_a, units_b = list(a.units.get(name, [])), list(b.units.get(name, []))
    changes = [ValueChange(f"{name} columns", *_where_unlike(cols_a, cols_b, range(max(len(cols_a), len(cols_b)))))
               ] if cols_a != cols_b else []
    if cols_a != cols_b and sorted(cols_a) == sorted(cols_b) and x.ndim > 1 and x.shape[1] == len(cols_b):
        order = [cols_a.index(c) for c in cols_b]
        x = x[:, order]
        if len(units_a) == len(order):
            units_a = [units_a[i] for i in order]
    if units_a != units_b:
        labels = cols_b if len(cols_b) == max(len(units_a), len(units_b)) else range(max(len(units_a), len(units_b)))
        changes.append(ValueChange(f"{name} units", *_where_unlike(units_a, units_b, labels)))
    return x, changes


def _where_unlike(a: list[str], b: list[str], labels: Any) -> tuple[dict[str, str | None], dict[str, str | None]]:
    """The items of two lists that differ, each under its label (its column, or its position)."""
    out_a: dict[str, str | None] = {}
    out_b: dict[str, str | None] = {}
    for i, label in enumerate(labels):
        x, y = a[i] if i < len(a) else None, b[i] if i < len(b) else None
        if x != y:
            out_a[str(label)], out_b[str(label)] = x, y
    return out_a, out_b


def deviations(x: np.ndarray, y: np.ndarray, bad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``|x - y|`` where ``bad`` (-1 elsewhere), and its ranking: a NaN deviation (a number against
    NaN) ranks above every other, so that the largest is found where it is."""
    with np.errstate(invalid="ignore"):
        dev = np.where(bad, np.abs(np.asarray(x, np.float64) - np.asarray(y, np.float64)), -1.0)
    return dev, np.where(np.isnan(dev), np.inf, dev)


def channels(name: str, x: np.ndarray, y: np.ndarray, e: EntryRecord, t: np.ndarray,
              tol: Tolerance) -> Iterator[ChannelChange]:
    """Each column of array ``name`` that moved beyond ``tol``: its largest deviation, with the time
    of that row where the array has a row per knot (or per interval); a humanoid's node arrays
    (``nodes_state``: steps x nodes x channels) by channel, naming the step and node, at the node's
    time. Integer arrays (codes) compare exactly."""
    nodes = _node_layout(name, y, e)
    if nodes is not None:
        x, y = x.reshape(-1, y.shape[2]), y.reshape(-1, y.shape[2])
    X, Y = x.reshape(len(x), -1) if x.ndim else x.reshape(1, 1), y.reshape(len(y), -1) if y.ndim else y.reshape(1, 1)
    exact = np.issubdtype(x.dtype, np.integer) and np.issubdtype(y.dtype, np.integer)  # codes: contact, step
    bad = (EXACT if exact else tol).exceeded(X, Y)
    if not bad.any():
        return
    names, units = column_names(name, y, e) if nodes is None else nodes[:2]
    dev, rank = deviations(X, Y, bad)
    for j in np.nonzero(bad.any(axis=0))[0]:
        row = int(np.argmax(rank[:, j]))
        column, at = names[j], None
        if nodes is not None:
            column, at = f"{column} (step {nodes[2][row][0]}, node {nodes[2][row][1]})", nodes[2][row][2]
        elif y.ndim and len(y) in (len(t), len(t) - 1):  # a row per knot (or per interval)
            at = float(t[row])
        yield ChannelChange(name, column, units[j], float(dev[row, j]), at, float(X[row, j]), float(Y[row, j]))


def _node_layout(name: str, y: np.ndarray, e: EntryRecord
                 ) -> tuple[list[str], list[str], list[tuple[int, int, float | None]]] | None:
    """For a humanoid's node array (S steps x M nodes x channels, named ``nodes_<array>`` and laid
    out as ``<array>``): the channels' names and units, and per flattened row its step, node and
    time (``nodes_t`` holds each step's start, its nodes and its end: a state at every one of those,
    a control at the nodes alone). None for any other array."""
    base = name.removeprefix("nodes_")
    cols = list(e.columns.get(base, []))
    if base == name or y.ndim != 3 or len(cols) != y.shape[2]:
        return None
    units = list(e.units.get(base, [])) or [""] * len(cols)
    times = np.asarray(e.arrays.get("nodes_t", np.zeros((0, 0))))
    first = 0 if times.ndim == 2 and times.shape[1] == y.shape[1] else 1  # controls: the nodes, not the ends
    rows = []
    for s in range(y.shape[0]):
        for n in range(y.shape[1]):
            k = n + first
            at = float(times[s, k]) if times.ndim == 2 and s < times.shape[0] and k < times.shape[1] else None
            rows.append((s, n, at))
    return cols, units, rows


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
