"""Cost terms of the push-off trajectory optimization (Eq. 16a-d, Sec. IV-B): tracking of the board
speed ramp and the riding stance, effort and its rate, and the final board speed."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import I_BOARD_ROLL, S_BOARD_V, S_OMEGA, S_POS, S_Q, S_RPY, S_VEL, U_F, U_QD
from skatelib.pipeline.ocp.terms import Stage
from skatelib.pipeline.quadruped.config import WeightsConfig
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.knots import P_RATE, P_TARGET, P_TERMINAL, P_VDES, board_origin, forward_speed


@dataclass(frozen=True)
class TrackingCost:
    """Eq. (16a-b): board speed and roll, trunk pose and velocity relative to the board, joints."""

    system: SkateSystem
    w: WeightsConfig
    com_rel0: np.ndarray  # centre of mass relative to the board origin at rest [m]
    q_nominal: np.ndarray
    name: str = "tracking"

    def cost(self, s: Stage) -> Any:
        x, w = s.x, self.w
        board_v = ca.vertcat(x[S_BOARD_V], 0)
        e_pos = x[S_POS] - board_origin(self.system, x) - ca.DM(self.com_rel0)
        terms = (
            w.board_velocity * (forward_speed(x) - s.p[P_VDES]) ** 2
            + w.board_roll * x[I_BOARD_ROLL] ** 2
            + w.base_position * ca.sumsqr(e_pos)
            + w.base_orientation * ca.sumsqr(x[S_RPY])
            + w.base_velocity * ca.sumsqr(x[S_VEL] - board_v)
            + w.base_angular_velocity * ca.sumsqr(x[S_OMEGA])
            + w.joint_position * ca.sumsqr(x[S_Q] - ca.DM(self.q_nominal))
        )
        return s.dt * terms


@dataclass(frozen=True)
class EffortCost:
    """Eq. (16c-d): forces and joint velocities, and their changes between knots."""

    w: WeightsConfig
    name: str = "effort"

    def cost(self, s: Stage) -> Any:
        w = self.w
        effort = w.force * ca.sumsqr(s.u[U_F]) + w.joint_velocity * ca.sumsqr(s.u[U_QD])
        rate = w.force_rate * ca.sumsqr(s.u_next[U_F] - s.u[U_F]) + w.joint_velocity_rate * ca.sumsqr(
            s.u_next[U_QD] - s.u[U_QD])
        return s.dt * effort + s.p[P_RATE] * rate


@dataclass(frozen=True)
class TerminalSpeedCost:
    """Final board speed error, added on the last stage."""

    w: WeightsConfig
    name: str = "terminal_speed"

    def cost(self, s: Stage) -> Any:
        return s.p[P_TERMINAL] * self.w.terminal_velocity * (forward_speed(s.x_next) - s.p[P_TARGET]) ** 2
