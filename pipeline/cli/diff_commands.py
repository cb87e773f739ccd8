"""The commands that compare and convert libraries: ``diff`` (``build --check`` shares its
comparison) and ``export``."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape
from skatelib.pipeline.cli.library_commands import LibArg
from skatelib.pipeline.cli.option_checks import MAX_ATOL, MAX_RTOL, exit_if_nothing_solved, finite
from skatelib.pipeline.views.console import json_text

AtolOpt = Annotated[float, typer.Option("--atol", min=0.0, max=MAX_ATOL, callback=finite,
                                        help="Absolute tolerance (in each channel's unit).")]
RtolOpt = Annotated[float, typer.Option("--rtol", min=0.0, max=MAX_RTOL, callback=finite, help="Relative tolerance.")]


def diff(
    a: LibArg,
    b: Annotated[Path, typer.Argument(help="The library to compare it with (.h5).")],
    atol: AtolOpt = 0.0,
    rtol: RtolOpt = 0.0,
    entry: Annotated[list[str] | None, typer.Option("--entry", "-e", help="Compare only this entry (repeatable).")
                     ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the comparison as one JSON document.")] = False,
) -> None:
    """What changed between two libraries: entries added, removed and changed (the largest deviation
    of each channel, with its unit and time), label-level figures, model, config keys and
    provenance. Exit 0 when equal within the tolerances (default: bit for bit), 1 when they differ,
    2 on bad usage (libraries of two kinds among it), 3 when a file is missing or damaged."""
    from skatelib.library.compare import KindsDiffer, Tolerance, compare
    from skatelib.library.reader import read_library
    from skatelib.pipeline.views.diff_view import show_diff

    A, B = read_library(a), read_library(b)
    if A.kind != B.kind:
        raise typer.BadParameter(str(KindsDiffer(A, B)), param_hint="B")
    known = set(A.entries) | set(B.entries)
    unknown = [k for k in entry or [] if k not in known]
    if unknown:
        raise typer.BadParameter(f"{', '.join(unknown)} is in neither library; entries: {', '.join(sorted(known))}",
                                 param_hint="--entry")
    d = compare(A, B, Tolerance(atol, rtol), entry)
    if as_json:
        print(json_text(d.as_dict()))
    else:
        show_diff(d)
    if not d.equal:
        raise typer.Exit(1)


class ExportFormat(enum.StrEnum):
    npz = "npz"
    csv = "csv"
    mcap = "mcap"


def export(
    library: LibArg,
    fmt: Annotated[ExportFormat, typer.Option("--format", "-f", help="npz or csv (a file per entry in the folder "
                                              "OUT), mcap (one ROS 2 bag, a file OUT ending in .mcap).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder (npz, csv) or file (mcap) to write.")],
) -> None:
    """Write a library in another tool's format: npz and csv per entry with column names and units;
    MCAP, a ROS 2 bag of the entries one after another (/robot_description, /tf, /joint_states,
    the board, every array) for Foxglove's 3D panel and ros2 bag play (pip install 'skatelib[export]')."""
    from skatelib.pipeline.build.preflight import check_folder, check_output
    from skatelib.pipeline.exports import export as write
    from skatelib.pipeline.views.console import console, count, left_out

    if fmt is ExportFormat.mcap:
        check_output(out, [library], what="mcap")
    else:
        check_folder(out)
    exit_if_nothing_solved(library, "export")
    from skatelib.runtime import MotionLibrary

    written = write(library, fmt.value, out)
    if written:
        more = " ..." if len(written) > 1 else ""
        console.print(escape(f"wrote {count(len(written), 'file')}: {written[0]}{more}"))
    left_out(MotionLibrary.open(library))


COMMANDS = (diff, export)
