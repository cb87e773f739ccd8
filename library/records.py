"""The record of one library entry, from writer to reader."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class EntryRecord:
    """One library entry, as the writer takes it and the reader returns it: named arrays plus
    scalar attributes.

    Attributes:
        key: Entry name (``v0.50_s2``).
        attrs: Scalars (at least ``schema.ENTRY_ATTRS``).
        arrays: Datasets by name (``t``, ``state``, ``control``, ...); the first axis is time.
        columns: Column names per dataset that has named columns.
        units: Column units per dataset, aligned with ``columns``.
    """

    key: str
    attrs: Mapping[str, Any]
    arrays: Mapping[str, np.ndarray]
    columns: Mapping[str, Sequence[str]] = field(default_factory=dict)
    units: Mapping[str, Sequence[str]] = field(default_factory=dict)


def jsonable(v: object) -> Any:
    """Plain JSON value of an attribute (numpy scalars and arrays converted)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, bytes):
        return v.decode()
    return v


def text(v: object) -> str:
    """An attribute's string (h5py hands out bytes or str)."""
    return v.decode() if isinstance(v, bytes) else str(v)
