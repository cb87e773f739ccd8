"""The model errors (``track --perturb``) that make the proving ground's model plant differ from the
controller's model, and the disturbances of a run beyond them."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from skatelib.control.params import SkateParams
from skatelib.library.errors import SkatelibError
from skatelib.library.perturb import BOUNDS, FACTOR, bounded, perturbation_items

if TYPE_CHECKING:  # the controller's reference, imported by the loops that ride it
    from skatelib.control.reference import Reference


class PerturbationError(SkatelibError, ValueError):
    """A ``--perturb`` item is malformed, names an unknown key or a value out of its range."""


# --perturb key -> the SkateParams field it changes.
PERTURB_KEYS: dict[str, str] = {
    "mass": "mass_kg",
    "inertia": "inertia_kgm2",
    "board_mass": "board_mass_kg",
    "kb": "kb_Nm_per_rad",
    "bb": "bb_Nms_per_rad",
    "rolling": "rolling_N",
    "mu": "mu",
    "tanh": "tanh_scale_s_per_m",
}
EXTRA_KEYS = ("com", "noise", "impulse", "impulse_t", "init")


@dataclass(frozen=True)
class Disturbances:
    """What happens to the plant beyond its parameters.

    Attributes:
        com_offset_m: Shift of the true COM from the model's, trunk frame y [m] (lateral).
        noise_std: Standard deviation of the feedback noise on positions [m] and angles [rad]
            (velocities get 5x that per second of it, joint angles none).
        impulse_Ns: Lateral impulse on the trunk [N s], applied over one plant step.
        impulse_t_s: When, from the start of the entry [s]: before the run's end
            (:func:`impulse_checked`).
        init_error_m: Initial lateral and vertical base position error [m].
    """

    com_offset_m: float = 0.0
    noise_std: float = 0.0
    impulse_Ns: float = 0.0
    impulse_t_s: float = 1.0
    init_error_m: float = 0.0


def parse_perturbation(text: str, nominal: SkateParams) -> tuple[SkateParams, Disturbances]:
    """Apply ``KEY=VALUE,...`` to the nominal parameters: ``+10%`` or ``-20%`` is relative, a plain
    number absolute (``mu=0.5``; for ``inertia`` a factor; ``com=0.01`` [m], ``noise=0.001``, ``impulse=0.5`` [N s] at
    ``impulse_t`` [s], ``init=0.01`` [m]). ``rolling`` changes the rolling-resistance coefficient
    (the force at the nominal weight); the force follows the plant's weight (``mass``, ``board_mass``).
    ``tanh`` is the plant's k of Eq. (10) [s/m] (``tanh=500``: rolling resistance close to Coulomb's).
    Each key's value (a factor of the nominal one for the figures that scale) within
    :data:`skatelib.library.perturb.BOUNDS`.

    Raises:
        PerturbationError: Naming the item and the valid keys, or the value and its allowed range.
    """
    changes: dict[str, Any] = {}
    extra: dict[str, float] = {}
    for item, key, number, relative in perturbation_items(text, [*PERTURB_KEYS, *EXTRA_KEYS], PerturbationError):
        if key in EXTRA_KEYS:
            if relative:
                raise PerturbationError(f"--perturb {item!r}: {key} takes an absolute value")
            extra[key] = bounded(item, key, number, PerturbationError)
            continue
        field = PERTURB_KEYS[key]
        base = getattr(nominal, field)
        if relative or key == "inertia":  # a plain number for inertia (a matrix) is a factor
            factor = 1.0 + number / 100.0 if relative else number
            new = base * factor
        else:
            new = number
            factor = number / base if base else (1.0 if number == 0 else math.inf)
        bounded(item, key, factor if BOUNDS[key].unit == FACTOR else float(new), PerturbationError)
        changes[field] = new
    # Rolling resistance is a coefficient times the weight on the wheels (Eq. 9b, the config's
    # rolling_friction_coeff): a heavier or lighter robot or board changes the force with it.
    changed = dataclasses.replace(nominal, **changes)
    weight_ratio = (changed.mass_kg + changed.board_mass_kg) / (nominal.mass_kg + nominal.board_mass_kg)
    changes["rolling_N"] = changes.get("rolling_N", nominal.rolling_N) * weight_ratio
    dist = Disturbances(
        com_offset_m=extra.get("com", 0.0), noise_std=extra.get("noise", 0.0),
        impulse_Ns=extra.get("impulse", 0.0), impulse_t_s=extra.get("impulse_t", 1.0),
        init_error_m=extra.get("init", 0.0),
    )
    return dataclasses.replace(nominal, **changes), dist


DEFAULT_PERTURBATION = "mass=+10%,kb=-20%,rolling=+100%,mu=0.5"


def run_updates(ref: Reference, mpc_dt_s: float) -> int:
    """How many MPC updates the loop (:mod:`skatelib.proving.loop`) ticks in a run of ``ref``: whole
    updates from ``ref.t0`` to the nearest of ``ref.t_stop`` (an entry's: its plan, then the
    transfer and the riding of its ``TrackSettings``; a chained ride's: the joined stages' plan,
    then the same; the steering maneuver's: its duration)."""
    return round((ref.t_stop - ref.t0) / mpc_dt_s)


def impulse_checked(dist: Disturbances, ref: Reference, rates: tuple[float, int], what: str = "the run") -> None:
    """Refuse an impulse timed where the run of ``ref`` would never apply it. The loop applies it in
    the plant step that starts within half a step of ``impulse_t``, so none at or after the run's
    end less half a step. The run's length is the reference's own: an entry's, a chained ride's
    and the steering maneuver's are each checked exactly.

    Args:
        dist: The disturbances (an impulse of 0 is never refused).
        ref: The run's reference.
        rates: The MPC's update period [s] and the plant steps per update.
        what: The run, for the message.

    Raises:
        PerturbationError: Naming ``impulse_t``, ``what`` and when it ends.
    """
    mpc_dt_s, substeps = rates
    end = ref.t0 + run_updates(ref, mpc_dt_s) * mpc_dt_s
    latest = end - mpc_dt_s / substeps / 2
    if dist.impulse_Ns and dist.impulse_t_s >= latest:
        plan = f" (its plan ends at {ref.t_end:.2f} s, then transfer and riding)" if ref.t_end > ref.t0 else ""
        raise PerturbationError(f"--perturb impulse_t={dist.impulse_t_s:g}: {what} ends at {end:.2f} s{plan}, so "
                                f"the impulse would never be applied; give an impulse_t below {latest:.3f} s")
