"""``skatelib track --plant mujoco``: each entry ridden on the physical twin, by the robot side's
controller (the MPC at 30 Hz and the whole-body controller at 510 Hz of ``skatelib.control``) on
the MuJoCo model of ``skatelib.sim``. The two packages do not know each other; a job here hands
the one's plant to the other's loop. Jobs are picklable and checked before any runs, like the
model plant's (:mod:`skatelib.proving.track`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from skatelib.control.mpc_config import MpcConfig
from skatelib.control.settings import TrackSettings
from skatelib.library.errors import SkatelibError
from skatelib.proving.track import chosen_keys
from skatelib.runtime import Entry, MotionLibrary

if TYPE_CHECKING:  # MuJoCo's side, imported when a job runs (check_twin names the missing extra)
    from skatelib.proving.steer import SteerResult
    from skatelib.proving.twin.loop import Shove, TwinRun
    from skatelib.proving.twin.verdict import TwinResult
    from skatelib.sim.errors import TwinErrors
    from skatelib.sim.plant import TwinPlant


@dataclass(frozen=True)
class TwinJob:
    """One entry on the twin with ``perturb``'s errors (:mod:`skatelib.sim.errors`); with
    ``video`` the run rendered to that file (:mod:`skatelib.sim.video`); with ``keep_run`` the run
    as an entry for a recording (:mod:`skatelib.proving.twin.record`). Returns (the verdict, the
    video's path or None, the entry or None)."""

    path: str
    key: str
    perturb: str
    mpc: MpcConfig
    settings: TrackSettings
    video: str | None = None
    keep_run: bool = False

    def __call__(self) -> tuple[TwinResult, str | None, Entry | None]:
        from skatelib.library import schema
        from skatelib.proving.twin.verdict import twin_result

        lib = MotionLibrary.open(self.path)
        label = float(lib[self.key].attrs[schema.A_TARGET_VELOCITY])
        run, plant = ride_twin(lib, self.key, self.perturb, (self.mpc, self.settings),
                               keep=self.keep_run or self.video is not None)
        entry = run.record.as_entry(self.key, label) if self.keep_run and len(run.record.forces) > 1 else None
        result = twin_result(self.key, label, run)
        written = None
        if self.video is not None:
            from skatelib.proving.twin.footage import film_run

            written = film_run(lib, lib[self.key], (run, plant.m), result, (self.perturb, self.settings.transfer_s, ()),
                               Path(self.video))
        return result, written, entry


def ride_twin(lib: MotionLibrary, what: str | Entry, perturb: str | TwinErrors,
              controller: tuple[MpcConfig, TrackSettings], keep: bool = False,
              shove: Shove | None = None) -> tuple[TwinRun, TwinPlant]:
    """Ride ``what`` (an entry's key, or an entry made of the library's: a chained ride) on the twin
    with ``perturb``'s errors (``--perturb`` text or the errors themselves) and ``shove``, the MPC's
    and the run's settings ``controller``, one BLAS thread; ``keep``: keep the run's configurations
    and record (for a recording or a video). Returns the run
    (:class:`skatelib.proving.twin.loop.TwinRun`) and the plant it rode."""
    from skatelib.control.params import SkateParams
    from skatelib.proving.setup import ClosedLoop, one_blas_thread
    from skatelib.proving.twin.loop import TwinLoop, TwinLoopSettings
    from skatelib.proving.twin.sensors import Sensors

    mpc, settings = controller
    nominal = SkateParams.from_library(lib)
    plant, errors = _plant(lib, perturb)
    loop = TwinLoop(lib, what, ClosedLoop(nominal, nominal, mpc=mpc, settings=settings), plant,
                    TwinLoopSettings(sensors=Sensors(errors.noise_std, errors.delay_s), state=settings.state,
                                     sensor_errors=errors.sensors, shove=shove),
                    keep=keep)
    with one_blas_thread():
        run = loop.ride()
    return run, plant


@dataclass(frozen=True)
class TwinSteerJob:
    """The steering maneuver at ``target_velocity_mps`` on the twin (:mod:`skatelib.proving.twin.steer`)."""

    path: str
    target_velocity_mps: float
    perturb: str
    mpc: MpcConfig
    settings: TrackSettings

    def __call__(self) -> SteerResult:
        from skatelib.control.params import SkateParams
        from skatelib.proving.setup import ClosedLoop, one_blas_thread
        from skatelib.proving.twin.loop import TwinLoopSettings
        from skatelib.proving.twin.sensors import Sensors
        from skatelib.proving.twin.steer import SteerRun, steer_twin

        lib = MotionLibrary.open(self.path)
        nominal = SkateParams.from_library(lib)
        plant, errors = _plant(lib, self.perturb)
        sensors = TwinLoopSettings(sensors=Sensors(errors.noise_std, errors.delay_s), state=self.settings.state,
                                   sensor_errors=errors.sensors)
        with one_blas_thread():
            return steer_twin(lib, ClosedLoop(nominal, nominal, mpc=self.mpc, settings=self.settings), plant,
                              self.target_velocity_mps, SteerRun(loop=sensors))


def _plant(lib: MotionLibrary, perturb: str | TwinErrors) -> tuple[TwinPlant, TwinErrors]:
    from skatelib.sim.errors import parse_twin_perturbation
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.plant import TwinPlant

    figures = TwinFigures.from_library(lib)
    errors = parse_twin_perturbation(perturb, figures) if isinstance(perturb, str) else perturb
    return TwinPlant(figures, errors), errors


def twin_library(path: Path, kind: str, other_kind: str, modules: Sequence[str]) -> MotionLibrary:
    """The library at ``path`` for a twin of ``kind``'s robots: ``modules`` importable (MuJoCo's and the
    controller's; else the install hint) and a library of that kind (else ``other_kind`` and its kind)."""
    import importlib

    try:
        for module in modules:
            importlib.import_module(module)
    except ImportError as e:
        raise SkatelibError(f"the twin needs MuJoCo and the controller ({e}); pip install 'skatelib[control,sim]'"
                            ) from e
    lib = MotionLibrary.open(path)
    if lib.kind != kind:
        raise SkatelibError(f"{path}: {other_kind}{lib.kind}")
    return lib


def check_twin(path: Path, perturb: str) -> MotionLibrary:
    """The library at ``path`` for the twin: a quadruped one, ``perturb`` valid and MuJoCo there."""
    lib = twin_library(path, "quadruped", "the MPC and whole-body controller ride a quadruped's entries on its twin "
                       "(a humanoid library is executed on its own twin by `skatelib track LIB --plant mujoco` or "
                       "skatelib.validate(LIB, closed_loop=True, plant='mujoco')); this library is ",
                       ("skatelib.control.params", "skatelib.sim.errors"))
    from skatelib.sim.errors import parse_twin_perturbation
    from skatelib.sim.figures import TwinFigures

    parse_twin_perturbation(perturb, TwinFigures.from_library(lib))  # refuse a bad --perturb before any work
    return lib


def twin_steer_jobs(path: Path, speeds: Sequence[float], perturb: str, mpc: MpcConfig,
                    settings: TrackSettings) -> list[TwinSteerJob]:
    """One steering job per speed on the twin."""
    check_twin(path, perturb)
    return [TwinSteerJob(str(path), v, perturb, mpc, settings) for v in speeds]


def video_path(video: Path, key: str, several: bool) -> Path:
    """Where an entry's video goes: ``video`` itself, or with several entries ``NAME-<key>.EXT``."""
    return video.with_name(f"{video.stem}-{key}{video.suffix}") if several else video


def twin_jobs(path: Path, keys: Sequence[str] | None, perturb: str, mpc: MpcConfig | None = None,
              settings: TrackSettings | None = None,
              outputs: tuple[Path | None, bool] = (None, False)) -> list[TwinJob]:
    """One twin job per chosen entry (all successful ones by default); ``outputs``: a video to
    render each run to (:func:`video_path`), and whether to keep the runs for a recording.

    Raises:
        SkatelibError: A library that is not a quadruped one, a bad perturbation, an unknown
            entry key (naming the valid ones), or MuJoCo missing, before any work.
    """
    video, keep_runs = outputs
    lib = check_twin(path, perturb)
    chosen = chosen_keys(lib, keys)
    mpc, settings = mpc or MpcConfig(), settings or TrackSettings()
    if video is not None:
        from skatelib.sim.video import FORMATS

        if video.suffix.lower() not in FORMATS:
            raise SkatelibError(f"--video {video}: give a file ending in {' or '.join(FORMATS)}")
    return [TwinJob(str(path), k, perturb, mpc, settings,
                    None if video is None else str(video_path(video, k, len(chosen) > 1)), keep_runs) for k in chosen]
