"""The push-off NLP's knot vector and stage parameters.

A knot holds the transcription state, the 28 channels of :mod:`skatelib.library.channels` plus the
board position (board_x, board_y) [m] integrated from the board velocity (so that feet on the
deck can be held to deck points, the position form of Eq. 15, without drift), then the 24 controls.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
from skatelib.library.channels import CONTROL_NAMES, NX, S_BOARD_V, S_RPY, STATE_NAMES
from skatelib.pipeline.quadruped.model.system import SkateSystem

NXA = NX + 2  # transcription state: the 28 channels, board_x, board_y
I_BOARD_XY = slice(NX, NX + 2)
KNOT_NAMES = (*STATE_NAMES, "board_x", "board_y", *CONTROL_NAMES)

# Stage parameters: desired board speed at knot k, terminal flag, rate flag, target speed, the
# direction the planted push foot drives the board (+1 a push, -1 a brake) and the speed the final
# speed's tolerance is relative to (the target; for a stop, the stop tolerance over the relative one),
# the friction coefficient the plan gives the foot on the ground (a brake plans with less).
P_VDES, P_TERMINAL, P_RATE, P_TARGET, P_DRIVE, P_SPEED_SCALE, P_MU_GROUND = range(7)
N_PARAMS = 7


def columns(first: str, last: str | None = None) -> slice:
    """Knot-vector columns of the channels ``first`` .. ``last`` (inclusive, in channel order)."""
    return slice(KNOT_NAMES.index(first), KNOT_NAMES.index(last or first) + 1)


def board_origin(system: SkateSystem, x: Any) -> Any:
    """The board frame's origin in the world (on the deck's top) from a transcription state [m]."""
    return ca.vertcat(x[I_BOARD_XY], system.board.deck_height_m)


def heading_frame(yaw: Any, xy: Any) -> tuple[Any, Any]:
    """A horizontal vector ``xy`` along and across the heading ``yaw`` (across: to the left), symbolic."""
    return ca.cos(yaw) * xy[0] + ca.sin(yaw) * xy[1], -ca.sin(yaw) * xy[0] + ca.cos(yaw) * xy[1]


def forward_speed(x: Any) -> Any:
    """The board's speed along its heading (the robot's yaw) [m/s], symbolic."""
    return heading_frame(x[S_RPY][2], x[S_BOARD_V])[0]
