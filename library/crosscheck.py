"""The full read of ``skatelib validate``: every HDF5 attribute and per-entry view of a library
agrees with its checksummed index (the default read takes everything from the index alone)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError
from skatelib.library.records import jsonable, text

# The file's own checksum holds, so its tree was changed after it was written.
CHANGED = "the file was changed after it was written; rebuild it with 'skatelib build'"


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
            raise LibraryFormatError(path, f"{where}@{k}", f"attribute differs from the checksummed index: {CHANGED}")
    for k in sorted(expected.keys() - attrs.keys()):
        raise LibraryFormatError(path, f"{where}@{k}", f"attribute missing, which the checksummed index has: {CHANGED}")


def _node(path: Path, f: h5py.File, name: str) -> Any:
    """The group or dataset ``name``, or the error naming it."""
    if name not in f:
        raise LibraryFormatError(path, f"/{name}", f"missing, which the checksummed index has: {CHANGED}")
    return f[name]


def check_against_index(path: Path, f: h5py.File, index: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """Every HDF5 attribute and per-entry view equals what the checksummed index says."""
    _compare_attrs(path, "/", f.attrs, index["root"], skip=(schema.A_CHECKSUM,))
    _compare_attrs(path, f"/{schema.G_MODEL}", _node(path, f, schema.G_MODEL).attrs, index["model"])
    _check_model_datasets(path, index, arrays)
    for meta in index["entries"]:
        base = f"{schema.G_ENTRIES}/{meta['key']}"
        _compare_attrs(path, f"/{base}", _node(path, f, base).attrs, meta["attrs"])
        for d, (a, b) in meta["rows"].items():
            view = _node(path, f, f"{base}/{d}")
            packed = arrays.get(f"{schema.G_PACKED}/{d}")
            if packed is None:
                raise LibraryFormatError(path, f"/{schema.G_PACKED}/{d}", f"missing, which the index names: {CHANGED}")
            if not np.array_equal(view[()], packed[a:b]):
                raise LibraryFormatError(path, f"/{base}/{d}", f"view differs from the packed data: {CHANGED}")
            for attr, expected in ((schema.A_COLUMNS, meta["columns"].get(d)), (schema.A_UNITS, meta["units"].get(d))):
                got = view.attrs.get(attr)
                if (got is None) != (expected is None) or (
                    got is not None and [text(x) for x in got] != list(expected or [])
                ):
                    raise LibraryFormatError(path, f"/{base}/{d}@{attr}",
                                             f"differs from the checksummed index: {CHANGED}")


def _check_model_datasets(path: Path, index: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
    """/model's datasets are exactly the index's model arrays and texts, with the same content."""
    mirrored = set(index.get("model_arrays", {})) | set(index.get("model_text", {}))
    stored = {k.split("/", 1)[1] for k in arrays if k.startswith(schema.G_MODEL + "/")}
    if mirrored != stored:
        raise LibraryFormatError(
            path, f"/{schema.G_MODEL}", f"datasets {sorted(stored ^ mirrored)} differ from the index: {CHANGED}"
        )
    for k, spec in index.get("model_arrays", {}).items():
        if not np.array_equal(
            arrays[f"{schema.G_MODEL}/{k}"],
            np.asarray(spec["data"], dtype=np.dtype(spec["dtype"])).reshape(spec["shape"]),
        ):
            raise LibraryFormatError(path, f"/{schema.G_MODEL}/{k}", f"differs from the checksummed index: {CHANGED}")
    for k, stored_text in index.get("model_text", {}).items():
        if arrays[f"{schema.G_MODEL}/{k}"].tobytes().decode() != stored_text:
            raise LibraryFormatError(path, f"/{schema.G_MODEL}/{k}", f"differs from the checksummed index: {CHANGED}")
