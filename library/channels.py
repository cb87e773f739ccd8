"""Channel names, units and conventions of the 28-dim state and 24-dim control (Eq. 17).

Conventions (the one place they are written down):

* World frame: x forward along the board's initial heading, y left, z up; origin on the
  ground under the board frame origin at t = 0.
* ``base_x..z``: the robot's centre of mass in the world [m] (the point whose acceleration is
  the sum of contact forces over the mass, Eq. 3). It sits at a fixed offset ``com_offset`` from
  the trunk frame origin, expressed in the trunk frame (single rigid body, SRBKM).
* ``base_roll, base_pitch, base_yaw``: Z-Y-X Euler angles of the trunk [rad]:
  ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` maps trunk-frame vectors to the world.
* ``base_vx..vz``: world-frame linear velocity of the centre of mass [m/s].
* ``base_wx..wz``: angular velocity in the trunk frame [rad/s].
* ``q_<leg>_<joint>``: joint angles [rad] in the URDF's convention (vendor convention for
  CyberDog2: abad about +x, hip and knee about -y, knee flexion positive).
* ``board_vx, board_vy``: world-frame planar velocity of the board frame origin C_B [m/s]
  (Eq. 4). ``board_roll`` [rad], ``board_roll_rate`` [rad/s] about the board x axis. The board's
  yaw equals the robot's (Sec. III-A-2).
* ``f_<leg>_{x,y,z}``: world-frame force [N] that the board or the ground exerts on the foot.
* ``qd_<leg>_<joint>``: joint velocities [rad/s]; control k holds on [t_k, t_{k+1}).
* Contact codes per leg: 0 swing, 1 on the board, 2 on the ground.
"""

from __future__ import annotations

from typing import Final

LEGS: Final = ("FL", "FR", "RL", "RR")
JOINTS: Final = ("abad", "hip", "knee")

SWING: Final = 0
BOARD: Final = 1
GROUND: Final = 2
CONTACT_NAMES: Final = {SWING: "swing", BOARD: "board", GROUND: "ground"}

BASE_CHANNELS: Final = (
    "base_x",
    "base_y",
    "base_z",
    "base_roll",
    "base_pitch",
    "base_yaw",
    "base_vx",
    "base_vy",
    "base_vz",
    "base_wx",
    "base_wy",
    "base_wz",
)
JOINT_CHANNELS: Final = tuple(f"q_{leg}_{joint}" for leg in LEGS for joint in JOINTS)
BOARD_CHANNELS: Final = ("board_vx", "board_vy", "board_roll", "board_roll_rate")
STATE_NAMES: Final = BASE_CHANNELS + JOINT_CHANNELS + BOARD_CHANNELS
CONTROL_NAMES: Final = tuple(f"f_{leg}_{ax}" for leg in LEGS for ax in "xyz") + tuple(
    f"qd_{leg}_{joint}" for leg in LEGS for joint in JOINTS
)

STATE_UNITS: Final = (
    ("m",) * 3 + ("rad",) * 3 + ("m/s",) * 3 + ("rad/s",) * 3 + ("rad",) * 12 + ("m/s", "m/s", "rad", "rad/s")
)
CONTROL_UNITS: Final = ("N",) * 12 + ("rad/s",) * 12

NX: Final = len(STATE_NAMES)
NU: Final = len(CONTROL_NAMES)


# Slices into the state and control vectors, derived from the names above.
S_POS: Final = slice(0, 3)
S_RPY: Final = slice(3, 6)
S_VEL: Final = slice(6, 9)
S_OMEGA: Final = slice(9, 12)
S_Q: Final = slice(12, 24)
S_BOARD_V: Final = slice(24, 26)
I_BOARD_ROLL: Final = 26
I_BOARD_ROLL_RATE: Final = 27
U_F: Final = slice(0, 12)
U_QD: Final = slice(12, 24)

assert NX == 28 and NU == 24

# The humanoid (HRP-2, Takasugi et al.): a point mass at the centre of mass, in the world frame.
HUMANOID_STATE_NAMES: Final = ("com_x", "com_y", "com_z", "com_vx", "com_vy", "com_vz")
HUMANOID_STATE_UNITS: Final = ("m", "m", "m", "m/s", "m/s", "m/s")
HUMANOID_CONTROL_NAMES: Final = ("com_ax", "com_ay", "com_az")
HUMANOID_CONTROL_UNITS: Final = ("m/s^2",) * 3
ZMP_NAMES: Final = ("zmp_x", "zmp_y")  # zero-moment point on the ground [m]
POINT_NAMES: Final = ("x", "y", "z")  # a contact point [m]
