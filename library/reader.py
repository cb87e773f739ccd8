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
from skatelib.library.digest import verify_raw
from skatelib.library.errors import LibraryFormatError
from skatelib.library.records import EntryRecord, jsonable

_H5_ERRORS = (OSError, RuntimeError, KeyError, ValueError)  # what h5py raises on damaged files
_USERBLOCK_MAX = 1 << 16  # HDF5 looks for its signature at 0, 512, 1024, ... (a user block before it)


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


def _str(v: Any) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def check_version(path: Path, version: str) -> None:
    """Refuse other major versions (with what to do); warn on another minor version."""
    field = f"/@{schema.A_FORMAT_VERSION}"
    try:
        major, minor = (int(p) for p in version.split("."))
    except ValueError:
        raise LibraryFormatError(path, field, f"{version!r} is not 'major.minor'") from None
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
    if not path.is_file():
        raise LibraryFormatError(path, "/", "no such file; build one with 'skatelib build'")
    raw = path.read_bytes()
    digest = _verify_before_parsing(path, raw) if verify_checksum else None
    try:
        with h5py.File(path, "r") as f:  # the native driver reads faster than one over ``raw``
            _check_format(path, f)
            arrays = _read_groups(path, f, (schema.G_MODEL, schema.G_PACKED) if full else (schema.G_PACKED,))
            index_key = f"{schema.G_PACKED}/{schema.D_INDEX}"
            if index_key not in arrays:
                raise LibraryFormatError(path, f"/{index_key}", "required dataset missing")
            if verify_checksum:
                _check_checksum_attribute(path, f.attrs.get(schema.A_CHECKSUM), digest)
            index = _parse_index(path, arrays[index_key])
            if full:
                _check_against_index(path, f, index, arrays)
    except _H5_ERRORS as e:
        raise LibraryFormatError(
            path, "/", f"cannot be read as HDF5 (truncated or corrupt: {e}); rebuild it with 'skatelib build'"
        ) from e
    for arr in arrays.values():
        arr.setflags(write=False)
    root, model = index["root"], index["model"]
    kind = _check_root(path, root, model)
    model_arrays = {}
    for k, spec in index.get("model_arrays", {}).items():
        a = np.asarray(spec["data"], dtype=np.dtype(spec["dtype"])).reshape(spec["shape"])
        a.setflags(write=False)
        model_arrays[k] = a
    return LibraryData(
        path=path,
        attrs=root,
        model_attrs=model,
        model_arrays=model_arrays,
        model_text=dict(index.get("model_text", {})),
        entries=_entries(path, kind, index, arrays),
        content_sha256=digest,
    )


def _check_format(path: Path, f: h5py.File) -> None:
    """The file says it is a skatelib library of a version this reader reads."""
    fmt = f.attrs.get(schema.A_FORMAT)
    if fmt is None or _str(fmt) != schema.FORMAT_NAME:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT}", f"not a skatelib motion library (format={fmt!r})")
    version = f.attrs.get(schema.A_FORMAT_VERSION)
    if version is None:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT_VERSION}", "missing")
    check_version(path, _str(version))


def _read_groups(path: Path, f: h5py.File, groups: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Every dataset of the groups, as ``group/name`` -> array."""
    arrays: dict[str, np.ndarray] = {}
    for gname in groups:
        if gname not in f:
            raise LibraryFormatError(path, f"/{gname}", "required group missing")
        for name, obj in f[gname].items():
            if not isinstance(obj, h5py.Dataset):
                raise LibraryFormatError(path, f"/{gname}/{name}", "damaged or unexpected object; rebuild it")
            arrays[f"{gname}/{name}"] = obj[()]
    return arrays


def _check_checksum_attribute(path: Path, stored_sum: Any, digest: str | None) -> None:
    """The checksum attribute HDF5 reads is the one verified on the raw bytes."""
    if stored_sum is None:
        raise LibraryFormatError(path, f"/@{schema.A_CHECKSUM}", "required root attribute missing")
    field = stored_sum if isinstance(stored_sum, bytes) else str(stored_sum).encode()
    if field.decode(errors="replace") != digest:
        raise LibraryFormatError(
            path, f"/@{schema.A_CHECKSUM}", "the file does not match its checksum: it is corrupt; rebuild it"
        )


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


def _verify_before_parsing(path: Path, raw: bytes) -> str:
    """Refuse a damaged file before HDF5 parses any of it (see :mod:`skatelib.library.digest`);
    returns the verified digest."""
    found, digest = verify_raw(raw, schema.A_CHECKSUM.encode())
    if digest is not None:
        return digest
    field = f"/@{schema.A_CHECKSUM}"
    if found:
        raise LibraryFormatError(path, field, "the file does not match its checksum: it is corrupt; rebuild it")
    if not raw.startswith(schema.HDF5_SIGNATURE) and schema.HDF5_SIGNATURE not in raw[:_USERBLOCK_MAX]:
        raise LibraryFormatError(path, "/", "not an HDF5 file (truncated, corrupt or of another type); "
                                            "give a library written by 'skatelib build'")
    eof = _hdf5_end_of_file(raw)
    if eof is not None and eof > len(raw):
        raise LibraryFormatError(path, "/", f"truncated: {len(raw)} of its {eof} bytes are there; "
                                            "copy it again or rebuild it with 'skatelib build'")
    if schema.FORMAT_NAME.encode() not in raw:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT}",
                                 "not a skatelib motion library (an HDF5 file without its format name)")
    raise LibraryFormatError(path, field, "checksum attribute missing or damaged: the file is corrupt; rebuild it")


def _hdf5_end_of_file(raw: bytes) -> int | None:
    """The file length HDF5's superblock (at offset 0, 8-byte addresses) records, or None."""
    if not raw.startswith(schema.HDF5_SIGNATURE) or len(raw) < 64:
        return None
    version = raw[8]
    if version in (0, 1):
        if raw[13] != 8:  # size of offsets
            return None
        at = 24 + (4 if version == 1 else 0) + 16  # fixed fields, base and free-space addresses
    elif version in (2, 3):
        if raw[9] != 8:
            return None
        at = 12 + 16  # fixed fields, base and superblock-extension addresses
    else:
        return None
    return int.from_bytes(raw[at:at + 8], "little")


def _parse_index(path: Path, blob: np.ndarray) -> dict[str, Any]:
    field = f"/{schema.G_PACKED}/{schema.D_INDEX}"
    try:
        index = json.loads(blob.tobytes().decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise LibraryFormatError(path, field, f"index is not valid JSON ({e}); rebuild the library") from e
    for key in ("root", "model", "entries"):
        if key not in index:
            raise LibraryFormatError(path, field, f"index lacks {key!r}")
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
        if d not in meta["rows"] or f"{schema.G_PACKED}/{d}" not in arrays:
            raise LibraryFormatError(path, f"{base}/{d}", "required dataset missing")
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


def _same(a: Any, b: Any) -> bool:
    a, b = jsonable(a), jsonable(b)
    if isinstance(a, float) or isinstance(b, float):
        return bool(np.isclose(a, b, rtol=0, atol=0) or (np.isnan(a) and np.isnan(b)))
    return bool(a == b)


def _compare_attrs(path: Path, where: str, attrs: Any, expected: dict[str, Any], skip: tuple[str, ...] = ()) -> None:
    for k, v in attrs.items():
        if k in skip:
            continue
        if k not in expected or not _same(v, expected[k]):
            raise LibraryFormatError(path, f"{where}@{k}", "attribute differs from the checksummed index")


def _check_against_index(path: Path, f: h5py.File, index: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Every HDF5 attribute and per-entry view equals what the checksummed index says."""
    _compare_attrs(path, "/", f.attrs, index["root"], skip=(schema.A_CHECKSUM,))
    _compare_attrs(path, f"/{schema.G_MODEL}", f[schema.G_MODEL].attrs, index["model"])
    _check_model_datasets(path, index, arrays)
    for meta in index["entries"]:
        base = f"{schema.G_ENTRIES}/{meta['key']}"
        _compare_attrs(path, f"/{base}", f[base].attrs, meta["attrs"])
        for d, (a, b) in meta["rows"].items():
            view = f[f"{base}/{d}"]
            if not np.array_equal(view[()], arrays[f"{schema.G_PACKED}/{d}"][a:b]):
                raise LibraryFormatError(path, f"/{base}/{d}", "view differs from the packed data")
            for attr, expected in ((schema.A_COLUMNS, meta["columns"].get(d)), (schema.A_UNITS, meta["units"].get(d))):
                got = view.attrs.get(attr)
                if (got is None) != (expected is None) or (
                    got is not None and [_str(x) for x in got] != list(expected or [])
                ):
                    raise LibraryFormatError(path, f"/{base}/{d}@{attr}", "differs from the checksummed index")


def _check_model_datasets(path: Path, index: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """/model's datasets are exactly the index's model arrays and texts, with the same content."""
    mirrored = set(index.get("model_arrays", {})) | set(index.get("model_text", {}))
    stored = {k.split("/", 1)[1] for k in arrays if k.startswith(schema.G_MODEL + "/")}
    if mirrored != stored:
        raise LibraryFormatError(
            path, f"/{schema.G_MODEL}", f"datasets {sorted(stored ^ mirrored)} differ from the index"
        )
    for k, spec in index.get("model_arrays", {}).items():
        if not np.array_equal(
            arrays[f"{schema.G_MODEL}/{k}"],
            np.asarray(spec["data"], dtype=np.dtype(spec["dtype"])).reshape(spec["shape"]),
        ):
            raise LibraryFormatError(path, f"/{schema.G_MODEL}/{k}", "differs from the checksummed index")
    for k, text in index.get("model_text", {}).items():
        if arrays[f"{schema.G_MODEL}/{k}"].tobytes().decode() != text:
            raise LibraryFormatError(path, f"/{schema.G_MODEL}/{k}", "differs from the checksummed index")
