"""Write motion libraries atomically: a temporary file in the target folder, then os.replace.

Layout (``docs/library-format.md``): ``/packed/<name>`` stacks every entry's array ``<name>``,
``/packed/index`` is a JSON mirror of all attributes with each entry's row offsets, and
``/entries/<key>/<name>`` are virtual views into the packed arrays carrying their column names
and units. Readers that only need the data open a handful of datasets.
"""

from __future__ import annotations

import io
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.atomic import write_atomic
from skatelib.library.digest import placeholder, seal
from skatelib.library.records import EntryRecord, jsonable


def _stored(group: h5py.Group, name: str, data: np.ndarray) -> np.ndarray:
    arr = np.ascontiguousarray(data)
    # fletcher32 needs chunked storage; one chunk per dataset keeps a read to one call.
    group.create_dataset(name, data=arr, fletcher32=True, chunks=arr.shape if arr.size else None)
    return arr


def _strings(values: Sequence[str]) -> np.ndarray:
    return np.array(list(values), dtype=h5py.string_dtype())


def _dataset_names(entries: Sequence[EntryRecord]) -> list[str]:
    """The entries' dataset names, the same for each; refuses a key a reader would refuse."""
    names = list(entries[0].arrays) if entries else []
    for e in entries:
        why = schema.entry_key_problem(e.key)
        if why:
            raise ValueError(why)
        if list(e.arrays) != names:
            raise ValueError(f"entry {e.key} has datasets {list(e.arrays)}, expected {names}")
    return names


def write_library(
    path: Path | str,
    root_attrs: Mapping[str, Any],
    model_attrs: Mapping[str, Any],
    model_arrays: Mapping[str, np.ndarray],
    model_text: Mapping[str, str],
    entries: Sequence[EntryRecord],
) -> Path:
    """Write a complete library file; a reader never sees a half-written one.

    Raises:
        ValueError: When entries disagree on their dataset names or trailing shapes, or a key is not
            a plain name (``schema.ENTRY_KEY_RULE``).
    """
    return write_atomic(Path(path), library_bytes(root_attrs, model_attrs, model_arrays, model_text, entries))


def library_bytes(
    root_attrs: Mapping[str, Any],
    model_attrs: Mapping[str, Any],
    model_arrays: Mapping[str, np.ndarray],
    model_text: Mapping[str, str],
    entries: Sequence[EntryRecord],
) -> bytearray:
    """The bytes of a complete, sealed library file (:func:`write_library` writes them).

    Raises:
        ValueError: As :func:`write_library`.
    """
    names = _dataset_names(entries)
    root = {
        **{k: jsonable(v) for k, v in root_attrs.items()},
        schema.A_FORMAT: schema.FORMAT_NAME,
        schema.A_FORMAT_VERSION: schema.FORMAT_VERSION_STR,
    }
    index: dict[str, Any] = {
        "root": root,
        "model": {k: jsonable(v) for k, v in model_attrs.items()},
        # Mirrors of /model's datasets, so a reader needs only /packed (the file hash covers all).
        "model_arrays": {
            k: {"dtype": np.asarray(v).dtype.str, "shape": list(np.shape(v)), "data": jsonable(np.asarray(v))}
            for k, v in model_arrays.items()
        },
        "model_text": dict(model_text),
        "entries": [],
    }
    offsets = dict.fromkeys(names, 0)
    for e in entries:
        rows = {}
        for n in names:
            rows[n] = [offsets[n], offsets[n] + len(e.arrays[n])]
            offsets[n] += len(e.arrays[n])
        index["entries"].append(
            {
                "key": e.key,
                "attrs": {k: jsonable(v) for k, v in e.attrs.items()},
                "rows": rows,
                "columns": {k: list(v) for k, v in e.columns.items()},
                "units": {k: list(v) for k, v in e.units.items()},
            }
        )
    marker = placeholder()
    # HDF5 writes into memory and Python writes the bytes: a full device is then an error of one
    # write() (refused before it starts when the free space is short), never one inside HDF5's
    # own I/O, which can leave the library in a state that crashes the process.
    buffer = io.BytesIO()
    _write_h5(buffer, index, _Model(model_attrs, model_arrays, model_text), entries, marker)
    raw = bytearray(buffer.getbuffer())
    seal(raw, marker)
    return raw


@dataclass(frozen=True)
class _Model:
    """What goes into /model: attributes, arrays, texts (the URDF)."""

    attrs: Mapping[str, Any]
    arrays: Mapping[str, np.ndarray]
    text: Mapping[str, str]


def _write_h5(target: io.BytesIO, index: dict[str, Any], model: _Model, entries: Sequence[EntryRecord],
              marker: bytes) -> None:
    names = list(entries[0].arrays) if entries else []
    stored: dict[str, np.ndarray] = {}
    with h5py.File(target, "w") as f:
        group = f.create_group(schema.G_MODEL)
        for k, v in model.attrs.items():
            group.attrs[k] = v
        for k, arr in model.arrays.items():
            stored[f"{schema.G_MODEL}/{k}"] = _stored(group, k, arr)
        for k, text in model.text.items():
            stored[f"{schema.G_MODEL}/{k}"] = _stored(group, k, np.frombuffer(text.encode(), dtype=np.uint8))
        packed = f.create_group(schema.G_PACKED)
        for n in names:
            stored[f"{schema.G_PACKED}/{n}"] = _stored(packed, n, np.concatenate([e.arrays[n] for e in entries]))
        _write_views(f.create_group(schema.G_ENTRIES), entries, index, names, stored)
        blob = np.frombuffer(json.dumps(index, sort_keys=True).encode(), dtype=np.uint8)
        _stored(packed, schema.D_INDEX, blob)
        for k, v in index["root"].items():
            f.attrs[k] = v
        f.attrs[schema.A_CHECKSUM] = np.bytes_(marker)  # fixed length: sealed in place after closing


def _write_views(group: h5py.Group, entries: Sequence[EntryRecord], index: dict[str, Any], names: list[str],
                 stored: dict[str, np.ndarray]) -> None:
    """/entries/<key>: attributes and virtual views into the packed rows, with column names and units."""
    for e, meta in zip(entries, index["entries"], strict=True):
        g = group.create_group(e.key)
        for k, v in e.attrs.items():
            g.attrs[k] = v
        for n in names:
            src = stored[f"{schema.G_PACKED}/{n}"]
            a, b = meta["rows"][n]
            layout = h5py.VirtualLayout(shape=(b - a, *src.shape[1:]), dtype=src.dtype)
            layout[:] = h5py.VirtualSource(".", f"{schema.G_PACKED}/{n}", shape=src.shape)[a:b]
            d = g.create_virtual_dataset(n, layout)
            if n in e.columns:
                d.attrs[schema.A_COLUMNS] = _strings(e.columns[n])
            if n in e.units:
                d.attrs[schema.A_UNITS] = _strings(e.units[n])
