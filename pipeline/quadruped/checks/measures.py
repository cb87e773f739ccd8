"""The measures of :mod:`skatelib.pipeline.quadruped.checks.verify`, each on the stored arrays of one
trajectory: how it ends, the fine re-integration's defect, foot slip on the ground and on the deck,
the swinging foot's clearance and the joint torques. None uses the transcription."""

from __future__ import annotations

import weakref
from collections.abc import Callable

import casadi as ca
import numpy as np
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, NX, S_BOARD_V, S_OMEGA, S_RPY, S_VEL, SWING
from skatelib.library.margins import momentum_speed
from skatelib.library.rotations import board_rotations
from skatelib.pipeline.quadruped.model.dynamics import dynamics_function, joint_torques, modes_for, rk4_step
from skatelib.pipeline.quadruped.model.system import SkateSystem


def riding_end(system: SkateSystem, x: np.ndarray, label: float) -> dict[str, float]:
    """How the entry ends: the speeds robot and board ride on at, by momentum (no model code)."""
    heading = np.array([np.cos(x[5]), np.sin(x[5])])
    v_robot, v_board = x[S_VEL][:2], x[S_BOARD_V]
    v_mom = float(momentum_speed(x, system.srb.mass_kg, system.board.mass_kg))
    return {
        "final_board_speed_mps": float(heading @ v_board), "final_robot_speed_mps": float(heading @ v_robot),
        "momentum_speed_mps": v_mom, "momentum_speed_error": abs(v_mom - label) / (label or 1.0),
        "final_relative_speed_mps": float(np.linalg.norm(v_robot - v_board)),
        "final_vertical_speed_mps": float(abs(x[S_VEL][2])),
        "final_angular_speed_radps": float(np.abs(x[S_OMEGA]).max()),
    }


def board_lateral_speed(state: np.ndarray) -> float:
    """The board's largest velocity across its heading over the knots [m/s] (no model code: the
    stored yaw and board velocity)."""
    yaw = state[:, S_RPY][:, 2]
    left = np.stack([-np.sin(yaw), np.cos(yaw)], axis=-1)
    return float(np.abs(np.einsum("kj,kj->k", left, state[:, S_BOARD_V])).max(initial=0.0))


# CasADi functions the checks build, per process and system: an entry goes when its system does
# (weakref.finalize), so an id is never served to another system and a process that makes many
# systems (validate() on many libraries) does not keep them all.
_BUILT: dict[tuple[object, ...], ca.Function] = {}


def _built(system: SkateSystem, what: tuple[object, ...], build: Callable[[], ca.Function]) -> ca.Function:
    key = (id(system), *what)
    if key not in _BUILT:
        _BUILT[key] = build()
        weakref.finalize(system, _BUILT.pop, key, None)
    return _BUILT[key]


def _fine_step(system: SkateSystem, h: float, substeps: int) -> ca.Function:
    """The fine RK4 step over ``h`` of the accelerating mode's dynamics (built once per system)."""

    def build() -> ca.Function:
        f = dynamics_function(system, modes_for(system.push_leg)["accelerating"])
        x_sym, u_sym = ca.SX.sym("x", NX), ca.SX.sym("u", 24)
        step = rk4_step(f, x_sym, u_sym, ca.DM(system.stance.cr), h, substeps)
        return ca.Function("fine", [x_sym, u_sym], [step])

    return _built(system, ("fine", h, substeps), build)


def defect(system: SkateSystem, t: np.ndarray, state: np.ndarray, control: np.ndarray, substeps: int) -> float:
    """Largest mismatch between each knot and a fine RK4 re-integration from the one before (the
    intervals of one length integrated together)."""
    steps = [round(float(t[k + 1] - t[k]), 12) for k in range(len(t) - 1)]
    defect = 0.0
    for h in dict.fromkeys(steps):
        ks = np.array([k for k, hk in enumerate(steps) if hk == h])
        fine = _fine_step(system, h, substeps).map(len(ks))
        nxt = np.asarray(fine(state[ks].T, control[ks].T)).T
        defect = max(defect, float(np.abs(nxt - state[ks + 1]).max()))
    return defect


def ground_slip(contact: np.ndarray, foot: np.ndarray) -> float:
    """Largest distance the push foot moves from where it touched down, per ground run."""
    slip, k = 0.0, 0
    while k < len(contact) - 1:
        if contact[k] == GROUND:
            k0 = k
            while k < len(contact) - 1 and contact[k] == GROUND:
                k += 1
            run = foot[k0:k + 1]
            slip = max(slip, float(np.linalg.norm(run - run[0], axis=1).max()))
        else:
            k += 1
    return slip


def board_slip(system: SkateSystem, state: np.ndarray, contact: np.ndarray, foot_pos: np.ndarray,
                board_pos: np.ndarray) -> float:
    """Largest distance of a foot on the deck from its deck point (Eq. 8) [m]."""
    R_B = board_rotations(state[:, S_RPY][:, 2], state[:, I_BOARD_ROLL])
    h = system.board.roll_axis_depth_m  # the deck rolls about its axles, h below its top
    cr = np.vstack([system.stance.cr, np.full(4, h)])  # (3, 4) deck points from the roll axis, board frame
    points = board_pos[:, None, :3] + np.einsum("kij,jl->kli", R_B, cr) - np.array([0.0, 0.0, h])
    dist = np.linalg.norm(foot_pos - points, axis=-1)
    return float(dist[contact == BOARD].max(initial=0.0))


def swing_clearance(system: SkateSystem, state: np.ndarray, contact: np.ndarray, foot_pos: np.ndarray,
                     board_pos: np.ndarray) -> float:
    """Lowest point of the swinging push foot above the ground, and above the deck top wherever it
    is over the deck's footprint [m]."""
    p = system.push_index
    k = np.flatnonzero(contact[:, p] == SWING)
    if k.size == 0:
        return float("inf")
    bottom = foot_pos[k, p]
    R_B = board_rotations(state[k, S_RPY][:, 2], state[k, I_BOARD_ROLL])
    local = np.einsum("kji,kj->ki", R_B, bottom - board_pos[k, :3])
    b = system.board
    over = (np.abs(local[:, 0]) <= b.deck_length_m / 2) & (np.abs(local[:, 1]) <= b.deck_width_m / 2)
    above_deck = np.where(over, local[:, 2], np.inf)
    return float(np.minimum(bottom[:, 2], above_deck).min())


def max_torque(system: SkateSystem, state: np.ndarray, control: np.ndarray) -> float:
    """The largest quasi-static joint torque over the control knots [N m]."""

    def build() -> ca.Function:
        x_sym, u_sym = ca.SX.sym("x", NX), ca.SX.sym("u", 24)
        return ca.Function("tau", [x_sym, u_sym], [joint_torques(system, x_sym, u_sym)])

    many = _built(system, ("tau",), build).map(len(control))
    return float(np.abs(np.asarray(many(state[:len(control)].T, control.T))).max())


def wheel_loads(system: SkateSystem, state: np.ndarray, control: np.ndarray, contact: np.ndarray) -> float:
    """The least load [N] the wheels of the lighter side carry over the control knots: half the
    wheels' load less what the feet's roll moment on the deck (about its roll axis) takes, N / 2 -
    |M| / w. Below zero a wheel lifts."""
    b, n = system.board, len(control)
    R_B = board_rotations(state[:n, S_RPY][:, 2], state[:n, I_BOARD_ROLL])
    local = np.vstack([system.stance.cr, np.full(4, b.roll_axis_depth_m)])
    arms = np.einsum("kij,jl->kli", R_B, local)  # (n, 4, 3)
    f = control[:, :12].reshape(n, 4, 3)
    on_deck = (contact[:n] == BOARD)[:, :, None]
    moment = np.einsum("kji,kj->ki", R_B, np.sum(np.cross(arms, -f) * on_deck, axis=1))[:, 0]
    load = b.mass_kg * system.gravity_mps2 + np.sum(f[:, :, 2] * on_deck[:, :, 0], axis=1)
    return float(np.min(load / 2 - np.abs(moment) / b.wheel_track_m, initial=np.inf))


def near_ground_speeds(system: SkateSystem, t: np.ndarray, contact: np.ndarray, foot_pos: np.ndarray
                       ) -> tuple[float, float]:
    """The push foot's largest horizontal speed over the ground and largest descent speed [m/s]
    on intervals in the air that reach within ``contact.near_ground_m`` of the ground (the lower
    of the two knots' heights of the sphere's bottom)."""
    c = system.contact
    if c is None:
        return 0.0, 0.0
    p = system.push_index
    airborne = (contact[:-1, p] == SWING) | (contact[1:, p] == SWING)
    foot = foot_pos[:, p]
    low = np.minimum(foot[:-1, 2], foot[1:, 2]) < c.near_ground_m - 1e-4  # a knot held at the band's edge is above it
    v = np.diff(foot, axis=0) / np.diff(t)[:, None]
    near = airborne & low
    return (float(np.linalg.norm(v[near, :2], axis=1).max(initial=0.0)),
            float((-v[near, 2]).max(initial=0.0)))
