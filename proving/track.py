"""A library's entries (or the steering experiment's speeds) as closed-loop jobs: picklable
callables, checked before any runs, that a caller runs in any order and on any worker (the
command line runs them on the build's parallel runner, ``skatelib.pipeline.build.sweep.run_calls``;
``[job() for job in jobs]`` runs them here)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from skatelib.control.mpc import MpcConfig
from skatelib.control.params import SkateParams
from skatelib.control.settings import TrackSettings
from skatelib.library.errors import SkatelibError
from skatelib.proving.closed_loop import track_entry
from skatelib.proving.perturb import parse_perturbation
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.steer import SteerResult, steer
from skatelib.proving.verdict import TrackResult
from skatelib.runtime import Entry, MotionLibrary


@dataclass(frozen=True)
class JobSpec:
    """What every job of one command shares: the library, the plant's perturbation and the
    controller's settings."""

    path: str
    perturb: str
    mpc: MpcConfig
    settings: TrackSettings

    def loop(self, lib: MotionLibrary) -> ClosedLoop:
        nominal = SkateParams.from_library(lib)
        plant, dist = parse_perturbation(self.perturb, nominal)
        return ClosedLoop(nominal, plant, dist, self.mpc, self.settings)


@dataclass(frozen=True)
class TrackJob:
    """One entry in closed loop; with ``keep_run`` its run as an entry (states, forces, contacts at
    the MPC's rate: what a viewer needs, a thirtieth of what would cross a process boundary)."""

    spec: JobSpec
    key: str
    keep_run: bool = False

    def __call__(self) -> tuple[TrackResult, Entry | None]:
        lib = MotionLibrary.open(self.spec.path)
        result, trace = track_entry(lib, self.key, self.spec.loop(lib), keep_trace=self.keep_run)
        stride = self.spec.settings.plant_substeps
        return result, trace.as_entry(self.key, result.target_velocity_mps, stride) if trace is not None else None


@dataclass(frozen=True)
class SteerJob:
    """The steering experiment at one speed, with the library's model and stance."""

    spec: JobSpec
    target_velocity_mps: float

    def __call__(self) -> SteerResult:
        lib = MotionLibrary.open(self.spec.path)
        return steer(lib, self.spec.loop(lib), self.target_velocity_mps)


def chosen_keys(lib: MotionLibrary, keys: Sequence[str] | None) -> list[str]:
    """The entries a ride or a certificate asks for: ``keys`` (each once), or every successful entry
    when None.

    Raises:
        TypeError: One string for the keys (one key is a list of one; a string would be ridden letter
            by letter).
        ValueError: No key (an empty list asks for nothing; it rode every entry before).
        EntryNotFound: A key the library does not hold, naming the valid ones.
    """
    if keys is None:
        return [e.key for e in lib if e.success]
    if isinstance(keys, (str, bytes)):
        raise TypeError(f"entries: a list of entry keys, not the string {keys!r} (one key: [{keys!r}])")
    chosen = list(dict.fromkeys(keys))
    if not chosen:
        raise ValueError("entries: an empty list asks for no entry; give None for every successful one")
    for k in chosen:
        lib[k]  # an unknown key raises EntryNotFound, naming the valid ones
    return chosen


def _quadruped(path: Path, perturb: str, what: str) -> MotionLibrary:
    lib = MotionLibrary.open(path)
    if lib.kind != "quadruped":
        raise SkatelibError(f"{path}: {what} is for quadruped libraries; this one is {lib.kind}")
    parse_perturbation(perturb, SkateParams.from_library(lib))  # refuse a bad --perturb before any work
    return lib


def track_jobs(path: Path, keys: Sequence[str] | None, perturb: str, mpc: MpcConfig | None = None,
               settings: TrackSettings | None = None, keep_runs: bool = False) -> list[TrackJob]:
    """One job per chosen entry (all successful ones by default).

    Raises:
        SkatelibError: A library that is not a quadruped one, a bad perturbation (an ``impulse_t``
            at or after an entry's run ends among it), or an unknown entry key (naming the valid
            ones), before any work.
    """
    from skatelib.proving.loop import entry_impulses_checked

    lib = _quadruped(path, perturb, "closed-loop tracking")
    chosen = chosen_keys(lib, keys)
    spec = JobSpec(str(path), perturb, mpc or MpcConfig(), settings or TrackSettings())
    entry_impulses_checked(lib, chosen, spec.loop(lib))  # an impulse no run would apply: before any ride
    return [TrackJob(spec, k, keep_runs) for k in chosen]


def steer_jobs(path: Path, speeds: Sequence[float], perturb: str, mpc: MpcConfig | None = None,
               settings: TrackSettings | None = None) -> list[SteerJob]:
    """One steering job per speed (:mod:`skatelib.proving.steer`)."""
    _quadruped(path, perturb, "the steering experiment")
    spec = JobSpec(str(path), perturb, mpc or MpcConfig(), settings or TrackSettings())
    return [SteerJob(spec, v) for v in speeds]
