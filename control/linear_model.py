"""The paper's linear MPC model, Eq. (17)-(18), in numpy.

At each MPC update the feedback fixes the lever arms r_Ri (contact point minus COM), r_Bi (Eq. 8),
the attitudes theta_R and the deck roll; they stay constant over the horizon, so each step is
linear: X(k+1) = A_d X(k) + B_d(k) U(k) + c_d(k). The mode of step k (which legs push on the
deck, on the ground or swing) comes from the library's contact schedule.

Choices beyond the printed equations (each written where it is used):

* Eq. (17)'s last row reads ``-K_B, -B_B``; Eq. (7) divides the trunk torque by I_Bx, so the row
  is ``-K_B / I_Bx, -B_B / I_Bx`` here (the printed one drops the inertia).
* Discretization is exact zero-order hold: A is block diagonal with a nilpotent part (A^2 = 0:
  positions from velocities, Euler angles from rates) and the 2 x 2 deck-roll block, so
  exp(A dt) = I + A dt outside the roll block and the roll block's is computed once.
* ``B_vB`` and ``C_vB`` per mode as printed; sign() of the feedback forward speed with a dead band.
* The board's velocity turns with its yaw (the wheels roll along the heading and do not slide):
  the centripetal term v_fwd * yaw_rate across the heading, which Eq. (9a) leaves out, with the
  forward speed frozen at the feedback's (as the attitudes are), so that it is linear in the
  angular velocity and A stays nilpotent outside the roll block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, I_BOARD_ROLL, I_BOARD_ROLL_RATE, NU, NX, SWING
from skatelib.library.margins import forward_speed
from skatelib.library.rotations import board_rotations, euler_rate_map, rpy_matrices, skew

_SIGN_DEADBAND_MPS = 0.02  # |v| below this: sign() = 0 (the board is at rest)


@dataclass(frozen=True)
class Feedback:
    """What the MPC freezes at an update: the state and the lever arms of every foot.

    Attributes:
        x: (28,) state.
        r_robot: (3, 4) contact point minus COM, world [m] (r_Ri).
        r_board: (3, 4) R_B times the deck point of each foot, world [m] (r_Bi, Eq. 8).
        torque_maps: (4, 3, 3) per leg the matrix giving its joint torques from its foot force in
            the world (-J(q)^T R^T at the measured joint angles, the whole-body controller's
            Jacobians); None: no torque rows in the QP.
    """

    x: np.ndarray
    r_robot: np.ndarray
    r_board: np.ndarray
    torque_maps: np.ndarray | None = None


def continuous_model(p: SkateParams, fb: Feedback, contact: np.ndarray,
                     accelerating: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A (28 x 28), B (28 x 24), C (28,) of Eq. (17) for one contact mode.

    Args:
        contact: (4,) codes per leg (0 swing, 1 board, 2 ground).
        accelerating: The acceleration mode (Eq. 9: the board's own mass and rolling friction),
            for the whole push-off including the push leg's swing, as in the optimization;
            otherwise the balancing model (Eq. 5a: the board follows the robot).
    """
    x = fb.x
    rpy = x[3:6]
    R = rpy_matrices(rpy)
    R_B = board_rotations(rpy[2], x[I_BOARD_ROLL])
    A = np.zeros((NX, NX))
    A[0:3, 6:9] = np.eye(3)
    A[3:6, 9:12] = euler_rate_map(rpy)
    A[I_BOARD_ROLL, I_BOARD_ROLL_RATE] = 1.0
    A[I_BOARD_ROLL_RATE, I_BOARD_ROLL] = -p.loaded_roll_stiffness / p.roll_inertia_kgm2
    A[I_BOARD_ROLL_RATE, I_BOARD_ROLL_RATE] = -p.bb_Nms_per_rad / p.roll_inertia_kgm2
    B = np.zeros((NX, NU))
    C = np.zeros(NX)
    g = np.array([0.0, 0.0, -p.gravity_mps2])
    C[6:9] = g
    I_inv = np.linalg.inv(p.inertia_kgm2)
    yaw = rpy[2]
    T_vB = board_rotations(yaw, 0.0)[:2, :2] @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # Eq. (5b)
    S_xy_RB_Sx = R_B[:2, :] @ np.diag([1.0, 0.0, 0.0])
    for i in range(4):
        if contact[i] == SWING:
            continue
        cols = slice(3 * i, 3 * i + 3)
        B[6:9, cols] = np.eye(3) / p.mass_kg
        B[9:12, cols] = I_inv @ R.T @ skew(fb.r_robot[:, i])
        if contact[i] == BOARD:
            B[I_BOARD_ROLL_RATE, cols] = -(R_B.T @ skew(fb.r_board[:, i]))[0] / p.roll_inertia_kgm2
            if accelerating:
                B[24:26, cols] = -S_xy_RB_Sx @ R_B.T / p.board_mass_kg
        if not accelerating:
            B[24:26, cols] = T_vB @ R.T / p.mass_kg
    if accelerating:
        # Rolling resistance in proportion to the wheels' load (the board's weight and the deck
        # feet's vertical forces): rolling_N is the board's with the robot's weight on it.
        v_fwd = float(forward_speed(x))
        sign = 0.0 if abs(v_fwd) < _SIGN_DEADBAND_MPS else float(np.sign(v_fwd))
        per_newton = sign * p.rolling_N / ((p.board_mass_kg + p.mass_kg) * p.gravity_mps2)
        drag = -S_xy_RB_Sx @ np.array([per_newton, 0.0, 0.0]) / p.board_mass_kg
        C[24:26] = drag * p.board_mass_kg * p.gravity_mps2
        for leg in np.flatnonzero(contact == BOARD):
            B[24:26, 3 * int(leg) + 2] += drag
    else:
        C[24:26] = T_vB @ R.T @ g
    B[12:24, 12:24] = np.eye(12)
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    A[24:26, 9:12] = np.outer(left * float(forward_speed(x)), euler_rate_map(rpy)[2])
    return A, B, C


class Discretizer:
    """Exact zero-order hold of Eq. (17) at a fixed step (Eq. 18), reusing the deck-roll block."""

    def __init__(self, p: SkateParams, dt_s: float):
        from scipy.linalg import expm

        self.dt = dt_s
        M = np.array([[0.0, 1.0], [-p.loaded_roll_stiffness / p.roll_inertia_kgm2,
                                   -p.bb_Nms_per_rad / p.roll_inertia_kgm2]])
        aug = np.zeros((4, 4))
        aug[:2, :2], aug[:2, 2:] = M, np.eye(2)
        E = expm(aug * dt_s)
        self.roll_exp, self.roll_gamma = E[:2, :2], E[:2, 2:]  # exp(M dt), int_0^dt exp(M s) ds

    def __call__(self, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        dt = self.dt
        r = slice(I_BOARD_ROLL, I_BOARD_ROLL_RATE + 1)
        An = A.copy()
        An[r, r] = 0.0
        Ad = np.eye(NX) + An * dt
        Gamma = np.eye(NX) * dt + An * (dt * dt / 2.0)
        Ad[r, r] = self.roll_exp
        Gamma[r, r] = self.roll_gamma
        return Ad, Gamma @ B, Gamma @ C
