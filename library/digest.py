"""Read a whole HDF5 file into memory and fingerprint it (SHA-256 of datasets and attributes).

Writer and reader use the same two functions, so a library's ``content_sha256`` root attribute
catches any change of a byte of data or metadata (h5py alone reads a zeroed block back silently).
"""

from __future__ import annotations

import hashlib
from typing import Any

import h5py
import numpy as np
from skatelib.library import schema


def read_all(f: h5py.File) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
    """Every dataset (by path) and every object's attributes (by path; root is ``""``)."""
    arrays: dict[str, np.ndarray] = {}
    attrs: dict[str, dict[str, Any]] = {"": dict(f.attrs)}

    def visit(name: str, obj: Any) -> None:
        attrs[name] = dict(obj.attrs)
        if isinstance(obj, h5py.Dataset):
            arrays[name] = obj[()]

    f.visititems(visit)
    return arrays, attrs


def _canonical(value: Any) -> bytes:
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "OSU":
            return repr([v.decode() if isinstance(v, bytes) else str(v) for v in value.reshape(-1)]).encode()
        return value.dtype.str.encode() + str(value.shape).encode() + np.ascontiguousarray(value).tobytes()
    if isinstance(value, bytes):
        return value
    if isinstance(value, np.generic):
        return repr(value.item()).encode()
    return repr(value).encode()


def digest(arrays: dict[str, np.ndarray], attrs: dict[str, dict[str, Any]]) -> str:
    """SHA-256 over sorted dataset paths and bytes, then sorted attributes (the checksum excluded)."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        h.update(name.encode() + b"\0" + _canonical(np.asarray(arrays[name])))
    for name in sorted(attrs):
        for key in sorted(attrs[name]):
            if name == "" and key == schema.A_CHECKSUM:
                continue
            h.update(f"{name}@{key}".encode() + b"\0" + _canonical(attrs[name][key]))
    return h.hexdigest()
