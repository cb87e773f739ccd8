"""Chain continuity: an entry that ends at a speed and an entry that starts riding at it agree, so a
controller can ride the one into the other. Measured on the stored arrays, each end in its own
board's heading frame, against the library's ``[terminal]`` tolerances (stored in /model): the
centre of mass over the deck, its height, the trunk's roll and pitch, the joint angles, the speeds
of body and board, the joints' speeds and the push foot's height. A start-up starts at rest with
its push foot on the ground: the ride puts it there (the transfer), so no end is compared with it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from skatelib.library.channels import I_BOARD_ROLL, S_BOARD_V, S_OMEGA, S_Q, S_RPY, S_VEL, U_QD
from skatelib.pipeline.quadruped.model.system import END_BAND_M
from skatelib.runtime import Entry, MotionLibrary
from skatelib.runtime.routes import speed_key

SLACK = 1e-6  # IPOPT holds a bound to its tolerance: an end at a tolerance may pass it by this much


def _riding(e: Entry, k: int, p: int) -> dict[str, Any]:
    """What the riding state of ``e`` at knot ``k`` is, in its board's heading frame."""
    x = np.asarray(e.state[k], dtype=np.float64)
    assert e.board_pos is not None and e.foot_pos is not None  # a quadruped entry
    board = np.asarray(e.board_pos[k], dtype=np.float64)
    c, s = np.cos(board[3]), np.sin(board[3])
    R = np.array([[c, s], [-s, c]])  # world -> heading frame
    qd = np.asarray(e.control[min(k, len(e.control) - 1)], dtype=np.float64)[U_QD]
    return {
        "com_xy_m": R @ (x[0:2] - board[0:2]), "height_m": x[2] - board[2], "attitude_rad": x[S_RPY][0:2],
        "joints_rad": x[S_Q], "relative_speed_mps": R @ (x[S_VEL][0:2] - x[S_BOARD_V]),
        "vertical_speed_mps": x[S_VEL][2], "angular_speed_radps": x[S_OMEGA], "board_speed_mps": (R @ x[S_BOARD_V])[0],
        "joint_speed_radps": qd, "deck_roll_rad": x[I_BOARD_ROLL],
        "push_foot_height_m": float(np.asarray(e.foot_pos[k], dtype=np.float64)[p, 2]),
    }


@dataclass(frozen=True)
class ChainGap:
    """How far ``end``'s last knot is from ``start``'s first, per quantity, and the tolerances."""

    end: str
    start: str
    gaps: dict[str, float]
    limits: dict[str, float]

    def failures(self) -> list[str]:
        return [f"{k} differs by {v:.4g} (at most {self.limits[k]:.4g})" for k, v in self.gaps.items()
                if not v <= self.limits[k] + SLACK]


def tolerances(lib: MotionLibrary, v: float) -> dict[str, float]:
    """The end's tolerances of ``lib`` (its /model ``terminal_*``) for a junction at ``v`` [m/s]: an
    end's roll and pitch are held near level, a start has the riding stance's (``stance_ride_trunk``);
    the deck roll is held to the trunk's attitude tolerance; the push foot's height to half the
    end's height band."""
    m = lib.quadruped_model
    trunk = m.arrays.stance_ride_trunk
    ride_attitude = float(np.max(np.abs(trunk[2:4]))) if trunk is not None else 0.0
    tol = m.terminal
    return {"com_xy_m": tol["position_tol_m"], "height_m": tol["height_tol_m"],
            "attitude_rad": tol["attitude_tol_rad"] + ride_attitude, "joints_rad": tol["joint_tol_rad"],
            "relative_speed_mps": tol["relative_speed_tol_mps"], "vertical_speed_mps": tol["vertical_speed_tol_mps"],
            "angular_speed_radps": tol["angular_speed_tol_radps"],
            "board_speed_mps": m.final_velocity_tol * v if v > 0 else m.stop_speed_tol_mps,
            "joint_speed_radps": tol["joint_velocity_tol_radps"],
            "deck_roll_rad": tol["attitude_tol_rad"], "push_foot_height_m": END_BAND_M / 2}


def chain_gaps(lib: MotionLibrary) -> list[ChainGap]:
    """Every (end, start) pair of successful entries that meet at a riding speed (see the module
    docstring); empty for a library without transitions."""
    p = lib.quadruped_model.push_leg_index
    ok = [e for e in lib if e.success]
    out = []
    for b in (e for e in ok if e.from_velocity_mps > 0):
        start = _riding(b, 0, p)
        for a in (e for e in ok if speed_key(e.target_velocity_mps) == speed_key(b.from_velocity_mps)):
            end = _riding(a, len(a.t) - 1, p)
            gaps = {k: float(np.max(np.abs(np.subtract(end[k], start[k])))) for k in start}
            gaps["joint_speed_radps"] = float(np.max(np.abs(end["joint_speed_radps"])))  # the end is still
            out.append(ChainGap(a.key, b.key, gaps, tolerances(lib, b.from_velocity_mps)))
    return out
