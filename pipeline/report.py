"""What the commands print: the consoles (wide into a pipe) and the tables both robot kinds share."""

from __future__ import annotations

import os
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


def parameter_table(title: str, rows: list[tuple[str, Any]], number: str = "{:.4g}", head: str = "parameter") -> None:
    """Print a two-column table of named values (numbers as ``number``)."""
    t = Table(title=title)
    t.add_column(head)
    t.add_column("value", justify="right")
    for name, value in rows:
        t.add_row(escape(name), number.format(value) if isinstance(value, float) else escape(str(value)))
    console.print(t)


def frontier_table(points: list[Any]) -> None:
    """The reachable-speed frontier per stride count."""
    t = Table(title="reachable-speed frontier: fastest label that converges and passes the physics checks")
    for col in ("strides", "fastest [m/s]", "first failure [m/s]", "what stops it", "probes"):
        t.add_column(escape(col), justify="left" if col == "what stops it" else "right")
    for p in points:
        fail = "-" if p.first_failure_mps is None else f"{p.first_failure_mps:.3f}"
        t.add_row(str(p.n_strides), f"{p.fastest_mps:.3f}", fail, escape(p.limit), str(len(p.probes)))
    console.print(t)
