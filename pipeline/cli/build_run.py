"""``skatelib build`` on the terminal: :func:`skatelib.build` (the Python API, which checks the
output and the options and runs the sweep) drawn as a progress bar from its entry events, the
kind's table, the notes and the file written."""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path
from typing import Any

from rich.markup import escape
from skatelib.library.errors import Interrupted
from skatelib.pipeline.build.contract import BuildOptions, BuildRun
from skatelib.pipeline.kinds import kind_of
from skatelib.pipeline.views.console import console, count
from skatelib.pipeline.views.progress import BuildBar, build_bar


def run_build(cfg: Any, out: Path, opts: BuildOptions, force: bool | None = None) -> BuildRun:
    """``skatelib build``: :func:`skatelib.build` (the output and the options checked, the sweep)
    with the progress bar, drawn once the checks pass, then the kind's table. ``force``: overwrite a
    file of another type.

    Raises:
        Interrupted: On Ctrl-C or SIGTERM (what is cached is kept; no library is written).
    """
    from skatelib.pipeline import api

    kind = kind_of(cfg)
    with ExitStack() as stack:
        bars: list[BuildBar] = []
        totals: list[int] = []

        def start(total: int) -> None:  # the output and the options are checked: nothing is printed before
            totals.append(total)
            console.print(f"building {count(total, 'entry')} of {escape(str(cfg.path))} -> {escape(str(out))}")
            kind.announce(cfg)
            bars.append(stack.enter_context(build_bar(total, opts.progress)))

        try:
            report = api.build(cfg, out, jobs=opts.jobs, progress=lambda event: bars[0](event), cache=opts.cache,
                               frontier=opts.frontier, backend="dask" if opts.backend == "dask" else "loky",
                               scheduler=opts.scheduler, force=bool(force), allow_large=opts.yes, on_start=start)
        except KeyboardInterrupt:
            done = f"{len(bars[0].done)} of {totals[0]}" if bars and totals else "0"
            kept = f"{done} entries are cached" if opts.cache else "nothing is cached (--no-cache)"
            raise Interrupted(f"interrupted: {kept}; no library was written. Run the same command to resume.") from None
    kind.summary(report.written)
    for o in report.outcomes:
        if o.note:
            console.print(f"[yellow]note:[/] {escape(o.note)}")
    console.print(f"wrote {escape(str(report.path))} in {report.wall_time_s:.1f} s")
    return BuildRun(report.path, len(report.failed))


def profiled_build(cfg: Any, out: Path, opts: BuildOptions, force: bool, profile: Path) -> BuildRun:
    """``build --profile``: the build with every process's spans recorded, written to ``profile``
    and printed by phase."""
    from skatelib.pipeline.build.profile import profiling, write_profile
    from skatelib.pipeline.views.console import phase_table

    with profiling() as spans:
        run = run_build(cfg, out, opts, force)
    rows, wall = write_profile(profile, spans, opts.jobs)
    phase_table(rows, wall, opts.jobs)
    console.print(escape(f"wrote the profile {profile}"))
    return run
