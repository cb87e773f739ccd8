"""Numpy helpers shared by the physics checks, the Rerun views, the runtime and the reference
controller (numpy only): Coulomb friction margins and forward speed of stored trajectories."""

from __future__ import annotations

import numpy as np
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, S_BOARD_V, S_RPY, S_VEL
from skatelib.library.rotations import board_rotations

UNLOADED_N = 1e-3  # [N]


def contact_forces_local(state: np.ndarray, control: np.ndarray, contact: np.ndarray) -> np.ndarray:
    """Per control knot and foot, the force in its contact's frame (deck frame on the board, world
    on the ground): (K-1, 4, 3), normal component last."""
    n = len(control)
    R_B = board_rotations(state[:n, S_RPY][:, 2], state[:n, I_BOARD_ROLL])
    f = control[:, :12].reshape(n, 4, 3)
    return np.where((contact[:n] == BOARD)[:, :, None], np.einsum("kji,klj->kli", R_B, f), f)


def friction_margins(state: np.ndarray, control: np.ndarray, contact: np.ndarray,
                     mu: float) -> tuple[np.ndarray, np.ndarray]:
    """Per control knot: the smallest Coulomb margin mu f_n - |f_t| [N] (the exact cone, |f_t| the
    Euclidean norm of the tangential force) and the smallest normal force [N] over the feet in
    contact; +inf where none is."""
    local = contact_forces_local(state, control, contact)
    touching = np.isin(contact[:len(control)], (BOARD, GROUND))
    margin = np.where(touching, mu * local[:, :, 2] - np.hypot(local[:, :, 0], local[:, :, 1]), np.inf)
    return margin.min(axis=1), np.where(touching, local[:, :, 2], np.inf).min(axis=1)


def friction_use(state: np.ndarray, control: np.ndarray, contact: np.ndarray, mu: float) -> float:
    """The largest |f_t| / (mu f_n) over feet in contact: 1 is on the cone, above 1 slides [-].
    Feet whose whole force is below ``UNLOADED_N`` count as unused (the ratio means nothing there)."""
    local = contact_forces_local(state, control, contact)
    touching = np.isin(contact[:len(control)], (BOARD, GROUND))
    ft, fn = np.hypot(local[:, :, 0], local[:, :, 1]), local[:, :, 2]
    unloaded = np.hypot(ft, fn) <= UNLOADED_N  # a foot that carries (almost) nothing uses no friction
    use = np.where(fn > 0.0, ft / (mu * np.maximum(fn, 1e-300)), np.inf)
    return float(np.where(touching & ~unloaded, use, 0.0).max(initial=0.0))


def forward_speed(state: np.ndarray) -> np.ndarray:
    """The board's speed along its heading (its yaw is the robot's) [m/s], per knot."""
    yaw = state[..., S_RPY][..., 2]
    v = state[..., S_BOARD_V]
    return np.cos(yaw) * v[..., 0] + np.sin(yaw) * v[..., 1]


def momentum_speed(state: np.ndarray, robot_mass_kg: float, board_mass_kg: float) -> np.ndarray:
    """(m_R v_R + m_B v_B) / (m_R + m_B) along the heading [m/s], per knot: the speed robot and
    board ride at together once the feet hold on the deck."""
    yaw = state[..., S_RPY][..., 2]
    v = (robot_mass_kg * state[..., S_VEL][..., :2] + board_mass_kg * state[..., S_BOARD_V]) / (
        robot_mass_kg + board_mass_kg)
    return np.cos(yaw) * v[..., 0] + np.sin(yaw) * v[..., 1]
