"""What the humanoid twin tells: its sensors' readings (:class:`Readings`) and what happened
(:class:`Truth`), as :class:`skatelib.sim.humanoid.plant.HumanoidPlant` reads them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Readings:
    """The robot's sensors at one instant (noise included).

    Attributes:
        imu_quat_wxyz / imu_gyro: The waist's orientation and its rate in the waist frame.
        ft_force / ft_torque: (2, 3) right then left: the wrench the ground side exerts on the foot
            below each ankle sensor, in the foot frame, about the sensor's point.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    imu_quat_wxyz: np.ndarray
    imu_gyro: np.ndarray
    ft_force: np.ndarray
    ft_torque: np.ndarray


@dataclass(frozen=True)
class Truth:
    """What happened (world frame): the COM, each sole's contact and the other links on the floor.

    Attributes:
        sole_force: (2, 3) the floor's (or a skate's deck's) force on each sole box; sole_zmp (2, 2)
            its centre of pressure on the plane of its bottom (NaN without contact); zmp (2,) both
            soles' together, on the plane ``truth``'s ``plane_z`` names.
        sole_pos / sole_yaw: (2, 3) / (2,) the soles' frames; sole_v / sole_wz their velocity and
            yaw rate.
    """

    t: float
    com: np.ndarray
    com_v: np.ndarray
    base_pos: np.ndarray
    base_R: np.ndarray
    sole_force: np.ndarray
    sole_zmp: np.ndarray
    zmp: np.ndarray
    sole_pos: np.ndarray
    sole_yaw: np.ndarray
    sole_v: np.ndarray
    sole_wz: np.ndarray
    torque: np.ndarray
    floor_touches: tuple[str, ...]
    deck_pos: np.ndarray | None = None  # a skate's deck: its top's centre (3,), orientation (3, 3) and velocity (3,)
    deck_R: np.ndarray | None = None
    deck_v: np.ndarray | None = None

    def on_deck(self, p: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the deck's frame (its top's centre, x forward)."""
        if self.deck_pos is None or self.deck_R is None:
            raise ValueError("the twin has no board")
        return np.asarray((np.asarray(p) - self.deck_pos) @ self.deck_R)
