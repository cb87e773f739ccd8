"""The MPC's constraint rows from the contact schedule: per step and leg, zero force in swing; in
contact, the normal force within [f_min, f_max] along the surface normal (deck normal R_B e_z, or
world z on the ground) inside the pyramid of ``facets`` sides inscribed in Coulomb's cone of
mu_mpc; with the feedback's torque maps, the loaded legs' joint torques within the limit."""

from __future__ import annotations

import numpy as np
from skatelib.control.linear_model import Feedback
from skatelib.control.mpc_config import MpcConfig
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, I_BOARD_ROLL, SWING
from skatelib.library.rotations import board_rotations, skew

NF = 12  # force variables per step
# The first step's deck pyramids also hold this far beyond the roll the update predicts at its end:
# the plant's deck rolls on with what the model does not know (its stiffness, the feet's levers).
ROLL_SLACK_RAD = 0.01


def leg_rows(p: SkateParams, cfg: MpcConfig, x0: np.ndarray, contact: np.ndarray,
               rolls: tuple[float, ...], torque_maps: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of the friction pyramid and normal bounds for one step's forces (12 columns). A foot on
    the deck gets the pyramid about the deck normal at each of ``rolls`` (the first step's force
    is held while the deck rolls on: its pyramid must hold at both ends of the update). With
    ``torque_maps``, each loaded leg's joint torques at the feedback's joint angles stay within
    the torque limit (the joints are held over the horizon: the linearizable part of the limit)."""
    mu = p.mu_plan if cfg.mu is None else cfg.mu
    angles = np.arange(cfg.facets) * (2.0 * np.pi / cfg.facets)
    directions = np.stack([np.cos(angles), np.sin(angles), np.full(cfg.facets, -mu * np.cos(np.pi / cfg.facets))])

    def pyramid(frame: np.ndarray) -> np.ndarray:  # (facets + 1, 3): facet rows, then the normal
        return np.vstack([directions.T @ frame.T, frame[:, 2]])

    ground = [pyramid(board_rotations(x0[5], 0.0))]
    deck = [pyramid(board_rotations(x0[5], r)) for r in rolls]
    rows: list[np.ndarray] = []
    lo: list[float] = []
    hi: list[float] = []
    for i in range(4):
        if contact[i] == SWING:
            continue
        for j, facets in enumerate(deck if contact[i] == BOARD else ground):
            block = np.zeros((cfg.facets + (j == 0), 12))
            block[:, 3 * i:3 * i + 3] = facets[:len(block)]
            rows.append(block)
            lo.extend((-np.inf,) * cfg.facets + ((cfg.f_min_N,) if j == 0 else ()))
            hi.extend((0.0,) * cfg.facets + ((cfg.f_max_N,) if j == 0 else ()))
        if torque_maps is not None and np.isfinite(p.torque_limit_Nm):
            block = np.zeros((3, 12))
            block[:, 3 * i:3 * i + 3] = torque_maps[i]
            rows.append(block)
            lo.extend((-p.torque_limit_Nm,) * 3)
            hi.extend((p.torque_limit_Nm,) * 3)
    wheels = wheel_rows(p, x0, contact)
    if wheels is not None:
        rows.append(wheels[0])
        lo.extend(wheels[1])
        hi.extend((np.inf, np.inf))
    return (np.vstack(rows) if rows else np.zeros((0, 12))), np.array(lo), np.array(hi)


def wheel_rows(p: SkateParams, x0: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, list[float]] | None:
    """Every wheel keeps a load: the feet's roll moment on the deck M and the wheels' load N
    (board weight + the feet's vertical forces) with ``(1 - margin) N w / 2 -/+ M >= 0``; two rows
    (12 columns) and their lower bounds, or None without a wheel track or a foot on the deck."""
    on_deck = contact == BOARD
    if p.wheel_track_m <= 0.0 or not np.any(on_deck):
        return None
    R_B = board_rotations(x0[5], x0[I_BOARD_ROLL])
    arms = p.moment_arms(R_B)
    half = (1.0 - p.wheel_load_margin) * p.wheel_track_m / 2
    block = np.zeros((2, 12))
    for i in np.flatnonzero(on_deck):
        moment = (R_B.T @ skew(arms[:, i]))[0]  # M = -moment . f_i summed: the feet push the deck with -f
        block[0, 3 * i:3 * i + 3] = half * np.array([0.0, 0.0, 1.0]) + moment
        block[1, 3 * i:3 * i + 3] = half * np.array([0.0, 0.0, 1.0]) - moment
    floor = -half * p.board_mass_kg * p.gravity_mps2
    return block, [floor, floor]


def step_constraints(p: SkateParams, cfg: MpcConfig, fb: Feedback, contact: np.ndarray, dt: float
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, ...]]:
    """The contact rows of every step of the horizon: ``(C, l, u, rows per step)``, C block
    diagonal over the steps (12 force columns each), l <= C f <= u. The first step's deck pyramid
    holds at the deck's roll now and one update later; torque rows on the first
    ``cfg.torque_steps`` steps."""
    rows_cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    per_step = []
    roll, roll_rate = fb.x[I_BOARD_ROLL], fb.x[I_BOARD_ROLL + 1]
    N = len(contact)
    for k in range(N):
        torque = k < cfg.torque_steps
        key = contact[k].tobytes() + bytes([k == 0, torque])
        if key not in rows_cache:
            end = roll + roll_rate * dt  # the first step's force is held while the deck rolls on
            rolls = (roll, end - ROLL_SLACK_RAD, end + ROLL_SLACK_RAD) if k == 0 else (roll,)
            rows_cache[key] = leg_rows(p, cfg, fb.x, contact[k], rolls, fb.torque_maps if torque else None)
        per_step.append(rows_cache[key])
    C = np.zeros((sum(len(rows) for rows, _, _ in per_step), N * NF))
    at = 0
    for k, (rows, _, _) in enumerate(per_step):
        C[at:at + len(rows), k * NF:(k + 1) * NF] = rows
        at += len(rows)
    lo = np.concatenate([l_k for _, l_k, _ in per_step])
    hi = np.concatenate([h_k for _, _, h_k in per_step])
    return C, lo, hi, tuple(len(rows) for rows, _, _ in per_step)
