"""Add attributes to a finished library file: the file is read and verified, then written again
whole (atomically, with a new checksum, keeping its permission bits); nothing else changes."""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.atomic import write_atomic
from skatelib.library.errors import LibraryFormatError, OutputError
from skatelib.library.reader import read_library
from skatelib.library.records import EntryRecord
from skatelib.library.writer import library_bytes

_ANY_WRITE = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH


def check_amendable(path: Path | str) -> int:
    """Refuse a library file that is not to be rewritten: one without a write bit for anyone (a file
    made read-only, which root could otherwise replace), one this user may not write, or one in a
    folder where its replacement cannot be made. Returns the file's permission bits.

    Raises:
        LibraryFormatError: No such file.
        OutputError: Naming the file, what stops the rewrite and what to do.
    """
    path = Path(path)
    if not path.is_file():
        raise LibraryFormatError(path, "/", "no such library file")
    mode = stat.S_IMODE(os.stat(path).st_mode)
    if not mode & _ANY_WRITE:
        raise OutputError(path, f"is read-only (mode {mode:04o}); skatelib leaves it as it is. Make it writable "
                                "(chmod u+w) or work on a copy")
    if not os.access(path, os.W_OK):
        raise OutputError(path, f"cannot be written by this user (mode {mode:04o}); work on a copy")
    folder = path.parent
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(path, f"its folder {folder} cannot be written, so the file cannot be replaced; "
                                "work on a copy elsewhere")
    return mode


def amend_library(path: Path | str, root_attrs: Mapping[str, Any],
                  entry_attrs: Mapping[str, Mapping[str, Any]]) -> Path:
    """Set root attributes and per-entry attributes (``{key: {name: value}}``) of a library; the
    file keeps its permission bits.

    Raises:
        LibraryFormatError: The file is damaged, or a key is not an entry of it.
        OutputError: The file is not to be rewritten (:func:`check_amendable`).
    """
    data = read_library(path)
    mode = check_amendable(path)
    for key in entry_attrs:
        if key not in data.entries:
            raise LibraryFormatError(path, f"/{schema.G_ENTRIES}/{key}", "no such entry")
    protected = {schema.A_FORMAT, schema.A_FORMAT_VERSION, schema.A_CHECKSUM}
    root = {k: v for k, v in data.attrs.items() if k not in protected} | dict(root_attrs)
    entries = [EntryRecord(key=r.key, attrs={**r.attrs, **entry_attrs.get(r.key, {})}, arrays=dict(r.arrays),
                         columns=dict(r.columns), units=dict(r.units)) for r in data.entries.values()]
    raw = library_bytes(root, data.model_attrs, data.model_arrays, data.model_text, entries)
    return write_atomic(Path(path), raw, mode)
