"""A closed-loop run's settings that the entry reference reads (the transfer, the ride after it)
besides the proving ground's (plant steps, seed)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TrackSettings:
    """Closed-loop run settings.

    Attributes:
        plant_substeps: Plant RK4 steps per MPC update (30 Hz x 17 = 510 Hz).
        transfer_s: Push leg back onto the deck after the entry [s] (Sec. IV-A: 0.4 s).
        ride_s: Four-leg riding after the transfer [s].
        seed: Random seed of the feedback noise (and of the sensors' errors).
        state: On a multibody plant, what the controller is fed: ``"estimate"`` (the robot's
            estimator on the plant's IMU and joint encoders) or ``"true"`` (the plant's state).
        board_mass_always: The MPC models the board with its mass (Eq. 9) also while balancing;
            False uses the paper's balancing model Eq. (5a) there (the board follows the robot),
            with which the default model-error set falls after the push-off (docs/closed-loop.md).
    """

    plant_substeps: int = 17
    board_mass_always: bool = True
    transfer_s: float = 0.4
    ride_s: float = 1.5
    seed: int = 0
    state: str = "true"
