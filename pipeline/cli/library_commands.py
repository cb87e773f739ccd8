"""The commands that read a library: ``info``, ``validate``, ``inspect``, ``plot`` (``track`` is
in :mod:`.track_commands`), and the option types they share. Each parses its options, calls one
library function and prints."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.library.perturb import BOUNDS, DEFAULT_PLANT_PERTURBATION, DEFAULT_SENSOR_PERTURBATION, bounds_text
from skatelib.pipeline.cli.option_checks import MAX_JOBS, perturbation
from skatelib.pipeline.views.console import (
    console,
    count,
    json_text,
    left_out,
    mesh_note,
    viewer_hint,
)
from skatelib.pipeline.views.verdict_tables import track_table, twin_table

LibArg = Annotated[Path, typer.Argument(help="Motion library file (.h5).")]


class Maneuver(enum.StrEnum):
    entries = "entries"
    steer = "steer"


class PlantKind(enum.StrEnum):
    model = "model"
    mujoco = "mujoco"


class FigureFormat(enum.StrEnum):
    png = "png"
    svg = "svg"


class QpSolver(enum.StrEnum):
    """The MPC's QP backends (the names of ``skatelib.control.qp.SOLVERS``; a test holds them equal)."""

    daqp = "daqp"
    proxqp = "proxqp"
    osqp = "osqp"


def info(
    library: LibArg,
    wide: Annotated[bool, typer.Option("--wide", help="Full tables: provenance, the model's parameters, every "
                                                     "entry's figures, the stored verdicts' figures.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print all of it as one JSON document instead.")] = False,
) -> None:
    """Summarize a motion library: what it holds and one row per entry (fits 100 columns)."""
    from skatelib.pipeline.views.info_summary import library_summary
    from skatelib.pipeline.views.info_view import library_json, library_wide
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(library)  # verifies the checksum first
    if as_json:
        print(json_text(library_json(lib, library)))
    elif wide:
        library_wide(lib, library)
    else:
        library_summary(lib, library)


PerturbOpt = Annotated[str, typer.Option(
    help="Plant model error, KEY=VALUE,...: +10% or -20% relative to the planned figure; a plain number an "
         "absolute value in the key's unit, the same on both plants (mass=9.37 is a 9.37 kg robot): mass, "
         "board_mass (the whole board) [kg], kb [N m/rad], bb [N m s/rad], rolling [N at the planned weight], "
         "armature [kg m^2 per joint], motor [N m per commanded N m], the others in their ranges' units below; "
         "inertia takes a factor; impulse_t [s from the entry's start] before the run ends. Model plant: mass "
         "inertia board_mass kb bb rolling mu tanh com noise impulse impulse_t init; twin (--plant mujoco): mass "
         "mu kb bb rolling armature board_mass motor payload payload_x payload_y payload_z, with --state true "
         "noise delay (on the twin's own state), and on the estimate (track's default) the sensors' gyro_bias "
         "accel_bias imu_noise encoder_offset imu_tilt sensor_delay (omitted: "
         f"{DEFAULT_SENSOR_PERTURBATION}). 'none' for the plant as planned. Ranges (a factor of the planned "
         f"figure where one scales): {bounds_text(BOUNDS)}.", callback=perturbation)]
DEFAULT_PERTURB = DEFAULT_PLANT_PERTURBATION


def validate(
    library: LibArg,
    closed_loop: Annotated[bool, typer.Option(
        "--closed-loop", help="Also track every successful entry in closed loop (as `track`; on the twin fed the "
                              "twin's own state, as `track --state true`) and store each "
                              "verdict in the library (entry attribute closed_loop_json); the file must be "
                              "writable and keeps its permissions.")] = False,
    perturb: PerturbOpt = DEFAULT_PERTURB,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Entries tracked in parallel.")] = 2,
    as_json: Annotated[bool, typer.Option("--json", help="Print the verdicts as one JSON document instead.")] = False,
    plant: Annotated[PlantKind, typer.Option(
        help="With --closed-loop: model (the verdicts in closed_loop_json) or mujoco (the twin under the "
             "whole-body controller, in closed_loop_twin_json; a humanoid library's twin under its balance "
             "stabilizer, with the humanoid's --perturb keys: the only plant for it).")] = PlantKind.model,
) -> None:
    """Re-check a library's integrity (checksum, fields) and every entry's physics."""
    from skatelib.pipeline.api import validate as validate_api
    from skatelib.pipeline.validate import closed_loop_jobs, closed_loop_perturbation

    # the rides made (the file writable, --perturb parsed) before any check or ride
    rides = []
    if not closed_loop and (perturb != DEFAULT_PERTURB or plant is not PlantKind.model):
        raise typer.BadParameter("--perturb and --plant choose the closed-loop rides: add --closed-loop",
                                 param_hint="--perturb" if perturb != DEFAULT_PERTURB else "--plant")
    if closed_loop:
        from skatelib.sim.humanoid.errors import HumanoidPerturbationError

        perturb = closed_loop_perturbation(library, perturb, DEFAULT_PERTURB)
        try:
            rides = closed_loop_jobs(library, perturb, plant.value)
        except HumanoidPerturbationError as e:
            raise typer.BadParameter(str(e), param_hint="--perturb") from None

    def show(v: Any) -> None:
        if not as_json:
            console.print(escape(f"{v.key}: {v.message}"))

    report = validate_api(library, on_entry=show)
    problems, usable = report.failed, report.usable
    verdicts = [{"key": v.key, "status": v.status, "message": v.message, **v.figures} for v in report.entries]
    if not as_json:
        console.print(f"[bold red]{count(problems, 'entry')} (or junction between entries) failed validation[/]"
                      if problems
                      else _valid_line(report, library) if usable
                      else "[bold red]no entry of this library was solved: nothing in it can be used[/]")
    results, failed = _closed_loop(library, (perturb, rides), jobs, plant, as_json) if closed_loop else ([], 0)
    if as_json:
        doc = {"library": str(library), "valid": not problems and usable, "usable": usable, "entries": verdicts}
        if closed_loop:
            doc["closed_loop"] = {"plant": perturb, "simulator": plant.value, "failed": failed,
                                  "entries": [r.as_dict() for r in results]}
        print(json_text(doc))
    if problems or failed or not usable:
        raise typer.Exit(1)


def _valid_line(report: Any, library: Path) -> str:
    """The verdict of a library whose solved entries are all valid, counting those stored as failed
    (skipped: the build already said they failed; the library keeps them marked)."""
    from skatelib.runtime import MotionLibrary

    skipped = sum(v.status == "skipped" for v in report.entries)
    if not skipped:
        return "[green]all entries valid[/]"
    solved = len(MotionLibrary.open(library)) - skipped
    return (f"[green]{count(solved, 'solved entry')} valid[/]; "
            f"{count(skipped, 'entry')} stored as failed (skipped)")


def _closed_loop(library: Path, rides: tuple[str, list[Any]], jobs: int, plant: PlantKind,
                 as_json: bool) -> tuple[list[Any], int]:
    """``validate --closed-loop``: ``rides`` (the plant's name and the jobs) ridden, the verdicts
    stored and (unless ``as_json``) shown; returns them and how many failed."""
    from skatelib.pipeline.validate import closed_loop_verdicts

    perturb, calls = rides
    if plant is PlantKind.mujoco:
        mesh_note(library)
    results = closed_loop_verdicts(library, perturb, calls, jobs, plant.value)
    from skatelib.pipeline.cli.track_humanoid import is_humanoid
    from skatelib.pipeline.views.humanoid_table import humanoid_table

    table = (humanoid_table if is_humanoid(library) else twin_table if plant is PlantKind.mujoco
             else track_table)
    failed = sum(not r.passed for r in results) if as_json else table(results, perturb)
    if not as_json:
        console.print(escape(f"stored {len(results)} closed-loop verdicts in {library} ({failed} failed)"))
    return results, failed


def inspect(
    library: LibArg,
    entry: Annotated[list[str] | None,
                     typer.Option("--entry", "-e", help="Entry key (repeatable); all by default.")] = None,
    save: Annotated[Path | None, typer.Option(help="Write a Rerun recording (.rrd).")] = None,
    spawn: Annotated[bool, typer.Option(help="Open a Rerun viewer.")] = False,
    overlay: Annotated[bool, typer.Option(help="Overlay entries instead of side by side.")] = False,
    force: Annotated[bool, typer.Option(help="Overwrite --save even if it is not a Rerun recording.")] = False,
) -> None:
    """Look at trajectories in Rerun: robot, board, forces and plots, with a default layout."""
    from skatelib.pipeline.build.preflight import check_output

    try:
        from skatelib.pipeline.views.rerun_inspect import inspect_library
    except ImportError as e:
        raise ImportError(f"Rerun is not installed ({e}); pip install 'skatelib[viz]'") from e
    if save is None and not spawn:
        save = library.with_suffix(".rrd")
    if save is not None:
        check_output(save, [library], force, what="recording")
    mesh_note(library)
    roots = inspect_library(library, entry, save, spawn, overlay)
    where = escape(f" to {save}; {viewer_hint(save)}") if save else ""
    console.print(f"logged {count(len(roots), 'entry')}{where}")
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(library)
    failed = [k for k in (entry or [e.key for e in lib]) if not lib[k].success]
    if failed:
        console.print(escape(f"{count(len(failed), 'entry')} failed to solve and marked FAILED in its summary: "
                             f"{', '.join(failed)}"))


def plot(
    library: LibArg,
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder for the figures.")] = Path("out/figures"),
    frontier_file: Annotated[Path | None, typer.Option(
        "--frontier", help="A `skatelib frontier -o` file to draw (default: the library's stored frontier, if any).")
                             ] = None,
    fmt: Annotated[list[FigureFormat] | None, typer.Option(
        "--format", "-f", help="png and/or svg (repeatable); both by default.")] = None,
) -> None:
    """Figures of a library (matplotlib). Quadruped: board and momentum speed over time (the paper's
    Fig. 6), deck roll, the push foot's forces against the friction cone, the reachable-speed
    frontier. Humanoid: COM speed and height, COM and ZMP paths over the support polygons."""
    from skatelib.pipeline.build.preflight import check_folder
    from skatelib.pipeline.views.figures import FORMATS, NothingSolved, write_figures
    from skatelib.runtime import MotionLibrary

    check_folder(out)
    formats = tuple(f.value for f in fmt) if fmt else FORMATS
    try:
        written = write_figures(library, out, frontier_file, formats)
    except NothingSolved as e:
        console.print(f"[bold red]{escape(str(e))}[/]")
        raise typer.Exit(1) from e
    for p in written:
        console.print(escape(str(p)))
    left_out(MotionLibrary.open(library))


COMMANDS = (info, validate, inspect, plot)
