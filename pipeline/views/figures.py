"""Figures of a motion library with matplotlib (``skatelib plot``): what a paper or a review shows,
from the file alone. Each robot kind draws its own (its ``figures(lib, plt, frontier_file) -> {stem:
figure}``, from the ``plots`` module of its subpackage); here the shared parts and
the writer.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from skatelib.library.atomic import atomic_path
from skatelib.pipeline.kinds import kind_named
from skatelib.runtime import Entry, MotionLibrary

FORMATS = ("png", "svg")


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


def by_strides(lib: MotionLibrary) -> dict[int, list[Entry]]:
    groups: dict[int, list[Entry]] = {}
    for e in lib:
        groups.setdefault(e.n_strides, []).append(e)
    return dict(sorted(groups.items()))


def panels(plt: Any, n: int, title: str) -> tuple[Any, list[Any]]:
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.6 * n), sharex=True, squeeze=False, layout="constrained")
    fig.suptitle(title)
    return fig, list(axes[:, 0])


def write_figures(path: Path, out_dir: Path, frontier_file: Path | None = None,
                  formats: tuple[str, ...] = FORMATS) -> list[Path]:
    """Write the figures of the library at ``path`` into ``out_dir`` (each file atomically).

    Raises:
        SkatelibError: A frontier file that is not one, or one given for a kind without a frontier.
    """
    lib = MotionLibrary.open(path)
    kind = kind_named(lib.kind, lib.path)  # an unknown kind is refused, naming the known ones
    plt = _pyplot()
    figures = kind.figures(lib, plt, frontier_file)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, fig in figures.items():
        for fmt in formats:
            target = out_dir / f"{stem}.{fmt}"
            with atomic_path(target) as tmp:
                fig.savefig(tmp, format=fmt, dpi=110)
            written.append(target)
        plt.close(fig)
    return written


