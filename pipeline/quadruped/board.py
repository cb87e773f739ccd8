"""The steerable skateboard: roll spring-damper (Eq. 6), steering kinematics (Eq. 11-14) and
rolling friction with tanh smoothing (Eq. 9b, 10).

The board frame C_B has its origin on the deck's top surface, on the centre line, at the point
whose velocity has no lateral component (Eq. 12); its x axis points forward. The deck rolls about
that x axis (roll phi_B) and yaws with the robot (Sec. III-A-2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
from skatelib.pipeline.quadruped.config import BoardConfig


@dataclass(frozen=True)
class BoardModel:
    """Numbers of the skateboard model, all derived quantities computed once from the config."""

    mass_kg: float
    roll_inertia_kgm2: float
    roll_stiffness_Nm_per_rad: float  # K_B, Eq. (6)
    roll_damping_Nms_per_rad: float  # B_B, Eq. (6)
    rolling_friction_N: float  # f_fri, Eq. (9b), as planned: the board's x the planning factor
    rolling_friction_nominal_N: float  # f_fri of the board itself
    tanh_scale_s_per_m: float  # k, Eq. (10)
    rake_front_rad: float
    rake_rear_rad: float
    l_front_m: float  # distance C_B -> front truck pivot, Eq. (12)
    l_rear_m: float
    K_board_m: float  # l_f / cot(gamma_f), Eq. (12)
    deck_height_m: float
    deck_length_m: float
    deck_width_m: float
    truck_width_m: float
    roll_limit_rad: float

    @staticmethod
    def from_config(cfg: BoardConfig, robot_mass_kg: float, gravity_mps2: float,
                    calibration_foot_y_m: float, rolling_factor: float = 1.0) -> BoardModel:
        """Derive K_B, B_B, f_fri and the steering geometry from the config; the dynamics use
        ``rolling_factor`` x the board's rolling resistance (a planning margin).

        K_B is calibrated so that the robot's whole weight resting on the feet of one side, at
        ``calibration_foot_y_m`` from the centre line, holds the deck at ``cfg.calibration_roll_rad``
        (paper Fig. 5: about 0.12 rad when the far legs unload): K_B phi = m g y cos(phi).
        """
        phi = cfg.calibration_roll_rad
        k_b = robot_mass_kg * gravity_mps2 * calibration_foot_y_m * math.cos(phi) / phi
        b_b = 2.0 * cfg.roll_damping_ratio * math.sqrt(k_b * cfg.roll_inertia_kgm2)
        cot_f, cot_r = 1.0 / math.tan(cfg.rake_front_rad), 1.0 / math.tan(cfg.rake_rear_rad)
        l_f = cfg.truck_distance_m * cot_f / (cot_f + cot_r)  # Eq. (12): l_f / l_r = cot_f / cot_r
        total_weight = (robot_mass_kg + cfg.mass_kg) * gravity_mps2
        return BoardModel(
            mass_kg=cfg.mass_kg, roll_inertia_kgm2=cfg.roll_inertia_kgm2,
            roll_stiffness_Nm_per_rad=k_b, roll_damping_Nms_per_rad=b_b,
            rolling_friction_N=rolling_factor * cfg.rolling_friction_coeff * total_weight,
            rolling_friction_nominal_N=cfg.rolling_friction_coeff * total_weight,
            tanh_scale_s_per_m=cfg.tanh_scale_s_per_m,
            rake_front_rad=cfg.rake_front_rad, rake_rear_rad=cfg.rake_rear_rad,
            l_front_m=l_f, l_rear_m=cfg.truck_distance_m - l_f, K_board_m=l_f / cot_f,
            deck_height_m=cfg.deck_height_m, deck_length_m=cfg.deck_length_m,
            deck_width_m=cfg.deck_width_m, truck_width_m=cfg.truck_width_m,
            roll_limit_rad=cfg.roll_limit_rad,
        )

    def roll_torque(self, phi: Any, psi: Any) -> Any:
        """Truck torque about the deck x axis [N m], Eq. (6): -K_B phi - B_B psi."""
        return -self.roll_stiffness_Nm_per_rad * phi - self.roll_damping_Nms_per_rad * psi

    def steering_angles(self, phi: Any) -> tuple[Any, Any]:
        """Front and rear truck steering angles delta_f, delta_r [rad], Eq. (11)."""
        return (ca.atan(ca.sin(phi) / ca.tan(self.rake_front_rad)),
                ca.atan(ca.sin(phi) / ca.tan(self.rake_rear_rad)))

    def steering_residual(self, phi: Any, v_forward: Any, yaw_rate: Any) -> Any:
        """Residual of Eq. (14): sin(phi) v_Bx^B + K_board omega_z (zero when rolling without slip)."""
        return ca.sin(phi) * v_forward + self.K_board_m * yaw_rate

    def friction_force(self, v_forward: Any) -> Any:
        """Rolling resistance along the deck x axis [N], Eq. (10): tanh(k v) f_fri."""
        return ca.tanh(self.tanh_scale_s_per_m * v_forward) * self.rolling_friction_N
