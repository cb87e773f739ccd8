"""What the twin is built from: the figures a library stores in ``/model`` (or a config gives the
same way), and the few a rigid-body model needs that the optimizer's model does not (wheels,
hangers, rotors), each with its source."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.runtime import MotionLibrary

# Figures of the jointed model that the optimizer's model has no use for. The wheels' radius is the
# optimizer's roll-axis height (the axles), their spacing its wheel track.
WHEEL_MASS_KG = 0.049  # the public quadruped-skateboard model (docs/sources.md)
HANGER_MASS_KG = 0.055  # the same model
DECK_THICKNESS_M = 0.015  # a 7-ply maple deck is about 12-15 mm
DECK_INERTIA_KGM2 = (0.00903, 0.0475, 0.0565)  # the public model's deck (docs/sources.md)
# Rotor inertia reflected through the gearbox: a rotor of 0.0567 kg (docs/sources.md) as a 30 mm
# disc (m r^2 / 2 = 2.55e-5 kg m^2) through CyberDog2's published 7.75:1 reduction.
ROTOR_INERTIA_KGM2 = 2.55e-5
GEAR_RATIO = 7.75
JOINT_DAMPING_NMS = 0.01  # bearing and gear friction: no public figure, chosen small
TIMESTEP_S = 0.001


@dataclass(frozen=True)
class BoardFigures:
    """The skateboard as the optimizer's model has it, plus the truck pivot in physical terms.

    Attributes:
        pivot_from_horizontal_rad: The trucks' pivot axis angle from the ground (lambda): a
            deck roll phi steers each truck by tan(delta) = sin(phi) tan(lambda).
    """

    mass_kg: float
    deck_length_m: float
    deck_width_m: float
    deck_height_m: float  # the deck's top above the ground
    l_front_m: float
    l_rear_m: float
    truck_width_m: float
    roll_stiffness_Nm_per_rad: float
    roll_damping_Nms_per_rad: float
    rolling_friction_coeff: float  # rolling resistance over the normal load on the wheels [-]
    pivot_from_horizontal_rad: float
    deck_mass_kg: float  # the deck's share of the mass (the rest: 2 hangers and 4 wheels)
    wheel_radius_m: float  # the axles' height: the deck's roll axis
    wheel_track_m: float  # between the left and right wheels' centres

    @property
    def wheel_y_m(self) -> float:
        return self.wheel_track_m / 2

    @property
    def axle_below_deck_m(self) -> float:
        return self.deck_height_m - self.wheel_radius_m


@dataclass(frozen=True)
class TwinFigures:
    """Everything :mod:`skatelib.sim.scene` builds the twin from."""

    urdf: str
    foot_radius_m: float
    friction_mu: float
    torque_limit_Nm: float
    gravity_mps2: float
    robot_mass_kg: float
    board: BoardFigures
    stance_q_rad: np.ndarray  # (12,) the four-leg stance on the deck (FL FR RL RR x abad hip knee)
    deck_points_m: np.ndarray  # (2, 4) the feet's deck points (x, y) in the board frame

    @staticmethod
    def from_model(model: Mapping[str, Any], arrays: Mapping[str, np.ndarray], urdf: str) -> TwinFigures:
        """From a library's ``/model`` attributes and arrays and its URDF.

        A library of format 1.1 names the truck pivot ``board_rake_front_rad``; its config gives
        that figure as the angle from the ground (the public model's truck axis, 1.1904 rad), and
        the twin builds it so, whatever the optimizer made of it; its other board figures the twin
        takes from the same public model (deck 1.874 kg, 30 mm wheels 0.22 m apart).
        """
        pivot = float(model.get("board_pivot_from_horizontal_rad", model.get("board_rake_front_rad", math.pi / 4)))
        total_weight = (float(model["robot_mass_kg"]) + float(model["board_mass_kg"])) * float(model["gravity_mps2"])
        coeff = float(model.get("board_rolling_coeff", float(model["board_rolling_friction_N"]) / total_weight))
        mass = float(model["board_mass_kg"])
        board = BoardFigures(
            mass_kg=float(model["board_mass_kg"]), deck_length_m=float(model["board_deck_length_m"]),
            deck_width_m=float(model["board_deck_width_m"]), deck_height_m=float(model["board_deck_height_m"]),
            l_front_m=float(model["board_l_front_m"]), l_rear_m=float(model["board_l_rear_m"]),
            truck_width_m=float(model["board_truck_width_m"]),
            roll_stiffness_Nm_per_rad=float(model["board_roll_stiffness_Nm_per_rad"]),
            roll_damping_Nms_per_rad=float(model["board_roll_damping_Nms_per_rad"]),
            rolling_friction_coeff=coeff, pivot_from_horizontal_rad=pivot,
            deck_mass_kg=float(model.get("board_deck_mass_kg", mass - 2 * HANGER_MASS_KG - 4 * WHEEL_MASS_KG)),
            wheel_radius_m=float(model.get("board_roll_axis_height_m", 0.03)),
            wheel_track_m=float(model.get("board_wheel_track_m", 0.22)))
        return TwinFigures(
            urdf=urdf, foot_radius_m=float(model["foot_radius_m"]), friction_mu=float(model["friction_mu"]),
            torque_limit_Nm=float(model["torque_limit_Nm"]), gravity_mps2=float(model["gravity_mps2"]),
            robot_mass_kg=float(model["robot_mass_kg"]), board=board,
            stance_q_rad=np.asarray(arrays["stance_q_board_rad"], dtype=np.float64).reshape(12),
            deck_points_m=np.asarray(arrays["stance_deck_points_m"], dtype=np.float64).reshape(-1, 4)[:2])

    @staticmethod
    def from_library(lib: MotionLibrary) -> TwinFigures:
        return TwinFigures.from_model(lib.model, lib.model_arrays, lib.urdf)
