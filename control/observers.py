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
    ``min_speed_mps``, where friction has its full size (tanh(k v) ~ 1); None until two in a coast.

    With ``fit`` (the default, ``MpcConfig.coast_fit``) the estimate is the slope of lines fitted
    to the coasts' momentum speeds (one slope for all, each stretch of samples its own offset), each
    earlier coast weighing ``1 - gain`` of the one after it (0: all alike; 1: the latest alone). A
    fit over a coast's samples averages the feedback's noise, which a difference of two updates
    divides by ``dt``: ``--perturb noise=0.002`` (1 cm/s on the speeds) spreads one difference at
    30 Hz by 0.3-0.5 m/s^2, twice the deceleration it measures. A stretch ends at a change between
    two updates that rolling friction cannot have made (:func:`friction_changes`: a shove, a foot
    touching the floor), which so weighs nothing in the fit; and the estimate is at least 0, as
    friction only slows. Without ``fit`` the estimate is a low-pass filter (``gain`` per update) of
    one-update decelerations, which takes a shove's deceleration, and the feedback's noise divided
    by ``dt``, for friction."""

    def __init__(self, gain: float, min_speed_mps: float = 0.05, fit: bool = True):
        self.estimate_mps2: float | None = None
        self.gain = gain
        self.min_speed_mps = min_speed_mps
        self.fit = fit
        self._coasts: list[tuple[float, list[float]]] = []  # each coast's update period [s] and speeds [m/s]
        self._coasting = False
        self._last: float | None = None

    def update(self, coasting: bool, momentum_speed_mps: float, dt: float) -> float | None:
        if not self.fit:
            return self._filtered(coasting, momentum_speed_mps, dt)
        if not (coasting and abs(momentum_speed_mps) > self.min_speed_mps):
            self._coasting = False
            return self.estimate_mps2
        if not self._coasting:
            self._coasts.append((dt, []))
            del self._coasts[:-MAX_COASTS]  # a robot that rides on keeps a bounded memory and update
            self._coasting = True
        self._coasts[-1][1].append(abs(momentum_speed_mps))  # its sign cannot change within a coast
        fit = self._fit()
        if fit is not None:
            self.estimate_mps2 = fit
        return self.estimate_mps2

    def _filtered(self, coasting: bool, momentum_speed_mps: float, dt: float) -> float | None:
        """Without ``fit``: a low-pass filter (``gain`` per update) of one-update decelerations."""
        usable = coasting and abs(momentum_speed_mps) > self.min_speed_mps
        if usable and self._last is not None:
            sample = -(momentum_speed_mps - self._last) / dt * np.sign(momentum_speed_mps)
            last = sample if self.estimate_mps2 is None else self.estimate_mps2
            self.estimate_mps2 = last + self.gain * (sample - last)
        self._last = momentum_speed_mps if usable else None
        return self.estimate_mps2

    def _fit(self) -> float | None:
        """The stretches' common slope, as a deceleration [m/s^2]; None without a stretch of two."""
        n = len(self._coasts)
        coasts = [(dt, np.asarray(v), (1.0 - self.gain) ** (n - 1 - i))
                  for i, (dt, v) in enumerate(self._coasts) if len(v) >= 2]
        if not coasts:
            return None
        v = np.concatenate([s for _, s, _ in coasts])
        t = np.concatenate([dt * np.arange(len(s)) for dt, s, _ in coasts])
        weight = np.concatenate([np.full(len(s), w) for _, s, w in coasts])
        first = np.concatenate([np.arange(len(s)) == 0 for _, s, _ in coasts])
        within = ~first[1:]  # consecutive samples of one coast
        starts = first.copy()  # where a stretch starts: a coast's first sample, or after a change friction cannot make
        starts[1:][within] = ~friction_changes(-np.diff(v)[within] / np.diff(t)[within])
        stretch = np.cumsum(starts) - 1
        count, st, sv = (np.bincount(stretch, x) for x in (None, t, v))
        sxx = np.bincount(stretch, weight * t * t) - weight[starts] * st * st / count
        sxy = np.bincount(stretch, weight * t * v) - weight[starts] * st * sv / count
        total = float(np.sum(sxx))
        return max(-float(np.sum(sxy)) / total, 0.0) if total > 1e-12 * float(np.sum(weight * t * t)) else None


# The coasts a fit reads, the latest: at the default gain (0.2) the one before them would weigh
# 0.8^32 ~ 8e-4 of the latest, and an update fits some 600 samples at most.
MAX_COASTS = 32

# A change this many robust standard deviations from the median is no noise: Iglewicz and Hoaglin's
# outlier bound on the modified z-score 0.6745 (x - median) / MAD.
NOISE_SIGMAS = 3.5


def friction_changes(d: np.ndarray) -> np.ndarray:
    """Which of the one-update decelerations ``d`` [m/s^2] of coasts rolling friction can have
    made. Friction only slows the board, and steadily through a coast (the wheels carry the whole
    weight), so a change that does not slow it, or slows it more than twice as hard as the median
    change, is something else; where the feedback's noise spreads the changes wider than that, the
    bound is :data:`NOISE_SIGMAS` robust standard deviations (1.4826 median absolute deviations)
    from the median."""
    median = float(np.median(d))
    spread = 1.4826 * float(np.median(np.abs(d - median)))
    return np.abs(d - median) < max(abs(median), NOISE_SIGMAS * spread)
