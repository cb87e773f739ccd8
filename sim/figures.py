"""What the twin is built from: the figures a library stores in ``/model`` (or a config gives the
same way), and the few a rigid-body model needs that the optimizer's model does not (wheels,
hangers, rotors), each with its source."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.library.model import PUBLIC_HANGER_MASS_KG, PUBLIC_WHEEL_MASS_KG, QuadrupedModel
from skatelib.runtime import MotionLibrary

# Figures of the jointed model that the optimizer's model has no use for. The wheels' radius is the
# optimizer's roll-axis height (the axles), their spacing its wheel track.
WHEEL_MASS_KG = PUBLIC_WHEEL_MASS_KG  # the public quadruped-skateboard model (docs/sources.md)
HANGER_MASS_KG = PUBLIC_HANGER_MASS_KG  # the same model
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
    deck_inertia_kgm2: tuple[float, float, float] = DECK_INERTIA_KGM2  # about the deck's centre, deck frame

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
    def from_record(model: QuadrupedModel, urdf: str) -> TwinFigures:
        """From a library's ``/model`` record (:mod:`skatelib.library.model`: a format 1.1 library's
        truck axis is its ``board_rake_front_rad``, the angle from the ground, and its other board
        figures the public model's) and its URDF: the physical board, whatever the optimizer made of it."""
        b = model.board
        board = BoardFigures(
            mass_kg=b.mass_kg, deck_length_m=b.deck_length_m, deck_width_m=b.deck_width_m,
            deck_height_m=b.deck_height_m, l_front_m=b.l_front_m, l_rear_m=b.l_rear_m, truck_width_m=b.truck_width(),
            roll_stiffness_Nm_per_rad=b.roll_stiffness_Nm_per_rad, roll_damping_Nms_per_rad=b.roll_damping_Nms_per_rad,
            rolling_friction_coeff=b.rolling_coefficient(model.total_weight()),
            pivot_from_horizontal_rad=b.pivot_from_horizontal_rad, deck_mass_kg=b.deck_mass(),
            wheel_radius_m=b.roll_axis_height_m, wheel_track_m=b.wheel_track_m)
        return TwinFigures(
            urdf=urdf, foot_radius_m=model.foot_radius_m, friction_mu=model.friction_mu,
            torque_limit_Nm=model.torque_limit_Nm, gravity_mps2=model.gravity_mps2,
            robot_mass_kg=model.robot_mass_kg, board=board, stance_q_rad=model.arrays.stance_q_board_rad,
            deck_points_m=model.arrays.stance_deck_points_m)

    @staticmethod
    def from_library(lib: MotionLibrary) -> TwinFigures:
        return TwinFigures.from_record(lib.quadruped_model, lib.urdf)
