"""``skatelib track --plant mujoco``: each entry ridden on the physical twin, by the robot side's
controller (the MPC at 30 Hz and the whole-body controller at 510 Hz of ``skatelib.control``) on
the MuJoCo model of ``skatelib.sim``. The two packages do not know each other; a job here hands
the one's plant to the other's loop. Jobs are picklable and checked before any runs, like the
model plant's (:mod:`skatelib.control.track`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from skatelib.library.errors import SkatelibError
from skatelib.runtime import MotionLibrary


@dataclass(frozen=True)
class TwinJob:
    """One entry on the twin with ``perturb``'s errors (:mod:`skatelib.sim.errors`); with
    ``keep_run`` the plant's configurations at the MPC's rate (for a recording or a video)."""

    path: str
    key: str
    perturb: str
    mpc: Any
    settings: Any
    keep_run: bool = False

    def __call__(self) -> tuple[Any, Any]:
        from skatelib.control.params import SkateParams
        from skatelib.control.settings import ClosedLoop
        from skatelib.control.twin_feedback import Sensors
        from skatelib.control.twin_loop import TwinLoop, TwinLoopSettings
        from skatelib.control.twin_verdict import twin_result
        from skatelib.library import schema
        from skatelib.sim.errors import parse_twin_perturbation
        from skatelib.sim.figures import TwinFigures
        from skatelib.sim.plant import TwinPlant

        lib = MotionLibrary.open(self.path)
        nominal = SkateParams.from_library(lib)
        errors = parse_twin_perturbation(self.perturb, nominal.mu)
        plant = TwinPlant(TwinFigures.from_library(lib), errors)
        loop_settings = TwinLoopSettings(sensors=Sensors(errors.noise_std, errors.delay_s))
        loop = TwinLoop(lib, self.key, ClosedLoop(nominal, nominal, mpc=self.mpc, settings=self.settings), plant,
                        loop_settings, keep=self.keep_run)
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            run = loop.ride()
        label = float(lib[self.key].attrs[schema.A_TARGET_VELOCITY])
        result = twin_result(self.key, label, run)
        return result, (run.times, run.qpos) if self.keep_run else None


def twin_jobs(path: Path, keys: Sequence[str] | None, perturb: str, mpc: Any = None, settings: Any = None,
              keep_runs: bool = False) -> list[TwinJob]:
    """One twin job per chosen entry (all successful ones by default).

    Raises:
        SkatelibError: A library that is not a quadruped one, a bad perturbation, an unknown
            entry key (naming the valid ones), or MuJoCo missing, before any work.
    """
    try:
        from skatelib.control.mpc import MpcConfig
        from skatelib.control.params import SkateParams
        from skatelib.control.settings import TrackSettings
        from skatelib.sim.errors import parse_twin_perturbation
    except ImportError as e:
        raise SkatelibError(f"the twin needs MuJoCo and the controller ({e}); pip install 'skatelib[control,sim]'"
                            ) from e
    lib = MotionLibrary.open(path)
    if lib.kind != "quadruped":
        raise SkatelibError(f"{path}: the twin is a quadruped's; this library is {lib.kind}")
    parse_twin_perturbation(perturb, SkateParams.from_library(lib).mu)  # refuse a bad --perturb before any work
    chosen = list(keys) if keys else [e.key for e in lib if e.success]
    for k in chosen:
        lib[k]  # an unknown key raises EntryNotFound, naming the valid ones
    mpc = mpc or MpcConfig()
    settings = settings or TrackSettings()
    return [TwinJob(str(path), k, perturb, replace(mpc), settings, keep_runs) for k in chosen]
