"""The proving ground's multibody plant as the controller senses it: the :class:`MultibodyPlant`
protocol a plant meets (the MuJoCo twin), and the state the controller is fed from it, with the
sensors' noise and delay.

The controller's estimate is the plant's own state, delayed by ``delay_s`` and with white noise
of ``noise_std`` on the trunk's position [m] and attitude [rad] (5x that on their rates, per
second): no estimator is modelled, so a run shows what the controller makes of a state as good
as a robot's kinematic-inertial estimate at best.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np


class MultibodyPlant(Protocol):
    """A plant driven by joint torques (channel order), stepped at its own timestep."""

    @property
    def timestep_s(self) -> float: ...

    @property
    def axle_below_deck_m(self) -> float: ...  # the deck's roll axis below its top (its state's origin)

    def qpos(self) -> np.ndarray: ...

    def place(self, trunk_pos: np.ndarray, trunk_quat_wxyz: np.ndarray, q: np.ndarray,
              deck_pose: np.ndarray) -> None: ...

    def launch(self, speed_mps: float) -> None: ...  # robot and board rolling forward, wheels turning

    def foot_centres(self) -> np.ndarray: ...

    def shift_robot(self, dz: float) -> None: ...

    def push(self, force_N: np.ndarray) -> None: ...  # a force on the trunk [N], world frame, held

    def step(self, tau: np.ndarray, n: int = 1) -> None: ...

    def state(self) -> Any:
        """The plant now, a state of its own: the run's meter keeps up to a chunk of them before it
        measures them, so no later step may change one."""
        ...



@dataclass(frozen=True)
class Sensors:
    noise_std: float = 0.0
    delay_s: float = 0.0


class SensedState:
    """The plant's states as the controller gets them: ``delay_s`` late, with noise."""

    def __init__(self, sensors: Sensors, tick_s: float, seed: int):
        self.sensors = sensors
        self.lag = max(0, round(sensors.delay_s / tick_s))
        self.queue: deque[Any] = deque(maxlen=self.lag + 1)
        self.rng = np.random.default_rng(seed)

    def __call__(self, st: Any) -> Any:
        self.queue.append(st)
        out = self.queue[0]
        sd = self.sensors.noise_std
        if sd <= 0:
            return out
        rng = self.rng
        a = rng.normal(0.0, sd, 3)
        c, s = math.cos, math.sin
        turn = (np.array([[1, 0, 0], [0, c(a[0]), -s(a[0])], [0, s(a[0]), c(a[0])]])
                @ np.array([[c(a[1]), 0, s(a[1])], [0, 1, 0], [-s(a[1]), 0, c(a[1])]])
                @ np.array([[c(a[2]), -s(a[2]), 0], [s(a[2]), c(a[2]), 0], [0, 0, 1]]))
        return replace(out, trunk_pos=out.trunk_pos + rng.normal(0.0, sd, 3), trunk_R=out.trunk_R @ turn,
                       trunk_v=out.trunk_v + rng.normal(0.0, 5 * sd, 3),
                       trunk_omega=out.trunk_omega + rng.normal(0.0, 5 * sd, 3))
