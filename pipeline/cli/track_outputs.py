"""What ``skatelib track`` writes beside its tables: a Rerun recording (``--save``) and an HTML
report (``--report``), their paths checked before any run."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.views.console import console


def report_checked(library: Path, report: Path | None, of_entries: bool = True) -> None:
    """A report's path checked before any run: an .html file that may be written, of entries' runs."""
    if report is None:
        return
    if not of_entries:
        raise SkatelibError("--report shows the entries' runs: leave out --ride and --maneuver steer")
    if report.suffix.lower() not in (".html", ".htm"):
        raise SkatelibError(f"{report}: a report is an HTML file: give a path ending in .html")
    from skatelib.pipeline.build.preflight import check_output

    check_output(report, [library], what="report")


def write_report(library: Path, report: Path | None, runs: list[tuple[Any, Any]], where: str, errors: str) -> None:
    """Write the report of ``runs`` (each verdict and its kept run) when one was asked for: ridden
    ``where``, under the --perturb text ``errors``."""
    if report is None:
        return
    from skatelib.pipeline.views.track_report import write_report
    from skatelib.runtime import MotionLibrary

    write_report(report, MotionLibrary.open(library), runs, f"skatelib track {where}, errors: {errors}", errors)
    console.print(escape(f"wrote {report}"))


def recording(library: Path, save: Path | None, writer: Callable[[], Any] | None = None) -> Any:
    """The recording's writer (``writer()``; by default ``save_closed_loop``) when a recording is
    asked for, its output checked before the runs; None when none is."""
    if save is None:
        return None
    if save.suffix.lower() != ".rrd":
        raise typer.BadParameter(f"{save}: a Rerun recording is written to a file ending in .rrd", param_hint="--save")
    from skatelib.pipeline.build.preflight import check_output

    try:
        save_runs = (writer or _closed_loop_writer)()
    except ImportError as e:
        raise ImportError(f"Rerun is not installed ({e}); pip install 'skatelib[viz]'") from e
    check_output(save, [library], what="recording")
    return save_runs


def _closed_loop_writer() -> Any:
    from skatelib.pipeline.views.rerun_inspect import save_closed_loop

    return save_closed_loop
