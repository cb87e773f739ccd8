"""``skatelib build`` on the terminal: the options checked, the sweep of
:func:`skatelib.pipeline.build.orchestrate.build_library` drawn as a progress bar from its entry
events, the kind's table, the notes and the file written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rich.markup import escape
from skatelib.library.errors import Interrupted
from skatelib.pipeline.build.contract import BuildOptions, BuildRun, EntryEvent
from skatelib.pipeline.build.orchestrate import build_library, check_options
from skatelib.pipeline.kinds import kind_of
from skatelib.pipeline.views.console import console, count


class _Progress:
    """The progress bar's text: the entries being solved and the last one finished."""

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



def run_build(cfg: Any, out: Path, opts: BuildOptions) -> BuildRun:
    """``skatelib build``: check the options, sweep with a progress bar, print the kind's table.

    Raises:
        Interrupted: On Ctrl-C or SIGTERM (what is cached is kept; no library is written).
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    kind = kind_of(cfg)
    check_options(cfg, opts)
    total = sum(t.n_entries for t in kind.tasks(cfg))
    console.print(f"building {count(total, 'entry')} of {escape(str(cfg.path))} -> {escape(str(out))}")
    kind.announce(cfg)
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("eta"), TimeRemainingColumn(), console=console, disable=not opts.progress) as bar:
        progress = _Progress(bar, bar.add_task("solving", total=total))
        try:
            report = build_library(cfg, out, opts, on_entry=progress)
        except KeyboardInterrupt:
            kept = (f"{len(progress.done)} of {total} entries are cached" if opts.cache
                    else "nothing is cached (--no-cache)")
            raise Interrupted(f"interrupted: {kept}; no library was written. Run the same command to resume.") from None
    kind.summary(report.written)
    for o in report.outcomes:
        if o.note:
            console.print(f"[yellow]note:[/] {escape(o.note)}")
    console.print(f"wrote {escape(str(report.path))} in {report.wall_time_s:.1f} s")
    return BuildRun(report.path, len(report.failed))
