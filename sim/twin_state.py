"""One instant of the quadruped twin, as :class:`skatelib.sim.plant.TwinPlant` reads it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.library.rotations import roll_of, yaw_of


@dataclass
class TwinState:
    """One instant of the twin (world frame unless named otherwise).

    Attributes:
        trunk_omega: Angular velocity of the trunk in the trunk frame.
        deck_omega: Angular velocity of the deck in the world frame.
        foot_centres / foot_velocities: (3, 4) the foot spheres' centres and their velocities.
        foot_touch: (4,) per foot NO_CONTACT, ON_DECK or ON_FLOOR.
        contact_points: (3, 4) where each touching foot touches (its centre less a radius along
            the surface normal otherwise).
        foot_spins: (3, 4) the foot spheres' angular velocities (for the slip at the contact point).
        foot_load_N: (4,) each foot's normal force on what it touches.
        wheel_load_N: (4,) normal force of each wheel on the floor.
        wheel_force_N: (3,) the floor's force on all four wheels.
        system_v: (3,) velocity of the centre of mass of robot and board together.
        system_mass_kg: Their mass.
        floor_touches: Names of the geoms other than feet and wheels that touch the floor.
    """

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
    foot_spins: np.ndarray
    foot_load_N: np.ndarray
    wheel_load_N: np.ndarray
    wheel_force_N: np.ndarray
    system_v: np.ndarray
    system_mass_kg: float
    floor_touches: tuple[str, ...]

    @property
    def deck_yaw(self) -> float:
        return yaw_of(self.deck_R)

    @property
    def deck_roll(self) -> float:
        """Roll about the deck's own x axis (Z-Y-X angles)."""
        return roll_of(self.deck_R)
