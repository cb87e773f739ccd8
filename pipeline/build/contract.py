"""What a build passes between the generic machinery (sweep, cache, progress) and a robot kind:
the options, the tasks a kind cuts its build into, the outcome of each entry and its events."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol


@dataclass(frozen=True)
class BuildOptions:
    """How to run a build (``skatelib build``'s options), whatever the kind."""

    jobs: int = 2
    backend: str = "loky"
    scheduler: str | None = None
    progress: bool = True
    cache: bool = True
    frontier: bool = False
    yes: bool = False  # go on past the size bounds (skatelib.pipeline.build.size)


@dataclass(frozen=True)
class BuildRun:
    """What a build wrote and how many entries failed."""

    path: Path
    failed: int


@dataclass(frozen=True)
class EntryEvent:
    """What the progress display hears of an entry: it started (``done`` False) or finished, with
    its status. Small, so that no trajectory crosses the process boundary for it."""

    key: str
    done: bool
    status: str = ""
    success: bool = False
    cached: bool = False


ProgressFn = Callable[[EntryEvent], None]


class EventSink(Protocol):
    """Where a task reports its entries' events (a queue across processes, or a direct call)."""

    def put(self, event: EntryEvent) -> None: ...


class Outcome(Protocol):
    """A finished entry of any kind, as the sweep and the build see it."""

    @property
    def key(self) -> str: ...

    @property
    def success(self) -> bool: ...

    @property
    def cached(self) -> bool: ...

    @property
    def cache_key(self) -> str: ...

    @property
    def note(self) -> str: ...

    def event(self) -> EntryEvent: ...


class BuildTask(Protocol):
    """A picklable unit of a build: it solves ``n_entries`` entries in order and returns their
    outcomes, reporting each start and finish to ``events``."""

    @property
    def n_entries(self) -> int: ...

    def run(self, use_cache: bool, events: EventSink | None) -> Sequence[Outcome]: ...


@dataclass(frozen=True)
class Written:
    """What a kind's ``write`` produced: the file, the outcomes in the library's order and what
    else the kind found (the quadruped's frontier, when asked)."""

    path: Path
    outcomes: Sequence[Outcome]
    extra: Any = None
