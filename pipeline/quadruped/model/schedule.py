"""Contact scheduler (Sec. IV-A): periodic push cycles of one leg.

On the robot: four-leg balancing -> three-leg transfer (push leg board -> ground) -> n strides of
[push on the ground (duty x period), swing (rest of the period)] -> three-leg transfer (push leg
back onto the board) -> four-leg balancing. The trajectory optimization covers the strides (the
accelerating mode, :func:`knot_schedule`); the transfers and balancing are the controller's
(``skatelib.proving.closed_loop``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.library.channels import BOARD, GROUND, LEGS, SWING
from skatelib.pipeline.quadruped.config import ScheduleConfig


@dataclass(frozen=True)
class KnotSchedule:
    """Contacts on a uniform grid of knots.

    Attributes:
        t: (K,) knot times [s], K = N + 1.
        contact: (K, 4) int8 per knot and leg: the contact on [t_k, t_k+1) (the last knot repeats
            the phase that ends there).
    """

    t: np.ndarray
    contact: np.ndarray

    @property
    def n_intervals(self) -> int:
        return len(self.t) - 1

    def stance_intervals(self, leg: int, code: int) -> list[tuple[int, int]]:
        """Maximal runs [k0, k1) of intervals where ``leg`` has contact ``code``."""
        mask = self.contact[:-1, leg] == code
        runs, k = [], 0
        while k < len(mask):
            if mask[k]:
                k0 = k
                while k < len(mask) and mask[k]:
                    k += 1
                runs.append((k0, k))
            else:
                k += 1
        return runs


def knot_schedule(cfg: ScheduleConfig, n_strides: int, dt: float, lead_s: float = 0.0,
                  ground_s: float | None = None) -> KnotSchedule:
    """Contacts of the accelerating window on knots spaced ``dt`` apart: ``n_strides`` strides of the
    push foot on the ground (``ground_s``, the schedule's ``push_duty`` x ``period_s`` when None)
    then in the air to the end of the period; with ``lead_s`` the window starts that long earlier
    with the foot in the air (a transition from riding: the foot comes down from beside the deck).

    Raises:
        ValueError: When ``dt`` does not divide the period, the lead or the push time.
    """
    per = cfg.period_s / dt
    n_push = (cfg.push_duty * cfg.period_s if ground_s is None else ground_s) / dt
    n_lead = lead_s / dt
    for what, value in (("the period", per), ("the lead-in", n_lead)):
        if abs(value - round(value)) > 1e-6:
            raise ValueError(f"dt {dt} s does not divide {what} ({value * dt} s)")
    per_i, push_i, lead_i = round(per), round(n_push), round(n_lead)
    if push_i < 1 or push_i >= per_i:
        raise ValueError(f"push phase of {n_push:.2f} knots is empty or fills the period")
    p = LEGS.index(cfg.push_leg)
    n = lead_i + n_strides * per_i
    t = np.arange(n + 1) * dt
    contact = np.full((n + 1, 4), BOARD, dtype=np.int8)
    local = (np.arange(n + 1) - lead_i) % per_i
    contact[:, p] = np.where(local < push_i, GROUND, SWING)
    contact[:lead_i, p] = SWING
    contact[-1, p] = SWING  # the window ends at the end of the last swing
    return KnotSchedule(t=t, contact=contact)
