"""Write motion libraries atomically: a temporary file in the target folder, then os.replace.

Layout (``docs/library-format.md``): ``/packed/<name>`` stacks every entry's array ``<name>``,
``/packed/index`` is a JSON mirror of all attributes with each entry's row offsets, and
``/entries/<key>/<name>`` are virtual views into the packed arrays carrying their column names
and units. Readers that only need the data open a handful of datasets.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.digest import placeholder, seal


@dataclass(frozen=True)
class EntryData:
    """One library entry: named arrays plus scalar attributes.

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


def jsonable(v: Any) -> Any:
    """Plain JSON value of an attribute (numpy scalars and arrays converted)."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, bytes):
        return v.decode()
    return v


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yield a temporary path in ``path``'s folder; on success it replaces ``path``, on error it is removed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    # The writer's pid is in the name, so a later run can tell a dead writer's leftover (kill -9)
    # from a concurrent writer's file in progress (remove_stale_temporaries).
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a library is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def remove_stale_temporaries(folder: Path, prefix: str = "") -> list[Path]:
    """Remove temporary files and folders (``.NAME.PID.*.tmp`` of :func:`atomic_path`, or
    ``PREFIX-PID-*`` folders) left in ``folder`` by processes that no longer exist; returns them."""
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for p in folder.iterdir():
        parts = p.name.split(".") if p.name.endswith(".tmp") else p.name.split("-")
        is_ours = p.name.endswith(".tmp") and p.name.startswith(".") and len(parts) >= 5
        is_ours = is_ours or bool(prefix and p.name.startswith(f"{prefix}-") and len(parts) >= 3)
        pid_part = parts[-3] if p.name.endswith(".tmp") else parts[1] if len(parts) > 1 else ""
        if not is_ours or not pid_part.isdigit() or _alive(int(pid_part)):
            continue
        with contextlib.suppress(OSError):
            if p.is_dir():
                shutil.rmtree(p)
            else:
                p.unlink()
            removed.append(p)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _stored(group: h5py.Group, name: str, data: np.ndarray) -> np.ndarray:
    arr = np.ascontiguousarray(data)
    # fletcher32 needs chunked storage; one chunk per dataset keeps a read to one call.
    group.create_dataset(name, data=arr, fletcher32=True, chunks=arr.shape if arr.size else None)
    return arr


def _strings(values: Sequence[str]) -> np.ndarray:
    return np.array(list(values), dtype=h5py.string_dtype())


def write_library(
    path: Path | str,
    root_attrs: Mapping[str, Any],
    model_attrs: Mapping[str, Any],
    model_arrays: Mapping[str, np.ndarray],
    model_text: Mapping[str, str],
    entries: Sequence[EntryData],
) -> Path:
    """Write a complete library file; a reader never sees a half-written one.

    Raises:
        ValueError: When entries disagree on their dataset names or trailing shapes.
    """
    path = Path(path)
    names = list(entries[0].arrays) if entries else []
    for e in entries:
        if list(e.arrays) != names:
            raise ValueError(f"entry {e.key} has datasets {list(e.arrays)}, expected {names}")
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
    stored: dict[str, np.ndarray] = {}
    marker = placeholder()
    with atomic_path(path) as tmp:
        _write_h5(tmp, root, model_attrs, model_arrays, model_text, entries, names, index, stored, marker)
        seal(tmp, marker)
    return path


def _write_h5(
    tmp: Path,
    root: dict[str, Any],
    model_attrs: Mapping[str, Any],
    model_arrays: Mapping[str, np.ndarray],
    model_text: Mapping[str, str],
    entries: Sequence[EntryData],
    names: list[str],
    index: dict[str, Any],
    stored: dict[str, np.ndarray],
    marker: bytes,
) -> None:
    with h5py.File(tmp, "w") as f:
        model = f.create_group(schema.G_MODEL)
        for k, v in model_attrs.items():
            model.attrs[k] = v
        for k, arr in model_arrays.items():
            stored[f"{schema.G_MODEL}/{k}"] = _stored(model, k, arr)
        for k, text in model_text.items():
            stored[f"{schema.G_MODEL}/{k}"] = _stored(model, k, np.frombuffer(text.encode(), dtype=np.uint8))
        packed = f.create_group(schema.G_PACKED)
        for n in names:
            stored[f"{schema.G_PACKED}/{n}"] = _stored(packed, n, np.concatenate([e.arrays[n] for e in entries]))
        group = f.create_group(schema.G_ENTRIES)
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
        blob = np.frombuffer(json.dumps(index, sort_keys=True).encode(), dtype=np.uint8)
        stored[f"{schema.G_PACKED}/{schema.D_INDEX}"] = _stored(packed, schema.D_INDEX, blob)
        for k, v in root.items():
            f.attrs[k] = v
        f.attrs[schema.A_CHECKSUM] = np.bytes_(marker)  # fixed length: sealed in place after closing
