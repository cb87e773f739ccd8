"""What ``track`` and its Python function share: the controller's settings from the command's
options, and the closed-loop runner with its progress (a function of yours, or the command's bar)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Final


def controller(solver: str, mpc_mu: float | None, seed: int, state: str) -> tuple[Any, Any]:
    """The MPC's and the run's settings of ``track``, ``mpc_mu`` checked.

    Raises:
        ImportError: The controller's packages are missing, naming the extra.
        ValueError: ``mpc_mu`` not a number from 0.05 to 2.
    """
    if mpc_mu is not None and not (isinstance(mpc_mu, int | float) and 0.05 <= mpc_mu <= 2.0):
        raise ValueError(f"skatelib.track(mpc_mu={mpc_mu!r}): mpc_mu is a friction coefficient from 0.05 to 2")
    try:
        from skatelib.control.mpc import MpcConfig
        from skatelib.control.settings import TrackSettings
    except ImportError as e:
        raise ImportError(f"the controller's packages are missing ({e}); pip install 'skatelib[control]'") from e
    return MpcConfig(solver=solver, mu=mpc_mu), TrackSettings(seed=seed, state=state)


# What `track --plant mujoco` feeds the controller unless told: the robot's estimator on the twin's
# sensors, as on the robot ("true": the twin's own state, what the build's twin judge, `validate
# --closed-loop` and `TrackSettings` ride on).
DEFAULT_TWIN_STATE: Final = "estimate"

# The twin's --perturb keys that act on the twin's own state fed to the controller, and the
# sensors' keys that do the same on the estimate.
SENSED_KEYS = {"noise": "imu_noise", "delay": "sensor_delay"}


def plant_errors(perturb: str, on_twin: bool, state: str, option: str = "--perturb") -> str:
    """``track``'s model-error text (``none``: none), a text that names errors
    (:func:`named_errors`), its sensed-state keys checked on the twin (:func:`sensed_keys_checked`)."""
    errors = "" if named_errors(perturb, on_twin, option) == "none" else perturb
    if on_twin:
        sensed_keys_checked(errors, state, option)
    return errors


def unnamed_errors(perturb: object) -> str | None:
    """Why ``perturb`` names no model error (an empty text, commas alone, not a text; the command
    line's ``--perturb`` and the Python functions refuse it alike), or None when it names one."""
    if isinstance(perturb, str) and any(s.strip() for s in perturb.split(",")):
        return None
    what = "names no model error" if isinstance(perturb, str) else "is not a text"
    return f"{perturb!r} {what}: give KEY=VALUE,... or 'none' for the plant as planned"


def named_errors(perturb: object, on_twin: bool, option: str) -> str:
    """``perturb`` when it is a text that names at least one model error, or ``none``: what the
    command line's ``--perturb`` refuses at its edge, checked for the Python functions too (an
    empty text would ride the plant as planned under the name '').

    Raises:
        PerturbationError: (TwinPerturbationError on the twin; both a ValueError) naming ``option``,
            the value and the spelling of no error.
    """
    why = unnamed_errors(perturb)
    if why is None:
        return str(perturb)
    message = f"{option}: {why}"
    if on_twin:
        from skatelib.sim.errors import TwinPerturbationError

        raise TwinPerturbationError(message)
    from skatelib.proving.perturb import PerturbationError

    raise PerturbationError(message)


def sensed_keys_checked(perturb: str, state: str, option: str = "--perturb") -> None:
    """On the estimate, refuse the keys that add noise and delay to the twin's own state (the
    estimate never reads that state: they would change nothing).

    Raises:
        SkatelibError: Naming the keys, their sensors' counterparts and ``--state true``; a text
            the twin's parser refuses (an unknown key, a value out of its range), as it does.
    """
    if state != "estimate":
        return
    from skatelib.library.errors import SkatelibError
    from skatelib.library.perturb import bounded, perturbation_items
    from skatelib.sim.errors import TWIN_KEYS, TwinPerturbationError

    given: set[str] = set()
    for item, key, number, _ in perturbation_items(perturb, TWIN_KEYS, TwinPerturbationError):
        if key in SENSED_KEYS:
            bounded(item, key, number, TwinPerturbationError)  # a value out of its range is refused as such first
            given.add(key)
    bad = sorted(given)
    if bad:
        instead = ", ".join(SENSED_KEYS[k] for k in bad)
        raise SkatelibError(f"{option} {', '.join(bad)}: noise and delay on the twin's own state, which the "
                            f"controller does not read on the estimate (the default): give the sensors' "
                            f"{instead}, or add --state true")


def run_jobs(calls: Sequence[Callable[[], Any]], jobs: int, progress: bool | Callable[[int, int], None],
             label: str) -> list[Any]:
    """Run the picklable ``calls`` on ``jobs`` workers (the build's runner); progress goes to a
    function of (done, total), to the command's bar (True) or to nothing."""
    if callable(progress):
        from skatelib.pipeline.build.sweep import run_calls

        return run_calls(calls, jobs, lambda n: progress(n, len(calls)))
    from skatelib.pipeline.views.console import run_with_progress

    return run_with_progress(calls, jobs, label, bool(progress))
