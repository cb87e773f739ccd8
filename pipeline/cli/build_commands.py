"""The commands that build: ``model``, ``build``, ``frontier``, ``solve``. Each parses its options,
calls one library function and prints."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.pipeline.build.size import MAX_ENTRIES, MAX_SOLVE_VARIABLES
from skatelib.pipeline.cli.option_checks import MAX_ATOL, MAX_JOBS, MAX_RTOL, finite
from skatelib.pipeline.config import field_range
from skatelib.pipeline.quadruped.config import SweepConfig
from skatelib.pipeline.views.console import console, count, mesh_note


class Backend(enum.StrEnum):
    """Where build workers run."""

    loky = "loky"
    dask = "dask"


VELOCITY_RANGE = field_range(SweepConfig, "velocities_mps")  # one range, defined with the config
STRIDE_RANGE = tuple(round(x) for x in field_range(SweepConfig, "strides"))

# Where the workers run, shared by build and certify.
JobsOpt = Annotated[int, typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Worker processes (loky backend).")]
BackendOpt = Annotated[Backend, typer.Option(help="loky: worker processes on this machine; dask: a cluster.")]
SchedulerOpt = Annotated[str | None, typer.Option(
    help="Dask scheduler address, tcp://HOST:PORT or tls://HOST:PORT (certificates from the dask config); "
         "a scheduler runs code on its workers: use your own cluster only.")]
ProgressOpt = Annotated[bool, typer.Option("--progress/--no-progress", help="Show a progress bar.")]
ConfigArg = Annotated[Path | None, typer.Argument(help="Build config (TOML); the shipped default when omitted.")]
YesOpt = Annotated[bool, typer.Option(
    "--yes", help=f"Go on past the size bounds ({MAX_ENTRIES} entries, {MAX_SOLVE_VARIABLES:,} variables in one "
                  "solve): a build that large can take hours and many GB of memory.")]


def model(
    config: Annotated[Path | None, typer.Argument(
        help="Build config (TOML), or with --twin a library (.h5, quadruped or humanoid); the shipped default "
             "config when omitted.")] = None,
    twin: Annotated[Path | None, typer.Option(
        help="Write the physical twin (MuJoCo MJCF: robot and jointed skateboard) to this file.")] = None,
) -> None:
    """Print the robot and board model of a config: SRB mass and inertia from the URDF, board
    figures; for a humanoid config, its point-mass model and the LIP/DCM time constant. With
    --twin, write the MuJoCo model of robot and board built from the same figures (open it with
    python -m mujoco.viewer --mjcf OUT.xml)."""
    from skatelib.pipeline.build.preflight import is_hdf5
    from skatelib.pipeline.twin import write_twin

    # a library (by its bytes, or by its name: a missing or empty .h5 is a library the reader names as such)
    if config is not None and (is_hdf5(config) or config.suffix.lower() in (".h5", ".hdf5")):
        if twin is None:
            raise typer.BadParameter("a library's model is shown by skatelib info; give --twin OUT.xml",
                                     param_hint="CONFIG")
        mesh_note(config)
        console.print(escape(f"wrote {write_twin(config, twin)}"))
        return
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.kinds import kind_of

    cfg = load_config(config)
    kind_of(cfg).print_model(cfg)
    if twin is not None:
        console.print(escape(f"wrote {write_twin(cfg, twin)}; open it with: python -m mujoco.viewer --mjcf {twin}"))


OutOpt = Annotated[Path | None, typer.Option(
    "-o", "--out", help="Library file to write (.h5).", show_default="out/<config's meta.name>.h5")]


def build(
    config: ConfigArg = None,
    out: OutOpt = None,
    jobs: JobsOpt = 2,
    backend: BackendOpt = Backend.loky,
    scheduler: SchedulerOpt = None,
    progress: ProgressOpt = True,
    allow_failures: Annotated[bool, typer.Option(help="Exit 0 even when entries failed.")] = False,
    cache: Annotated[bool, typer.Option("--cache/--no-cache", help="Reuse finished entries (resume).")] = True,
    frontier: Annotated[bool, typer.Option(
        "--frontier", help="Also search the reachable-speed frontier of every stride count (with transitions: the "
                           "fastest speed-up from each riding speed, the fastest a stop stops from) and store it.")
                                ] = False,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an output file that is not a skatelib library.")
                     ] = False,
    check: Annotated[Path | None, typer.Option(
        "--check", help="Build into a temporary file and compare it with this library as `skatelib diff` does, "
                        "without writing or replacing anything; exit 1 when they differ.")] = None,
    atol: Annotated[float, typer.Option("--atol", min=0.0, max=MAX_ATOL, callback=finite,
                                        help="With --check: absolute tolerance.")] = 0.0,
    rtol: Annotated[float, typer.Option("--rtol", min=0.0, max=MAX_RTOL, callback=finite,
                                        help="With --check: relative tolerance.")] = 0.0,
    yes: YesOpt = False,
    profile: Annotated[Path | None, typer.Option(
        "--profile", help="Write where the build's time went to this JSON file (every process's spans: compile, "
                          "solves and their attempts, physics checks, twin rides, writing) and print it by phase, "
                          "with the workers' idle time (loky backend).")] = None,
) -> None:
    """Build a motion library: sweep target speeds x stride counts through the push-off TO
    (quadruped configs) or walking/skating step velocities through the GPM (humanoid configs)."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import default_output
    from skatelib.pipeline.cli.build_run import profiled_build, run_build
    from skatelib.pipeline.config import load_config

    cfg = load_config(config)
    opts = BuildOptions(jobs, backend.value, scheduler, progress, cache, frontier, yes)
    if check is not None:
        if out is not None:
            raise typer.BadParameter("--check compares with LIB and writes nothing: leave out -o", param_hint="-o")
        _build_and_check(cfg, opts, check, (atol, rtol), allow_failures)
        return
    if profile is not None:
        if backend == Backend.dask or check is not None:
            raise typer.BadParameter("a profile is of a build on this machine: leave out --backend dask and --check",
                                     param_hint="--profile")
        target = out or default_output(cfg)
        _check_profile_output(profile, target, cfg)
        run = profiled_build(cfg, target, opts, force, profile)
    else:
        run = run_build(cfg, out or default_output(cfg), opts, force)
    if run.failed and not allow_failures:
        console.print(f"[bold red]{count(run.failed, 'entry')} failed[/] (kept in the file with success=false); "
                      "rerun with --allow-failures to accept")
        raise typer.Exit(1)


def _check_profile_output(profile: Path, library: Path, cfg: Any) -> None:
    """``--profile``'s file, refused before the build as every output is: not the library the build
    writes, not an input, not a file of another type, in a folder that can be written."""
    from skatelib.library.errors import OutputError
    from skatelib.pipeline.build.preflight import check_output

    if profile.resolve() == library.resolve():
        raise OutputError(profile, "is the library this build writes; name another file for the profile, e.g. "
                                   f"{library.with_suffix('.profile.json')}")
    check_output(profile, [p for p in (cfg.path,) if p is not None], what="profile")


def _build_and_check(cfg: Any, opts: Any, reference: Path, tolerance: tuple[float, float],
                     allow_failures: bool) -> None:
    """``build --check``: the build in a temporary folder, compared with ``reference``."""
    import tempfile

    from skatelib.library.compare import Tolerance, compare_files
    from skatelib.library.reader import read_library
    from skatelib.pipeline.cli.build_run import run_build
    from skatelib.pipeline.kinds import kind_of
    from skatelib.pipeline.views.diff_view import show_diff

    kind = read_library(reference).kind  # a missing or damaged reference is refused before any solve (exit 3)
    if kind != kind_of(cfg).name:
        raise typer.BadParameter(f"{reference} is a {kind} library and {cfg.path} a {kind_of(cfg).name} config: "
                                 "compare a build with a library of its kind", param_hint="--check")
    with tempfile.TemporaryDirectory(prefix="skatelib-check-") as tmp:
        built = Path(tmp) / reference.name
        run = run_build(cfg, built, opts)
        d = compare_files(reference, built, Tolerance(*tolerance))
        show_diff(d)
    if not d.equal:
        console.print(escape(f"the build differs from {reference} (left as it was)"))
        raise typer.Exit(1)
    if run.failed and not allow_failures:
        console.print(f"[bold red]{count(run.failed, 'entry')} failed[/], as in {escape(str(reference))}")
        raise typer.Exit(1)


def solve(
    velocity: Annotated[float, typer.Option("--velocity", "-V", min=VELOCITY_RANGE[0], max=VELOCITY_RANGE[1],
                                            callback=finite,
                                            help="Target board speed, m/s (the range of sweep.velocities_mps).")],
    strides: Annotated[int, typer.Option("--strides", "-s", min=STRIDE_RANGE[0], max=STRIDE_RANGE[1],
                                         help="Number of push strides.")],
    out: Annotated[Path | None, typer.Option(
        "-o", "--out", help="One-entry library to write (.h5).",
        show_default="out/<config's meta.name>-v<velocity>_s<strides>.h5")] = None,
    config: ConfigArg = None,
    config_option: Annotated[Path | None, typer.Option("--config", help="The same, as an option.")] = None,
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Print IPOPT's iteration log.")] = False,
    yes: YesOpt = False,
) -> None:
    """Solve one push-off and write it as a one-entry motion library."""
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library
    from skatelib.pipeline.build.preflight import check_output
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig

    if config is not None and config_option is not None and config != config_option:
        raise typer.BadParameter(f"two configs given ({config} and --config {config_option}); give one")
    cfg = load_config(config or config_option, QuadrupedConfig)
    from skatelib.library.schema import entry_key
    from skatelib.pipeline.build.size import check_size
    from skatelib.pipeline.quadruped.builder import one_start_up, summary
    from skatelib.pipeline.quadruped.size import build_size

    check_size(cfg.path, build_size(one_start_up(cfg, velocity, strides)), yes)

    out = out or Path("out") / f"{cfg.meta.name}-{entry_key(velocity, strides)}.h5"
    check_output(out, [cfg.path])
    if cfg.optimization.compile:
        from skatelib.pipeline.build.preflight import check_compile_dir

        check_compile_dir()
    cfg = one_start_up(cfg, velocity, strides)  # that entry alone: no transitions
    report = build_library(cfg, out, BuildOptions(jobs=1, cache=False), ipopt=(("print_level", 5),) if verbose else ())

    summary(report.written)
    console.print(f"wrote {escape(str(report.path))}")
    if report.failed:
        raise typer.Exit(1)


COMMANDS = (model, build, solve)
