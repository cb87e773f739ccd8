"""The ``skatelib`` command line. Each command parses, calls one library function and prints."""

from __future__ import annotations

import enum
import json
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from rich.table import Table
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.config import field_range
from skatelib.pipeline.quadruped.config import SweepConfig
from skatelib.pipeline.report import console, count, entry_table, err_console, fmt, frontier_table

app = typer.Typer(add_completion=True, no_args_is_help=True, rich_markup_mode=None,
                  help="Offline motion-library pipeline for legged robots on skateboards.")


def _jsonable(v: Any) -> Any:
    """numpy scalars and arrays as JSON numbers and lists."""
    return v.tolist() if hasattr(v, "tolist") else str(v)


def _print_version(value: bool) -> None:
    if value:
        from importlib import metadata

        console.print(f"skatelib {metadata.version('skatelib')}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """Offline motion-library pipeline for legged robots on skateboards.

    Exit codes: 0 ok, 1 entries failed, 2 usage/config/output error, 3 bad library file,
    4 missing optional package, 130 interrupted. Add --debug for a traceback instead of a message.
    """


class Backend(enum.StrEnum):
    """Where build workers run."""

    loky = "loky"
    dask = "dask"


VELOCITY_RANGE = field_range(SweepConfig, "velocities_mps")  # one range, defined with the config

ConfigArg = Annotated[Path | None, typer.Argument(help="Build config (TOML); the shipped default when omitted.")]


@app.command()
def model(config: ConfigArg = None) -> None:
    """Print the robot and board model of a config: SRB mass and inertia from the URDF, board
    figures; for a humanoid config, its point-mass model and the LIP/DCM time constant."""
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.kinds import kind_of

    cfg = load_config(config)
    kind_of(cfg).print_model(cfg)


OutOpt = Annotated[Path | None, typer.Option(
    "-o", "--out", help="Library file to write (.h5).", show_default="out/<config's meta.name>.h5")]


@app.command()
def build(
    config: ConfigArg = None,
    out: OutOpt = None,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, help="Worker processes (loky backend).")] = 2,
    backend: Annotated[Backend, typer.Option(help="loky: worker processes on this machine; dask: a cluster.")
                       ] = Backend.loky,
    scheduler: Annotated[str | None, typer.Option(help="Dask scheduler address, tcp://HOST:PORT.")] = None,
    progress: Annotated[bool, typer.Option("--progress/--no-progress", help="Show a progress bar.")] = True,
    allow_failures: Annotated[bool, typer.Option(help="Exit 0 even when entries failed.")] = False,
    cache: Annotated[bool, typer.Option("--cache/--no-cache", help="Reuse finished entries (resume).")] = True,
    frontier: Annotated[bool, typer.Option(
        "--frontier", help="Also search the reachable-speed frontier of every stride count and store it.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an output file that is not a skatelib library.")
                     ] = False,
) -> None:
    """Build a motion library: sweep target speeds x stride counts through the push-off TO
    (quadruped configs) or walking/skating step velocities through the GPM (humanoid configs)."""
    from skatelib.pipeline.build import default_output
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.kinds import BuildOptions, kind_of
    from skatelib.pipeline.preflight import check_output

    cfg = load_config(config)
    target = out or default_output(cfg)
    check_output(target, [cfg.path], force)
    run = kind_of(cfg).run_build(cfg, target, BuildOptions(jobs, backend.value, scheduler, progress, cache, frontier))
    if run.failed and not allow_failures:
        console.print(f"[bold red]{count(run.failed, 'entry')} failed[/] (kept in the file with success=false); "
                      "rerun with --allow-failures to accept")
        raise typer.Exit(1)


@app.command()
def frontier(
    config: ConfigArg = None,
    strides: Annotated[list[int] | None, typer.Option("--strides", "-s", help="Stride counts (repeatable); "
                                                      "default: the config's sweep.")] = None,
    start: Annotated[float, typer.Option(min=0.05, max=3.0, help="First speed tried [m/s].")] = 0.5,
    step: Annotated[float, typer.Option(min=0.01, max=1.0, help="Climbing step [m/s].")] = 0.25,
    resolution: Annotated[float, typer.Option(min=0.001, max=0.5, help="Bisection resolution [m/s].")] = 0.02,
    max_speed: Annotated[float, typer.Option(min=0.05, max=3.0, help="Highest speed tried [m/s].")] = 3.0,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, help="Worker processes.")] = 2,
    out: Annotated[Path | None, typer.Option("-o", "--out", help="Also write the frontier as JSON.")] = None,
) -> None:
    """Find, per stride count, the fastest label that converges and passes the physics checks
    (warm-started climb, then bisection)."""
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.frontier import FrontierSearch, find_frontier, frontier_json

    cfg = load_config(config, QuadrupedConfig)
    search = FrontierSearch(start_mps=start, step_mps=step, resolution_mps=resolution, max_mps=max_speed)
    points = find_frontier(cfg, strides or cfg.sweep.strides, search, jobs)
    frontier_table(points)
    if out is not None:
        from skatelib.library.atomic import atomic_path

        with atomic_path(out) as tmp:
            tmp.write_text(frontier_json(points, search))
        console.print(f"wrote {escape(str(out))}")


@app.command()
def solve(
    velocity: Annotated[float, typer.Option("--velocity", "-V", min=VELOCITY_RANGE[0], max=VELOCITY_RANGE[1],
                                            help="Target board speed, m/s (the range of sweep.velocities_mps).")],
    strides: Annotated[int, typer.Option("--strides", "-s", min=1, max=20, help="Number of push strides.")],
    out: Annotated[Path | None, typer.Option(
        "-o", "--out", help="One-entry library to write (.h5).",
        show_default="out/<config's meta.name>-v<velocity>_s<strides>.h5")] = None,
    config: ConfigArg = None,
    config_option: Annotated[Path | None, typer.Option("--config", help="The same, as an option.")] = None,
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Print IPOPT's iteration log.")] = False,
) -> None:
    """Solve one push-off and write it as a one-entry motion library."""
    from skatelib.pipeline.build import build_library
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.kinds import BuildOptions
    from skatelib.pipeline.preflight import check_output
    from skatelib.pipeline.quadruped.config import QuadrupedConfig

    if config is not None and config_option is not None and config != config_option:
        raise typer.BadParameter(f"two configs given ({config} and --config {config_option}); give one")
    cfg = load_config(config or config_option, QuadrupedConfig)
    from skatelib.library.schema import entry_key

    out = out or Path("out") / f"{cfg.meta.name}-{entry_key(velocity, strides)}.h5"
    check_output(out, [cfg.path])
    cfg = replace(cfg, sweep=replace(cfg.sweep, velocities_mps=(velocity,), strides=(strides,)))
    report = build_library(cfg, out, BuildOptions(jobs=1, cache=False), ipopt=(("print_level", 5),) if verbose else ())
    from skatelib.pipeline.quadruped.kind import summary

    summary(report.outcomes)
    console.print(f"wrote {escape(str(report.path))}")
    if report.failed:
        raise typer.Exit(1)


LibArg = Annotated[Path, typer.Argument(help="Motion library file (.h5).")]


class Maneuver(enum.StrEnum):
    entries = "entries"
    steer = "steer"


class FigureFormat(enum.StrEnum):
    png = "png"
    svg = "svg"


class QpSolver(enum.StrEnum):
    """The MPC's QP solvers (``skatelib.control.mpc.SOLVERS``)."""

    daqp = "daqp"
    proxqp = "proxqp"
    osqp = "osqp"


@app.command()
def info(
    library: LibArg,
    as_json: Annotated[bool, typer.Option("--json", help="Print it as one JSON document instead.")] = False,
) -> None:
    """Summarize a motion library: provenance, model and entries."""
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(library)  # verifies the checksum first
    a = lib.attrs
    sha = lib.content_sha256
    if as_json:
        entries = [{"key": e.key, "target_velocity_mps": e.target_velocity_mps, "n_strides": e.n_strides,
                    "success": e.success, "status": str(e.attrs["status"]), "iterations": int(e.attrs["iterations"]),
                    "knots": len(e.t), "duration_s": e.duration_s, "solve_time_s": e.attrs.get("solve_time_s"),
                    "physics": json.loads(str(e.attrs.get("physics_json", "{}")))} for e in lib]
        provenance = {k: a[k] for k in ("name", "format_version", "skatelib_version", "created_utc", "git_commit",
                                        "git_dirty", "casadi_version", "ipopt_version", "pinocchio_version")
                      if k in a}
        print(json.dumps({"library": str(library), "kind": lib.kind, **provenance, "content_sha256": sha,
                          "model": dict(lib.model),
                          "entries": entries}, indent=1, default=_jsonable))
        return
    console.print(escape(f"{library}: {a.get('name', '?')} ({lib.kind}), format {a['format_version']}, "
                         f"skatelib {a['skatelib_version']}, created {a['created_utc']}"))
    console.print(escape(f"git {a['git_commit'][:12]}{' (dirty)' if a['git_dirty'] else ''}; casadi "
                         f"{a['casadi_version']}, ipopt {a['ipopt_version']}, pinocchio {a['pinocchio_version']}"))
    console.print(escape(f"content sha256 {sha}"))
    m = Table(title="model")
    m.add_column("parameter")
    m.add_column("value", justify="right")
    for k, v in sorted(lib.model.items()):
        if not str(k).endswith("_source"):
            m.add_row(escape(str(k)), escape(f"{v:.6g}" if isinstance(v, float) else str(v)))
    console.print(m)
    t = entry_table(count(len(lib), "entry"), ("entry", "v [m/s]", "strides", "success", "status", "iter", "knots",
                                                "duration [s]", "solve [s]", "momentum [m/s]", "off label",
                                                "Coulomb margin [N]", "defect"))
    for e in lib:
        ph = json.loads(str(e.attrs.get("physics_json", "{}")))
        off = (f"{(ph['momentum_speed_mps'] - e.target_velocity_mps) / e.target_velocity_mps:+.2%}"
               if "momentum_speed_mps" in ph and e.target_velocity_mps else "-")
        t.add_row(e.key, f"{e.target_velocity_mps:.2f}", str(e.n_strides), str(e.success),
                  escape(str(e.attrs["status"])),
                  str(e.attrs["iterations"]), str(len(e.t)), f"{e.duration_s:.2f}",
                  fmt(e.attrs, "solve_time_s", "{:.2f}"), fmt(ph, "momentum_speed_mps", "{:.3f}"),
                  off, fmt(ph, "min_friction_margin_N", "{:.3f}"),
                  fmt(ph, "max_defect", "{:.1e}"))
    console.print(t)


PerturbOpt = Annotated[str, typer.Option(
    help="Plant model error, KEY=VALUE,... (+10% relative, 0.5 absolute; keys mass inertia board_mass "
         "kb bb rolling mu com noise impulse impulse_t init). 'none' for the exact model.")]
DEFAULT_PERTURB = "mass=+10%,kb=-20%,rolling=+100%,mu=0.5"


@app.command()
def validate(
    library: LibArg,
    closed_loop: Annotated[bool, typer.Option(
        "--closed-loop", help="Also track every successful entry in closed loop (as `track`) and store each "
                              "verdict in the library (entry attribute closed_loop_json).")] = False,
    perturb: PerturbOpt = DEFAULT_PERTURB,
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Entries tracked in parallel.")] = 2,
    as_json: Annotated[bool, typer.Option("--json", help="Print the verdicts as one JSON document instead.")] = False,
) -> None:
    """Re-check a library's integrity (checksum, fields) and every entry's physics."""
    from skatelib.pipeline.validate import validate_library

    verdicts: list[dict[str, Any]] = []

    def report(key: str, status: str, message: str, figures: dict[str, float]) -> None:
        verdicts.append({"key": key, "status": status, "message": message, **figures})
        if not as_json:
            console.print(escape(f"{key}: {message}"))

    problems = validate_library(library, report)
    if not as_json:
        console.print(f"[bold red]{count(problems, 'entry')} failed validation[/]" if problems
                      else "[green]all entries valid[/]")
    failed = 0
    results: list[Any] = []
    if closed_loop:
        import datetime

        from skatelib.library.amend import amend_library

        try:
            from skatelib.control.track import track_library
        except ImportError as e:
            raise ImportError(f"the controller's packages are missing ({e}); pip install 'skatelib[control]'") from e
        results = [r for r, _ in track_library(library, None, "" if perturb == "none" else perturb, jobs=jobs)]
        failed = sum(not r.passed for r in results) if as_json else _track_table(results, perturb)
        amend_library(library, {"closed_loop_plant": perturb,
                                "closed_loop_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")},
                      {r.key: {"closed_loop_json": json.dumps(r.as_dict(), sort_keys=True)} for r in results})
        if not as_json:
            console.print(escape(f"stored {len(results)} closed-loop verdicts in {library} ({failed} failed)"))
    if as_json:
        doc = {"library": str(library), "valid": not problems, "entries": verdicts}
        if closed_loop:
            doc["closed_loop"] = {"plant": perturb, "failed": failed, "entries": [r.as_dict() for r in results]}
        print(json.dumps(doc, indent=1, default=_jsonable))
    if problems or failed:
        raise typer.Exit(1)


@app.command()
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
    from skatelib.pipeline.preflight import check_output

    try:
        from skatelib.pipeline.inspect_rerun import inspect_library
    except ImportError as e:
        raise ImportError(f"Rerun is not installed ({e}); pip install 'skatelib[viz]'") from e
    if save is None and not spawn:
        save = library.with_suffix(".rrd")
    if save is not None:
        check_output(save, [library], force, what="recording")
    roots = inspect_library(library, entry, save, spawn, overlay)
    where = escape(f" to {save}; open it with: rerun {save}") if save else ""
    console.print(f"logged {count(len(roots), 'entry')}{where}")


@app.command()
def plot(
    library: LibArg,
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder for the figures.")] = Path("out/figures"),
    frontier_file: Annotated[Path | None, typer.Option(
        "--frontier", help="A `skatelib frontier -o` file to draw (default: the library's stored frontier, if any).")
                             ] = None,
    fmt: Annotated[list[FigureFormat] | None, typer.Option(
        "--format", "-f", help="png and/or svg (repeatable); both by default.")] = None,
) -> None:
    """Figures of a quadruped library (matplotlib): board and momentum speed over time (the paper's
    Fig. 6), deck roll, the push foot's forces against the friction cone, the reachable-speed
    frontier."""
    from skatelib.pipeline.plots import FORMATS, write_figures

    formats = tuple(f.value for f in fmt) if fmt else FORMATS
    written = write_figures(library, out, frontier_file, formats)
    for p in written:
        console.print(escape(str(p)))
    if frontier_file is None and not any(p.stem == "frontier" for p in written):
        console.print("no frontier in the library (build --frontier, or pass --frontier F.json "
                      "from skatelib frontier -o)")


@app.command()
def track(
    library: LibArg,
    entry: Annotated[list[str] | None,
                     typer.Option("--entry", "-e", help="Entry key (repeatable); all successful ones by default.")
                     ] = None,
    perturb: PerturbOpt = DEFAULT_PERTURB,
    solver: Annotated[QpSolver, typer.Option(help="QP solver: daqp or proxqp (condensed, dense), osqp (sparse).")
                      ] = QpSolver.daqp,
    mpc_mu: Annotated[float | None, typer.Option(
        help="Friction coefficient the MPC assumes (its 8-facet pyramid is inside it); default: the library's "
             "planning value friction_mu_plan.", min=0.05, max=2.0)] = None,
    seed: Annotated[int, typer.Option(help="Seed of the feedback noise.")] = 0,
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Entries run in parallel.")] = 2,
    save: Annotated[Path | None, typer.Option(
        help="Write a Rerun recording (.rrd): each entry's reference beside its closed-loop run.")] = None,
    maneuver: Annotated[Maneuver, typer.Option(
        help="entries: track the library's entries; steer: four-leg deck-roll tracking (0.1 rad, 3 s period, "
             "9 s) at rest and at 0.5 m/s.")] = Maneuver.entries,
) -> None:
    """Closed loop: the paper's linear MPC (30 Hz), fed by the runtime, drives a nonlinear plant
    with model error through each entry, the transfer and 1.5 s of riding (exit 1 if any fails)."""
    try:
        from skatelib.control.closed_loop import TrackSettings
        from skatelib.control.mpc import MpcConfig
        from skatelib.control.track import steer_library, track_library
    except ImportError as e:
        raise ImportError(f"the controller's packages are missing ({e}); pip install 'skatelib[control]'") from e
    plant_error = "" if perturb == "none" else perturb
    mpc = MpcConfig(solver=solver.value, mu=mpc_mu)
    if maneuver is Maneuver.steer:
        _steer_table(steer_library(library, (0.0, 0.5), plant_error, mpc, TrackSettings(seed=seed), jobs), perturb)
        return
    if save is not None:
        from skatelib.pipeline.preflight import check_output

        try:  # before the runs, not after them
            from skatelib.pipeline.inspect_rerun import save_closed_loop
        except ImportError as e:
            raise ImportError(f"Rerun is not installed ({e}); pip install 'skatelib[viz]'") from e
        check_output(save, [library], what="recording")
    runs = track_library(library, entry, plant_error, mpc, TrackSettings(seed=seed), jobs, keep_runs=save is not None)
    results = [r for r, _ in runs]
    if save is not None:
        from skatelib.runtime import MotionLibrary

        save_closed_loop(MotionLibrary.open(library), [(r.key, run) for r, run in runs if run is not None], save)
        console.print(escape(f"wrote {save}; open it with: rerun {save}"))
    failed = _track_table(results, perturb)
    if failed:
        console.print(f"[bold red]{failed} of {count(len(results), 'entry')} failed in closed loop[/]")
        raise typer.Exit(1)


def _track_table(results: list[Any], perturb: str) -> int:
    """Print the closed-loop verdicts; returns how many failed."""
    t = Table(title=escape(f"closed loop, plant: {perturb}"))
    for col in ("entry", "label", "p/m end", "v +1 s", "delivered", "error", "roll max", "pos err", "att err",
                "min f_n", "fric margin", "slips", "tau max", "MPC ms med/max", "verdict"):
        t.add_column(escape(col), justify="right")
    for r in results:
        t.add_row(r.key, f"{r.label_mps:.2f}", f"{r.momentum_at_end_mps:.3f}", f"{r.speed_after_1s_mps:.3f}",
                  f"{r.delivered_mps:.3f}", f"{100 * r.speed_error:+.1f}%", f"{r.max_deck_roll_rad:.3f}",
                  f"{1e3 * r.max_position_error_m:.1f} mm", f"{r.max_attitude_error_rad:.3f}",
                  f"{r.min_normal_N:.1f}", f"{r.min_friction_margin_N:.2f} N", str(r.slips),
                  f"{r.max_joint_torque_Nm:.1f}", f"{r.mpc_median_ms:.1f}/{r.mpc_max_ms:.1f}",
                  "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    console.print(escape("p/m end: momentum speed (m_R v_R + m_B v_B) / (m_R + m_B) when the entry ends [m/s]; "
                         "delivered: the momentum speed 1 s later plus what rolling friction took meanwhile; "
                         "fric margin: the smallest mu f_n - |f_t| of a commanded foot force in the plant's cone "
                         "(< 0: clipped, a slip); tau max: the largest stance-joint torque at the "
                         "inverse-kinematics angles [N m]"))
    for r in results:
        if not r.passed:
            console.print(escape(f"{r.key}: {r.reasons}"))
    return sum(not r.passed for r in results)


def _steer_table(results: list[Any], perturb: str) -> None:
    t = Table(title=escape(f"four-leg steering, deck roll 0.1 rad sine, 3 s period; plant: {perturb}"))
    for col in ("speed [m/s]", "roll RMS err [rad]", "roll max [rad]", "torso shift [m]", "min f_n [N]",
                "unloaded", "slips", "MPC ms", "verdict"):
        t.add_column(escape(col), justify="right")
    for r in results:
        t.add_row(f"{r.speed_mps:.2f}", f"{r.roll_rms_error_rad:.4f}", f"{r.max_roll_rad:.3f}",
                  f"{r.max_lateral_shift_m:.3f}", f"{r.min_normal_N:.2f}", str(r.unloaded_steps), str(r.slips),
                  f"{r.mpc_median_ms:.1f}", "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    failed = [r for r in results if not r.passed]
    for r in failed:
        console.print(escape(f"{r.speed_mps:.2f} m/s: {r.reasons}"))
    if failed:
        raise typer.Exit(1)


def _sigterm(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt  # SIGTERM stops a build like Ctrl-C: workers stopped, finished entries cached


def main() -> None:
    """Entry point: errors become a one-paragraph message on stderr and a documented exit code
    (README "Exit codes"), not a traceback; ``--debug`` anywhere on the line shows the traceback."""
    import signal
    import sys

    from skatelib.library.errors import EXIT_INTERRUPTED, exit_code

    debug = "--debug" in sys.argv
    if debug:
        sys.argv.remove("--debug")
    signal.signal(signal.SIGTERM, _sigterm)
    try:
        app()
    except SystemExit as e:
        if e.code == EXIT_INTERRUPTED:  # typer's answer to Ctrl-C in a command that does not say more
            err_console.print("interrupted")
        raise
    except (SkatelibError, ImportError) as e:
        if debug:
            raise
        err_console.print(f"[bold red]error:[/] {escape(str(e))}")
        raise SystemExit(exit_code(e)) from None
