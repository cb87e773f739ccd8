"""Write motion libraries atomically: a temporary file in the target folder, then os.replace."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.digest import digest, read_all


@dataclass(frozen=True)
class EntryData:
    """One library entry: named arrays plus scalar attributes.

    Attributes:
        key: Entry name (``v0.50_s2``).
        attrs: Scalars (at least ``format.ENTRY_ATTRS``).
        arrays: Datasets by name (``t``, ``state``, ``control``, ...).
        columns: Column names per dataset that has named columns.
        units: Column units per dataset, aligned with ``columns``.
    """

    key: str
    attrs: Mapping[str, Any]
    arrays: Mapping[str, np.ndarray]
    columns: Mapping[str, Sequence[str]] = field(default_factory=dict)
    units: Mapping[str, Sequence[str]] = field(default_factory=dict)


@contextlib.contextmanager
def _atomic_path(path: Path) -> Iterator[Path]:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _dataset(
    group: h5py.Group, name: str, data: np.ndarray, columns: Sequence[str] | None, units: Sequence[str] | None
) -> None:
    arr = np.asarray(data)
    # fletcher32 needs chunked storage; one chunk per dataset keeps reads to one call.
    d = group.create_dataset(name, data=arr, fletcher32=True, chunks=arr.shape if arr.ndim else None)
    if columns is not None:
        d.attrs[schema.A_COLUMNS] = np.array(list(columns), dtype=h5py.string_dtype())
    if units is not None:
        d.attrs[schema.A_UNITS] = np.array(list(units), dtype=h5py.string_dtype())


def write_library(
    path: Path | str,
    root_attrs: Mapping[str, Any],
    model_attrs: Mapping[str, Any],
    model_arrays: Mapping[str, np.ndarray],
    model_text: Mapping[str, str],
    entries: Sequence[EntryData],
) -> Path:
    """Write a complete library file; a reader never sees a half-written one.

    Returns:
        The final path.
    """
    path = Path(path)
    with _atomic_path(path) as tmp, h5py.File(tmp, "w") as f:
        for k, v in root_attrs.items():
            f.attrs[k] = v
        f.attrs[schema.A_FORMAT] = schema.FORMAT_NAME
        f.attrs[schema.A_FORMAT_VERSION] = schema.FORMAT_VERSION_STR
        model = f.create_group(schema.G_MODEL)
        for k, v in model_attrs.items():
            model.attrs[k] = v
        for k, arr in model_arrays.items():
            _dataset(model, k, arr, None, None)
        for k, text in model_text.items():
            model.create_dataset(k, data=np.frombuffer(text.encode(), dtype=np.uint8), fletcher32=True, chunks=True)
        group = f.create_group(schema.G_ENTRIES)
        for e in entries:
            g = group.create_group(e.key)
            for k, v in e.attrs.items():
                g.attrs[k] = v
            for k, arr in e.arrays.items():
                _dataset(g, k, arr, e.columns.get(k), e.units.get(k))
        f.attrs[schema.A_CHECKSUM] = digest(*read_all(f))
    return path
