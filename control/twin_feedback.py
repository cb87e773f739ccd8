"""What the controller reads from a multibody plant (the twin, or a robot's estimator): the
:class:`MultibodyPlant` protocol a plant meets, and the state the MPC and the whole-body
controller are fed from it, with the sensors' noise and delay.

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
from skatelib.library.channels import NX

# A foot's touch code in ``MultibodyState.foot_touch`` (0: touching nothing).
ON_DECK, ON_FLOOR = 1, 2


class MultibodyState(Protocol):
    """The fields of one plant instant the controller reads (world frame; see the twin's state)."""

    t: float
    trunk_pos: np.ndarray
    trunk_R: np.ndarray
    trunk_v: np.ndarray
    trunk_omega: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    deck_pos: np.ndarray
    deck_R: np.ndarray
    deck_v: np.ndarray
    deck_omega: np.ndarray
    foot_centres: np.ndarray
    foot_velocities: np.ndarray
    foot_touch: np.ndarray
    contact_points: np.ndarray

    @property
    def deck_yaw(self) -> float: ...

    @property
    def deck_roll(self) -> float: ...


class MultibodyPlant(Protocol):
    """A plant driven by joint torques (channel order), stepped at its own timestep."""

    @property
    def timestep_s(self) -> float: ...

    def qpos(self) -> np.ndarray: ...

    def place(self, trunk_pos: np.ndarray, trunk_quat_wxyz: np.ndarray, q: np.ndarray,
              deck_pose: np.ndarray) -> None: ...

    def launch(self, speed_mps: float) -> None: ...  # robot and board rolling forward, wheels turning

    def foot_centres(self) -> np.ndarray: ...

    def shift_robot(self, dz: float) -> None: ...

    def step(self, tau: np.ndarray, n: int = 1) -> None: ...

    def state(self) -> Any: ...


def rpy_of(R: np.ndarray) -> np.ndarray:
    """Z-Y-X angles (roll, pitch, yaw) of a rotation matrix."""
    return np.array([math.atan2(R[2, 1], R[2, 2]), -math.asin(max(-1.0, min(1.0, R[2, 0]))),
                     math.atan2(R[1, 0], R[0, 0])])


def quat_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return np.asarray(q / np.linalg.norm(q))


def mpc_state(st: MultibodyState, com: np.ndarray, com_v: np.ndarray) -> np.ndarray:
    """The MPC's 28 channels: the centre of mass (of the controller's model at the measured
    joints), trunk angles and rates, joints, board."""
    x = np.zeros(NX)
    R = st.trunk_R
    x[0:3] = com
    x[3:6] = rpy_of(R)
    x[6:9] = com_v
    x[9:12] = st.trunk_omega
    x[12:24] = st.q
    x[24:26] = st.deck_v[0:2]
    x[26] = st.deck_roll
    x[27] = float(st.deck_R[:, 0] @ st.deck_omega)
    return x


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
