"""What the controller reads of the robot and its board at a tick (from the robot's estimator,
or a multibody plant's state in the proving ground): the :class:`MultibodyState` protocol, and
the MPC's 28 channels made of it."""

from __future__ import annotations

import math
from typing import Protocol

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
