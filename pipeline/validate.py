"""``skatelib validate``: integrity and physics of every entry of a library file."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from skatelib.library.reader import read_library
from skatelib.pipeline.kinds import kind_named
from skatelib.runtime import MotionLibrary

Report = Callable[[str, str, str, dict[str, float]], None]  # key, "ok" | "failed" | "skipped", message, figures


def validate_library(path: Path | str, report: Report) -> int:
    """Check the file (raises on a corrupt one) and each entry's physics; returns the failures.
    ``report`` gets each entry's key, verdict, message and the figures measured."""
    read_library(path, full=True)  # integrity: checksum, and every attribute and view against the index
    lib = MotionLibrary.open(path)
    return int(kind_named(lib.kind, lib.path).validate_entries(lib, report))
