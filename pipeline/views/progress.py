"""A build's progress bar on the terminal (rich), drawn from its entries' events: the command line
and the Python API (``skatelib.build(..., progress=True)``) draw the same."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rich.markup import escape
from skatelib.pipeline.build.contract import EntryEvent, ProgressFn
from skatelib.pipeline.views.console import console


class BuildBar:
    """A build's progress bar: the entries being solved and the last one finished. Call it with each
    :class:`~skatelib.pipeline.build.contract.EntryEvent`; ``done`` lists the finished entries' keys."""

    def __init__(self, bar: Any, task: Any):
        self.bar, self.task = bar, task
        self.done: list[str] = []
        self.flying: list[str] = []  # oldest first

    def __call__(self, event: EntryEvent) -> None:
        if not event.done:
            self.flying.append(event.key)
        else:
            self.done.append(event.key)
            if event.key in self.flying:
                self.flying.remove(event.key)
        text = f"solving {', '.join(self.flying)}" if self.flying else "solving"
        if event.done:
            status = "ok" if event.success else event.status.split(":")[0]
            text += f" (last: {event.key} {'cached, ' if event.cached else ''}{status})"
        self.bar.update(self.task, advance=1 if event.done else 0, description=escape(text))


@contextmanager
def build_bar(total: int, enabled: bool = True) -> Iterator[BuildBar]:
    """A build's bar of ``total`` entries (done / total, elapsed, time left) on the console; drawn
    only when ``enabled``, though its ``done`` list fills either way."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("eta"), TimeRemainingColumn(), console=console, disable=not enabled) as bar:
        yield BuildBar(bar, bar.add_task("solving", total=total))


__all__ = ["BuildBar", "ProgressFn", "build_bar"]
