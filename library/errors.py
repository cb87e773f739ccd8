"""The exception hierarchy of skatelib: one root, subclasses that carry their context."""

from __future__ import annotations

from pathlib import Path
from typing import Any


class SkatelibError(Exception):
    """Root of every error skatelib raises on purpose."""


class ConfigError(SkatelibError):
    """A configuration file has a missing, unknown or out-of-range field.

    Attributes:
        path: The config file.
        key: Dotted key of the offending field (``"board.mass_kg"``).
        message: What is wrong and what to do.
    """

    def __init__(self, path: Path | str, key: str, message: str) -> None:
        self.path = Path(path)
        self.key = key
        self.message = message
        super().__init__(f"{self.path}: [{key}] {message}")


class ModelError(SkatelibError):
    """A robot description cannot be used (missing joint or frame, wrong joint type)."""


class SolveFailed(SkatelibError):
    """A trajectory optimization did not converge.

    Attributes:
        spec: The problem specification that was solved.
        status: The solver's return status (e.g. ``"Infeasible_Problem_Detected"``).
        stats: Solver statistics (iterations, times).
    """

    def __init__(self, spec: Any, status: str, stats: dict[str, Any] | None = None) -> None:
        self.spec = spec
        self.status = status
        self.stats = stats or {}
        super().__init__(f"solve failed with status {status!r} for {spec!r}")


class LibraryFormatError(SkatelibError):
    """A motion-library file is corrupt, truncated, of an unsupported version or incomplete.

    Attributes:
        path: The library file.
        field: The HDF5 path or attribute at fault (``"/entries/v0.50_s2/state"``).
        message: What is wrong and what to do.
    """

    def __init__(self, path: Path | str, field: str, message: str) -> None:
        self.path = Path(path)
        self.field = field
        self.message = message
        super().__init__(f"{self.path}: {field}: {message}")
