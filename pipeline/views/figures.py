"""Figures of a motion library with matplotlib (``skatelib plot``): what a paper or a review shows,
from the file alone. Each robot kind draws its own (its ``figures(lib, plt, frontier_file) -> {stem:
figure}``, from the ``plots`` module of its subpackage); here the shared parts and
the writer.
"""

from __future__ import annotations

import io
import shutil
from pathlib import Path
from typing import Any

from skatelib.library.atomic import atomic_folder, no_room
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.kinds import kind_named
from skatelib.runtime import Entry, MotionLibrary

FORMATS = ("png", "svg")


class NothingSolved(SkatelibError):
    """A library none of whose entries was solved: there is nothing to draw or track."""

    def __init__(self, path: Path) -> None:
        self.path = path
        super().__init__(f"{path}: no entry of this library was solved (every one is stored with success = false); "
                         "nothing in it can be drawn. See `skatelib info` for their statuses")


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")  # files only, no display
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise ImportError("skatelib plot needs matplotlib: pip install 'skatelib[plot]'") from e
    return plt


def library_name(lib: MotionLibrary) -> str:
    return str(lib.attrs.get("name", lib.path.stem))


def solved(lib: MotionLibrary) -> list[Entry]:
    """The entries the figures draw: those solved (a failed entry's trajectory is no motion to show)."""
    return [e for e in lib if e.success]


def by_panel(lib: MotionLibrary) -> dict[str, list[Entry]]:
    """The solved entries per panel: start-ups by stride count, then transitions by start speed."""
    groups: dict[str, list[Entry]] = {}
    for n, entries in by_strides(lib, starts_only=True).items():
        groups[f"start-ups, {n} stride{'s' if n != 1 else ''}"] = entries
    for e in sorted((e for e in solved(lib) if e.from_velocity_mps), key=lambda e: e.from_velocity_mps):
        groups.setdefault(f"transitions from {e.from_velocity_mps:.2f} m/s", []).append(e)
    return groups


def panel_label(e: Entry) -> str:
    """An entry's line label in a panel of :func:`by_panel`."""
    if e.from_velocity_mps:
        return f"to {e.target_velocity_mps:.2f} m/s, {e.n_strides} stride{'s' if e.n_strides != 1 else ''}"
    return f"{e.target_velocity_mps:.2f} m/s"


def by_strides(lib: MotionLibrary, starts_only: bool = False) -> dict[int, list[Entry]]:
    groups: dict[int, list[Entry]] = {}
    for e in solved(lib):
        if not (starts_only and e.from_velocity_mps):
            groups.setdefault(e.n_strides, []).append(e)
    return dict(sorted(groups.items()))


def panels(plt: Any, n: int, title: str) -> tuple[Any, list[Any]]:
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.6 * n), sharex=True, squeeze=False, layout="constrained")
    fig.suptitle(title)
    return fig, list(axes[:, 0])


def write_figures(path: Path, out_dir: Path, frontier_file: Path | None = None,
                  formats: tuple[str, ...] = FORMATS) -> list[Path]:
    """Write the figures of the library at ``path`` into ``out_dir``, all or none: they are drawn
    in memory, written into a temporary folder and moved into place only when every one is written
    (:func:`skatelib.library.atomic.atomic_folder`: a failure leaves no folder it made).

    Raises:
        SkatelibError: A frontier file that is not one, or one given for a kind without a frontier;
            a library with no solved entry.
        OutputError: No room for the figures (nothing written, old figures untouched).
    """
    lib = MotionLibrary.open(path)
    kind = kind_named(lib.kind, lib.path)  # an unknown kind is refused, naming the known ones
    if not solved(lib):
        raise NothingSolved(lib.path)
    plt = _pyplot()
    drawn: dict[str, bytes] = {}
    for stem, fig in kind.figures(lib, plt, frontier_file).items():
        for fmt in formats:
            buffer = io.BytesIO()
            fig.savefig(buffer, format=fmt, dpi=110)
            drawn[f"{stem}.{fmt}"] = buffer.getvalue()
        plt.close(fig)
    needed = sum(len(b) for b in drawn.values())
    nearest = next(p for p in (out_dir, *out_dir.parents) if p.exists())
    if shutil.disk_usage(nearest).free < needed:
        raise no_room(out_dir, needed)
    with atomic_folder(out_dir) as staging:
        for name, data in drawn.items():
            (staging / name).write_bytes(data)
    return [out_dir / name for name in drawn]
