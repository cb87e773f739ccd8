"""Read and verify motion libraries: format and version, checksum, required fields.

Every failure raises :class:`LibraryFormatError` naming the file and the field, and saying what
to do. Arrays handed out are read-only.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.digest import digest, read_all
from skatelib.library.errors import LibraryFormatError


@dataclass(frozen=True)
class EntryRecord:
    """One entry as stored: attributes, read-only arrays, and column names/units per dataset."""

    key: str
    attrs: dict[str, Any]
    arrays: dict[str, np.ndarray]
    columns: dict[str, tuple[str, ...]]
    units: dict[str, tuple[str, ...]]


@dataclass(frozen=True)
class LibraryData:
    """A whole library file in memory."""

    path: Path
    attrs: dict[str, Any]
    model_attrs: dict[str, Any]
    model_arrays: dict[str, np.ndarray]
    model_text: dict[str, str]
    entries: dict[str, EntryRecord]

    @property
    def kind(self) -> str:
        return str(self.attrs[schema.A_KIND])


def _str(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _names(v: Any) -> tuple[str, ...]:
    return tuple(_str(x) for x in np.asarray(v).reshape(-1))


def check_version(path: Path, version: str) -> None:
    """Refuse other major versions (with what to do); warn on another minor version."""
    try:
        major, minor = (int(p) for p in version.split("."))
    except ValueError:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT_VERSION}", f"{version!r} is not 'major.minor'") from None
    ours = schema.FORMAT_VERSION
    if major > ours[0]:
        raise LibraryFormatError(
            path,
            f"/@{schema.A_FORMAT_VERSION}",
            f"format {version} is newer than this skatelib reads ({schema.FORMAT_VERSION_STR}); "
            "update skatelib (pip install -U skatelib) to read it",
        )
    if major < ours[0]:
        raise LibraryFormatError(
            path,
            f"/@{schema.A_FORMAT_VERSION}",
            f"format {version} is older than {schema.FORMAT_VERSION_STR}; rebuild the library with "
            "'skatelib build' from the config stored in its config_toml attribute",
        )
    if minor != ours[1]:
        warnings.warn(
            f"{path}: format {version}, this skatelib writes {schema.FORMAT_VERSION_STR}; reading what it knows",
            stacklevel=3,
        )


def read_library(path: Path | str, verify_checksum: bool = True) -> LibraryData:
    """Load a library file completely, verifying it.

    Raises:
        LibraryFormatError: Not HDF5, truncated or corrupt, wrong format or version, checksum
            mismatch, or a required field missing.
    """
    path = Path(path)
    if not path.is_file():
        raise LibraryFormatError(path, "/", "no such file; build one with 'skatelib build'")
    try:
        with h5py.File(path, "r") as f:
            fmt = f.attrs.get(schema.A_FORMAT)
            if fmt is None or _str(fmt) != schema.FORMAT_NAME:
                raise LibraryFormatError(
                    path, f"/@{schema.A_FORMAT}", f"not a skatelib motion library (format={fmt!r})"
                )
            version = f.attrs.get(schema.A_FORMAT_VERSION)
            if version is None:
                raise LibraryFormatError(path, f"/@{schema.A_FORMAT_VERSION}", "missing")
            check_version(path, _str(version))
            arrays, attrs = read_all(f)
    except OSError as e:
        raise LibraryFormatError(
            path, "/", f"cannot be read as HDF5 (truncated or corrupt: {e}); rebuild it with 'skatelib build'"
        ) from e
    root = attrs[""]
    for key in schema.ROOT_REQUIRED:
        if key not in root:
            raise LibraryFormatError(path, f"/@{key}", "required root attribute missing")
    if verify_checksum:
        stored = _str(root[schema.A_CHECKSUM])
        if digest(arrays, attrs) != stored:
            raise LibraryFormatError(
                path, f"/@{schema.A_CHECKSUM}", "content does not match its checksum: the file is corrupt; rebuild it"
            )
    kind = _str(root[schema.A_KIND])
    if kind not in schema.ENTRY_DATASETS:
        raise LibraryFormatError(
            path, f"/@{schema.A_KIND}", f"unknown kind {kind!r}; known: {', '.join(schema.ENTRY_DATASETS)}"
        )
    for arr in arrays.values():
        if isinstance(arr, np.ndarray):
            arr.setflags(write=False)
    return LibraryData(
        path=path,
        attrs={k: (_str(v) if isinstance(v, bytes) else v) for k, v in root.items()},
        model_attrs=_model_attrs(path, kind, attrs),
        model_arrays=_model_arrays(arrays),
        model_text=_model_text(arrays),
        entries=_entries(path, kind, arrays, attrs),
    )


def _model_attrs(path: Path, kind: str, attrs: dict[str, dict[str, Any]]) -> dict[str, Any]:
    if schema.G_MODEL not in attrs:
        raise LibraryFormatError(path, f"/{schema.G_MODEL}", "required group missing")
    model = attrs[schema.G_MODEL]
    if kind == "quadruped":
        for key in schema.QUADRUPED_MODEL_ATTRS:
            if key not in model:
                raise LibraryFormatError(path, f"/{schema.G_MODEL}@{key}", "required model parameter missing")
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in model.items()}


def _model_arrays(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    prefix = schema.G_MODEL + "/"
    return {k[len(prefix) :]: v for k, v in arrays.items() if k.startswith(prefix) and v.dtype != np.uint8}


def _model_text(arrays: dict[str, np.ndarray]) -> dict[str, str]:
    prefix = schema.G_MODEL + "/"
    return {
        k[len(prefix) :]: v.tobytes().decode()
        for k, v in arrays.items()
        if k.startswith(prefix) and v.dtype == np.uint8
    }


def _entries(
    path: Path, kind: str, arrays: dict[str, np.ndarray], attrs: dict[str, dict[str, Any]]
) -> dict[str, EntryRecord]:
    prefix = schema.G_ENTRIES + "/"
    keys = sorted({name[len(prefix) :].split("/")[0] for name in attrs if name.startswith(prefix)})
    out = {}
    for key in keys:
        base = f"{schema.G_ENTRIES}/{key}"
        eattrs = attrs[base]
        for a in schema.ENTRY_ATTRS:
            if a not in eattrs:
                raise LibraryFormatError(path, f"/{base}@{a}", "required entry attribute missing")
        data, cols, units = {}, {}, {}
        for d in schema.ENTRY_DATASETS[kind]:
            name = f"{base}/{d}"
            if name not in arrays:
                raise LibraryFormatError(path, f"/{name}", "required dataset missing")
            data[d] = arrays[name]
        for name, arr in arrays.items():
            if name.startswith(base + "/"):
                d = name[len(base) + 1 :]
                data[d] = arr
                if schema.A_COLUMNS in attrs[name]:
                    cols[d] = _names(attrs[name][schema.A_COLUMNS])
                    units[d] = _names(attrs[name].get(schema.A_UNITS, []))
        for d in (schema.D_STATE, schema.D_CONTROL):
            if d not in cols:
                raise LibraryFormatError(path, f"/{base}/{d}@{schema.A_COLUMNS}", "channel names missing")
            if len(cols[d]) != data[d].shape[-1]:
                raise LibraryFormatError(
                    path, f"/{base}/{d}@{schema.A_COLUMNS}", f"{len(cols[d])} names for {data[d].shape[-1]} columns"
                )
        out[key] = EntryRecord(
            key=key,
            attrs={
                k: (v.item() if isinstance(v, np.generic) else _str(v) if isinstance(v, bytes) else v)
                for k, v in eattrs.items()
            },
            arrays=data,
            columns=cols,
            units=units,
        )
    return out
