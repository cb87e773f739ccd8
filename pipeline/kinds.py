"""The robot kinds: what every kind provides (:class:`RobotKind`) and the table of kinds.

Every command goes through this table (``load_config``, ``kind_of(config)``,
``kind_named(lib.kind)``, ``build``, ``validate``, ``inspect``, ``plot``), so a third robot is a
new subpackage whose ``kind`` module defines ``KIND``, an object with the operations below (a
:class:`SubpackageKind` over its modules), and one row of :data:`KINDS`; the command line does
not change. Both kinds name their modules alike:
``config`` (the config class, ``from_toml``, ``from_json``), ``kind`` (``KIND``), ``builder``
(its part of the build), ``tasks`` (``BuildTask``, ``EntryOutcome``), ``verify`` (the independent
checks and ``judge``; the quadruped's in ``checks.verify``), ``entries`` (the library it writes),
``rerun`` and ``plots`` (its views).

A kind's modules are imported when a command needs them: ``skatelib --help`` imports no solver.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from skatelib.library.errors import LibraryFormatError

if TYPE_CHECKING:
    from skatelib.pipeline.build.contract import BuildOptions, BuildTask, Outcome, Written
    from skatelib.runtime import MotionLibrary

ReportFn = Callable[[str, str, str, dict[str, float]], None]
"""``report(key, verdict, message, figures)``: one validated entry (verdict ok, failed or skipped)."""


class KindConfig(Protocol):
    """What the generic code reads of any kind's config."""

    @property
    def path(self) -> Path: ...

    @property
    def meta(self) -> Any: ...

    @property
    def sweep(self) -> Any: ...

    def resolved_json(self) -> str: ...


class RobotKind(Protocol):
    """The operations every robot kind provides."""

    name: str
    config_class: type

    def from_toml(self, path: Path, data: dict[str, Any], text: str) -> Any:
        """The validated config of a TOML file (``data`` parsed from ``text``)."""

    def from_json(self, data: dict[str, Any], origin: Path, urdf: Path | None) -> Any:
        """The config a library stored (its resolved JSON), with the stored robot description."""

    def print_model(self, cfg: Any) -> None:
        """What ``skatelib model`` shows of a config."""

    def validate_entries(self, lib: MotionLibrary, report: ReportFn) -> int:
        """The independent checks of every entry of a library; returns the failures."""

    def check(self, cfg: Any, opts: BuildOptions) -> None:
        """Refuse build options the kind cannot honour, before anything runs."""

    def announce(self, cfg: Any) -> None:
        """What the user should know before the solves start."""

    def tasks(self, cfg: Any, ipopt: tuple[tuple[str, Any], ...] = ()) -> Sequence[BuildTask]:
        """The build cut into picklable tasks."""

    def prepare(self, cfg: Any, opts: BuildOptions) -> None:
        """Ready what the workers share (in the build's process)."""

    def write(self, cfg: Any, out: Path, outcomes: Sequence[Outcome], opts: BuildOptions) -> Written:
        """Write the library of the finished outcomes."""

    def summary(self, written: Written) -> None:
        """Print the build's table."""

    def rerun_panels(self) -> list[tuple[str, str]]:
        """The plots of an entry's tab in ``skatelib inspect``: (title, channel)."""

    def rerun_logger(self, lib: MotionLibrary) -> Any:
        """The function that draws one entry into a Rerun recording."""

    def figures(self, lib: MotionLibrary, plt: Any, frontier_file: Path | None) -> dict[str, Any]:
        """``skatelib plot``'s figures: {file stem: matplotlib figure}."""


@dataclass(frozen=True)
class SubpackageKind:
    """A robot kind whose parts are the modules of one subpackage (``config``, ``builder``,
    ``rerun``, ``plots``), imported when an operation needs them, with its model summary and its
    library checks as functions."""

    name: str
    config_class: type
    package: str
    print_model_fn: Callable[[Any], None]
    validate_fn: Callable[[MotionLibrary, ReportFn], int]

    def _part(self, module: str) -> Any:
        return importlib.import_module(f"{self.package}.{module}")

    def from_toml(self, path: Path, data: dict[str, Any], text: str) -> Any:
        return self._part("config").from_toml(path, data, text)

    def from_json(self, data: dict[str, Any], origin: Path, urdf: Path | None) -> Any:
        return self._part("config").from_json(data, origin, urdf)

    def print_model(self, cfg: Any) -> None:
        self.print_model_fn(cfg)

    def validate_entries(self, lib: MotionLibrary, report: ReportFn) -> int:
        return self.validate_fn(lib, report)

    def check(self, cfg: Any, opts: BuildOptions) -> None:
        self._part("builder").check(cfg, opts)

    def announce(self, cfg: Any) -> None:
        self._part("builder").announce(cfg)

    def tasks(self, cfg: Any, ipopt: tuple[tuple[str, Any], ...] = ()) -> Sequence[BuildTask]:
        tasks: Sequence[BuildTask] = self._part("builder").tasks(cfg, ipopt)
        return tasks

    def prepare(self, cfg: Any, opts: BuildOptions) -> None:
        self._part("builder").prepare(cfg, opts)

    def write(self, cfg: Any, out: Path, outcomes: Sequence[Outcome], opts: BuildOptions) -> Written:
        written: Written = self._part("builder").write(cfg, out, outcomes, opts)
        return written

    def summary(self, written: Written) -> None:
        self._part("builder").summary(written)

    def rerun_panels(self) -> list[tuple[str, str]]:
        return list(self._part("rerun").PANELS)

    def rerun_logger(self, lib: MotionLibrary) -> Any:
        return self._part("rerun").logger(lib)

    def figures(self, lib: MotionLibrary, plt: Any, frontier_file: Path | None) -> dict[str, Any]:
        figures: dict[str, Any] = self._part("plots").figures(lib, plt, frontier_file)
        return figures


@dataclass(frozen=True)
class KindRow:
    """One row of the table: a kind's name and the module that defines its ``KIND``."""

    name: str
    module: str

    def load(self) -> RobotKind:
        kind: RobotKind = importlib.import_module(self.module).KIND
        return kind


KINDS: dict[str, KindRow] = {row.name: row for row in (
    KindRow("quadruped", "skatelib.pipeline.quadruped.kind"),
    KindRow("humanoid", "skatelib.pipeline.humanoid.kind"),
)}


def check_library_kind(name: str, origin: Path | None = None) -> None:
    """Refuse a library whose ``kind`` is not in the table.

    Raises:
        LibraryFormatError: ``name`` is no kind of the table (in the file at ``origin``).
    """
    if name not in KINDS:
        raise LibraryFormatError(origin or Path("?"), "/@kind", f"{name!r} is not one of {', '.join(KINDS)}")


def kind_named(name: str, origin: Path | None = None) -> RobotKind:
    """The kind of ``name`` (a library's ``kind`` attribute or a config's ``meta.kind``).

    Raises:
        LibraryFormatError: An unknown kind in the file at ``origin``.
    """
    check_library_kind(name, origin)
    return KINDS[name].load()


def kind_of(config: KindConfig) -> RobotKind:
    """The kind of a loaded config."""
    return kind_named(config.meta.kind, config.path)
