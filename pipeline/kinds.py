"""The robot kinds: one row per kind, naming the robot's subpackage.

Every command goes through this table (``load_config``, ``kind_of(config)``,
``kind_named(lib.kind)``, ``build``, ``inspect``, ``plot``), so a third robot is a new subpackage
with the modules below and one row here; the command line does not change. Its modules:

* ``config``: ``CONFIG_CLASS``, ``from_toml`` and ``from_json`` (read by ``pipeline/config.py``);
* ``kind``: ``CONFIG_CLASS``, ``print_model(cfg)`` (what ``skatelib model`` shows) and
  ``validate_entries(lib, report) -> int`` (the independent checks of every entry; failures);
* ``builder``: its part of the one build path (``pipeline/build.py``): ``check``, ``announce``,
  ``tasks``, ``prepare``, ``write``, ``summary``;
* ``rerun`` (imported by ``inspect`` only): ``PANELS`` (the plots of an entry's tab) and
  ``logger(lib)`` (draws one entry);
* ``plots`` (imported by ``plot`` only): ``figures(lib, plt, frontier_file) -> {stem: figure}``.

The modules are imported when a command needs them: ``skatelib --help`` imports no solver.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from skatelib.library.errors import LibraryFormatError

# meta.kind (and a library's kind attribute) -> the robot's subpackage
KINDS: dict[str, str] = {
    "quadruped": "skatelib.pipeline.quadruped",
    "humanoid": "skatelib.pipeline.humanoid",
}


def part(name: str, module: str) -> ModuleType:
    """A module of a known kind's subpackage (``config``, ``kind``, ``builder``, ``rerun``, ``plots``),
    imported when asked."""
    return importlib.import_module(f"{KINDS[name]}.{module}")


def check_library_kind(name: str, origin: Path | None = None) -> None:
    """Refuse a library whose ``kind`` is not in the table.

    Raises:
        LibraryFormatError: ``name`` is no kind of the table (in the file at ``origin``).
    """
    if name not in KINDS:
        raise LibraryFormatError(origin or Path("?"), "/@kind", f"{name!r} is not one of {', '.join(KINDS)}")


@dataclass(frozen=True)
class BuildOptions:
    """How to run a build (``skatelib build``'s options), whatever the kind."""

    jobs: int = 2
    backend: str = "loky"
    scheduler: str | None = None
    progress: bool = True
    cache: bool = True
    frontier: bool = False


@dataclass(frozen=True)
class BuildRun:
    """What a build wrote and how many entries failed."""

    path: Path
    failed: int


def kind_named(name: str, origin: Path | None = None) -> ModuleType:
    """The kind module of ``name`` (a library's ``kind`` attribute or a config's ``meta.kind``).

    Raises:
        LibraryFormatError: An unknown kind in the file at ``origin``.
    """
    check_library_kind(name, origin)
    return part(name, "kind")


def kind_of(config: Any) -> ModuleType:
    """The kind module of a loaded config."""
    return kind_named(config.meta.kind, config.path)
