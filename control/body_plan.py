"""What the whole-body controller follows between the MPC's updates: the entry's body and feet
relative to the board (the robot controls where it stands on the deck, not where the
optimization's world frame was), and after the entry the push leg's transfer back onto the deck
(``transfer_s``, its foot over a raised arc to its deck point) and four-leg riding.

Everything is stored in the board's frame (its origin, turned by its yaw) at the entry's knots and
placed on the measured board at run time: a target is the measured board origin plus the
measured yaw's rotation of the plan's relative vector.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pinocchio as pin
from skatelib.control.reference import EntryReference
from skatelib.library.channels import BOARD

AFTER_STEP_S = 0.005  # the table's step over the transfer
TRANSFER_APEX_M = 0.04  # how high over its deck point the push foot crosses the deck's edge


def _smoothstep(w: float) -> float:
    """0 to 1 with zero slope at both ends, for w from 0 to 1 (clamped)."""
    w = min(max(w, 0.0), 1.0)
    return w * w * (3 - 2 * w)


def _rz(yaw: np.ndarray) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


@dataclass
class BodyTargets:
    """The plan at one time, in the board's frame (positions from its origin on the deck's top)."""

    com: np.ndarray  # (3,)
    com_v: np.ndarray  # (3,) relative to the board's origin
    rpy: np.ndarray  # (3,) yaw from the board's
    omega: np.ndarray  # (3,) trunk frame
    feet: np.ndarray  # (3, 4) foot centres
    feet_v: np.ndarray  # (3, 4)
    feet_a: np.ndarray  # (3, 4)
    q: np.ndarray  # (12,) joint angles (the posture)
    board_v: np.ndarray  # (3,) the plan's board velocity (a foot bound for the ground lands at the plan's ground speed)


class Plan(Protocol):
    """What the whole-body controller's tasks ask of a body plan (an entry's :class:`BodyPlan`, or a
    maneuver's): the targets at a time (a plan may adapt while it runs)."""

    def at(self, tau: float) -> BodyTargets: ...


class BodyPlan:
    """The entry relative to its board, then the transfer and the ride (module docstring)."""

    def __init__(self, ref: EntryReference, foot_radius_m: float):
        entry = ref.e
        t = np.asarray(entry.t, dtype=np.float64)
        x = np.asarray(entry.state, dtype=np.float64)
        board = np.asarray(entry.board_pos, dtype=np.float64)
        feet = np.asarray(entry.foot_pos, dtype=np.float64)  # (K, 4, 3) contact points
        Rt = np.swapaxes(_rz(board[:, 3]), -1, -2)  # world to board frame
        origin = board[:, 0:3]
        self.t = t
        self.t_end = float(t[-1])
        self.transfer_end = ref.transfer_end
        self.com = np.einsum("kij,kj->ki", Rt, x[:, 0:3] - origin)
        v_board = np.column_stack([x[:, 24:26], np.zeros(len(t))])
        self.com_v = np.einsum("kij,kj->ki", Rt, x[:, 6:9] - v_board)
        self.board_v = np.einsum("kij,kj->ki", Rt, v_board)
        self.rpy = x[:, 3:6].copy()
        self.rpy[:, 2] -= board[:, 3]
        self.omega = x[:, 9:12]
        self.q = x[:, 12:24]
        centres = feet + np.array([0.0, 0.0, foot_radius_m])
        self.feet = np.einsum("kij,klj->kil", Rt, centres - origin[:, None, :])  # (K, 3, 4)
        self.contact = np.asarray(entry.contact)
        self.push_leg = ref.p.push_leg
        self.q_board = ref.q_board
        self.deck_feet = np.vstack([ref.p.deck_points_m, np.full(4, foot_radius_m)])  # (3, 4) on the deck
        feet_v = np.gradient(self.feet, t, axis=0)  # the feet's path between knots: its rates at the knots
        feet_a = np.gradient(feet_v, t, axis=0)
        K = len(t)
        rows = np.hstack([self.com, self.com_v, self.rpy, self.omega, self.q, self.board_v,
                          self.feet.reshape(K, 12), feet_v.reshape(K, 12), feet_a.reshape(K, 12)])
        # The transfer and the ride sampled every 5 ms (then held): every tick one interpolation.
        steps = round((self.transfer_end + 0.1 - self.t_end) / AFTER_STEP_S)
        after = self.t_end + np.arange(1, steps + 1) * AFTER_STEP_S
        self._entry_times = t.tolist()
        self._times = np.r_[t, after].tolist()
        self._rows = np.vstack([rows, *(self._after_row(tau) for tau in after)])

    @staticmethod
    def _interp(tau: float, t: list[float], rows: np.ndarray) -> np.ndarray:
        tau = min(max(tau, t[0]), t[-1])
        i = min(max(bisect.bisect_right(t, tau) - 1, 0), len(t) - 2)
        a = (tau - t[i]) / (t[i + 1] - t[i])
        return np.asarray(rows[i] + a * (rows[i + 1] - rows[i]))

    def feet_at(self, tau: float) -> np.ndarray:
        """(3, 4) foot centres relative to the board at ``tau``."""
        if tau <= self.t_end:
            return self._interp(tau, self._entry_times, self.feet)
        out = self.feet[-1].copy()
        board_feet = self.contact[-1] == BOARD
        out[:, board_feet] = self.deck_feet[:, board_feet]
        leg = self.push_leg
        w = min((tau - self.t_end) / max(self.transfer_end - self.t_end, 1e-9), 1.0)
        start, end = self.feet[-1][:, leg], self.deck_feet[:, leg]
        # Held while the body leans in, lifted, over the deck's edge once above it, put down.
        across = _smoothstep((w - 0.45) / 0.35)
        out[0:2, leg] = start[0:2] + across * (end[0:2] - start[0:2])
        apex = end[2] + TRANSFER_APEX_M
        out[2, leg] = (start[2] + _smoothstep((w - 0.3) / 0.25) * (apex - start[2])
                       - _smoothstep((w - 0.75) / 0.25) * (apex - end[2]))
        return out

    def at(self, tau: float) -> BodyTargets:
        """The plan at ``tau``: one interpolation of every channel at once."""
        r = self._interp(tau, self._times, self._rows)
        return BodyTargets(com=r[0:3], com_v=r[3:6], rpy=r[6:9], omega=r[9:12], q=r[12:24], board_v=r[24:27],
                           feet=r[27:39].reshape(3, 4), feet_v=r[39:51].reshape(3, 4), feet_a=r[51:63].reshape(3, 4))

    def _after_row(self, tau: float) -> np.ndarray:
        """The transfer or the ride at ``tau`` (after the entry) as a row of the table."""
        h = 0.005
        p0, pm, pp = self.feet_at(tau), self.feet_at(tau - h), self.feet_at(tau + h)
        w = min((tau - self.t_end) / max(self.transfer_end - self.t_end, 1e-9), 1.0)
        rpy = self.rpy[-1].copy()
        rpy[0:2] = 0.0
        q = (1 - w) * self.q[-1] + w * self.q_board
        return np.concatenate([self.com[-1], np.zeros(3), rpy, np.zeros(3), q, self.board_v[-1], p0.ravel(),
                               ((pp - pm) / (2 * h)).ravel(), ((pp - 2 * p0 + pm) / (h * h)).ravel()])


def yaw_matrix(yaw: float) -> np.ndarray:
    """Rz(yaw) (pinocchio's, a tenth of the time numpy takes to build a 3 x 3)."""
    return np.asarray(pin.rpy.rpyToMatrix(0.0, 0.0, float(yaw)))


def place(board_origin: np.ndarray, board_yaw: float, rel: np.ndarray) -> np.ndarray:
    """Board-frame vectors (3,) or (3, n) turned by the measured yaw and put on the measured origin."""
    out = yaw_matrix(board_yaw) @ rel
    return np.asarray(out + (board_origin if rel.ndim == 1 else board_origin[:, None]))


def turn(board_yaw: float, rel: np.ndarray) -> np.ndarray:
    """Board-frame directions turned into the world."""
    return np.asarray(yaw_matrix(board_yaw) @ rel)
