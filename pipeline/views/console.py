"""What the commands print: the consoles (wide into a pipe) and the tables both robot kinds share."""

from __future__ import annotations

import json
import math
import os
import shlex
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.table import Table

PIPE_WIDTH = 260


def _console(stderr: bool = False) -> Console:
    """Rich's console; into a pipe or file (no terminal, no COLUMNS) 260 columns instead of rich's
    80, so that tables are not wrapped or their cells cut ("Solve_S...") in a log."""
    c = Console(stderr=stderr)
    if not c.is_terminal and "COLUMNS" not in os.environ:
        c = Console(stderr=stderr, width=PIPE_WIDTH)
    return c


console = _console()
err_console = _console(stderr=True)


def run_with_progress(jobs: Sequence[Callable[[], Any]], n_jobs: int, label: str, enabled: bool = True) -> list[Any]:
    """``sweep.run_calls`` with a progress bar (done / total, elapsed) unless ``enabled`` is False."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from skatelib.pipeline.build.sweep import run_calls

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console, disable=not enabled, transient=True) as bar:
        task = bar.add_task(label, total=len(jobs))
        return run_calls(jobs, n_jobs, lambda n: bar.update(task, completed=n))


def viewer_hint(save: Path) -> str:
    """How to open a recording: the viewer beside this Python (on PATH or not), paths quoted."""
    viewer = Path(sys.executable).parent / "rerun"
    return f"open it with: {shlex.quote(str(viewer))} {shlex.quote(str(save))}"


def left_out(lib: Any) -> None:
    """Say which entries a command left out because they are stored as failed (plot, export)."""
    failed = [e.key for e in lib if not e.success]
    if failed:
        console.print(escape(f"left out {count(len(failed), 'failed entry')} (stored with success = false): "
                             f"{', '.join(failed)}"))


def mesh_note(library: Path) -> None:
    """Say (on stderr) that a library's URDF names mesh files, which skatelib does not read: once, by
    the command that draws or builds the robot (inspect, the twin)."""
    from skatelib.library.urdf import mesh_files
    from skatelib.runtime import MotionLibrary

    names = mesh_files(MotionLibrary.open(library).urdf)
    if names:
        shown = ", ".join(repr(n) for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
        text = (f"the library's URDF names mesh files ({shown}); skatelib draws and builds the robot from its "
                "primitive shapes and reads no mesh file")
        err_console.print(f"[yellow]note:[/] {escape(text)}")


def count(n: int, noun: str) -> str:
    """'1 entry', '18 entries'."""
    plural = noun[:-1] + "ies" if noun.endswith("y") else noun + "s"
    return f"{n} {noun if n == 1 else plural}"


def fmt(figures: dict[str, Any], key: str, pattern: str) -> str:
    """A figure formatted, or "-" where it was not measured."""
    return pattern.format(figures[key]) if key in figures else "-"


def entry_table(title: str, columns: tuple[str, ...]) -> Table:
    """A table with one row per entry: the key and status columns stay whole in a narrow terminal
    (the numbers, right-aligned, give way)."""
    t = Table(title=title)
    for col in columns:
        if col in ("entry", "status"):
            t.add_column(escape(col), no_wrap=col == "entry", min_width=8 if col == "entry" else 6, overflow="fold")
        else:
            t.add_column(escape(col), justify="right")
    return t


def print_failures(results: list[Any], why: Callable[[Any], str]) -> int:
    """Print ``key: why`` for each failed result (``.key``, ``.passed``); returns how many failed."""
    failed = [r for r in results if not r.passed]
    for r in failed:
        console.print(escape(f"{r.key}: {why(r)}"))
    return len(failed)


def parameter_table(title: str, rows: list[tuple[str, Any]], number: str = "{:.4g}", head: str = "parameter") -> None:
    """Print a two-column table of named values (numbers as ``number``)."""
    t = Table(title=title)
    t.add_column(head)
    t.add_column("value", justify="right")
    for name, value in rows:
        t.add_row(escape(name), number.format(value) if isinstance(value, float) else escape(str(value)))
    console.print(t)


def frontier_table(points: list[Any]) -> None:
    """The reachable-speed frontier per search (start-ups, speed-ups from a speed, stops) and stride
    count."""
    t = Table(title="reachable-speed frontier: fastest label that converges and passes the physics checks "
                    "(a stop: the fastest speed it stops from)")
    for col in ("search", "strides", "fastest [m/s]", "first failure [m/s]", "what stops it", "probes"):
        t.add_column(escape(col), justify="left" if col in ("search", "what stops it") else "right")
    for p in points:
        fail = "-" if p.first_failure_mps is None else f"{p.first_failure_mps:.3f}"
        t.add_row(escape(p.lane.label), str(p.n_strides), f"{p.fastest_mps:.3f}", fail, escape(p.limit),
                  str(len(p.probes)))
    console.print(t)


def label_error(label: float, speed: float | None, digits: int = 1) -> str:
    """How far ``speed`` ends from its ``label`` in % of the label (a "[%]" column); "-" when there
    is no speed or the label is 0 (a stop: the speed it leaves is the speed column's)."""
    if speed is None or not label:
        return "-"
    return f"{100 * (speed - label) / label:+.{digits}f}"


def json_text(doc: Any) -> str:
    """``doc`` as strict JSON, which every parser reads: a number that is not finite (NaN, an
    infinity) as ``null`` (JSON has no other way to write it), numpy values as numbers and lists,
    anything else as its string."""
    return json.dumps(_strict(doc), indent=1, allow_nan=False)


def _strict(v: Any) -> Any:
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {str(k): _strict(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_strict(x) for x in v]
    if v is None or isinstance(v, (str, int)):
        return v
    return _strict(v.tolist()) if hasattr(v, "tolist") else str(v)


def phase_table(rows: list[Any], wall_s: float, jobs: int) -> None:
    """Print a build profile's phases (:class:`skatelib.pipeline.build.profile.PhaseRow`): seconds of
    one process each, their share of the build's process time (``jobs`` workers x the wall time)."""
    t = Table(title=f"where the build's time went: {wall_s:.1f} s wall, {count(jobs, 'worker')}")
    for col in ("phase", "seconds", "share", "spans", "what"):
        t.add_column(col, justify="right" if col in ("seconds", "share", "spans") else "left")
    total = max(jobs, 1) * wall_s
    for r in rows:
        t.add_row(escape(r.phase), f"{r.seconds:.1f}", f"{100 * r.seconds / total:.0f} %" if total else "-",
                  str(r.count) if r.count else "", escape(r.note))
    console.print(t)
