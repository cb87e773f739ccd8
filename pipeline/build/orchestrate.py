"""``skatelib build`` for every robot kind: config -> the kind's tasks -> parallel sweep (cache,
progress) -> verified, atomically written motion library.

The kind (:class:`skatelib.pipeline.kinds.RobotKind`) supplies what differs: ``check(cfg, opts)``
refuses its own options before anything runs, ``announce(cfg)``, ``tasks(cfg, ipopt)`` cuts the
build into picklable tasks (:class:`skatelib.pipeline.build.contract.BuildTask`), ``prepare(cfg,
opts)`` readies what the workers share, ``write(cfg, out, outcomes, opts)`` writes the library and
``summary(written)`` prints its table. The sweep, the entry cache, the progress bar, interruption
and the exit code are the same for every kind.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.markup import escape
from skatelib.library.errors import Interrupted, SkatelibError
from skatelib.pipeline.build.contract import BuildOptions, BuildRun, EntryEvent, Outcome, ProgressFn, Written
from skatelib.pipeline.build.sweep import run_sweep
from skatelib.pipeline.kinds import KindConfig, kind_of
from skatelib.pipeline.views.console import console, count


@dataclass(frozen=True)
class BuildReport:
    """What a build produced: what the kind wrote (the file, its entries' outcomes in the library's
    order and what else it found: the quadruped's frontier, when asked) and the wall time."""

    written: Written
    wall_time_s: float

    @property
    def path(self) -> Path:
        return self.written.path

    @property
    def outcomes(self) -> Sequence[Outcome]:
        return self.written.outcomes

    @property
    def frontier(self) -> Any:
        return self.written.extra

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if not o.success]


def default_output(config: KindConfig) -> Path:
    return Path("out") / f"{config.meta.name}.h5"


def build_library(config: Any, out: Path | None = None, options: BuildOptions | None = None,
                  on_entry: ProgressFn | None = None, ipopt: tuple[tuple[str, Any], ...] = ()) -> BuildReport:
    """Solve every entry of ``config.sweep`` and write the library (failed entries included,
    marked ``success = false`` with their status). ``ipopt``: extra IPOPT options of every solve
    (the quadruped's; ``(("print_level", 5),)`` shows its log)."""
    t0 = time.perf_counter()
    out = out or default_output(config)
    options = options or BuildOptions()
    kind = kind_of(config)
    kind.prepare(config, options)
    outcomes = run_sweep(kind.tasks(config, ipopt), options, on_entry)
    written: Written = kind.write(config, out, outcomes, options)
    return BuildReport(written, time.perf_counter() - t0)


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


def check_options(cfg: Any, opts: BuildOptions) -> None:
    """Refuse options that cannot work before anything runs: a dask backend without a reachable
    scheduler, an unwritable cache folder, and what the kind's ``check`` refuses."""
    from skatelib.pipeline.build.preflight import check_cache_dir, check_scheduler

    if opts.backend == "dask":
        if opts.scheduler is None:
            raise SkatelibError("--backend dask needs --scheduler tcp://HOST:PORT")
        check_scheduler(opts.scheduler)
    if opts.cache:
        check_cache_dir()
    kind_of(cfg).check(cfg, opts)


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
