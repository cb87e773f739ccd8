"""How a closed loop is set up: the whole set-up (model, plant, disturbances, MPC, settings) that
every closed-loop function of the proving ground takes as one object."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from skatelib.control.mpc import MpcConfig
from skatelib.control.params import SkateParams
from skatelib.control.settings import TrackSettings
from skatelib.proving.perturb import Disturbances


@dataclass(frozen=True)
class ClosedLoop:
    """One closed-loop set-up.

    Attributes:
        model: What the controller believes (the library's model).
        plant: What it drives (the model with the perturbation applied).
        dist: Disturbances of the run (noise, an impulse, a COM offset, an initial error).
        mpc: The MPC's settings.
        settings: The run's settings.
    """

    model: SkateParams
    plant: SkateParams
    dist: Disturbances = field(default_factory=Disturbances)
    mpc: MpcConfig = field(default_factory=MpcConfig)
    settings: TrackSettings = field(default_factory=TrackSettings)


def one_blas_thread() -> Any:
    """A context in which every BLAS a ride calls runs on one thread (a ride's matrices are small;
    more threads only spin on the other core, and the MPC's timings would measure them). SciPy's
    own OpenBLAS, which the MPC's solves call, is loaded when ``scipy.linalg`` is first imported:
    a limit set before that would leave it on every core for the first ride of each process."""
    import scipy.linalg  # noqa: F401  (loads SciPy's BLAS, so that the limit reaches it)
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
