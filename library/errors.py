"""The exception hierarchy of skatelib: one root, subclasses that carry their context."""

from __future__ import annotations

from pathlib import Path


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

    def __reduce__(self) -> tuple[type, tuple[Path, str, str]]:
        return type(self), (self.path, self.key, self.message)  # whole across processes (a worker's error)


class ModelError(SkatelibError):
    """A robot description cannot be used (missing joint or frame, wrong joint type)."""


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

    def __reduce__(self) -> tuple[type, tuple[Path, str, str]]:
        return type(self), (self.path, self.field, self.message)


class OutputError(SkatelibError):
    """An output path cannot or must not be written (a directory, the input itself, a foreign file,
    an unwritable folder); raised before any work starts.

    Attributes:
        path: The output path.
        message: What is wrong and what to do.
    """

    def __init__(self, path: Path | str, message: str) -> None:
        self.path = Path(path)
        self.message = message
        super().__init__(f"{self.path}: {message}")

    def __reduce__(self) -> tuple[type, tuple[Path, str]]:
        return type(self), (self.path, self.message)


class Interrupted(SkatelibError):
    """The user (Ctrl-C) or the system (SIGTERM) stopped a command; finished work is kept."""


# Exit codes of the ``skatelib`` command (README "Exit codes").
EXIT_FAILED = 1  # entries failed to solve or validate
EXIT_USAGE = 2  # bad usage, config or output path
EXIT_LIBRARY = 3  # a library file is missing, corrupt, incomplete or of another major version
EXIT_DEPENDENCY = 4  # an optional package is missing (install the extra named in the message)
EXIT_INTERRUPTED = 130  # Ctrl-C or SIGTERM


def exit_code(error: BaseException) -> int:
    """The documented exit code for an error that reached the command line."""
    if isinstance(error, Interrupted):
        return EXIT_INTERRUPTED
    if isinstance(error, LibraryFormatError):
        return EXIT_LIBRARY
    if isinstance(error, ImportError):
        return EXIT_DEPENDENCY
    return EXIT_USAGE
