"""What the humanoid twin is built from: a humanoid library's URDF and ``/model`` figures (sole,
friction, gravity), the joints' torque limits from the URDF's ``effort``, and the few figures a
jointed model needs that the planner does not (servo gains, rotor inertia, damping, the floor's
torsional friction), each with its source in docs/sources.md."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace

import numpy as np
from skatelib.library.errors import ModelError
from skatelib.library.model import HumanoidBoard, HumanoidModel
from skatelib.sim.figures import DECK_THICKNESS_M, BoardFigures

# HRP-2 drives each joint by a brushless motor through a harmonic drive and servoes its angle on
# the motor driver (Kaneko et al. 2004): the controller sends joint angles. No public figure of its
# rotors or servo gains: chosen for a 150 W-class rotor (about 1e-5 kg m^2) through a 1:160
# reduction, and a servo as stiff as a position-controlled humanoid's (docs/sources.md).
ROTOR_INERTIA_KGM2 = 1.0e-5
GEAR_RATIO = 160.0
SERVO_KP_NM_PER_RAD = 3000.0
SERVO_KD_NMS_PER_RAD = 60.0
JOINT_DAMPING_NMS = 0.5  # harmonic drive and bearing friction: chosen
# Torsional friction of a rubber sole [m]: the moment about the normal over the normal force, about
# a quarter of the sole's half-width for a pressure spread over it (chosen; docs/sources.md).
TORSIONAL_FRICTION_M = 0.015
SOLE_THICKNESS_M = 0.02
SOLES = ("R_sole", "L_sole")
FEET = ("R_foot", "L_foot")
ANKLES = ("R_ankle_roll", "L_ankle_roll")  # the joint at the 6-axis force/torque sensor (HRP-2: at the ankle)
TIMESTEP_S = 0.001


@dataclass(frozen=True)
class HumanoidFigures:
    """Everything :mod:`skatelib.sim.humanoid.robot` builds the twin from.

    Attributes:
        joint_names: The actuated joints in the library's order.
        torque_limit_Nm: (n,) each joint's torque limit (the URDF's ``effort``).
        q0_rad, base0: The first knot's joints and waist pose (x, y, z, qx, qy, qz, qw).
    """

    urdf: str
    joint_names: tuple[str, ...]
    torque_limit_Nm: np.ndarray
    foot_length_m: float
    foot_width_m: float
    friction_mu: float
    gravity_mps2: float
    robot_mass_kg: float
    q0_rad: np.ndarray
    base0: np.ndarray
    torsional_friction_m: float = TORSIONAL_FRICTION_M
    board: BoardFigures | None = None  # a skate's skateboard (the quadruped's board builder's figures)
    deck_mu: float = 1.0  # the deck's grip tape against a sole
    deck_xy: tuple[float, float] = (0.0, 0.0)  # the deck's centre at the start [m]

    @staticmethod
    def from_record(model: HumanoidModel, urdf: str, joint_names: tuple[str, ...], q0: np.ndarray,
                    base0: np.ndarray, board_sole_xy: np.ndarray | None = None) -> HumanoidFigures:
        """From a humanoid library's record; a skate's board is placed under the board sole's first
        place ``board_sole_xy`` (x, y)."""
        f = HumanoidFigures(urdf=urdf, joint_names=joint_names, torque_limit_Nm=effort_limits(urdf, joint_names),
                            foot_length_m=model.foot_length_m, foot_width_m=model.foot_width_m,
                            friction_mu=model.friction_mu, gravity_mps2=model.gravity_mps2,
                            robot_mass_kg=model.robot_mass_kg, q0_rad=np.asarray(q0, dtype=float),
                            base0=np.asarray(base0, dtype=float))
        b = model.board
        if b is None or board_sole_xy is None:
            return f
        centre = b.deck_centre(np.asarray(board_sole_xy))
        return replace(f, board=board_figures(b), deck_mu=b.deck_mu, deck_xy=(float(centre[0]), float(centre[1])))


def board_figures(b: HumanoidBoard) -> BoardFigures:
    """The board builder's figures of a humanoid skate's board: the deck a uniform plank of
    ``DECK_THICKNESS_M``; its truck width the wheel track."""
    m, L, W, T = b.deck_mass_kg, b.deck_length_m, b.deck_width_m, DECK_THICKNESS_M
    inertia = (m * (W**2 + T**2) / 12, m * (L**2 + T**2) / 12, m * (L**2 + W**2) / 12)
    return BoardFigures(mass_kg=b.mass_kg, deck_length_m=L, deck_width_m=W, deck_height_m=b.deck_height_m,
                        l_front_m=b.l_front_m, l_rear_m=b.l_rear_m, truck_width_m=b.wheel_track_m,
                        roll_stiffness_Nm_per_rad=b.roll_stiffness_Nm_per_rad,
                        roll_damping_Nms_per_rad=b.roll_damping_Nms_per_rad, rolling_friction_coeff=b.rolling_coeff,
                        pivot_from_horizontal_rad=b.pivot_from_horizontal_rad, deck_mass_kg=b.deck_mass_kg,
                        wheel_radius_m=b.wheel_radius_m, wheel_track_m=b.wheel_track_m, deck_inertia_kgm2=inertia)


def effort_limits(urdf: str, joint_names: tuple[str, ...]) -> np.ndarray:
    """Each joint's ``<limit effort>`` [N m].

    Raises:
        ModelError: A joint the URDF does not give a finite positive effort.
    """
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as e:
        raise ModelError(f"the robot description (URDF) is not well-formed XML: {e}") from e
    effort = {}
    for j in root.iter("joint"):
        lim = j.find("limit")
        if lim is not None and lim.get("effort") is not None:
            effort[j.get("name")] = float(lim.get("effort", "nan"))
    missing = [n for n in joint_names if not (effort.get(n, 0.0) > 0.0 and np.isfinite(effort[n]))]
    if missing:
        raise ModelError(f"the robot description gives {', '.join(missing)} no positive <limit effort=...>: the "
                         "twin's motors are limited to it")
    return np.array([effort[n] for n in joint_names])
