"""Physical parameters of the controller's model, read from a library (the proving ground's
model errors make its plant's from them: :mod:`skatelib.proving.perturb`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from skatelib.library.model import QuadrupedModel
from skatelib.runtime import MotionLibrary


@dataclass(frozen=True)
class SkateParams:
    """Everything Eq. (3)-(9) need, in SI units.

    Attributes:
        mass_kg: Robot mass m_R.
        inertia_kgm2: (3, 3) robot inertia I_R about the COM, trunk frame.
        com_offset_m: (3,) COM in the trunk frame (the feedback reports the trunk's idea of it).
        board_mass_kg: m_B (moves along the deck x axis only).
        roll_inertia_kgm2: I_Bx.
        kb_Nm_per_rad: K_B, Eq. (6).
        bb_Nms_per_rad: B_B, Eq. (6).
        rolling_N: f_fri, Eq. (9b), of the board.
        rolling_plan_N: The f_fri the optimization planned with (a margin above ``rolling_N``).
        tanh_scale_s_per_m: k of Eq. (10).
        mu: Friction coefficient of feet on deck and ground.
        gravity_mps2: g.
        deck_points_m: (2, 4) foot contact points x, y on the deck (Eq. 8), legs FL FR RL RR.
        roll_limit_rad: Deck roll at which the deck touches the wheels.
        joint_velocity_limit_radps: |qd| bound.
        push_leg: Index of the pushing leg (0..3).
        torque_limit_Nm: |tau| bound of every joint (the MPC's torque rows).
        mu_plan: The friction coefficient the optimization planned with (a margin inside ``mu``);
            the MPC's default, leaving the same margin for the deck's roll within an update.
        roll_axis_depth_m: The deck's roll axis below its top (0: about the top, as Eq. 8 reads).
        deck_mass_kg: The deck's share of the board's mass, which rolls about that axis.
        pivot_rad: The trucks' pivot axis angle from the ground (the roll torque's kinematics).
        wheel_track_m: Between the wheels' contact points; 0: no wheel-load rows.
        wheel_load_margin: The deck loads' roll moment at most (1 - margin) of what the track holds.
        k_board_m: K_board of Eq. (14), the turning radius times the sine of the roll; 0: unknown.
    """

    mass_kg: float
    inertia_kgm2: np.ndarray
    com_offset_m: np.ndarray
    board_mass_kg: float
    roll_inertia_kgm2: float
    kb_Nm_per_rad: float
    bb_Nms_per_rad: float
    rolling_N: float
    rolling_plan_N: float
    tanh_scale_s_per_m: float
    mu: float
    gravity_mps2: float
    deck_points_m: np.ndarray
    roll_limit_rad: float
    joint_velocity_limit_radps: float
    push_leg: int
    mu_plan: float
    torque_limit_Nm: float = math.inf
    roll_axis_depth_m: float = 0.0
    deck_mass_kg: float = 0.0
    pivot_rad: float = math.pi / 2
    wheel_track_m: float = 0.0
    wheel_load_margin: float = 0.0
    k_board_m: float = 0.0

    @property
    def upright_roll_stiffness(self) -> float:
        """The deck's roll stiffness at small rolls [N m/rad]: the trucks', less what the deck's own
        weight takes about the roll axis."""
        return self.kb_Nm_per_rad - self.deck_mass_kg * self.gravity_mps2 * self.roll_axis_depth_m

    @property
    def loaded_roll_stiffness(self) -> float:
        """The same with the robot's weight on the deck's top [N m/rad]: about the roll axis, h below
        the feet, a rolled deck moves their vertical loads outwards (the linear model's roll block,
        whose arms are frozen at an update's roll, would miss it otherwise)."""
        return self.upright_roll_stiffness - self.mass_kg * self.gravity_mps2 * self.roll_axis_depth_m

    def roll_torque(self, phi: float, psi: float) -> float:
        """The trucks' torque on the deck about its roll axis and the deck's weight's [N m] (the
        trucks' kinematics: see ``skatelib.pipeline.quadruped.model.board``)."""
        c = math.cos(self.pivot_rad)
        if c < 1e-9:  # a vertical pivot: the linear spring of Eq. (6)
            trucks = -self.kb_Nm_per_rad * phi
        else:
            theta = math.atan(math.tan(phi) / c)
            trucks = -self.kb_Nm_per_rad * c * theta / (math.cos(phi) ** 2 + math.sin(phi) ** 2 / c**2)
        gravity = self.deck_mass_kg * self.gravity_mps2 * self.roll_axis_depth_m * math.sin(phi)
        return trucks - self.bb_Nms_per_rad * psi + gravity

    def deck_points(self, R_B: np.ndarray) -> np.ndarray:
        """(3, 4) the feet's deck points relative to the board origin (the deck's top centre), world."""
        h = self.roll_axis_depth_m
        return self.moment_arms(R_B) - np.array([[0.0], [0.0], [h]])

    def moment_arms(self, R_B: np.ndarray) -> np.ndarray:
        """(3, 4) the feet's deck points relative to the roll axis, world (Eq. 8's r_Bi)."""
        local = np.vstack([self.deck_points_m, np.full(4, self.roll_axis_depth_m)])
        return np.asarray(R_B @ local)

    @staticmethod
    def from_library(lib: MotionLibrary) -> SkateParams:
        """The nominal parameters a quadruped library was built with (its /model group)."""
        return SkateParams.from_model(lib.quadruped_model)

    @staticmethod
    def from_model(m: QuadrupedModel) -> SkateParams:
        """The parameters of the optimizer's model in a ``/model`` record (a format 1.1 library's
        board: Eq. (6)'s linear spring about the deck's top)."""
        b, a = m.board, m.arrays
        return SkateParams(
            mass_kg=m.robot_mass_kg, inertia_kgm2=a.robot_inertia_kgm2, com_offset_m=a.robot_com_offset_m,
            board_mass_kg=b.mass_kg, roll_inertia_kgm2=b.roll_inertia_kgm2, kb_Nm_per_rad=b.roll_stiffness_Nm_per_rad,
            bb_Nms_per_rad=b.roll_damping_Nms_per_rad, rolling_N=b.rolling_friction_N,
            rolling_plan_N=b.rolling_friction_N if b.rolling_friction_plan_N is None else b.rolling_friction_plan_N,
            tanh_scale_s_per_m=b.tanh_scale_s_per_m, mu=m.friction_mu, gravity_mps2=m.gravity_mps2,
            deck_points_m=a.stance_deck_points_m, roll_limit_rad=b.roll_limit_rad,
            joint_velocity_limit_radps=m.joint_velocity_limit_radps, push_leg=m.push_leg_index, mu_plan=m.mu_plan,
            torque_limit_Nm=m.torque_limit_Nm, roll_axis_depth_m=b.planned_roll_axis_depth_m(),
            deck_mass_kg=b.planned_deck_mass_kg(), pivot_rad=b.planned_pivot_rad(),
            wheel_track_m=b.planned_wheel_track_m(), wheel_load_margin=b.wheel_load_margin, k_board_m=b.K_board_m,
        )
