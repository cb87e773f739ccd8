"""Constraint terms that keep the plan physical where the twin showed it was not: the wheels keep
a load (the deck loads' roll moment within what the wheel track holds), and the push foot lands
and lifts off instead of skimming the floor.

``WheelLoads``: at every knot, with M the moment the feet on the deck exert about its roll axis
(deck x) and N the wheels' load (the board's weight and the feet's vertical forces),
``|M| <= (1 - margin) N w / 2``, w the wheel track: at the bound the inner wheels carry nothing.

``GentleContact``: the push foot reaches the ground, and leaves it, slowly. Let the band be the
heights within ``h0`` (1 cm) of the ground (of the sphere's bottom). The two intervals after each
lift-off and the two before each touchdown may touch the band: on them the foot moves at most
``v_h`` over the ground and descends at most ``v_z``. Every knot in the air but the first and the
last of each swing is above the band, so no other interval touches it. (With 0.03 s intervals two
of them give the foot 18 mm to land from at 0.3 m/s.)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import I_BOARD_ROLL, NX, S_RPY, SWING
from skatelib.pipeline.ocp.terms import Stage
from skatelib.pipeline.quadruped.board_config import ContactConfig
from skatelib.pipeline.quadruped.model.dynamics import board_rotation, foot_centres_world
from skatelib.pipeline.quadruped.model.schedule import KnotSchedule
from skatelib.pipeline.quadruped.model.system import SkateSystem

INF = np.inf


def deck_load_moment(system: SkateSystem, x: Any, u: Any, legs: tuple[int, ...]) -> tuple[Any, Any]:
    """(M, N): the roll moment [N m] the feet of ``legs`` exert on the deck about its roll axis
    (deck x component, Eq. 8's arms) and the wheels' load [N]."""
    board = system.board
    R_B = board_rotation(x[I_BOARD_ROLL], x[S_RPY][2])
    cr = system.stance.cr
    moment = ca.DM.zeros(3)
    down = 0
    for i in legs:
        f = u[3 * i: 3 * i + 3]
        moment = moment + ca.cross(board.moment_arm(R_B, cr[0, i], cr[1, i]), -f)
        down = down + f[2]
    return (R_B.T @ moment)[0], board.wheel_load(down)


@dataclass(frozen=True)
class WheelLoads:
    """Every wheel keeps a load: ``(1 - margin) N w / 2 -/+ M >= 0`` at every knot."""

    system: SkateSystem
    legs: tuple[int, ...]
    name: str = "wheel_loads"

    def rows(self, s: Stage) -> Any:
        b = self.system.board
        moment, load = deck_load_moment(self.system, s.x[:NX], s.u, self.legs)
        cap = (1.0 - b.wheel_load_margin) * load * b.wheel_track_m / 2
        return ca.vertcat(cap - moment, cap + moment)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros((n, 2)), np.full((n, 2), INF)


@dataclass(frozen=True)
class GentleContact:
    """The push foot near the ground moves slowly over it (see the module docstring).

    Rows per interval: the foot's velocity over the ground (x, y: each within v_h / sqrt(2), a
    square inside the circle of v_h, linear rows), its descent speed, its height at k+1.
    """

    system: SkateSystem
    schedule: KnotSchedule
    contact: ContactConfig
    dt: float
    name: str = "gentle_contact"

    def rows(self, s: Stage) -> Any:
        p, r = self.system.push_index, self.system.foot_radius_m
        c0 = foot_centres_world(self.system, s.x[:NX])[:, p]
        c1 = foot_centres_world(self.system, s.x_next[:NX])[:, p]
        v = (c1 - c0) / self.dt
        return ca.vertcat(v[0], v[1], -v[2], c1[2] - r)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        c = self.contact
        lo, hi = np.full((n, 4), -INF), np.full((n, 4), INF)
        box = c.near_ground_speed_mps / np.sqrt(2.0)  # |v_x|, |v_y| <= v_h / sqrt(2): inside the circle |v_xy| <= v_h
        for k in band_intervals(self.schedule.contact[:, self.system.push_index], n):
            lo[k, 0:2], hi[k, 0:2] = -box, box
            hi[k, 2] = c.near_ground_descent_mps
        for k in above_band_knots(self.schedule.contact[:, self.system.push_index], n):
            lo[k - 1, 3] = c.near_ground_m
        return lo, hi


def band_intervals(push_contact: np.ndarray, n: int, reach: int = 2) -> list[int]:
    """The intervals k (knot k to k+1) within ``reach`` of a lift-off or touchdown of the push foot."""
    out: set[int] = set()
    for k in range(n):
        if push_contact[k] == SWING and k > 0 and push_contact[k - 1] != SWING:  # first knot in the air
            out.update(range(k - 1, min(k - 1 + reach, n)))
        if push_contact[k] == SWING and k + 1 <= n and push_contact[k + 1] != SWING:  # last knot in the air
            out.update(range(max(k + 1 - reach, 0), k + 1))
    return sorted(i for i in out if 0 <= i < n)


def above_band_knots(push_contact: np.ndarray, n: int) -> list[int]:
    """The knots in the air (1..n) next to no knot on the ground: they stay above the band, so
    every interval that touches it starts or ends next to the ground (a band interval)."""
    def grounded(k: int) -> bool:
        return 0 <= k <= n and push_contact[k] != SWING

    return [k for k in range(1, n + 1) if push_contact[k] == SWING and not grounded(k - 1) and not grounded(k + 1)]
