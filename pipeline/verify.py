"""Independent physics checks of a solved push-off trajectory.

Nothing here uses the transcription: each shooting interval is re-integrated with a fine-step
RK4 of the mode dynamics, and friction, slip, joint and torque limits are measured on the
stored arrays. ``skatelib validate`` runs these on every library entry.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import casadi as ca
import numpy as np
from skatelib.library.channels import BOARD, GROUND, NX
from skatelib.pipeline.dynamics import board_rotation, dynamics_function, joint_torques, modes_for, rk4_step
from skatelib.pipeline.system import SkateSystem


@dataclass(frozen=True)
class PhysicsReport:
    """Measured margins; negative margins and positive violations are failures.

    Attributes:
        max_defect: Largest state mismatch between knot k+1 and a fine re-integration from knot k.
        min_friction_margin_N: Smallest mu f_n - |f_t| (per tangent axis) over feet in contact [N].
        min_normal_force_N: Smallest normal force over feet in contact [N].
        max_ground_slip_m: Largest motion of the pushing foot while on the ground [m].
        max_board_slip_m: Largest distance of a foot from its deck point [m].
        max_joint_limit_violation_rad: Largest joint-angle excursion past a limit [rad].
        max_torque_Nm: Largest quasi-static joint torque [N m] (limit: ``torque_limit_Nm``).
        max_joint_velocity_radps: Largest joint speed [rad/s].
        max_board_roll_rad: Largest |deck roll| [rad].
    """

    max_defect: float
    min_friction_margin_N: float
    min_normal_force_N: float
    max_ground_slip_m: float
    max_board_slip_m: float
    max_joint_limit_violation_rad: float
    max_torque_Nm: float
    max_joint_velocity_radps: float
    max_board_roll_rad: float

    def as_dict(self) -> dict[str, float]:
        return {k: float(v) for k, v in asdict(self).items()}

    def failures(self, system: SkateSystem, defect_tol: float = 1e-3, force_tol: float = 1e-4,
                 slip_tol: float = 1e-5, angle_tol: float = 1e-6) -> list[str]:
        """Human-readable list of the checks that fail; empty when the trajectory is valid."""
        out = []
        if self.max_defect > defect_tol:
            out.append(f"dynamics defect {self.max_defect:.2e} > {defect_tol:.0e}")
        if self.min_friction_margin_N < -force_tol:
            out.append(f"friction cone violated by {-self.min_friction_margin_N:.2e} N")
        if self.min_normal_force_N < -force_tol:
            out.append(f"pulling normal force {self.min_normal_force_N:.2e} N")
        if self.max_ground_slip_m > slip_tol:
            out.append(f"push foot slides {self.max_ground_slip_m:.2e} m on the ground")
        if self.max_board_slip_m > slip_tol:
            out.append(f"foot leaves its deck point by {self.max_board_slip_m:.2e} m")
        if self.max_joint_limit_violation_rad > angle_tol:
            out.append(f"joint limit exceeded by {self.max_joint_limit_violation_rad:.2e} rad")
        if self.max_torque_Nm > system.torque_limit_Nm * (1 + 1e-6) + force_tol:
            out.append(f"torque {self.max_torque_Nm:.3f} N m > {system.torque_limit_Nm} N m")
        if self.max_joint_velocity_radps > system.joint_velocity_limit_radps * (1 + 1e-6):
            out.append(f"joint speed {self.max_joint_velocity_radps:.2f} rad/s over the limit")
        if self.max_board_roll_rad > system.board.roll_limit_rad * (1 + 1e-6):
            out.append(f"deck roll {self.max_board_roll_rad:.3f} rad over the limit")
        return out


def board_rotations(yaw: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """R_B = Rz(yaw) Rx(roll) for arrays of angles: (K, 3, 3)."""
    cy, sy, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(roll), np.sin(roll)
    z = np.zeros_like(yaw)
    return np.stack([np.stack([cy, -sy * cr, sy * sr], -1), np.stack([sy, cy * cr, -cy * sr], -1),
                     np.stack([z, sr, cr], -1)], axis=-2)


def friction_margins(state: np.ndarray, control: np.ndarray, contact: np.ndarray,
                     mu: float) -> tuple[np.ndarray, np.ndarray]:
    """Per control knot: the smallest mu f_n - |f_t| [N] and the smallest normal force [N] over the
    feet in contact (deck frame on the board, world on the ground); +inf where none is."""
    n = len(control)
    R_B = board_rotations(state[:n, 5], state[:n, 26])
    f = control[:, :12].reshape(n, 4, 3)
    local = np.where((contact[:n] == BOARD)[:, :, None], np.einsum("kji,klj->kli", R_B, f), f)
    tangential = np.maximum(np.abs(local[:, :, 0]), np.abs(local[:, :, 1]))
    touching = np.isin(contact[:n], (BOARD, GROUND))
    margin = np.where(touching, mu * local[:, :, 2] - tangential, np.inf).min(axis=1)
    normal = np.where(touching, local[:, :, 2], np.inf).min(axis=1)
    return margin, normal


def check_trajectory(system: SkateSystem, t: np.ndarray, state: np.ndarray, control: np.ndarray,
                     contact: np.ndarray, foot_pos: np.ndarray, board_pos: np.ndarray,
                     substeps: int = 40) -> PhysicsReport:
    """Measure a push-off trajectory (library arrays) against the model's physics."""
    mode = modes_for(system.push_leg)["accelerating"]
    f = dynamics_function(system, mode)
    cr = ca.DM(system.stance.cr)
    x_sym, u_sym = ca.SX.sym("x", NX), ca.SX.sym("u", 24)
    fine: dict[float, ca.Function] = {}
    defect = 0.0
    for k in range(len(t) - 1):
        h = round(float(t[k + 1] - t[k]), 12)
        if h not in fine:
            fine[h] = ca.Function("fine", [x_sym, u_sym], [rk4_step(f, x_sym, u_sym, cr, h, substeps)])
        nxt = np.asarray(fine[h](state[k], control[k])).reshape(-1)
        defect = max(defect, float(np.abs(nxt - state[k + 1]).max()))

    margins, normals = friction_margins(state, control, contact, system.friction_mu)
    margin, normal = float(margins.min(initial=np.inf)), float(normals.min(initial=np.inf))

    p = system.push_index
    ground_slip = 0.0
    k = 0
    while k < len(t) - 1:
        if contact[k, p] == GROUND:
            k0 = k
            while k < len(t) - 1 and contact[k, p] == GROUND:
                k += 1
            run = foot_pos[k0:k + 1, p]
            ground_slip = max(ground_slip, float(np.linalg.norm(run - run[0], axis=1).max()))
        else:
            k += 1

    board_slip = 0.0
    for k in range(len(t)):
        R_B = np.asarray(board_rotation(state[k, 26], state[k, 5]))
        origin = board_pos[k, :3]
        for i in range(4):
            if contact[k, i] == BOARD:
                point = origin + R_B @ np.array([system.stance.cr[0, i], system.stance.cr[1, i], 0.0])
                board_slip = max(board_slip, float(np.linalg.norm(foot_pos[k, i] - point)))

    q = state[:, 12:24]
    lim = float(max(np.max(system.robot.lower_limits - q), np.max(q - system.robot.upper_limits), 0.0))
    tau_fn = ca.Function("tau", [x_sym, u_sym], [joint_torques(system, x_sym, u_sym)])
    tau = max(float(np.abs(np.asarray(tau_fn(state[k], control[k]))).max()) for k in range(len(t) - 1))
    return PhysicsReport(
        max_defect=defect, min_friction_margin_N=float(margin), min_normal_force_N=float(normal),
        max_ground_slip_m=ground_slip, max_board_slip_m=board_slip, max_joint_limit_violation_rad=lim,
        max_torque_Nm=tau, max_joint_velocity_radps=float(np.abs(control[:, 12:24]).max()),
        max_board_roll_rad=float(np.abs(state[:, 26]).max()),
    )
