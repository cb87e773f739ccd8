"""The closed-loop command ``track``: a library's entries (or the steering maneuver) on the model
plant or, with ``--plant mujoco``, on the physical twin under the whole-body controller."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.cli.library_commands import (
    DEFAULT_PERTURB,
    LibArg,
    Maneuver,
    PerturbOpt,
    PlantKind,
    QpSolver,
)
from skatelib.pipeline.cli.option_checks import MAX_JOBS, MAX_SEED, distinct, exit_if_nothing_solved, finite
from skatelib.pipeline.cli.track_draw import track_draw
from skatelib.pipeline.cli.track_humanoid import is_humanoid, track_humanoid
from skatelib.pipeline.cli.track_outputs import recording, report_checked, write_report
from skatelib.pipeline.cli.track_ride import track_ride
from skatelib.pipeline.track_setup import DEFAULT_TWIN_STATE, plant_errors, run_jobs
from skatelib.pipeline.views.console import (
    console,
    count,
    mesh_note,
    viewer_hint,
)
from skatelib.pipeline.views.verdict_tables import steer_table, track_table, twin_table

STATE_HELP = ("With --plant mujoco: what the controller is fed: estimate (the robot's estimator on the twin's IMU "
              "and joint encoders, as on the robot; the verdict adds its error) or true (the twin's own state). "
              "--draw rides on the certificate's own state; a humanoid's twin on its ankle sensors and IMU.")

REPORT_HELP = ("Write an HTML report (.html): per entry the plan against the closed loop (board speed, heading, deck "
               "roll, Coulomb margin) and the verdict with its reasons (either plant).")

DRAW_HELP = "With --plant mujoco and one --entry: ride a certificate's draw of this seed again (skatelib certify)."


class StateKind(enum.StrEnum):
    true = "true"
    estimate = "estimate"


DEFAULT_STATE = StateKind(DEFAULT_TWIN_STATE)


EntryOpt = Annotated[list[str] | None, typer.Option(
    "--entry", "-e", callback=distinct, help="Entry key (repeatable); all successful ones by default.")]


def track(
    library: LibArg,
    entry: EntryOpt = None,
    perturb: PerturbOpt = DEFAULT_PERTURB,
    solver: Annotated[QpSolver, typer.Option(help="QP solver: daqp or proxqp (condensed, dense), osqp (sparse).")
                      ] = QpSolver.daqp,
    mpc_mu: Annotated[float | None, typer.Option(
        help="Friction coefficient the MPC assumes (its 8-facet pyramid is inside it); default: the library's "
             "planning value friction_mu_plan.", min=0.05, max=2.0, callback=finite)] = None,
    seed: Annotated[int, typer.Option(min=0, max=MAX_SEED, help="Seed of the feedback noise.")] = 0,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Entries run in parallel.")] = 2,
    progress: Annotated[bool, typer.Option("--progress/--no-progress", help="Show a progress bar.")] = True,
    save: Annotated[Path | None, typer.Option(
        help="Write a Rerun recording (.rrd): each entry's reference beside its closed-loop run (either plant)."
    )] = None,
    maneuver: Annotated[Maneuver, typer.Option(
        help="entries: track the library's entries; steer: four-leg deck-roll tracking (0.1 rad, 3 s period, "
             "9 s) at rest and at 0.5 m/s.")] = Maneuver.entries,
    video: Annotated[Path | None, typer.Option(
        help="With --plant mujoco: render each run to OUT.mp4 or OUT.gif (several entries: OUT-<key>.mp4); "
             "MUJOCO_GL=egl renders without a display.")] = None,
    plant: Annotated[PlantKind, typer.Option(
        help="model: the single-rigid-body plant of the MPC's family (the legs by inverse kinematics); mujoco: "
             "the physical twin (skatelib.sim), the MPC over a 510 Hz whole-body controller.")] = PlantKind.model,
    ride: Annotated[str | None, typer.Option(
        help="Ride a chain of stages FROM:TO,... in m/s (e.g. 0:0.5,0.5:0.8,0.8:0.3,0.3:0), each by the "
             "library's entries (a route of several where no single one gets there), on either plant.")] = None,
    state: Annotated[StateKind, typer.Option(help=STATE_HELP)] = DEFAULT_STATE,
    draw: Annotated[int | None, typer.Option(min=0, max=MAX_SEED, help=DRAW_HELP)] = None,
    report: Annotated[Path | None, typer.Option(help=REPORT_HELP)] = None,
) -> None:
    """Closed loop: the paper's MPC (30 Hz) drives a plant with model error through each entry, the transfer
    and 1.5 s of riding (exit 1 if any fails): the model plant, the twin (--plant mujoco), a humanoid's twin."""
    if is_humanoid(library):
        quadruped_only = (ride is not None or maneuver is not Maneuver.entries or (report, draw, mpc_mu) != (None,) * 3
                          or state is not DEFAULT_STATE or solver is not QpSolver.daqp)
        return track_humanoid(library, entry, None if perturb == DEFAULT_PERTURB else perturb,
                              (plant is PlantKind.mujoco, quadruped_only), (jobs, progress, seed), (save, video))
    mpc, settings = _controller(solver, mpc_mu, seed, state, plant is PlantKind.mujoco)
    if draw is not None:
        refused = _given(save=save, report=report, ride=ride, maneuver=maneuver is not Maneuver.entries,
                         perturb=perturb != DEFAULT_PERTURB, seed=seed != 0, state=state is not DEFAULT_STATE)
        return track_draw(library, entry, draw, (plant is PlantKind.mujoco, video), (
            refused, _given(solver=solver is not QpSolver.daqp, mpc_mu=mpc_mu), mpc))
    plant_error = plant_errors(perturb, plant is PlantKind.mujoco, state.value)
    _library_checked(library, maneuver is Maneuver.entries and not entry, plant is PlantKind.mujoco,
                     (report, ride if maneuver is Maneuver.entries else "the steering maneuver"))
    if ride is not None:
        return track_ride(library, ride, (plant_error, perturb), (mpc, settings), (save, video),
                           (maneuver is Maneuver.entries and not entry, plant is PlantKind.mujoco))
    if maneuver is Maneuver.steer:
        return _track_steer(library, plant is PlantKind.mujoco, (plant_error, perturb), (mpc, settings), jobs,
                            _given(entry=entry, save=save, video=video))
    if plant is PlantKind.mujoco:
        return _track_twin(library, entry, plant_error, perturb, mpc, settings, (jobs, progress), (save, video, report))
    if video is not None:
        raise SkatelibError("--video renders runs on the twin: add --plant mujoco")
    return _track_model(library, entry, plant_error, perturb, mpc, settings, (jobs, progress), (save, report))


def _track_steer(library: Path, on_twin: bool, errors: tuple[str, str], controller: tuple[Any, Any], jobs: int,
                 given: list[str]) -> None:
    """The steering maneuver (four legs on the deck, at rest and at 0.5 m/s) on either plant; exit 1
    if it fails. ``given``: options of the entries' runs, refused (it rides its own two runs)."""
    if given:
        raise SkatelibError(f"the steering maneuver rides its own two runs (no entry of the library) and records "
                            f"none: leave out {', '.join(given)}")
    from skatelib.pipeline.build.sweep import run_calls

    (plant_error, perturb), (mpc, settings) = errors, controller
    calls: list[Any]
    if on_twin:
        from skatelib.proving.twin.track import twin_steer_jobs

        calls, title = twin_steer_jobs(library, (0.0, 0.5), plant_error, mpc, settings), (
            f"{perturb} (MuJoCo twin, whole-body controller)")
    else:
        from skatelib.proving.track import steer_jobs

        calls, title = steer_jobs(library, (0.0, 0.5), plant_error, mpc, settings), perturb
    if steer_table(run_calls(calls, jobs), title):
        raise typer.Exit(1)


def _given(**options: Any) -> list[str]:
    """The options given (a value, or True where a comparison with the default was made), as spelt."""
    return [f"--{name.replace('_', '-')}" for name, v in options.items() if v is not None and v is not False]


def _controller(solver: QpSolver, mpc_mu: float | None, seed: int, state: StateKind, on_twin: bool
                ) -> tuple[Any, Any]:
    """The MPC's and the run's settings (the controller's packages there, or the install hint); a
    ``--state`` other than the default is the twin's alone (the model plant feeds its own state)."""
    if state is not DEFAULT_STATE and not on_twin:
        raise typer.BadParameter("what the controller is fed is chosen on the twin: add --plant mujoco (the model "
                                 "plant feeds the controller its own state, with --perturb noise)",
                                 param_hint="--state")
    from skatelib.pipeline.track_setup import controller

    return controller(solver.value, mpc_mu, seed, state.value)


def _library_checked(library: Path, all_entries: bool, on_twin: bool, report: tuple[Path | None, str | None]
                     ) -> None:
    """Exit 1 when every entry is to be tracked and none was solved; on the twin, a note on mesh files;
    ``report``: the report's path, checked, and the ride or maneuver asked for (a report shows entries'
    runs)."""
    report_checked(library, report[0], report[1] is None)
    if all_entries:
        exit_if_nothing_solved(library, "track")
    if on_twin:
        mesh_note(library)


def _track_model(library: Path, entry: list[str] | None, plant_error: str, perturb: str, mpc: Any, settings: Any,
                 runner: tuple[int, bool], outputs: tuple[Path | None, Path | None]) -> None:
    """``runner``: parallel jobs, and whether to show progress; ``outputs``: a recording and a report."""
    from skatelib.proving.track import track_jobs

    jobs, progress = runner
    save, report = outputs
    save_closed_loop = recording(library, save)
    report_checked(library, report)
    runs = run_jobs(track_jobs(library, entry, plant_error, mpc, settings,
                               keep_runs=save is not None or report is not None), jobs, progress, "tracking")
    results = [r for r, _ in runs]
    if save is not None and save_closed_loop is not None:
        from skatelib.runtime import MotionLibrary

        save_closed_loop(MotionLibrary.open(library), [(r.key, run) for r, run in runs if run is not None], save)
        console.print(escape(f"wrote {save}; {viewer_hint(save)}"))
    failed = track_table(results, perturb)
    write_report(library, report, list(runs), "on the model plant", perturb)
    if failed:
        console.print(f"[bold red]{failed} of {count(len(results), 'entry')} failed in closed loop[/]")
        raise typer.Exit(1)


def _track_twin(library: Path, entry: list[str] | None, plant_error: str, perturb: str, mpc: Any, settings: Any,
                runner: tuple[int, bool], outputs: tuple[Path | None, Path | None, Path | None]) -> None:
    """``runner``: parallel jobs, and whether to show progress; ``outputs``: a recording, a video and a
    report."""
    jobs, progress = runner
    from skatelib.proving.twin.track import twin_jobs

    save, video, report = outputs
    save_closed_loop = recording(library, save)
    if video is not None:
        from skatelib.pipeline.build.preflight import check_output

        check_output(video, [library], what="video")
    report_checked(library, report)
    keep = save is not None or report is not None
    runs = run_jobs(twin_jobs(library, entry, plant_error, mpc, settings, (video, keep)), jobs, progress,
                    "riding on the twin")
    results = [r for r, _, _ in runs]
    for _, written, _ in runs:
        if written:
            console.print(escape(f"wrote {written}"))
    if save is not None and save_closed_loop is not None:
        from skatelib.runtime import MotionLibrary

        save_closed_loop(MotionLibrary.open(library), [(r.key, e) for r, _, e in runs if e is not None], save)
        console.print(escape(f"wrote {save}; {viewer_hint(save)}"))
    failed = twin_table(results, perturb)
    write_report(library, report, [(r, e) for r, _, e in runs], "on the MuJoCo twin", perturb)
    if failed:
        console.print(f"[bold red]{failed} of {count(len(results), 'entry')} failed on the twin[/]")
        raise typer.Exit(1)


COMMANDS = (track,)
