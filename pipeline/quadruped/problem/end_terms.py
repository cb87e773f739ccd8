"""Constraint terms of how a push-off or transition ends (Sec. IV-B's last knot): robot and board at
the target speed together, the body over the deck where the riding stance has it
(:mod:`skatelib.pipeline.quadruped.model.riding`). The other end conditions are variable bounds
(:mod:`skatelib.pipeline.quadruped.problem.bounds`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import S_BOARD_V, S_POS, S_RPY, S_VEL
from skatelib.pipeline.ocp.terms import Stage
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.knots import (
    P_SPEED_SCALE,
    P_TARGET,
    board_origin,
    forward_speed,
    heading_frame,
)

INF = np.inf


@dataclass(frozen=True)
class FinalSpeed:
    """At the end, the board's and the robot COM's forward speeds both within a relative tolerance
    of the target (stage parameter ``P_TARGET``; relative to ``P_SPEED_SCALE``, which is the target
    except for a stop), and the COM's velocity relative to the board, forward and lateral, within
    ``relative_tol_mps``: robot and board ride on together at the label speed."""

    SPEEDS, RELATIVE = slice(0, 2), slice(2, 4)

    rel_tol: float
    relative_tol_mps: float
    name: str = "final_speed"

    def rows(self, s: Stage) -> Any:
        x = s.x_next
        yaw = x[S_RPY][2]
        along, lateral = heading_frame(yaw, x[S_VEL][0:2] - x[S_BOARD_V])
        robot_fwd = heading_frame(yaw, x[S_VEL])[0]
        scale = s.p[P_SPEED_SCALE]
        return ca.vertcat((forward_speed(x) - s.p[P_TARGET]) / scale, (robot_fwd - s.p[P_TARGET]) / scale, along,
                          lateral)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = np.full((n, 4), -INF), np.full((n, 4), INF)
        lo[-1, self.SPEEDS], hi[-1, self.SPEEDS] = -self.rel_tol, self.rel_tol
        lo[-1, self.RELATIVE], hi[-1, self.RELATIVE] = -self.relative_tol_mps, self.relative_tol_mps
        return lo, hi


@dataclass(frozen=True)
class RidingEnd:
    """At the end the centre of mass is over the deck where the riding stance has it: x and y in the
    board's heading frame within ``tol_m`` of the stance's (``SkateSystem.riding_com_m``), so that a
    transition from riding starts where this entry ends."""

    system: SkateSystem
    tol_m: float
    name: str = "riding_end"

    def rows(self, s: Stage) -> Any:
        x = s.x_next
        return ca.vertcat(*heading_frame(x[S_RPY][2], x[S_POS] - board_origin(self.system, x)))

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        com = self.system.riding_com_m[:2]
        lo, hi = np.full((n, 2), -INF), np.full((n, 2), INF)
        lo[-1], hi[-1] = com - self.tol_m, com + self.tol_m
        return lo, hi
