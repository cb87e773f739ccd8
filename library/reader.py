"""Read and verify motion libraries: format and version, checksum, required fields.

The default read loads the file's bytes once, checks their SHA-256 against ``content_sha256``
(every byte counts), then opens only the stored datasets under /model and /packed (a few reads)
and takes every attribute from the index.
``full=True`` (``skatelib validate``) also reads every HDF5 attribute and every per-entry view
and checks that they agree with the index. Every failure raises :class:`LibraryFormatError`
naming the file and the field, and saying what to do. Arrays handed out are read-only.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.crosscheck import check_against_index
from skatelib.library.digest import check_checksum_attribute, read_raw, refuse_damaged
from skatelib.library.errors import LibraryFormatError
from skatelib.library.index import check_index
from skatelib.library.records import EntryRecord, text

_H5_ERRORS = (OSError, RuntimeError, KeyError, ValueError)  # what h5py raises on damaged files


@dataclass(frozen=True)
class LibraryData:
    """A whole library file in memory."""

    path: Path
    attrs: dict[str, Any]
    model_attrs: dict[str, Any]
    model_arrays: dict[str, np.ndarray]
    model_text: dict[str, str]
    entries: dict[str, EntryRecord]
    content_sha256: str | None = None  # the verified whole-file digest (None: read unverified)

    @property
    def kind(self) -> str:
        return str(self.attrs[schema.A_KIND])


def check_version(path: Path, version: str) -> None:
    """Refuse other major versions (with what to do); warn on another minor version."""
    field = f"/@{schema.A_FORMAT_VERSION}"
    try:
        major, minor = (int(p) for p in version.split("."))
    except ValueError:
        raise LibraryFormatError(path, field, f"{version!r} is not 'major.minor': the file is damaged or not written "
                                              "by skatelib; rebuild it with 'skatelib build'") from None
    ours = schema.FORMAT_VERSION
    if major > ours[0]:
        raise LibraryFormatError(
            path,
            field,
            f"format {version} is newer than this skatelib reads "
            f"({schema.FORMAT_VERSION_STR}); update skatelib (pip install -U skatelib)",
        )
    if major < ours[0]:
        raise LibraryFormatError(
            path,
            field,
            f"format {version} is older than {schema.FORMAT_VERSION_STR}; "
            "rebuild the library with 'skatelib build' from the config in its config_toml",
        )
    if minor != ours[1]:
        warnings.warn(
            f"{path}: format {version}, this skatelib writes {schema.FORMAT_VERSION_STR}; reading what it knows",
            stacklevel=3,
        )


def read_library(path: Path | str, verify_checksum: bool = True, full: bool = False) -> LibraryData:
    """Load a library file completely, verifying it.

    Args:
        verify_checksum: Compare the content with ``content_sha256`` (on by default).
        full: Also check every HDF5 attribute and per-entry view against the index.

    Raises:
        LibraryFormatError: Not HDF5, truncated or corrupt, wrong format or version, checksum
            mismatch, or a required field missing.
    """
    path = Path(path)
    raw = read_raw(path)
    digest = refuse_damaged(path, raw) if verify_checksum else None
    try:
        with h5py.File(path, "r") as f:  # the native driver reads faster than one over ``raw``
            _check_format(path, f)
            arrays = _read_groups(path, f, (schema.G_MODEL, schema.G_PACKED) if full else (schema.G_PACKED,))
            index_key = f"{schema.G_PACKED}/{schema.D_INDEX}"
            if index_key not in arrays:
                raise LibraryFormatError(path, f"/{index_key}",
                                         "required dataset missing; rebuild it with 'skatelib build'")
            if verify_checksum:
                check_checksum_attribute(path, f.attrs.get(schema.A_CHECKSUM), digest)
            index = _parse_index(path, arrays[index_key])
            if full:
                check_against_index(path, f, index, arrays)
    except _H5_ERRORS as e:
        raise LibraryFormatError(
            path, "/", f"cannot be read as HDF5 (truncated or corrupt: {e}); rebuild it with 'skatelib build'"
        ) from e
    for arr in arrays.values():
        arr.setflags(write=False)
    root, model = index["root"], index["model"]
    kind = _check_root(path, root, model)
    return LibraryData(
        path=path,
        attrs=root,
        model_attrs=model,
        model_arrays=_model_arrays(path, index),
        model_text=dict(index.get("model_text", {})),
        entries=_entries(path, kind, index, arrays),
        content_sha256=digest,
    )


def _model_arrays(path: Path, index: dict[str, Any]) -> dict[str, np.ndarray]:
    """The index's mirrors of /model's arrays, read-only."""
    out = {}
    for k, spec in index.get("model_arrays", {}).items():
        try:
            a = np.asarray(spec["data"], dtype=np.dtype(spec["dtype"])).reshape(spec["shape"])
        except (TypeError, ValueError) as e:
            raise LibraryFormatError(path, f"/{schema.G_MODEL}/{k}", f"its mirror in the index cannot be read ({e}); "
                                                                  "rebuild the library") from e
        a.setflags(write=False)
        out[k] = a
    return out


def _check_format(path: Path, f: h5py.File) -> None:
    """The file says it is a skatelib library of a version this reader reads."""
    fmt = f.attrs.get(schema.A_FORMAT)
    if fmt is None or text(fmt) != schema.FORMAT_NAME:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT}", f"not a skatelib motion library (format={fmt!r})")
    version = f.attrs.get(schema.A_FORMAT_VERSION)
    if version is None:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT_VERSION}", "missing: the file is damaged or not written by "
                                                                        "skatelib; rebuild it with 'skatelib build'")
    check_version(path, text(version))


def _read_groups(path: Path, f: h5py.File, groups: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Every dataset of the groups, as ``group/name`` -> array."""
    arrays: dict[str, np.ndarray] = {}
    for gname in groups:
        if gname not in f:
            raise LibraryFormatError(path, f"/{gname}", "required group missing; rebuild it with 'skatelib build'")
        for name, obj in f[gname].items():
            if not isinstance(obj, h5py.Dataset):
                raise LibraryFormatError(path, f"/{gname}/{name}", "damaged or unexpected object; rebuild it")
            arrays[f"{gname}/{name}"] = obj[()]
    return arrays


def _check_root(path: Path, root: dict[str, Any], model: dict[str, Any]) -> str:
    """Required root attributes, a known kind and its required model parameters; returns the kind."""
    for key in schema.ROOT_REQUIRED:
        if key not in root and key != schema.A_CHECKSUM:
            raise LibraryFormatError(path, f"/@{key}", "required root attribute missing")
    kind = str(root[schema.A_KIND])
    if kind not in schema.ENTRY_DATASETS:
        raise LibraryFormatError(
            path, f"/@{schema.A_KIND}", f"unknown kind {kind!r}; known: {', '.join(schema.ENTRY_DATASETS)}"
        )
    if kind == "quadruped":
        for key in schema.QUADRUPED_MODEL_ATTRS:
            if key not in model:
                raise LibraryFormatError(path, f"/{schema.G_MODEL}@{key}", "required model parameter missing")
    return kind


def _parse_index(path: Path, blob: np.ndarray) -> dict[str, Any]:
    field = f"/{schema.G_PACKED}/{schema.D_INDEX}"
    try:
        index = json.loads(blob.tobytes().decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise LibraryFormatError(path, field, f"index is not valid JSON ({e}); rebuild the library") from e
    check_index(path, index)  # the one check of its shape and its keys, before any of it is used
    return index


def _entries(path: Path, kind: str, index: dict[str, Any], arrays: dict[str, np.ndarray]) -> dict[str, EntryRecord]:
    out = {}
    for meta in index["entries"]:
        key = meta["key"]
        base = f"/{schema.G_ENTRIES}/{key}"
        for a in schema.ENTRY_ATTRS:
            if a not in meta["attrs"]:
                raise LibraryFormatError(path, f"{base}@{a}", "required entry attribute missing")
        data = _entry_arrays(path, base, kind, meta, arrays)
        out[key] = EntryRecord(
            key=key,
            attrs=meta["attrs"],
            arrays=data,
            columns=_entry_columns(path, base, meta, data),
            units={k: tuple(v) for k, v in meta["units"].items()},
        )
    return out


def _entry_arrays(path: Path, base: str, kind: str, meta: dict[str, Any],
                  arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """An entry's rows of the packed datasets (every dataset its kind requires)."""
    for d in schema.ENTRY_DATASETS[kind]:
        if d not in meta["rows"]:
            raise LibraryFormatError(path, f"{base}/{d}", "required dataset missing from the index; rebuild it with "
                                                           "'skatelib build'")
        if f"{schema.G_PACKED}/{d}" not in arrays:
            raise LibraryFormatError(path, f"/{schema.G_PACKED}/{d}", "required dataset missing; rebuild it with "
                                                                      "'skatelib build'")
    data = {}
    for d, (a, b) in meta["rows"].items():
        src = arrays.get(f"{schema.G_PACKED}/{d}")
        if src is None or b > len(src) or a < 0 or a > b:
            raise LibraryFormatError(path, f"{base}/{d}", "rows outside the packed data; rebuild the library")
        data[d] = src[a:b]
    return data


def _entry_columns(path: Path, base: str, meta: dict[str, Any],
                   data: dict[str, np.ndarray]) -> dict[str, tuple[str, ...]]:
    """Column names per dataset; state and control must name every column."""
    cols = {k: tuple(v) for k, v in meta["columns"].items()}
    for d in (schema.D_STATE, schema.D_CONTROL):
        if d not in cols:
            raise LibraryFormatError(path, f"{base}/{d}@{schema.A_COLUMNS}", "channel names missing")
        if len(cols[d]) != data[d].shape[-1]:
            raise LibraryFormatError(
                path, f"{base}/{d}@{schema.A_COLUMNS}", f"{len(cols[d])} names for {data[d].shape[-1]} columns"
            )
    return cols
