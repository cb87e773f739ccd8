"""Keeping the board on the plan's line: heading and lateral feedback through the deck's roll.

A skateboard turns only by rolling its deck (Eq. 14: omega_z = -v sin(phi) / K_board); its wheels
do not slide sideways, so a heading error becomes a lateral offset at the board's speed, and
nothing but a change of roll brings it back. The MPC tracks the plan's roll and the robot's yaw
(Eq. 17 has no Eq. 14: yaw moments at the feet cannot turn wheels that roll), so without this loop
the board goes where the errors of the real trucks (softer, stiffer, a load off the centre line)
steer it.

At each MPC update :class:`LineKeeper` compares the board's pose with the plan's at the same time
(after the entry: the line through the plan's last pose along its heading) and asks for a yaw
rate on top of the plan's, a second-order loop on the lateral offset e_y and the heading error
e_psi:

    omega_c = -(2 zeta w_n) e_psi - (w_n^2 / v) e_y,    d e_y / dt = v e_psi,

which Eq. (14) turns into a roll offset d_phi = -K_board omega_c / v (small angles). The offset
moves the MPC's roll reference over the horizon, and the robot's COM reference across the deck by
the lateral shift that holds the deck at that roll (the trucks' torque balanced by the weight),
for the MPC and for the whole-body controller's body plan (:class:`SteeredPlan`). Below
``min_speed_mps`` a roll steers too slowly to matter and the offset is zero; it is bounded by
``max_roll_rad`` and moves at most ``max_roll_rate_radps``. The robot's yaw reference turns with
the deck's heading error: its feet cannot twist a deck whose wheels roll, so the MPC does not try
to; the heading is the line keeper's alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from skatelib.control.body_plan import BodyTargets, Plan
from skatelib.control.mpc import HorizonRef
from skatelib.control.params import SkateParams
from skatelib.library.channels import I_BOARD_ROLL


@dataclass(frozen=True)
class SteeringGains:
    """The line keeper's loop.

    Attributes:
        natural_radps: w_n of the lateral loop [rad/s].
        damping: zeta.
        min_speed_mps: Below this forward speed no offset.
        max_roll_rad: Bound of the roll offset.
        max_roll_rate_radps: Bound of its rate.
    """

    natural_radps: float = 1.0
    damping: float = 1.0
    min_speed_mps: float = 0.25
    max_roll_rad: float = 0.02
    max_roll_rate_radps: float = 0.3


@dataclass(frozen=True)
class BoardPath:
    """The plan's board: times [s] and (x, y, yaw) per knot; after the last, its line."""

    t: np.ndarray
    xy: np.ndarray  # (K, 2)
    yaw: np.ndarray  # (K,)

    @staticmethod
    def from_board_pos(t: np.ndarray, board_pos: np.ndarray) -> BoardPath:
        """From an entry's ``t`` and ``board_pos`` (x, y, z, yaw per knot)."""
        b = np.asarray(board_pos, dtype=np.float64)
        return BoardPath(np.asarray(t, dtype=np.float64), b[:, 0:2].copy(), np.unwrap(b[:, 3]))

    def at(self, t: float) -> tuple[np.ndarray, float]:
        """The plan's board position and yaw at ``t`` (held at the ends: the lateral offset from a
        held point is the offset from the line through it along its heading)."""
        x = float(np.interp(t, self.t, self.xy[:, 0]))
        y = float(np.interp(t, self.t, self.xy[:, 1]))
        return np.array([x, y]), float(np.interp(t, self.t, self.yaw))


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class LineKeeper:
    """The roll offset that steers the board back onto the plan's line (module docstring)."""

    def __init__(self, path: BoardPath, p: SkateParams, gains: SteeringGains | None = None):
        self.path, self.p = path, p
        self.g = gains or SteeringGains()
        self.roll_rad = 0.0  # the last update's offset
        self.shift_m = 0.0  # the COM's lateral shift that holds it
        self.lateral_m = 0.0  # the last update's lateral offset from the plan's line
        self.heading_rad = 0.0  # and heading error
        self.active = False  # rolling fast enough to steer

    def update(self, t: float, board_xy: np.ndarray, board_yaw: float, speed_mps: float, dt: float) -> float:
        """The roll offset for the update at ``t`` on the measured board (origin, yaw, forward speed),
        ``dt`` after the last."""
        xy, yaw = self.path.at(t)
        left = np.array([-math.sin(yaw), math.cos(yaw)])
        self.lateral_m = float((np.asarray(board_xy) - xy) @ left)
        self.heading_rad = _wrap(board_yaw - yaw)
        g, v = self.g, speed_mps
        want = 0.0
        self.active = v >= g.min_speed_mps
        if self.active:
            omega = -2.0 * g.damping * g.natural_radps * self.heading_rad - g.natural_radps**2 / v * self.lateral_m
            want = float(np.clip(-self.p.k_board_m * omega / v, -g.max_roll_rad, g.max_roll_rad))
        step = g.max_roll_rate_radps * dt
        self.roll_rad = float(np.clip(want, self.roll_rad - step, self.roll_rad + step))
        self.shift_m = self.lateral_shift(self.roll_rad)
        return self.roll_rad

    def lateral_shift(self, roll: float) -> float:
        """The COM's offset from the deck's centre line (along its left) that holds it at ``roll``:
        the weight's moment balances the trucks' torque, m g y = roll_torque."""
        return self.p.roll_torque(roll, 0.0) / (self.p.mass_kg * self.p.gravity_mps2)

    def steer(self, horizon: HorizonRef) -> HorizonRef:
        """The MPC's horizon with the offset: its roll reference and the COM across the deck."""
        x_ref = horizon.x_ref.copy()
        if self.active:  # the robot turns with the deck (its feet cannot twist it back)
            x_ref[:, 5] += self.heading_rad
        yaw = x_ref[:, 5]
        x_ref[:, 0] -= np.sin(yaw) * self.shift_m
        x_ref[:, 1] += np.cos(yaw) * self.shift_m
        x_ref[:, I_BOARD_ROLL] += self.roll_rad
        return horizon._replace(x_ref=x_ref)


class SteeredPlan:
    """A body plan with the line keeper's COM shift across the deck (the board frame's y)."""

    def __init__(self, plan: Plan, keeper: LineKeeper):
        self.plan, self.keeper = plan, keeper

    def at(self, tau: float) -> BodyTargets:
        bt = self.plan.at(tau)
        if self.keeper.shift_m == 0.0:
            return bt
        com = bt.com.copy()
        com[1] += self.keeper.shift_m
        return replace(bt, com=com)
