"""The simulated plant: the nonlinear single rigid body and board of Eq. (3), (7) and (9),
integrated with RK4 at a fine step, which is not the MPC's model.

Differences from the MPC's linear model, on purpose:

* the full rigid-body rotation (the gyroscopic term, attitudes and lever arms that move);
* the board always has its mass along its x axis (Eq. 9 in every mode): deck forces cannot move
  robot and board together, so horizontal momentum changes only by ground pushes and rolling
  friction (the balancing model Eq. 5a lets the robot drag the board along);
* Coulomb's cone with the plant's own mu: a commanded force outside it is clipped to it (a slip,
  counted), a pulling normal force is set to zero;
* parameters that differ from the model's (``--perturb``), a COM that is not where the model
  thinks, feedback noise and a lateral impulse.

Feet in contact stay at their contact points: deck points (Eq. 8) for feet on the board, the
touch-down point for the push foot. Swinging feet carry no force (massless legs); the joint
angles integrate the commanded joint velocities.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, I_BOARD_ROLL_RATE, NX, SWING
from skatelib.library.margins import momentum_speed
from skatelib.library.rotations import board_rotations, euler_rate_map, rpy_matrices

NB = NX + 3  # plant state: the 28 channels, then the board origin x, y and the deck height z


@dataclass
class ContactLog:
    """Per plant step: slips, unloaded feet (a foot in contact whose commanded force does not press
    on the surface), the smallest normal force of a loaded foot, friction use."""

    slips: int = 0
    unloaded_steps: int = 0
    slip_excess_N: float = 0.0
    min_normal_N: float = np.inf
    max_friction_use: float = 0.0
    min_friction_margin_N: float = np.inf  # mu f_n - |f_t| of the commanded force, over loaded feet
    clipped_steps: list[float] = field(default_factory=list)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors (np.cross costs ten times as much on vectors this small)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class PlantInput(NamedTuple):
    """What drives the plant over a step: the commanded foot forces (3, 4) [N], the joint
    velocities (12,) [rad/s] and an external force on the robot's COM (3,) [N] or None."""

    forces: np.ndarray
    qd: np.ndarray
    external_N: np.ndarray | None = None


class Plant:
    """Nonlinear skateboarding dynamics with contacts held in place.

    Args:
        p: The plant's true parameters (the MPC may hold others).
        com_shift_m: (3,) true COM minus the model's COM, trunk frame.
    """

    def __init__(self, p: SkateParams, com_shift_m: np.ndarray | None = None):
        self.p = p
        self.com_shift = np.zeros(3) if com_shift_m is None else np.asarray(com_shift_m, float)
        self.I = p.inertia_kgm2
        self.I_inv = np.linalg.inv(p.inertia_kgm2)
        self.log = ContactLog()

    def contact_points(self, s: np.ndarray, contact: np.ndarray, ground_points: np.ndarray) -> np.ndarray:
        """(3, 4) world contact points: deck points moved with the board, ground points fixed."""
        R_B = board_rotations(s[5], s[I_BOARD_ROLL])
        deck = self.p.deck_points(R_B)
        out = np.array(ground_points, dtype=float, copy=True)
        origin = s[NX:NX + 3]
        for i in range(4):
            if contact[i] == BOARD:
                out[:, i] = origin + deck[:, i]
        return out

    def admissible(self, s: np.ndarray, forces: np.ndarray, contact: np.ndarray, t: float,
                   record: bool) -> np.ndarray:
        """The forces the contacts can give: zero for swinging feet, inside Coulomb's cone (mu of
        the plant) about the deck normal or the ground normal; clipping is counted as a slip."""
        out = np.zeros((3, 4))
        n_deck = board_rotations(s[5], s[I_BOARD_ROLL])[:, 2]
        for i in range(4):
            if contact[i] == SWING:
                continue
            n = n_deck if contact[i] == BOARD else np.array([0.0, 0.0, 1.0])
            f = forces[:, i]
            fn = float(f @ n)
            if fn <= 0.0:
                if record:
                    self.log.unloaded_steps += 1
                continue  # the surface cannot pull: the foot unloads
            ft = f - fn * n
            t_norm = float(np.linalg.norm(ft))
            limit = self.p.mu * fn
            if record:
                self.log.min_normal_N = min(self.log.min_normal_N, fn)
                self.log.max_friction_use = max(self.log.max_friction_use, t_norm / fn)
                self.log.min_friction_margin_N = min(self.log.min_friction_margin_N, limit - t_norm)
            if t_norm > limit:
                if record and t_norm - limit > 1e-3 * max(fn, 1.0):
                    self.log.slips += 1
                    self.log.slip_excess_N = max(self.log.slip_excess_N, t_norm - limit)
                    self.log.clipped_steps.append(t)
                ft = ft * (limit / t_norm)
            out[:, i] = fn * n + ft
        return out

    def derivative(self, s: np.ndarray, forces: np.ndarray, qd: np.ndarray, contact: np.ndarray,
                   ground_points: np.ndarray, external_N: np.ndarray | None = None) -> np.ndarray:
        """ds/dt of the plant state (28 channels, board origin) under admissible forces (3, 4)."""
        p = self.p
        rpy, v, w = s[3:6], s[6:9], s[9:12]
        R = rpy_matrices(rpy)
        com = s[0:3]
        pts = self.contact_points(s, contact, ground_points)
        total = forces.sum(axis=1) + (external_N if external_N is not None else 0.0)
        torque_world = np.zeros(3)
        for i in range(4):
            if contact[i] != SWING:
                torque_world += _cross(pts[:, i] - com, forces[:, i])
        acc = total / p.mass_kg + np.array([0.0, 0.0, -p.gravity_mps2])
        w_dot = self.I_inv @ (R.T @ torque_world - _cross(w, self.I @ w))
        yaw = rpy[2]
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        R_B = board_rotations(yaw, s[I_BOARD_ROLL])
        f_board = np.zeros(3)
        torque_board = np.zeros(3)
        arms = p.moment_arms(R_B)  # about the roll axis
        for i in range(4):
            if contact[i] == BOARD:
                f_board += forces[:, i]
                torque_board += _cross(arms[:, i], forces[:, i])
        v_fwd = float(heading @ s[24:26])
        # Rolling resistance grows with the wheels' load: rolling_N is the board's with the robot on it.
        load = (p.board_mass_kg * p.gravity_mps2 + f_board[2]) / ((p.board_mass_kg + p.mass_kg) * p.gravity_mps2)
        friction = p.rolling_N * load * np.tanh(p.tanh_scale_s_per_m * v_fwd)
        a_fwd = (-(R_B.T @ f_board)[0] - friction) / p.board_mass_kg  # Eq. (9b) in every mode
        psi_dot = (-(R_B.T @ torque_board)[0] + p.roll_torque(float(s[I_BOARD_ROLL]), float(s[I_BOARD_ROLL_RATE]))
                   ) / p.roll_inertia_kgm2
        ds = np.zeros(NB)
        ds[0:3] = v
        ds[3:6] = euler_rate_map(rpy) @ w
        ds[6:9] = acc
        ds[9:12] = w_dot
        ds[12:24] = qd
        # The wheels roll along the heading: the velocity turns with the yaw (the centripetal term).
        yaw_rate = float((euler_rate_map(rpy) @ w)[2])
        ds[24:26] = heading * a_fwd + np.array([-heading[1], heading[0]]) * (v_fwd * yaw_rate)
        ds[I_BOARD_ROLL] = s[I_BOARD_ROLL_RATE]
        ds[I_BOARD_ROLL_RATE] = psi_dot
        ds[NX:NX + 2] = s[24:26]
        return ds

    def step(self, s: np.ndarray, u: PlantInput, contact: np.ndarray, ground_points: np.ndarray, h: float,
             t: float) -> np.ndarray:
        """One RK4 step of ``h`` seconds; the commanded forces are made admissible at the start of
        the step and held (the whole-body controller's torques hold them between its updates)."""
        f = self.admissible(s, u.forces, contact, t, record=True)

        def d(x: np.ndarray) -> np.ndarray:
            return self.derivative(x, f, u.qd, contact, ground_points, u.external_N)

        k1 = d(s)
        k2 = d(s + h / 2 * k1)
        k3 = d(s + h / 2 * k2)
        k4 = d(s + h * k3)
        return s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def momentum_speed(self, s: np.ndarray) -> float:
        """(m_R v_R + m_B v_B) / (m_R + m_B) along the heading [m/s], with the plant's masses."""
        return float(momentum_speed(s[:NX], self.p.mass_kg, self.p.board_mass_kg))


__all__ = ["GROUND", "NB", "ContactLog", "Plant", "PlantInput"]
