"""The config tables of the skateboard (``[board]``) and of the push foot's contact with the ground
(``[contact]``), with their units, ranges and sources."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from skatelib.pipeline.config_tables import setting as _f

_RAKE = ("no longer read: it was used as gamma of Eq. (11), the pivot's angle from the vertical, while "
         "configs gave the angle from the ground. Write pivot_from_horizontal_rad = the trucks' pivot axis angle "
         "from the ground (0.785 for a typical 45-degree street truck)")


@dataclass(frozen=True)
class BoardConfig:
    RENAMED: ClassVar[dict[str, str]] = {"rake_front_rad": _RAKE, "rake_rear_rad": _RAKE}

    deck_length_m: float = _f(0.1, 2.0, "Deck length [m] (paper Sec. II-B: 0.74).")
    deck_width_m: float = _f(0.05, 1.0, "Deck width [m] (paper: 0.265).")
    deck_height_m: float = _f(0.0, 0.5, "Height of the deck's top surface above the ground [m].")
    truck_distance_m: float = _f(0.05, 2.0, "Distance between front and rear truck pivots [m] (0.49).")
    truck_width_m: float = _f(0.05, 1.0, "Truck (axle) width [m] (0.24).")
    mass_kg: float = _f(0.1, 50.0, "Whole skateboard mass m_B of Eq. (9b) [kg].")
    deck_mass_kg: float = _f(0.0, 50.0, "The deck's share of the mass: what rolls about the roll axis [kg].")
    roll_inertia_kgm2: float = _f(
        1e-5, 10.0, "Deck roll inertia about its centre of mass [kg m^2]; Eq. (7) adds m_deck h^2 about the roll axis.")
    pivot_from_horizontal_rad: float = _f(
        0.05, 1.52, "The trucks' pivot axis angle lambda from the ground: tan(delta) = sin(phi) tan(lambda) [rad].")
    roll_axis_height_m: float = _f(0.0, 0.5, "Height of the deck's roll axis (the axles) above the ground [m].")
    wheel_track_m: float = _f(0.02, 1.0, "Distance between the left and right wheels' contact points [m].")
    wheel_load_margin: float = _f(
        0.0, 0.9, "The deck loads' roll moment stays within (1 - margin) of what the wheel track holds [-].")
    calibration_roll_rad: float = _f(
        0.01, 0.5, "Steady roll [rad] when the robot's weight rests on one side's feet; K_B is set so."
    )
    roll_damping_ratio: float = _f(0.05, 10.0, "Damping ratio of the free deck roll; sets B_B of Eq. (6) [-].")
    rolling_friction_coeff: float = _f(0.0, 0.2, "Rolling resistance over the wheels' load, Eq. (9b) [-].")
    tanh_scale_s_per_m: float = _f(1.0, 1e4, "Scale k of the tanh smoothing of sign(v), Eq. (10) [s/m].")
    roll_limit_rad: float = _f(0.01, 0.6, "Largest allowed deck roll |phi_B| [rad].")
    source: str = _f(doc="Where the figures come from.", default="")


@dataclass(frozen=True)
class ContactConfig:
    near_ground_m: float = _f(0.0, 0.1, "Height of the push foot's sphere bottom below which it moves slowly [m].")
    near_ground_speed_mps: float = _f(0.0, 5.0, "Its largest horizontal speed over the ground there [m/s].")
    near_ground_descent_mps: float = _f(0.0, 5.0, "Its largest descent speed there [m/s].")
    min_deck_load_fraction: float = _f(
        0.0, 0.24, "Each foot on the deck pushes down with at least this share of the robot's weight [-]: the centre "
        "of mass stays inside the feet's support with a margin (0: a foot may unload, leaving the body balanced on an "
        "edge).",
        default=0.0)
