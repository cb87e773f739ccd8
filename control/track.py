"""Track every entry of a library in closed loop, in parallel over entries (joblib, like build);
the steering experiment at several speeds."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from skatelib.control.closed_loop import TrackResult, TrackSettings, track_entry
from skatelib.control.mpc import MpcConfig
from skatelib.control.params import SkateParams, parse_perturbation
from skatelib.control.steer import SteerResult, steer
from skatelib.library.errors import SkatelibError
from skatelib.runtime import Entry


def _one(path: str, key: str, perturb: str, cfg: MpcConfig, settings: TrackSettings,
         keep_run: bool) -> tuple[TrackResult, Entry | None]:
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(path)
    nominal = SkateParams.from_library(lib)
    plant, dist = parse_perturbation(perturb, nominal)
    result, trace = track_entry(lib, key, nominal, plant, dist, cfg, settings, keep_trace=keep_run)
    # At the MPC's rate: what a viewer needs, a thirtieth of what crosses the process boundary.
    run = trace.as_entry(key, result.label_mps, settings.plant_substeps) if trace is not None else None
    return result, run


def track_library(path: Path, keys: Sequence[str] | None, perturb: str, cfg: MpcConfig | None = None,
                  settings: TrackSettings | None = None, jobs: int = 2,
                  keep_runs: bool = False) -> list[tuple[TrackResult, Entry | None]]:
    """Closed-loop results of the chosen entries (all successful ones by default), each with its
    run as an entry (states, forces, contacts at the MPC's rate) when ``keep_runs``.

    Raises:
        SkatelibError: A library that is not a quadruped one, or an unknown entry key.
    """
    from joblib import Parallel, delayed
    from skatelib.runtime import MotionLibrary

    cfg = cfg or MpcConfig()
    settings = settings or TrackSettings()
    lib = MotionLibrary.open(path)
    if lib.kind != "quadruped":
        raise SkatelibError(f"{path}: closed-loop tracking is for quadruped libraries; this one is {lib.kind}")
    nominal = SkateParams.from_library(lib)
    parse_perturbation(perturb, nominal)  # refuse a bad --perturb before any work
    chosen = list(keys) if keys else [e.key for e in lib if e.success]
    for k in chosen:
        lib[k]  # an unknown key raises EntryNotFound, naming the valid ones, before any work
    return list(Parallel(n_jobs=min(jobs, len(chosen)) or 1)(
        delayed(_one)(str(path), k, perturb, cfg, settings, keep_runs) for k in chosen))


def _steer_one(path: str, speed: float, perturb: str, cfg: MpcConfig, settings: TrackSettings) -> SteerResult:
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(path)
    nominal = SkateParams.from_library(lib)
    plant, dist = parse_perturbation(perturb, nominal)
    return steer(lib, nominal, plant, speed, dist=dist, cfg=cfg, settings=settings)


def steer_library(path: Path, speeds: Sequence[float], perturb: str, cfg: MpcConfig | None = None,
                  settings: TrackSettings | None = None, jobs: int = 2) -> list[SteerResult]:
    """The steering experiment (:mod:`skatelib.control.steer`) at each speed, with the library's
    model and stance."""
    from joblib import Parallel, delayed
    from skatelib.runtime import MotionLibrary

    cfg = cfg or MpcConfig()
    settings = settings or TrackSettings()
    lib = MotionLibrary.open(path)
    if lib.kind != "quadruped":
        raise SkatelibError(f"{path}: the steering experiment is for quadruped libraries; this one is {lib.kind}")
    parse_perturbation(perturb, SkateParams.from_library(lib))
    return list(Parallel(n_jobs=min(jobs, len(speeds)) or 1)(
        delayed(_steer_one)(str(path), v, perturb, cfg, settings) for v in speeds))
