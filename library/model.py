"""The quadruped library's ``/model`` as typed records: the robot, its board and the build's
settings that the controller, the twin and the checks read, written to and read from the file
here and nowhere else (attribute names, defaults and the format's migrations in one place).

Each field's attribute name is in its metadata (``ATTR``); a field without a default is required
in every file; a default is the one value a file without the attribute means. The board's
figures are the physical board's; whether the optimizer modelled the trucks' kinematics, the
deck's roll axis, its mass and the wheels' loads (format 1.2 on) is ``BoardModel.modelled_trucks``:
a format 1.1 library was optimized with Eq. (6)'s linear roll spring about the deck's top, and
the controller's model of it is that (:meth:`BoardModel.planned_pivot_rad` and the others below).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

ATTR = "attr"
# The public quadruped-skateboard model's figures (docs/sources.md): what a format 1.1 library,
# which does not store them, is taken to have ridden on.
PUBLIC_PIVOT_RAD = math.pi / 4
PUBLIC_HANGER_MASS_KG = 0.055
PUBLIC_WHEEL_MASS_KG = 0.049
PUBLIC_WHEEL_RADIUS_M = 0.03
PUBLIC_WHEEL_TRACK_M = 0.22
LEGACY_PIVOT_ATTR = "board_rake_front_rad"  # format 1.1's name of the trucks' axis angle
LEGS = ("FL", "FR", "RL", "RR")


def _a(name: str, default: Any = dataclasses.MISSING) -> Any:
    """A field stored as the ``/model`` attribute ``name``."""
    return field(default=default, metadata={ATTR: name})


@dataclass(frozen=True, kw_only=True)
class BoardModel:
    """The skateboard (``board_*`` attributes), SI units."""

    mass_kg: float = _a("board_mass_kg")
    roll_stiffness_Nm_per_rad: float = _a("board_roll_stiffness_Nm_per_rad")
    roll_damping_Nms_per_rad: float = _a("board_roll_damping_Nms_per_rad")
    roll_inertia_kgm2: float = _a("board_roll_inertia_kgm2")
    rolling_friction_N: float = _a("board_rolling_friction_N")  # at the nominal weight
    rolling_friction_plan_N: float | None = _a("board_rolling_friction_plan_N", None)  # None: the nominal
    rolling_coeff: float | None = _a("board_rolling_coeff", None)  # None: the force over the weight
    rolling_coeff_plan: float | None = _a("board_rolling_coeff_plan", None)
    K_board_m: float = _a("board_K_board_m")
    deck_mass_kg: float | None = _a("board_deck_mass_kg", None)  # None: the public model's hangers and wheels off
    tanh_scale_s_per_m: float = _a("board_tanh_scale_s_per_m", 50.0)
    pivot_from_horizontal_rad: float = _a("board_pivot_from_horizontal_rad", PUBLIC_PIVOT_RAD)
    roll_axis_height_m: float = _a("board_roll_axis_height_m", PUBLIC_WHEEL_RADIUS_M)  # the axles
    wheel_track_m: float = _a("board_wheel_track_m", PUBLIC_WHEEL_TRACK_M)
    wheel_load_margin: float = _a("board_wheel_load_margin", 0.0)
    l_front_m: float = _a("board_l_front_m", math.nan)
    l_rear_m: float = _a("board_l_rear_m", math.nan)
    deck_height_m: float = _a("board_deck_height_m", math.nan)  # the deck's top above the ground
    deck_length_m: float = _a("board_deck_length_m", math.nan)
    deck_width_m: float = _a("board_deck_width_m", math.nan)
    truck_width_m: float | None = _a("board_truck_width_m", None)  # None: the deck's width
    roll_limit_rad: float = _a("board_roll_limit_rad", 0.2)
    source: str = _a("board_source", "")
    modelled_trucks: bool = True  # format >= 1.2: the optimizer modelled the trucks, roll axis, deck and wheels

    def deck_mass(self) -> float:
        """The deck's share of the mass [kg] (the rest: 2 hangers and 4 wheels)."""
        if self.deck_mass_kg is not None:
            return self.deck_mass_kg
        return self.mass_kg - 2 * PUBLIC_HANGER_MASS_KG - 4 * PUBLIC_WHEEL_MASS_KG

    def truck_width(self) -> float:
        """Between the trucks' ends [m]."""
        return self.deck_width_m if self.truck_width_m is None else self.truck_width_m

    def rolling_coefficient(self, total_weight_N: float) -> float:
        """Rolling resistance over the normal load on the wheels [-]."""
        return self.rolling_coeff if self.rolling_coeff is not None else self.rolling_friction_N / total_weight_N

    # What the optimizer's model of the board was (the controller's): the physical figures from
    # format 1.2 on; a 1.1 library's linear spring about the deck's top (no deck mass, no wheel rows).
    def planned_pivot_rad(self) -> float:
        return self.pivot_from_horizontal_rad if self.modelled_trucks else math.pi / 2

    def planned_roll_axis_depth_m(self) -> float:
        return self.deck_height_m - self.roll_axis_height_m if self.modelled_trucks else 0.0

    def planned_deck_mass_kg(self) -> float:
        return self.deck_mass() if self.modelled_trucks else 0.0

    def planned_wheel_track_m(self) -> float:
        return self.wheel_track_m if self.modelled_trucks else 0.0


@dataclass(frozen=True)
class QuadrupedArrays:
    """The ``/model`` datasets of a quadruped library (those added by later formats may be None)."""

    robot_inertia_kgm2: np.ndarray  # (3, 3) about the COM, trunk frame
    robot_com_offset_m: np.ndarray  # (3,) the COM in the trunk frame
    joint_lower_rad: np.ndarray  # (12,)
    joint_upper_rad: np.ndarray  # (12,)
    stance_q_board_rad: np.ndarray  # (12,) the four-leg stance on the deck
    stance_q_push_rad: np.ndarray | None  # (12,) the stance with the push leg on the ground
    stance_deck_points_m: np.ndarray  # (2, 4) the feet's deck points x, y (Eq. 8)
    stance_q_ride_rad: np.ndarray | None  # (12,) the riding stance (format 1.4)
    stance_ride_trunk: np.ndarray | None  # (4,) the riding trunk: height, x, roll, pitch
    stance_riding_com_m: np.ndarray | None  # (3,)

    @staticmethod
    def names() -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(QuadrupedArrays))


@dataclass(frozen=True, kw_only=True)
class QuadrupedModel:
    """A quadruped library's ``/model``: the robot, the board, the stance and the build's settings."""

    board: BoardModel
    arrays: QuadrupedArrays
    robot_mass_kg: float = _a("robot_mass_kg")
    friction_mu: float = _a("friction_mu")
    gravity_mps2: float = _a("gravity_mps2")
    foot_radius_m: float = _a("foot_radius_m", math.nan)
    torque_limit_Nm: float = _a("torque_limit_Nm", math.inf)
    joint_velocity_limit_radps: float = _a("joint_velocity_limit_radps", 31.0)
    push_leg: str = _a("push_leg", "RL")
    schedule_period_s: float = _a("schedule_period_s", math.nan)
    schedule_push_duty: float = _a("schedule_push_duty", math.nan)
    dt_s: float = _a("dt_s", math.nan)
    integrator: str = _a("integrator", "")
    robot_source: str = _a("robot_source", "")
    friction_model: str = _a("friction_model", "")
    friction_mu_plan: float | None = _a("friction_mu_plan", None)  # None: friction_mu
    joint_limit_margin_rad: float = _a("joint_limit_margin_rad", 0.0)
    terminal: Mapping[str, float] = field(default_factory=dict)  # the terminal_* attributes, without the prefix
    final_velocity_tol: float = _a("final_velocity_tol", 0.01)  # of the target speed, relative
    stop_speed_tol_mps: float = _a("stop_speed_tol_mps", 0.02)

    @property
    def push_leg_index(self) -> int:
        return LEGS.index(self.push_leg)

    @property
    def mu_plan(self) -> float:
        """The friction coefficient the optimization planned with."""
        return self.friction_mu if self.friction_mu_plan is None else self.friction_mu_plan

    def total_weight(self) -> float:
        """Robot and board on the wheels [N]."""
        return (self.robot_mass_kg + self.board.mass_kg) * self.gravity_mps2


@dataclass(frozen=True, kw_only=True)
class HumanoidBoard:
    """A humanoid skate's skateboard (``skate_board_*`` attributes), SI units: the deck the board
    foot stands on (its height is in the plan) and the figures the twin builds it from."""

    deck_height_m: float = _a("skate_board_deck_height_m")  # the deck's top above the ground
    deck_length_m: float = _a("skate_board_deck_length_m")
    deck_width_m: float = _a("skate_board_deck_width_m")
    foot_ahead_m: float = _a("skate_board_foot_ahead_m")  # the board foot's centre ahead of the deck's centre
    l_front_m: float = _a("skate_board_l_front_m")  # the front axle ahead of the deck's centre
    l_rear_m: float = _a("skate_board_l_rear_m")
    wheel_radius_m: float = _a("skate_board_wheel_radius_m")
    wheel_track_m: float = _a("skate_board_wheel_track_m")
    mass_kg: float = _a("skate_board_mass_kg")
    deck_mass_kg: float = _a("skate_board_deck_mass_kg")
    pivot_from_horizontal_rad: float = _a("skate_board_pivot_from_horizontal_rad")
    roll_stiffness_Nm_per_rad: float = _a("skate_board_roll_stiffness_Nm_per_rad")
    roll_damping_Nms_per_rad: float = _a("skate_board_roll_damping_Nms_per_rad")
    rolling_coeff: float = _a("skate_board_rolling_coeff")
    deck_mu: float = _a("skate_board_deck_mu")  # the grip tape's friction with a sole
    source: str = _a("skate_board_source", "")

    def deck_centre(self, board_sole_xy: np.ndarray) -> np.ndarray:
        """The deck's centre (x, y) under a board sole at ``board_sole_xy`` (the deck along x)."""
        return np.asarray(board_sole_xy, dtype=np.float64)[..., 0:2] - np.array([self.foot_ahead_m, 0.0])

    def over_deck(self, sole_xy: np.ndarray, board_sole_xy: np.ndarray) -> np.ndarray:
        """Whether a sole's centre lies over the deck's top (its footprint) with the board sole at
        ``board_sole_xy``; (..., 2) arrays."""
        d = np.asarray(sole_xy, dtype=np.float64)[..., 0:2] - self.deck_centre(board_sole_xy)
        return np.asarray((np.abs(d[..., 0]) <= self.deck_length_m / 2) & (np.abs(d[..., 1]) <= self.deck_width_m / 2))


@dataclass(frozen=True, kw_only=True)
class HumanoidModel:
    """A humanoid library's ``/model``: the robot as the GPM's point mass sees it and the build's settings."""

    robot_mass_kg: float = _a("robot_mass_kg")
    gravity_mps2: float = _a("gravity_mps2")
    com_height_m: float = _a("com_height_m")
    foot_length_m: float = _a("foot_length_m")
    foot_width_m: float = _a("foot_width_m")
    step_width_m: float = _a("step_width_m")
    friction_mu: float = _a("friction_mu")
    leg_min_m: float = _a("leg_min_m")
    leg_max_m: float = _a("leg_max_m")
    gpm_nodes: int = _a("gpm_nodes")
    gpm_solver: str = _a("gpm_solver")
    motion: str = _a("motion")
    source: str = _a("source", "")
    board: HumanoidBoard | None = None  # a skate's skateboard (None: a walk)

