"""Constraint terms of the push-off trajectory optimization (Sec. IV-B); the costs are in
:mod:`skatelib.pipeline.quadruped.problem.costs`, the variable bounds in
:mod:`~skatelib.pipeline.quadruped.problem.bounds`.

The knot vector's layout and the stage parameters are in :mod:`skatelib.pipeline.quadruped.problem.knots`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import (
    GROUND,
    I_BOARD_ROLL,
    NX,
    S_OMEGA,
    S_RPY,
    SWING,
)
from skatelib.pipeline.ocp.curvature import step_curvature
from skatelib.pipeline.ocp.integrators import integrator
from skatelib.pipeline.ocp.terms import Stage, fixed
from skatelib.pipeline.quadruped.config import StanceConfig
from skatelib.pipeline.quadruped.model.dynamics import board_rotation, foot_centres_world, joint_torques
from skatelib.pipeline.quadruped.model.schedule import KnotSchedule
from skatelib.pipeline.quadruped.model.system import END_BAND_M, SkateSystem
from skatelib.pipeline.quadruped.problem.knots import (
    NXA,
    P_DRIVE,
    P_MU_GROUND,
    board_origin,
    forward_speed,
    heading_frame,
)

INF = np.inf


@dataclass(frozen=True)
class DynamicsDefect:
    """Multiple-shooting continuity: x_{k+1} = F(x_k, u_k), F the integrator's step over dt."""

    step: ca.Function  # (x, u) -> x_next on the transcription state
    curvature: Callable[[], ca.Function] | None = None  # builds (x, u, lam) -> Hessian of lam' step: `of`
    name: str = "dynamics"

    @classmethod
    def of(cls, kind: str, f: ca.Function, dt: float, substeps: int, L: np.ndarray | None) -> DynamicsDefect:
        """The defect of ``integrator(kind, f, dt, substeps, L)`` with that step's curvature
        (:func:`~skatelib.pipeline.ocp.curvature.step_curvature`, built when it is differentiated)."""
        return cls(integrator(kind, f, dt, substeps, L), partial(step_curvature, kind, f, dt, substeps, L))

    @property
    def hessian_tag(self) -> str | None:
        """How :meth:`hessian` is formed (None: CasADi differentiates the rows)."""
        return None if self.curvature is None else "step chain rule"

    def rows(self, s: Stage) -> Any:
        return s.x_next - self.step(s.x, s.u)

    def hessian(self, s: Stage, lam: Any) -> tuple[Any, Any]:
        """The Hessian of ``lam' rows`` with respect to ``(x_k, u_k)``: the step's curvature, negated
        (``x_{k+1}`` enters linearly)."""
        if self.curvature is None:
            raise ValueError("a defect without a curvature has no given Hessian: CasADi differentiates its rows")
        return -self.curvature()(s.x, s.u, lam), ca.vertcat(s.x, s.u)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        return fixed(n, NXA, 0.0, 0.0)


@dataclass(frozen=True)
class FeetOnBoard:
    """Feet on the deck stay on their deck points (position form of Eq. 15, with Eq. 8)."""

    system: SkateSystem
    legs: tuple[int, ...]
    name: str = "feet_on_board"

    def rows(self, s: Stage) -> Any:
        x = s.x_next
        centres = foot_centres_world(self.system, x[:NX])
        R_B = board_rotation(x[I_BOARD_ROLL], x[S_RPY][2])
        r = self.system.foot_radius_m
        cr = self.system.stance.cr
        board = self.system.board
        return ca.vertcat(*[centres[:, i] - board_origin(self.system, x) - board.deck_point(R_B, cr[0, i], cr[1, i])
                            - R_B @ ca.DM([0.0, 0.0, r])
                            for i in self.legs])

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        return fixed(n, 3 * len(self.legs), 0.0, 0.0)


@dataclass(frozen=True)
class PushFoot:
    """The pushing foot: put on the ground during stance, lifted and clear of the deck in swing.

    Rows: foot displacement over the interval (``MOVE``), foot height at k+1 (``HEIGHT``), lateral
    distance of the foot from the deck centre line at k+1 (``LATERAL``).
    """

    MOVE, HEIGHT, LATERAL = slice(0, 3), 3, 4

    system: SkateSystem
    schedule: KnotSchedule
    stance: StanceConfig
    end_height_m: float = 0.0  # lift-off clearance of the foot above the ground at the last knot [m]
    name: str = "push_foot"

    def rows(self, s: Stage) -> Any:
        p = self.system.push_index
        c0 = foot_centres_world(self.system, s.x[:NX])[:, p]
        c1 = foot_centres_world(self.system, s.x_next[:NX])[:, p]
        lateral = heading_frame(s.x_next[S_RPY][2], c1 - board_origin(self.system, s.x_next))[1]
        side = float(np.sign(self.system.stance.push_foot_board_xy[1]))
        return ca.vertcat(c1 - c0, c1[2], side * lateral)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        p = self.system.push_index
        r = self.system.foot_radius_m
        contact = self.schedule.contact[:, p]
        lo, hi = np.full((n, 5), -INF), np.full((n, 5), INF)
        # Lift profile: a half sine over each swing run (a quarter cosine over a lead-in, which starts
        # with the foot lifted), at least r everywhere in the air.
        lift = np.zeros(n + 1)
        for k0, k1 in self.schedule.stance_intervals(p, SWING):
            s = (np.arange(k0, k1 + 1) - k0) / max(k1 - k0, 1)
            shape = np.cos(0.5 * np.pi * s) if k0 == 0 else np.sin(np.pi * s)
            lift[k0:k1 + 1] = np.maximum(lift[k0:k1 + 1], self.stance.swing_height_m * shape)
        for k in range(n):
            if contact[k] == GROUND:
                lo[k, self.MOVE] = hi[k, self.MOVE] = 0.0  # no slip on the ground
            if contact[k + 1] == GROUND and contact[k] != GROUND:
                lo[k, self.HEIGHT] = hi[k, self.HEIGHT] = r  # touchdown
            elif contact[k + 1] != GROUND and contact[k] != GROUND:
                lo[k, self.HEIGHT] = r + lift[k + 1]
        lo[:, self.LATERAL] = self.system.board.deck_width_m / 2 + r + self.stance.push_clearance_m
        if contact[n] != GROUND:  # the end: lifted beside the deck, where the transfer starts
            lo[n - 1, self.HEIGHT] = max(lo[n - 1, self.HEIGHT], r + self.end_height_m)
            hi[n - 1, self.HEIGHT] = r + self.end_height_m + END_BAND_M
        return lo, hi


@dataclass(frozen=True)
class FrictionCones:
    """Coulomb friction at every contact, in the deck frame on the board (it rolls) and the world frame
    on the ground; free rows where the foot swings (its force is fixed to zero).

    ``model="cone"``: the exact cone as ``mu^2 f_n^2 - |f_t|^2 >= 0`` with ``f_n >= 0`` (smooth, unlike
    the sqrt form). ``model="polygon8"``: eight facets of the inscribed octagon,
    ``n_j . f_t <= mu cos(pi/8) f_n`` (inside the cone; implies ``f_n >= 0``).
    ``mu`` is the planning coefficient (margin x the model's mu) on the deck; on the ground it is the
    stage parameter ``P_MU_GROUND`` (a brake plans with less, leaving the controller room to brake
    harder on a board that rolls easier than planned).
    """

    system: SkateSystem
    schedule: KnotSchedule
    board_legs: tuple[bool, ...]
    mu: float
    model: str = "cone"
    name: str = "friction"

    @property
    def rows_per_foot(self) -> int:
        return 2 if self.model == "cone" else 8

    def rows(self, s: Stage) -> Any:
        R_B = board_rotation(s.x[I_BOARD_ROLL], s.x[S_RPY][2])
        out = []
        for i in range(4):
            f = s.u[3 * i: 3 * i + 3]
            fl = R_B.T @ f if self.board_legs[i] else f
            mu = self.mu if self.board_legs[i] else s.p[P_MU_GROUND]
            if self.model == "cone":
                out += [mu**2 * fl[2] ** 2 - fl[0] ** 2 - fl[1] ** 2, fl[2]]
            else:
                c = mu * np.cos(np.pi / 8)
                out += [c * fl[2] - np.cos(a) * fl[0] - np.sin(a) * fl[1] for a in np.arange(8) * np.pi / 4]
        return ca.vertcat(*out)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        m = self.rows_per_foot
        lo, hi = np.zeros((n, 4 * m)), np.full((n, 4 * m), INF)
        for i in range(4):
            swing = self.schedule.contact[:n, i] == SWING
            lo[swing, m * i: m * i + m] = -INF
        return lo, hi


@dataclass(frozen=True)
class Propulsion:
    """The ground drives the planted push foot one way along the board heading: forward in a push,
    backward in a brake (stage parameter ``P_DRIVE``, +1 or -1), never the other way."""

    system: SkateSystem
    schedule: KnotSchedule
    name: str = "propulsion"

    def rows(self, s: Stage) -> Any:
        p = self.system.push_index
        return s.p[P_DRIVE] * heading_frame(s.x[S_RPY][2], s.u[3 * p: 3 * p + 2])[0]

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = np.full((n, 1), -INF), np.full((n, 1), INF)
        lo[self.schedule.contact[:n, self.system.push_index] == GROUND] = 0.0
        return lo, hi


@dataclass(frozen=True)
class TorqueLimits:
    """Joint torques through the foot Jacobians within +-limit (free for a swinging leg, whose
    force and so whose torques are zero)."""

    system: SkateSystem
    schedule: KnotSchedule
    name: str = "torque"

    def rows(self, s: Stage) -> Any:
        return joint_torques(self.system, s.x[:NX], s.u)

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        t = self.system.torque_limit_Nm
        lo, hi = fixed(n, 12, -t, t)
        for i in range(4):
            swing = self.schedule.contact[:n, i] == SWING
            lo[swing, 3 * i: 3 * i + 3], hi[swing, 3 * i: 3 * i + 3] = -INF, INF
        return lo, hi


@dataclass(frozen=True)
class Steering:
    """Eq. (14): the deck's roll and forward speed set its yaw rate."""

    system: SkateSystem
    name: str = "steering"

    def rows(self, s: Stage) -> Any:
        x = s.x_next
        return self.system.board.steering_residual(x[I_BOARD_ROLL], forward_speed(x), x[S_OMEGA][2])

    def bounds(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        return fixed(n, 1, 0.0, 0.0)
