"""What the humanoid twin is built from: a humanoid library's URDF and ``/model`` figures (sole,
friction, gravity), the joints' torque limits from the URDF's ``effort``, and the few figures a
jointed model needs that the planner does not (servo gains, rotor inertia, damping, the floor's
torsional friction), each with its source in docs/sources.md."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from skatelib.library.errors import ModelError
from skatelib.library.model import HumanoidModel

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

    @staticmethod
    def from_record(model: HumanoidModel, urdf: str, joint_names: tuple[str, ...], q0: np.ndarray,
                    base0: np.ndarray) -> HumanoidFigures:
        return HumanoidFigures(urdf=urdf, joint_names=joint_names, torque_limit_Nm=effort_limits(urdf, joint_names),
                               foot_length_m=model.foot_length_m, foot_width_m=model.foot_width_m,
                               friction_mu=model.friction_mu, gravity_mps2=model.gravity_mps2,
                               robot_mass_kg=model.robot_mass_kg, q0_rad=np.asarray(q0, dtype=float),
                               base0=np.asarray(base0, dtype=float))


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
