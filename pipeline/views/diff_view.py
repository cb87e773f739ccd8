"""``skatelib diff`` and ``build --check`` on the console: what was added, removed and changed,
each changed entry's largest deviations of each array (with units and times), its label-level
figures, the solver's effort, the model, the config's differing keys and the provenance."""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from skatelib.library.compare import ChannelChange, EntryChange, LibraryDiff, ValueChange
from skatelib.pipeline.views.console import console, count, entry_table

CHANNELS_SHOWN = 6  # values tables: the first; the rest counted
PER_ARRAY = 3  # per entry and array, its largest deviations (metres are not compared with newtons)
# The label-level figures shown first (the rest counted; --json has all): outcome, the speed it
# rides at, Coulomb's margin, the torque with the legs' mass, the re-integration defect, the verdicts.
HEADLINE = ("success", "status", "physics.momentum_speed_mps", "physics.min_friction_margin_N",
            "physics.max_torque_rigid_legs_Nm", "physics.max_defect", "closed_loop.passed", "closed_loop.delivered_mps",
            "closed_loop_twin.passed", "closed_loop_twin.delivered_mps", "physics.max_com_error_m")


def _v(x: Any) -> str:
    """A value for a table: numbers to 6 digits, text whole (a status names every failed check),
    anything else (a list) cut to 60 characters."""
    if isinstance(x, float):
        return f"{x:.6g}"
    s = str(x)
    return s if isinstance(x, str) or len(s) <= 60 else s[:57] + "..."


def _gap(a: Any, b: Any) -> str:
    """``|a - b|`` of two numbers (what 6 digits may not show), else empty."""
    numbers = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b))
    return f"{abs(float(a) - float(b)):.3g}" if numbers else ""


def _values(title: str, changes: tuple[ValueChange, ...], first: tuple[str, ...] = ()) -> None:
    """A table of changed values; with ``first``, those named in it alone and the others counted
    (none of them changed: the first few others)."""
    if not changes:
        return
    shown = [c for c in changes if c.name in first] if first else list(changes)
    if not shown:
        shown = list(changes[:CHANNELS_SHOWN])
    shown.sort(key=lambda c: first.index(c.name) if c.name in first else 0)
    t = entry_table(title, ("name", "a", "b", "|a - b|"))
    for c in shown:
        t.add_row(escape(c.name), escape(_v(c.a)), escape(_v(c.b)), _gap(c.a, c.b))
    if len(shown) < len(changes):
        t.add_row(f"(and {len(changes) - len(shown)} more: --json lists them)", "", "", "")
    console.print(t)


def _channels(e: EntryChange) -> None:
    """The entry's largest deviations, the :data:`PER_ARRAY` largest of each array (a force's
    newtons and a position's metres are not ranked against each other)."""
    if not e.channels:
        return
    t = entry_table(f"{e.key}: {count(len(e.channels), 'channel')} differ", (
        "array", "column", "unit", "max |a - b|", "at t [s]", "a", "b"))
    arrays: dict[str, list[ChannelChange]] = {}
    for c in e.channels:
        arrays.setdefault(c.array, []).append(c)
    shown = 0
    for changes in arrays.values():
        for c in sorted(changes, key=lambda c: -c.max_abs)[:PER_ARRAY]:
            t.add_row(c.array, escape(c.column), escape(c.unit), f"{c.max_abs:.3g}",
                      "-" if c.at_s is None else f"{c.at_s:.3f}", f"{c.a:.6g}", f"{c.b:.6g}")
            shown += 1
    if shown < len(e.channels):
        t.add_row("", f"(and {len(e.channels) - shown} more: --json lists them)", "", "", "", "", "")
    console.print(t)


def show_diff(d: LibraryDiff) -> None:
    """Print a comparison; the verdict last."""
    tol = d.tolerance
    console.print(escape(f"a: {d.a}\nb: {d.b}\ntolerance: |a - b| <= {tol.atol:g} + {tol.rtol:g} |b|"))
    if d.added:
        console.print(escape(f"added in b: {', '.join(d.added)}"))
    if d.removed:
        console.print(escape(f"removed in b: {', '.join(d.removed)}"))
    for e in d.changed:
        if e.differs:
            _channels(e)
            _values(f"{e.key}: arrays of another shape, columns or units", e.shapes)
            _values(f"{e.key}: outcome and figures", e.figures, HEADLINE)
        _values(f"{e.key}: solver effort (not counted)", e.effort)
    _values("model", d.model)
    _values("config (resolved; not counted: the entries show what it changed)", d.config)
    _values("provenance and other attributes (not counted)", d.provenance)
    _values("robustness certificate (not counted)", d.certificate)
    differing = [e.key for e in d.changed if e.differs]
    if d.equal:
        console.print(f"[green]equal[/]: {count(d.same, 'entry')} within the tolerance")
    else:
        parts = [f"{count(len(differing), 'entry')} changed ({', '.join(differing)})" if differing else "",
                 f"{len(d.added)} added" if d.added else "", f"{len(d.removed)} removed" if d.removed else "",
                 "the model changed" if d.model else ""]
        console.print(f"[bold red]differ[/]: {escape('; '.join(p for p in parts if p))}; {d.same} the same")
