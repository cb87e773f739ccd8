"""The commands as Python functions: :func:`build`, :func:`validate`, :func:`track` (and
:func:`skatelib.pipeline.api_certify.certify`), imported from
the package (``skatelib.build(...)``; ``import skatelib`` loads this module on first use).

Each takes the command's options as keyword arguments, checks them as the command does (a wrong
config key raises the same :class:`~skatelib.library.errors.ConfigError`, naming the file and the
key), runs the code the command runs, and returns its result records instead of printing. Progress
goes to a callback of yours, or (``progress=True``) to the command's own bar on the terminal. One
function per command, each named in ``skatelib.__all__`` (``api/__init__.py``).
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from skatelib.library.perturb import DEFAULT_PLANT_PERTURBATION
from skatelib.pipeline.limits import MAX_JOBS, MAX_SEED, check_choice, check_range
from skatelib.pipeline.track_setup import DEFAULT_TWIN_STATE, controller, plant_errors, run_jobs

if TYPE_CHECKING:
    from skatelib.pipeline.build.contract import EntryEvent
    from skatelib.pipeline.build.orchestrate import BuildReport
    from skatelib.pipeline.kinds import KindConfig
    from skatelib.pipeline.validate import EntryVerdict, ValidationReport
    from skatelib.proving.twin.verdict import TwinResult
    from skatelib.proving.verdict import TrackResult

PIPELINE_MODULES = ("typer", "rich", "casadi", "pinocchio", "joblib")  # the [build] extra's, as imported
PathLike = str | os.PathLike[str]
Backend = Literal["loky", "dask"]
"""Where a build's workers run: ``loky``, processes on this machine; ``dask``, a cluster."""
Plant = Literal["model", "mujoco"]
"""What the controller drives: ``model``, the single-rigid-body plant; ``mujoco``, the physical twin."""
QpSolver = Literal["daqp", "proxqp", "osqp"]
"""The MPC's QP solver: ``daqp`` or ``proxqp`` (condensed, dense), ``osqp`` (sparse)."""
StateSource = Literal["true", "estimate"]
"""On the twin, what the controller is fed: the twin's state, or the robot's estimator on its sensors."""


def build(config: PathLike | KindConfig | None = None, out: PathLike | None = None, *, jobs: int = 2,  # noqa: PLR0913
          progress: bool | Callable[[EntryEvent], None] = False, cache: bool = True, frontier: bool = False,
          backend: Backend = "loky", scheduler: str | None = None, force: bool = False,
          allow_large: bool = False, on_start: Callable[[int], None] | None = None) -> BuildReport:
    """Build a motion library from a config, as ``skatelib build`` does.

    Args:
        config: The build config (TOML), or a config loaded by
            :func:`skatelib.pipeline.config.load_config`; the shipped default when None.
        out: The library file to write (.h5); ``out/<meta.name>.h5`` when None. It is written to a
            temporary file beside it and moved into place: a reader never sees half a library.
        jobs: Worker processes (1 to 256; 1 solves in this process).
        progress: A function called with each entry's
            :class:`~skatelib.pipeline.build.contract.EntryEvent` (started, then finished with its
            status), True for the command's progress bar, False for nothing.
        cache: Reuse the entries a build with the same inputs finished (an interrupted build resumes).
        frontier: Also search the reachable-speed frontier and store it.
        backend: ``loky`` (processes here) or ``dask`` (the cluster at ``scheduler``, tcp://HOST:PORT).
        scheduler: The dask scheduler's address (run code only on a cluster you run).
        force: Overwrite an output file that is not a skatelib library.
        allow_large: Go on past the size bounds (a build that could take hours and many GB).
        on_start: Called with the number of entries once the config, the output and the options
            are checked, before any solve.

    Returns:
        The report: the file written, each entry's outcome (``report.failed``: those stored with
        ``success = false``; a failed entry does not raise) and the wall time [s].

    Raises:
        ConfigError: A config that is missing, not TOML, or has an unknown or out-of-range key
            (naming the file and the key).
        OutputError: An output that cannot be written (naming it and what to do).
        BuildTooLarge: A build beyond the size bounds without ``allow_large``.
        ValueError: An argument out of its range (naming it).
    """
    require_pipeline("skatelib.build")
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library, check_options, default_output
    from skatelib.pipeline.build.preflight import check_output
    from skatelib.pipeline.kinds import kind_of

    check_range("skatelib.build", "jobs", jobs, 1, MAX_JOBS)
    check_choice("skatelib.build", "backend", backend, ("loky", "dask"))
    cfg = _loaded(config)
    target = Path(out) if out is not None else default_output(cfg)
    check_output(target, [cfg.path], force)
    opts = BuildOptions(jobs, backend, scheduler, progress is not False, cache, frontier, allow_large)
    check_options(cfg, opts)
    total = sum(t.n_entries for t in kind_of(cfg).tasks(cfg))
    if on_start is not None:
        on_start(total)
    if callable(progress):
        return build_library(cfg, target, opts, on_entry=progress)
    from skatelib.pipeline.views.progress import build_bar

    with build_bar(total, enabled=bool(progress)) as bar:
        return build_library(cfg, target, opts, on_entry=bar)


def validate(library: PathLike, *, closed_loop: bool = False, plant: Plant = "model",
             perturb: str = DEFAULT_PLANT_PERTURBATION, jobs: int = 2,
             on_entry: Callable[[EntryVerdict], None] | None = None) -> ValidationReport:
    """Check a library as ``skatelib validate`` does: its integrity (checksum, every field) and each
    entry's physics; with ``closed_loop``, ride every successful entry and store each verdict in it.

    Args:
        library: The library file (.h5).
        closed_loop: Also track every successful entry in closed loop and store the verdicts in the
            file (it must be writable; it keeps its permissions).
        plant: With ``closed_loop``: ``model`` or ``mujoco`` (the twin; needs the ``[sim]`` extra; a
            humanoid library's only).
        perturb: With ``closed_loop``: the plant's model errors, ``KEY=VALUE,...`` (``none``: as planned;
            a humanoid library left at the default takes the humanoid's default set).
        jobs: Entries ridden in parallel (1 to 256).
        on_entry: Called with each entry's :class:`~skatelib.pipeline.validate.EntryVerdict` as it is checked.

    Returns:
        Every entry's verdict, the failures, and the closed-loop verdicts when asked for.

    Raises:
        LibraryFormatError: A missing, damaged or incomplete file (naming it and the field).
        SkatelibError: A bad ``perturb`` (empty, not a text, a key out of its range: naming it).
        ValueError: An argument out of its range (naming it).
    """
    require_pipeline("skatelib.validate")
    from skatelib.pipeline.track_setup import named_errors
    from skatelib.pipeline.validate import (
        EntryVerdict,
        ValidationReport,
        closed_loop_jobs,
        closed_loop_perturbation,
        validate_library,
    )

    check_range("skatelib.validate", "jobs", jobs, 1, MAX_JOBS)
    check_choice("skatelib.validate", "plant", plant, ("model", "mujoco"))
    path = Path(library)
    if closed_loop:
        named_errors(perturb, plant == "mujoco", "skatelib.validate(perturb=...)")
        perturb = closed_loop_perturbation(path, perturb, DEFAULT_PLANT_PERTURBATION)
    rides = closed_loop_jobs(path, perturb, plant) if closed_loop else []  # refused before any check or ride
    verdicts: list[EntryVerdict] = []

    def report(key: str, status: str, message: str, figures: dict[str, float]) -> None:
        verdicts.append(EntryVerdict(key, status, message, dict(figures)))
        if on_entry is not None:
            on_entry(verdicts[-1])

    failed = validate_library(path, report)
    results: tuple[Any, ...] = ()
    if closed_loop:
        from skatelib.pipeline.validate import closed_loop_verdicts

        results = tuple(closed_loop_verdicts(path, perturb, rides, jobs, plant))
    return ValidationReport(path, tuple(verdicts), failed, results)


def track(library: PathLike, entries: Sequence[str] | None = None, *, plant: Plant = "model",  # noqa: PLR0913
          perturb: str = DEFAULT_PLANT_PERTURBATION, solver: QpSolver = "daqp", mpc_mu: float | None = None,
          seed: int = 0, state: StateSource = DEFAULT_TWIN_STATE, jobs: int = 2,
          progress: bool | Callable[[int, int], None] = False) -> list[TrackResult] | list[TwinResult]:
    """Ride a quadruped library's entries in closed loop, as ``skatelib track`` does: the paper's
    linear MPC (30 Hz), fed by the runtime, drives a plant with model errors through each entry, the
    transfer and 1.5 s of riding.

    Args:
        library: The library file (.h5) of a quadruped.
        entries: Entry keys; every successful entry when None.
        plant: ``model`` (the single-rigid-body plant) or ``mujoco`` (the physical twin under the
            whole-body controller; needs the ``[sim]`` extra).
        perturb: The plant's model errors, ``KEY=VALUE,...`` (``+10%`` relative to the planned
            figure, ``0.5`` absolute in the key's unit on either plant; ``none``: the plant as
            planned); the keys are listed by ``skatelib track --help``.
        solver: The MPC's QP solver.
        mpc_mu: The friction coefficient the MPC assumes; the library's planning value when None.
        seed: Seed of the feedback noise (0 to 2**32 - 1).
        state: On the twin, what the controller is fed: ``estimate`` (the robot's estimator on the
            twin's sensors, as on the robot) or ``true`` (the twin's own state).
        jobs: Entries run in parallel (1 to 256).
        progress: A function called with (runs done, runs in all) as each run finishes, True for the
            command's progress bar, False for nothing.

    Returns:
        Each entry's verdict in the order asked (``passed``, ``reasons`` and the figures):
        :class:`~skatelib.proving.verdict.TrackResult` on the model plant,
        :class:`~skatelib.proving.twin.verdict.TwinResult` on the twin.

    Raises:
        SkatelibError: A library that is not a quadruped's, an unknown entry key (naming the valid
            ones) or a bad ``perturb`` (an empty text or not a text, a key out of its range, an
            ``impulse_t`` at or after an entry's run ends: naming it), before any run; a
            ``PerturbationError`` or ``TwinPerturbationError``, both a ValueError.
        ImportError: The controller's packages are missing, naming the extra (MuJoCo missing on
            ``plant="mujoco"``: a SkatelibError naming it).
        ValueError: An argument out of its range (naming it).
    """
    require_pipeline("skatelib.track")
    check_choice("skatelib.track", "plant", plant, ("model", "mujoco"))
    check_range("skatelib.track", "jobs", jobs, 1, MAX_JOBS)
    check_range("skatelib.track", "seed", seed, 0, MAX_SEED)
    mpc, settings = controller(check_choice("skatelib.track", "solver", solver, ("daqp", "proxqp", "osqp")),
                               mpc_mu, seed, check_choice("skatelib.track", "state", state, ("true", "estimate")))
    errors = plant_errors(perturb, plant == "mujoco", state, "skatelib.track(perturb=...)")
    keys = entries  # checked by the jobs (proving.track.chosen_keys)
    if plant == "mujoco":
        from skatelib.proving.twin.track import twin_jobs

        calls: list[Any] = list(twin_jobs(Path(library), keys, errors, mpc, settings))
    else:
        from skatelib.proving.track import track_jobs

        calls = list(track_jobs(Path(library), keys, errors, mpc, settings))
    label = "riding on the twin" if plant == "mujoco" else "tracking"
    return [out[0] for out in run_jobs(calls, jobs, progress, label)]


def _loaded(config: PathLike | KindConfig | None) -> KindConfig:
    """A config from its path (the shipped default for None), or one loaded already (the command
    line's, or a config changed in Python).

    Raises:
        ConfigError: Naming the file and the key.
    """
    if config is None or isinstance(config, str | os.PathLike):
        from skatelib.pipeline.config import load_config

        return load_config(None if config is None else Path(config))
    return config


def require_pipeline(where: str) -> None:
    """Refuse at once, naming what to install, when the build pipeline's packages are missing (a
    runtime-only install: numpy and h5py).

    Raises:
        ImportError: Naming ``where``, the missing packages and the extra that brings them.
    """
    missing = [m for m in PIPELINE_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        raise ImportError(f"{where} needs the build pipeline's packages; missing: {', '.join(missing)}; "
                          "pip install 'skatelib[pipeline]'")


__all__ = ["Backend", "Plant", "QpSolver", "StateSource", "build", "track", "validate"]
