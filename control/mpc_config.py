"""The MPC's settings (:class:`MpcConfig`): rate, horizon, friction pyramid, force bounds, weights,
the QP backend and the observers' gains."""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class MpcConfig:
    """MPC settings.

    Attributes:
        rate_hz: Update rate (the paper: 30 Hz) of the model plant's loop (:mod:`skatelib.proving.loop`);
            :class:`~skatelib.control.controller.SkateController` updates at its ``Rates``.
        horizon: Steps N (the paper's MIT-Cheetah lineage: 10).
        mu: Friction coefficient the MPC assumes (its pyramid is inside this cone); None: the
            one the library was planned with (``friction_mu_plan``, a margin inside ``friction_mu``).
        facets: Sides of the friction pyramid (4 or more).
        f_min_N / f_max_N: Normal force bounds of a loaded foot.
        q_weights / r_weights: Diagonals of Q (28) and R (24).
        solver: ``daqp``, ``proxqp`` or ``osqp`` (:mod:`skatelib.control.mpc_solvers`).
        disturbance_gain: Gain of the board-acceleration disturbance observer per update (0: off).
        coast_gain: The coast observer's gain (:class:`skatelib.control.observers.CoastObserver`):
            each earlier coast weighs ``1 - coast_gain`` of the one after it in the fit (0: all
            alike; 1: the latest alone); without ``coast_fit``, its filter's gain per update.
        coast_fit: The coast observer fits a line over the coasts and leaves out the changes
            rolling friction cannot make (a shove, a foot on the floor), instead of filtering
            one-update differences: it reads a shove and the feedback's noise far less as friction
            (docs/closed-loop.md, "How a coast is measured"). False: the low-pass filter.
        torque_steps: Steps of the horizon with torque rows (1: the applied force only; on the
            default library all 10 gave the same verdicts and torques at 0.2 ms more per update).
        coast_compensation: Move each push's speed reference by what the following coast will
            gain or lose against the plan (measured while coasting; before the first coast, see
            :meth:`skatelib.control.reference.EntryReference.prior_coast_mps2`), so that the entry
            still ends at its label; False: track the plan's speeds.
    """

    rate_hz: float = 30.0
    horizon: int = 10
    mu: float | None = None
    facets: int = 8
    f_min_N: float = 0.0
    f_max_N: float = 120.0
    solver: str = "daqp"
    disturbance_gain: float = 0.3
    coast_gain: float = 0.2
    coast_fit: bool = True
    torque_steps: int = 1
    coast_compensation: bool = True
    q_weights: tuple[float, ...] = field(default_factory=lambda: (
        (4e4, 4e4, 4e4) + (4e3, 4e3, 2e3) + (300.0, 300.0, 300.0) + (20.0, 20.0, 20.0) + (1.0,) * 12
        + (2e3, 2e3) + (2e3, 5.0)))
    r_weights: tuple[float, ...] = field(default_factory=lambda: (1e-2,) * 12 + (1e-2,) * 12)

    def __post_init__(self) -> None:
        """Raises:
            ValueError: A setting out of its range, naming it (a friction coefficient of 0 or below,
                a pyramid of fewer than 4 sides, force bounds that cross, weights of another
                length or not finite and at least 0, ...).
        """
        from skatelib.control.qp import SOLVERS

        checks = (
            ("rate_hz", math.isfinite(self.rate_hz) and self.rate_hz > 0, "a rate above 0 Hz"),
            ("horizon", self.horizon >= 1, "at least 1 step"),
            ("mu", self.mu is None or (math.isfinite(self.mu) and self.mu > 0), "None or a coefficient above 0"),
            ("facets", self.facets >= 4, "4 sides or more"),
            ("f_min_N", math.isfinite(self.f_min_N) and 0 <= self.f_min_N <= self.f_max_N, "0 up to f_max_N"),
            ("f_max_N", math.isfinite(self.f_max_N) and self.f_max_N > 0, "a force above 0 N"),
            ("solver", self.solver in SOLVERS, f"one of {', '.join(SOLVERS)}"),
            ("disturbance_gain", 0 <= self.disturbance_gain <= 1, "a gain from 0 to 1"),
            ("coast_gain", 0 <= self.coast_gain <= 1, "a gain from 0 to 1"),
            ("torque_steps", 1 <= self.torque_steps <= self.horizon, "1 up to the horizon"),
            ("q_weights", _weights(self.q_weights, 28), "28 finite weights, each at least 0"),
            ("r_weights", _weights(self.r_weights, 24), "24 finite weights, each at least 0"),
        )
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"MpcConfig({name}={getattr(self, name)!r}): {allowed}")

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz


def _weights(w: tuple[float, ...], n: int) -> bool:
    return len(w) == n and all(math.isfinite(x) and x >= 0 for x in w)
