"""The observers of the closed loop: what the model misses, estimated from the feedback.

:class:`DisturbanceObserver` makes the MPC offset-free (the board's unmodelled forward
acceleration and the robot's vertical one); :class:`CoastObserver` measures the rolling
deceleration while the robot and board coast, for the coast compensation of the entry reference.
"""

from __future__ import annotations

import numpy as np
from skatelib.control.mpc import BOARD_V_REDUCED, NF, ROBOT_VZ_REDUCED, MpcProblem, board_heading


class DisturbanceObserver:
    """Estimates the board's unmodelled forward acceleration (``bias_mps2``) and the robot's
    unmodelled vertical one (``vertical_mps2``: a heavier robot sags) from what the model
    predicted for the last update and what the feedback then showed, low-pass filtered with
    ``gain`` per update."""

    def __init__(self, gain: float):
        self.gain = gain
        self.bias_mps2 = 0.0
        self.vertical_mps2 = 0.0
        self._predicted: tuple[float, float] | None = None

    def update(self, v_forward_measured: float, dt: float, v_vertical_measured: float | None = None) -> float:
        """Returns the board's estimate; the robot's is updated when its vertical speed is given."""
        if self._predicted is not None:
            self.bias_mps2 += self.gain * (v_forward_measured - self._predicted[0]) / dt
            if v_vertical_measured is not None:
                self.vertical_mps2 += self.gain * (v_vertical_measured - self._predicted[1]) / dt
        return self.bias_mps2

    def predict(self, qp: MpcProblem, U: np.ndarray) -> None:
        """Remember the model's forward board speed and the robot's vertical speed one step after
        ``U`` is applied."""
        x1 = qp.Ad[0] @ qp.x0 + qp.Bd[0] @ U[:NF] + qp.cd[0]
        self._predicted = (float(board_heading(qp.x0_full) @ x1[BOARD_V_REDUCED]), float(x1[ROBOT_VZ_REDUCED]))


class CoastObserver:
    """How hard rolling friction slows robot and board together [m/s^2], measured while no foot
    touches the ground: then only rolling friction changes their momentum (m_R v_R + m_B v_B),
    whatever the masses, the deck's stiffness or the feet on the deck do. Samples only above
    ``min_speed_mps``, where friction has its full size (tanh(k v) ~ 1); None until the first."""

    def __init__(self, gain: float, min_speed_mps: float = 0.05):
        self.estimate_mps2: float | None = None
        self.gain = gain
        self.min_speed_mps = min_speed_mps
        self._last: float | None = None

    def update(self, coasting: bool, momentum_speed_mps: float, dt: float) -> float | None:
        usable = coasting and abs(momentum_speed_mps) > self.min_speed_mps
        if usable and self._last is not None:
            sample = -(momentum_speed_mps - self._last) / dt * np.sign(momentum_speed_mps)
            last = sample if self.estimate_mps2 is None else self.estimate_mps2
            self.estimate_mps2 = last + self.gain * (sample - last)
        self._last = momentum_speed_mps if usable else None
        return self.estimate_mps2
