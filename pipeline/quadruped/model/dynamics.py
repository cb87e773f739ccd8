"""Dynamics of the three skateboarding modes as CasADi functions of the state and control.

* four-leg balancing: robot Eq. (3) with n_R = 4, board Eq. (7) with n_B = 4;
* three-leg balancing: the same with the push leg swinging, n_R = n_B = 3 (Sec. III-B);
* accelerating: robot Eq. (3) with n_R = 4 (the push leg on the ground or swinging), board
  velocity from Eq. (9a) with the tanh friction of Eq. (10), roll from Eq. (7) with n_B = 3.

Channel order and conventions: :mod:`skatelib.library.channels`. Every function has inputs
``x`` (28), ``u`` (24) and ``cr`` (2 x 4: each foot's contact point x, y in the board frame,
Eq. 8, used only for feet on the board) and output ``xdot`` (28).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import (
    I_BOARD_ROLL,
    I_BOARD_ROLL_RATE,
    LEGS,
    NU,
    NX,
    S_BOARD_V,
    S_OMEGA,
    S_POS,
    S_Q,
    S_RPY,
    S_VEL,
    U_F,
    U_QD,
)
from skatelib.pipeline.ocp.integrators import rk4
from skatelib.pipeline.ocp.rotations import euler_rate_map, rot_x, rot_z, rpy_to_matrix
from skatelib.pipeline.quadruped.model.system import SkateSystem


@dataclass(frozen=True)
class Mode:
    """Which feet act on the robot (n_R) and on the board (n_B), and how the board speed evolves."""

    name: str
    robot_legs: tuple[bool, bool, bool, bool]
    board_legs: tuple[bool, bool, bool, bool]
    accelerating: bool


def modes_for(push_leg: str) -> dict[str, Mode]:
    """The three modes of Sec. III for a given pushing leg (the paper's is RL)."""
    others = tuple(leg != push_leg for leg in LEGS)
    return {
        "four_leg": Mode("four_leg", (True,) * 4, (True,) * 4, False),
        "three_leg": Mode("three_leg", others, others, False),  # type: ignore[arg-type]
        "accelerating": Mode("accelerating", (True,) * 4, others, True),  # type: ignore[arg-type]
    }


def board_rotation(roll: Any, yaw: Any) -> Any:
    """R_B: deck frame to world, roll phi_B about x after yaw (Eq. 7)."""
    return rot_z(yaw) @ rot_x(roll)


def foot_centres_world(system: SkateSystem, x: Any) -> Any:
    """Foot sphere centres in the world, (3, 4) [m]: p_com + R (fk(q) - com_offset)."""
    R = rpy_to_matrix(x[S_RPY])
    rel = system.robot.foot_positions_body(x[S_Q]) - ca.repmat(ca.DM(system.srb.com_offset_m), 1, 4)
    return ca.repmat(x[S_POS], 1, 4) + R @ rel


def contact_points_world(system: SkateSystem, x: Any, on_board: tuple[bool, ...]) -> Any:
    """Foot contact points, (3, 4) [m]: the sphere centre minus the radius along the surface normal
    (the deck normal R_B e_z for feet on the board, world z otherwise)."""
    centres = foot_centres_world(system, x)
    n_board = board_rotation(x[I_BOARD_ROLL], x[S_RPY][2])[:, 2]
    cols = [centres[:, i] - system.foot_radius_m * (n_board if on_board[i] else ca.DM([0, 0, 1]))
            for i in range(4)]
    return ca.horzcat(*cols)


def state_derivative(system: SkateSystem, mode: Mode, x: Any, u: Any, cr: Any) -> Any:
    """Right-hand side dx/dt of the given mode (see the module docstring for the equations)."""
    m = system.srb.mass_kg
    inertia = ca.DM(system.srb.inertia_kgm2)
    g = ca.DM([0.0, 0.0, -system.gravity_mps2])
    rpy, vel, omega = x[S_RPY], x[S_VEL], x[S_OMEGA]
    roll_b, psi_b = x[I_BOARD_ROLL], x[I_BOARD_ROLL_RATE]
    R = rpy_to_matrix(rpy)
    forces = ca.reshape(u[U_F], 3, 4)
    contacts = contact_points_world(system, x, mode.board_legs)
    r_robot = contacts - ca.repmat(x[S_POS], 1, 4)

    f_robot = ca.DM.zeros(3)
    torque_world = ca.DM.zeros(3)
    for i in range(4):
        if mode.robot_legs[i]:
            f_robot = f_robot + forces[:, i]
            torque_world = torque_world + ca.cross(r_robot[:, i], forces[:, i])
    acc = f_robot / m + g  # Eq. (3), third row
    omega_dot = ca.solve(inertia, R.T @ torque_world - ca.cross(omega, inertia @ omega))  # Eq. (3)

    yaw = rpy[2]
    R_B = board_rotation(roll_b, yaw)
    board = system.board
    torque_board = ca.DM.zeros(3)
    f_board = ca.DM.zeros(3)
    for i in range(4):
        if mode.board_legs[i]:
            r_b = board.moment_arm(R_B, cr[0, i], cr[1, i])  # Eq. (8), about the roll axis
            torque_board = torque_board + ca.cross(r_b, forces[:, i])
            f_board = f_board + forces[:, i]
    # Eq. (7), last row: the feet push the deck with -f_i.
    psi_dot = ((-(R_B.T @ torque_board))[0] + board.roll_torque(roll_b, psi_b)) / board.roll_inertia_kgm2
    heading = ca.vertcat(ca.cos(yaw), ca.sin(yaw))
    v_fwd = ca.dot(heading, x[S_BOARD_V])  # S_x R_B^T v_B: roll does not change the x component
    if mode.accelerating:
        rolling = board.friction_force(v_fwd, board.wheel_load(f_board[2]))  # Eq. (9b), (10)
        a_fwd = ((-(R_B.T @ f_board))[0] - rolling) / board.mass_kg
    else:
        a_fwd = (R.T @ acc)[0]  # Eq. (5a): the robot's acceleration along its own x axis
    # Eq. (5a) / (9a): T_vB and S_xy R_B map x^B to the world; the wheels roll along the heading and
    # do not slide, so as the board yaws its velocity turns with it: the centripetal term
    # v_fwd * yaw_rate across the heading, which the paper's Eq. (9a) leaves out.
    rpy_rate = euler_rate_map(rpy) @ omega
    left = ca.vertcat(-heading[1], heading[0])
    v_board_dot = heading * a_fwd + left * (v_fwd * rpy_rate[2])
    return ca.vertcat(
        vel,
        rpy_rate,
        acc,
        omega_dot,
        u[U_QD],
        v_board_dot,
        psi_b,
        psi_dot,
    )


def dynamics_function(system: SkateSystem, mode: Mode) -> ca.Function:
    """``xdot = f(x, u, cr)`` for one mode, as an SX CasADi function."""
    x, u, cr = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("cr", 2, 4)
    return ca.Function(f"dynamics_{mode.name}", [x, u, cr], [state_derivative(system, mode, x, u, cr)],
                       ["x", "u", "cr"], ["xdot"])


def rk4_step(f: ca.Function, x: Any, u: Any, cr: Any, h: float, substeps: int = 1) -> Any:
    """RK4 of one mode's dynamics over ``h`` seconds, control and contact points held."""
    return rk4(lambda xx: f(xx, u, cr), x, h, substeps)


def joint_torques(system: SkateSystem, x: Any, u: Any) -> Any:
    """Quasi-static joint torques tau = -J_leg^T R^T f for the 12 joints [N m] (SRBKM legs are
    massless), used for the 12 N m limits."""
    q = x[S_Q]
    R = rpy_to_matrix(x[S_RPY])
    feet = system.robot.foot_positions_body(q)
    forces = ca.reshape(u[U_F], 3, 4)
    taus = []
    for i in range(4):
        J = ca.jacobian(feet[:, i], q)[:, 3 * i: 3 * i + 3]
        taus.append(-J.T @ (R.T @ forces[:, i]))
    return ca.vertcat(*taus)


def numeric(fn: ca.Function, *args: Any) -> np.ndarray:
    """Evaluate a CasADi function on numbers and return a flat numpy array."""
    return np.asarray(fn(*args)).reshape(-1)


__all__ = [
    "U_QD",
    "Mode",
    "board_rotation",
    "contact_points_world",
    "dynamics_function",
    "foot_centres_world",
    "joint_torques",
    "modes_for",
    "numeric",
    "rk4_step",
    "state_derivative",
]
