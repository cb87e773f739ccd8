"""Tables that fit the console without cutting a cell: each column as wide as its cells, narrowed
where the console is narrower down to its longest word (headers and texts wrap at spaces), and,
where even that is too wide, split into parts that each repeat the first column (the entry)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from rich.cells import cell_len
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text


@dataclass(frozen=True)
class Col:
    """A column: its header (the unit in brackets, ``"delivered [m/s]"``) and whether its cells are
    text (left-aligned, wrapped at spaces) rather than figures (right-aligned)."""

    head: str
    text: bool = False


def _col(c: str | Col) -> Col:
    return c if isinstance(c, Col) else Col(c)


def _plain(cell: str) -> str:
    """A cell's text as shown (its markup, such as ``[green]pass[/]``, removed)."""
    return Text.from_markup(cell).plain


def _natural(texts: Sequence[str]) -> int:
    """The width that shows every text on its lines unwrapped."""
    return max((cell_len(line) for t in texts for line in t.splitlines() or [""]), default=0)


def _narrowest(texts: Sequence[str]) -> int:
    """The width that shows every text wrapped at its spaces, no word broken."""
    return max((cell_len(w) for t in texts for w in t.split()), default=0)


def table_width(widths: Sequence[int]) -> int:
    """The width of a table (rich's default box and padding) whose columns hold ``widths``: one
    space either side of each cell and a rule between and around the columns."""
    return sum(widths) + 3 * len(widths) + 1


def _widths(natural: Sequence[int], narrowest: Sequence[int], width: int) -> list[int]:
    """Each column's width: the natural ones where they fit; else the narrowest, the room left given
    first to the columns that need least to be whole (more headers on one line)."""
    room = width - table_width(natural)
    if room >= 0:
        return list(natural)
    out = list(narrowest)
    room = width - table_width(out)
    for i in sorted(range(len(out)), key=lambda i: natural[i] - narrowest[i]):
        grant = max(0, min(natural[i] - out[i], room))
        out[i] += grant
        room -= grant
    return out


def _packed(narrowest: Sequence[int], width: int) -> list[list[int]]:
    """The columns in order, in parts that each start with column 0 and fit ``width`` at their
    narrowest, each part filled before the next (a column too wide alone gets a part of its own)."""
    parts: list[list[int]] = [[0]]
    for i in range(1, len(narrowest)):
        if len(parts[-1]) > 1 and table_width([narrowest[j] for j in [*parts[-1], i]]) > width:
            parts.append([0])
        parts[-1].append(i)
    return parts


def _parts(narrowest: Sequence[int], width: int) -> list[list[int]]:
    """As few parts as :func:`_packed` makes, as even as they go: each packed to the smallest width
    that still needs no more parts (no last part holding one column under a wrapped title)."""
    n = len(_packed(narrowest, width))
    low, high = 0, width  # the smallest width in (low, high] that packs into n parts
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if len(_packed(narrowest, mid)) <= n else (mid, high)
    return _packed(narrowest, high)


def fitted_tables(title: str, columns: Sequence[str | Col], rows: Sequence[Sequence[str]],
                  width: int) -> list[Table]:
    """The tables that show ``rows`` (cells in rich markup; headers plain) within ``width``
    columns: one when it fits, else parts titled "(part i of n)" that repeat the first column.

    Args:
        title: The table's title (plain text).
        columns: The headers (or :class:`Col`); the first column is the key, its cells never wrapped.
        rows: The cells, one sequence per row, as many as ``columns``.
        width: The console's width [characters].

    Returns:
        The tables to print in order.
    """
    cols = [_col(c) for c in columns]
    cells = [[_plain(r[i]) for r in rows] for i in range(len(cols))]
    natural = [max(cell_len(c.head), _natural(cs)) for c, cs in zip(cols, cells, strict=True)]
    narrowest = [max(_narrowest([cols[0].head]), _natural(cells[0]))]  # the keys whole on one line
    narrowest += [max(_narrowest([c.head]), _narrowest(cs)) for c, cs in zip(cols[1:], cells[1:], strict=True)]
    parts = _parts(narrowest, width) if table_width(natural) > width else [list(range(len(cols)))]
    tables = []
    for n, part in enumerate(parts, 1):
        name = title if len(parts) == 1 else f"{title} (part {n} of {len(parts)})"
        t = Table(title=escape(name))
        part_widths = _widths([natural[i] for i in part], [narrowest[i] for i in part], width)
        for i, w in zip(part, part_widths, strict=True):
            c = cols[i]
            t.add_column(escape(c.head), width=w, justify="left" if i == 0 or c.text else "right")
        for r in rows:
            t.add_row(*(r[i] for i in part))
        tables.append(t)
    return tables


def print_table(console: Console, title: str, columns: Sequence[str | Col], rows: Sequence[Sequence[str]],
                legend: str = "") -> None:
    """Print :func:`fitted_tables` at the console's width, then ``legend`` (plain text), if any."""
    for t in fitted_tables(title, columns, rows, console.width):
        console.print(t)
    if legend:
        console.print(escape(legend))
