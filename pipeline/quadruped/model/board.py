"""The steerable skateboard: the trucks' roll torque (Eq. 6, with the trucks' kinematics), the
steering kinematics (Eq. 11-14), rolling resistance with tanh smoothing (Eq. 9b, 10), the deck's
roll axis and the wheel-load limit.

Board frame (C_B): x forward on the centre line, z up; its origin ``O`` on the deck's top surface
where the deck is level (above the point with no lateral velocity, Eq. 12). The deck rolls (phi_B)
about the line through the trucks' axles, ``roll_axis_depth_m`` below its top (a physical deck
rolls about its trucks, not about its top surface), and yaws with the robot (Sec. III-A-2). A deck
point (x, y) on the top is at ``O + R_B (x, y, h) - (0, 0, h)``, h the roll axis' depth, and its
moment arm about the roll axis is ``R_B (x, y, h)``.

Trucks: each hanger turns about its pivot axis, ``pivot_rad`` (lambda) from the ground. With the
wheels on the ground a deck roll phi turns each hanger by theta = atan(tan(phi) / cos(lambda)) and
steers it by tan(delta) = sin(phi) tan(lambda) (to first order in the truck's own roll); so
Eq. (11)'s cot(gamma) is tan(lambda), gamma the pivot's angle from the vertical, and K_board =
l_f / tan(lambda). Linear torsion springs in the trucks give the deck the roll torque
-K_B cos(lambda) theta / (cos(phi)^2 + sin(phi)^2 / cos(lambda)^2), K_B phi for small rolls.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
from skatelib.pipeline.quadruped.config import BoardConfig


@dataclass(frozen=True)
class BoardModel:
    """Numbers of the skateboard model, all derived quantities computed once from the config."""

    mass_kg: float
    deck_mass_kg: float
    roll_inertia_kgm2: float  # the deck's, about its roll axis
    roll_stiffness_Nm_per_rad: float  # K_B, Eq. (6): the trucks' small-roll stiffness
    roll_damping_Nms_per_rad: float  # B_B, Eq. (6)
    rolling_coeff: float  # rolling resistance per newton on the wheels, as planned (the planning factor in)
    rolling_coeff_nominal: float  # of the board itself
    tanh_scale_s_per_m: float  # k, Eq. (10)
    pivot_rad: float  # lambda: the trucks' pivot axis from the ground
    roll_axis_depth_m: float  # h: the roll axis below the deck's top
    wheel_track_m: float  # between the left and right wheels' contact points
    wheel_load_margin: float  # the loads' roll moment at most (1 - margin) of what the wheel track holds
    l_front_m: float  # distance C_B -> front axle, Eq. (12)
    l_rear_m: float
    K_board_m: float  # l_f / tan(lambda), Eq. (12)
    deck_height_m: float
    deck_length_m: float
    deck_width_m: float
    truck_width_m: float
    roll_limit_rad: float
    gravity_mps2: float
    rolling_friction_N: float  # the planned rolling resistance with the robot standing on the board
    rolling_friction_nominal_N: float  # the board's own, with the robot standing on it

    @staticmethod
    def from_config(cfg: BoardConfig, robot_mass_kg: float, gravity_mps2: float,
                    calibration_foot_y_m: float, rolling_factor: float = 1.0) -> BoardModel:
        """Derive K_B, B_B and the steering geometry from the config; the dynamics use
        ``rolling_factor`` x the board's rolling resistance (a planning margin).

        K_B is calibrated to the paper's Fig. 5 (about 0.12 rad when the far legs unload): the
        robot's whole weight resting on the feet of one side, at ``calibration_foot_y_m`` from the
        centre line, holds the deck at ``cfg.calibration_roll_rad`` about its physical roll axis,
        the deck's own weight included (:meth:`calibrated_stiffness`).
        """
        l_f = cfg.truck_distance_m / 2  # identical trucks: C_B midway (Eq. 12)
        h = cfg.deck_height_m - cfg.roll_axis_height_m
        total_weight = (cfg.mass_kg + robot_mass_kg) * gravity_mps2
        inertia = cfg.roll_inertia_kgm2 + cfg.deck_mass_kg * h**2  # about the roll axis (parallel axes)
        proto = BoardModel(
            mass_kg=cfg.mass_kg, deck_mass_kg=cfg.deck_mass_kg, roll_inertia_kgm2=inertia,
            roll_stiffness_Nm_per_rad=1.0, roll_damping_Nms_per_rad=0.0,
            rolling_coeff=rolling_factor * cfg.rolling_friction_coeff,
            rolling_coeff_nominal=cfg.rolling_friction_coeff, tanh_scale_s_per_m=cfg.tanh_scale_s_per_m,
            pivot_rad=cfg.pivot_from_horizontal_rad, roll_axis_depth_m=h, wheel_track_m=cfg.wheel_track_m,
            wheel_load_margin=cfg.wheel_load_margin, l_front_m=l_f, l_rear_m=cfg.truck_distance_m - l_f,
            K_board_m=l_f / math.tan(cfg.pivot_from_horizontal_rad), deck_height_m=cfg.deck_height_m,
            deck_length_m=cfg.deck_length_m, deck_width_m=cfg.deck_width_m, truck_width_m=cfg.truck_width_m,
            roll_limit_rad=cfg.roll_limit_rad, gravity_mps2=gravity_mps2,
            rolling_friction_N=rolling_factor * cfg.rolling_friction_coeff * total_weight,
            rolling_friction_nominal_N=cfg.rolling_friction_coeff * total_weight)
        k_b = proto.calibrated_stiffness(robot_mass_kg * gravity_mps2, calibration_foot_y_m, cfg.calibration_roll_rad)
        b_b = 2.0 * cfg.roll_damping_ratio * math.sqrt(k_b * inertia)
        return dataclasses.replace(proto, roll_stiffness_Nm_per_rad=k_b, roll_damping_Nms_per_rad=b_b)

    def truck_torque(self, phi: Any) -> Any:
        """The trucks' spring torque on the deck at roll ``phi`` [N m] (negative for phi > 0)."""
        c = math.cos(self.pivot_rad)
        theta = ca.atan(ca.tan(phi) / c)
        return -self.roll_stiffness_Nm_per_rad * c * theta / (ca.cos(phi) ** 2 + ca.sin(phi) ** 2 / c**2)

    def roll_torque(self, phi: Any, psi: Any) -> Any:
        """Trucks' torque about the roll axis [N m], Eq. (6) with the trucks' kinematics, and the
        deck's own weight about that axis."""
        gravity = self.deck_mass_kg * self.gravity_mps2 * self.roll_axis_depth_m * ca.sin(phi)
        return self.truck_torque(phi) - self.roll_damping_Nms_per_rad * psi + gravity

    def calibrated_stiffness(self, load_N: float, y_m: float, roll_rad: float) -> float:
        """K_B with which a vertical ``load_N`` on the deck's top at ``y_m`` from the centre line
        holds the deck at ``roll_rad`` (statics about the roll axis, the deck's weight included)."""
        h = self.roll_axis_depth_m
        moment = load_N * (y_m * math.cos(roll_rad) + h * math.sin(roll_rad))
        moment += self.deck_mass_kg * self.gravity_mps2 * h * math.sin(roll_rad)
        return float(moment / -self.truck_torque(roll_rad))  # truck_torque is linear in K_B (1 here)

    def steering_angles(self, phi: Any) -> tuple[Any, Any]:
        """Front and rear truck steering angles delta_f, delta_r [rad], Eq. (11)."""
        delta = ca.atan(ca.sin(phi) * math.tan(self.pivot_rad))
        return delta, delta

    def steering_residual(self, phi: Any, v_forward: Any, yaw_rate: Any) -> Any:
        """Residual of Eq. (14): sin(phi) v_Bx^B + K_board omega_z (zero when rolling without slip)."""
        return ca.sin(phi) * v_forward + self.K_board_m * yaw_rate

    def friction_force(self, v_forward: Any, wheel_load_N: Any) -> Any:
        """Rolling resistance along the deck x axis [N], Eq. (10): tanh(k v) c N, N the wheels'
        load (the board's weight and what the feet on the deck press with)."""
        return ca.tanh(self.tanh_scale_s_per_m * v_forward) * self.rolling_coeff * wheel_load_N

    def wheel_load(self, deck_normal_forces_N: Any) -> Any:
        """The wheels' load [N]: the board's weight and the feet's vertical forces on the deck."""
        return self.mass_kg * self.gravity_mps2 + deck_normal_forces_N

    def deck_point(self, R_B: Any, x: Any, y: Any) -> Any:
        """A point (x, y) of the deck's top relative to the board origin, in the world (3,)."""
        h = self.roll_axis_depth_m
        return R_B @ ca.vertcat(x, y, h) - ca.DM([0.0, 0.0, h])

    def moment_arm(self, R_B: Any, x: Any, y: Any) -> Any:
        """A point (x, y) of the deck's top relative to the roll axis, in the world (3,), Eq. (8)."""
        return R_B @ ca.vertcat(x, y, self.roll_axis_depth_m)
