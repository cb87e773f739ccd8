"""What a benchmark reports: figures with their baseline and target as data, and the table of
``docs/benchmarks.md`` that ``make bench`` rewrites from them."""

from __future__ import annotations

import platform
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

TABLE = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
START, END = "<!-- bench:start -->", "<!-- bench:end -->"


@dataclass(frozen=True)
class Figure:
    """One figure a benchmark measures.

    Attributes:
        key: Short stable name (the table's row id).
        what: What is measured, for a reader.
        unit: Unit of the value (``s``, ``ms``, ``us``, ``x``).
        target: The value not to exceed (or, with ``at_least``, to reach).
        baseline: What the value is compared with, measured in the same run.
        at_least: The target is a lower bound (a speed-up).
    """

    key: str
    what: str
    unit: str
    target: float
    baseline: str
    at_least: bool = False


@dataclass(frozen=True)
class Measured:
    """A figure's value in one run, its baseline's value in the same run, and a note."""

    figure: Figure
    value: float
    baseline_value: float
    note: str = ""

    @property
    def met(self) -> bool:
        f = self.figure
        return self.value >= f.target if f.at_least else self.value <= f.target

    @property
    def ratio(self) -> float:
        """How many times better than the baseline: baseline over value for a time, value over
        baseline for a figure to reach (``at_least``)."""
        if self.figure.at_least:
            return self.value / self.baseline_value if self.baseline_value else float("nan")
        return self.baseline_value / self.value if self.value else float("nan")

    def row(self) -> str:
        f = self.figure
        sign = ">=" if f.at_least else "<="
        return (f"| {f.key} | {f.what} | {_num(self.value)} {f.unit} | {f.baseline}: {_num(self.baseline_value)} "
                f"{f.unit} ({self.ratio:.1f}x) | {sign} {_num(f.target)} {f.unit} | {'yes' if self.met else '**no**'} "
                f"| {self.note} |")

    def line(self) -> str:
        return (f"{self.figure.key:22s} {_num(self.value):>10s} {self.figure.unit:3s} baseline "
                f"{_num(self.baseline_value):>10s} ({self.ratio:5.1f}x)  target {_num(self.figure.target)}  "
                f"{'met' if self.met else 'NOT MET'}  {self.note}")


def _num(x: float) -> str:
    return f"{x:.3g}" if abs(x) < 1000 else f"{x:.0f}"


HEADER = ("| figure | what | measured | baseline in the same run | target | met | note |\n"
          "|---|---|---|---|---|---|---|")


def write_table(results: Sequence[Measured], path: Path = TABLE) -> None:
    """Rewrite the table in ``path`` between its markers: the rows of the figures measured now
    replace theirs, the others stay as they were."""
    text = path.read_text()
    if START not in text or END not in text:
        raise ValueError(f"{path}: no {START} ... {END} markers for the benchmark table")
    head, rest = text.split(START, 1)
    body, tail = rest.split(END, 1)
    rows = {m.group(1): line for line in body.splitlines() if (m := re.match(r"\| ([\w.-]+) \|", line))
            and m.group(1) != "figure"}
    for r in results:
        rows[r.figure.key] = r.row()
    machine = f"{platform.machine()}, {platform.python_implementation()} {platform.python_version()}"
    table = "\n".join([HEADER, *rows.values()])
    path.write_text(f"{head}{START}\nLast written by `make bench` on {machine}.\n\n{table}\n{END}{tail}")
