"""Add attributes to a finished library file: the file is read and verified, then written again
whole (atomically, with a new checksum); nothing else changes."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError
from skatelib.library.reader import read_library
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library


def amend_library(path: Path | str, root_attrs: Mapping[str, Any],
                  entry_attrs: Mapping[str, Mapping[str, Any]]) -> Path:
    """Set root attributes and per-entry attributes (``{key: {name: value}}``) of a library.

    Raises:
        LibraryFormatError: The file is damaged, or a key is not an entry of it.
    """
    data = read_library(path)
    for key in entry_attrs:
        if key not in data.entries:
            raise LibraryFormatError(path, f"/{schema.G_ENTRIES}/{key}", "no such entry")
    protected = {schema.A_FORMAT, schema.A_FORMAT_VERSION, schema.A_CHECKSUM}
    root = {k: v for k, v in data.attrs.items() if k not in protected} | dict(root_attrs)
    entries = [EntryRecord(key=r.key, attrs={**r.attrs, **entry_attrs.get(r.key, {})}, arrays=dict(r.arrays),
                         columns=dict(r.columns), units=dict(r.units)) for r in data.entries.values()]
    return write_library(path, root, data.model_attrs, data.model_arrays, data.model_text, entries)
