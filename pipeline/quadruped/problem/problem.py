"""The transcribed push-off NLP for one config, stride count and knot window (paper Sec. IV-B): the
system, the knot schedule, the cost, constraint and bound terms, and what turns a solution vector
back into trajectories. Reused across speeds: the target enters through the stage parameters, the
start speed through the initial state's bounds.

A start-up begins at rest with the push foot on the ground; a transition from riding at ``v0``
(:class:`Window` with a lead-in) begins in the riding state (:func:`riding_state`), the state every
entry ends in, so that entries chain.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import NU, NX, S_BOARD_V, S_POS, S_Q, S_RPY, S_VEL
from skatelib.library.trust import compile_dir
from skatelib.pipeline.ocp.shooting import MultipleShooting, Transcribed, transcribe
from skatelib.pipeline.ocp.terms import ConstraintTerm, CostTerm, variable_bounds
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.model.dynamics import contact_points_world, dynamics_function, modes_for
from skatelib.pipeline.quadruped.model.schedule import KnotSchedule, knot_schedule
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.quadruped.problem.bounds import bound_terms
from skatelib.pipeline.quadruped.problem.contact_terms import GentleContact, WheelLoads
from skatelib.pipeline.quadruped.problem.costs import EffortCost, TerminalSpeedCost, TrackingCost
from skatelib.pipeline.quadruped.problem.end_terms import FinalSpeed, RidingEnd
from skatelib.pipeline.quadruped.problem.guess import initial_guess, memoized
from skatelib.pipeline.quadruped.problem.knots import (
    I_BOARD_XY,
    N_PARAMS,
    NXA,
    P_DRIVE,
    P_MU_GROUND,
    P_RATE,
    P_SPEED_SCALE,
    P_TARGET,
    P_TERMINAL,
    P_VDES,
)
from skatelib.pipeline.quadruped.problem.terms import (
    DynamicsDefect,
    FeetOnBoard,
    FrictionCones,
    Propulsion,
    PushFoot,
    Steering,
    TorqueLimits,
)


@dataclass(frozen=True)
class Window:
    """The knot window of a problem besides its strides: ``lead_s`` with the push foot in the air
    before its first touchdown (0 for a start-up, which starts with it on the ground) and the
    ground phase of each stride (None: the schedule's push duty)."""

    lead_s: float = 0.0
    ground_s: float | None = None

    @property
    def riding(self) -> bool:
        """Whether the window starts riding (a transition) rather than at rest."""
        return self.lead_s > 0.0


START_UP = Window()  # a start-up's window: no lead-in, the schedule's push time


def transition_window(config: QuadrupedConfig, from_velocity_mps: float, target_velocity_mps: float,
                      drive: float) -> Window:
    """The window of a transition from ``from_velocity_mps`` to ``target_velocity_mps`` [m/s] whose
    planted foot drives ``drive`` (+1 pushes, -1 brakes: ``SkateSystem.drive``): the touchdown
    lead-in, and ground phases no longer than the trunk takes to ride ``ground_sweep_m``
    (``brake_sweep_m`` for a brake) at the faster speed (a planted foot stays where it touched down:
    at 1 m/s the legs' reach holds it about a quarter second), whole knots, at most the push time."""
    tr, dt, faster = config.transitions, config.optimization.dt_s, max(from_velocity_mps, target_velocity_mps)
    push = config.schedule.push_duty * config.schedule.period_s
    sweep = tr.ground_sweep_m if drive > 0 else tr.brake_sweep_m
    knots = min(round(push / dt), int(sweep / faster / dt + 1e-9))
    return Window(lead_s=tr.touchdown_s, ground_s=max(knots, 1) * dt)


def riding_state(system: SkateSystem, v: float) -> np.ndarray:
    """The transcription state riding at ``v`` [m/s] along x: the riding stance on the board
    (:mod:`.riding`: ``Stance.ride_trunk``, ``Stance.q_ride``), body and board moving together,
    the deck level."""
    x = np.zeros(NXA)
    x[S_POS] = system.riding_com_m + np.array([0.0, 0.0, system.board.deck_height_m])
    x[S_RPY.start:S_RPY.start + 2] = system.stance.ride_trunk[2:4]
    x[S_Q] = system.stance.q_ride
    x[S_VEL.start] = x[S_BOARD_V.start] = v
    return x


_SYSTEMS: dict[str, SkateSystem] = {}


def system_for(config: QuadrupedConfig) -> SkateSystem:
    """The system of ``config``, built once per process (its riding stance is a small NLP)."""
    key = config.resolved_json()
    if key not in _SYSTEMS:
        _SYSTEMS[key] = SkateSystem.from_config(config)
    return _SYSTEMS[key]


class PushoffProblem:
    """The transcribed NLP for one config, stride count and window, reusable across speeds; its stage
    derivatives evaluated on ``threads`` threads."""

    def __init__(self, config: QuadrupedConfig, n_strides: int, window: Window = START_UP, threads: int = 1):
        t0 = time.perf_counter()
        self.config = config
        self.n_strides = n_strides
        self.window = window
        opt = config.optimization
        self.system = system = system_for(config)
        self.schedule: KnotSchedule = knot_schedule(config.schedule, n_strides, opt.dt_s, window.lead_s,
                                                    window.ground_s)
        N = self.schedule.n_intervals
        self.mode = modes_for(config.schedule.push_leg)["accelerating"]
        f = dynamics_function(system, self.mode)
        xa, ua = ca.SX.sym("x", NXA), ca.SX.sym("u", NU)
        cr = ca.DM(system.stance.cr)
        f_aug = ca.Function("f_aug", [xa, ua], [ca.vertcat(f(xa[:NX], ua, cr), xa[24:26])])
        defect = DynamicsDefect.of(opt.integrator, f_aug, opt.dt_s, opt.substeps, system.stiff_linear_part(NXA))
        p = system.push_index
        board_legs = tuple(i for i in range(4) if i != p)
        self.x0 = self._initial_state()
        com_rel0 = self.x0[S_POS] - np.array([0.0, 0.0, system.board.deck_height_m])
        q_nom = system.stance.q_board.copy()
        q_nom[3 * p: 3 * p + 3] = system.stance.q_push[3 * p: 3 * p + 3]
        w = opt.weights
        self.costs: list[CostTerm] = [TrackingCost(system, w, com_rel0, q_nom), EffortCost(w), TerminalSpeedCost(w)]
        mu_plan = opt.friction_margin * system.friction_mu
        term = config.terminal
        self.constraints: list[ConstraintTerm] = [
            defect, FeetOnBoard(system, board_legs),
            PushFoot(system, self.schedule, config.stance, term.push_foot_height_m),
            FrictionCones(system, self.schedule, self.mode.board_legs, mu_plan, opt.friction_model),
            Propulsion(system, self.schedule), TorqueLimits(system, self.schedule), Steering(system),
            WheelLoads(system, board_legs), GentleContact(system, self.schedule, config.contact, opt.dt_s),
            FinalSpeed(opt.final_velocity_tol, term.relative_speed_tol_mps), RidingEnd(system, term.position_tol_m),
        ]
        self.tr: Transcribed = transcribe(MultipleShooting(N, opt.dt_s, threads), (NXA, NU, N_PARAMS), self.costs,
                                          self.constraints, compile_dir=compile_dir() if opt.compile else None,
                                          native=opt.compile_native)
        x_sym = ca.SX.sym("x", NX)
        self._contacts = ca.Function("contacts", [x_sym], [contact_points_world(system, x_sym, self.mode.board_legs)])
        self.build_time_s = time.perf_counter() - t0
        self._solvers: dict[tuple[Any, ...], ca.Function] = {}
        self._guesses = memoized(lambda v0, v, k: initial_guess(system, self.schedule, self.start_state(v0), v0, v, k))

    @property
    def n(self) -> int:
        return NXA + NU

    def start_state(self, from_velocity_mps: float) -> np.ndarray:
        """Where the window starts: riding at ``from_velocity_mps`` (a transition), or at rest."""
        if self.window.riding:
            return riding_state(self.system, from_velocity_mps)
        if from_velocity_mps != 0.0:
            raise ValueError(f"a start-up starts at rest, not at {from_velocity_mps} m/s")
        return self.x0

    def _initial_state(self) -> np.ndarray:
        """Static stance on the board at rest, the push foot on the ground (accelerating mode)."""
        s, x = self.system, np.zeros(NXA)
        x[S_POS] = np.array([self.config.stance.base_x_offset_m, 0.0, s.stance.trunk_height_m]) + s.srb.com_offset_m
        x[S_Q] = s.stance.q_push
        return x

    def solver(self, options: dict[str, Any]) -> ca.Function:
        key = tuple(sorted(options.items()))
        if key not in self._solvers:
            opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                    **{f"ipopt.{k}": v for k, v in options.items()}, **self.tr.nlp.options}
            self._solvers[key] = ca.nlpsol("pushoff", "ipopt", self.tr.nlp.nlp, opts)
        return self._solvers[key]

    def parameters(self, from_velocity_mps: float, target_velocity_mps: float) -> np.ndarray:
        N, v0, v = self.schedule.n_intervals, from_velocity_mps, target_velocity_mps
        P = np.zeros((N, N_PARAMS))
        P[:, P_VDES] = v0 + (v - v0) * self.schedule.t[:N] / self.schedule.t[-1]
        P[:, P_RATE] = 1.0
        P[-1, P_RATE] = 0.0
        P[-1, P_TERMINAL] = 1.0
        P[:, P_TARGET] = v
        P[:, P_DRIVE] = drive = self.system.drive(v0, v, float(self.schedule.t[-1]))
        opt = self.config.optimization
        margin = opt.friction_margin if drive > 0 else self.config.transitions.brake_friction_margin
        P[:, P_MU_GROUND] = margin * self.system.friction_mu
        P[:, P_SPEED_SCALE] = v if v > 0 else self.config.transitions.stop_speed_tol_mps / max(
            opt.final_velocity_tol, 1e-9)
        return P.reshape(-1)  # row-major (N, n_p) == column-major (n_p, N)

    def bound_terms(self, from_velocity_mps: float) -> list[Any]:
        """The bound terms of a start at ``from_velocity_mps`` [m/s] (:mod:`.bounds`)."""
        return bound_terms(self.config, self.system, self.schedule, self.start_state(from_velocity_mps))

    def bounds(self, from_velocity_mps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Variable bounds (the bound terms' intersection) and constraint-row bounds; the start speed
        fixes the first knot, the targets enter through the stage parameters."""
        lbx, ubx = variable_bounds(self.bound_terms(from_velocity_mps), len(self.schedule.t), self.n)
        return lbx, ubx, self.tr.lbg.copy(), self.tr.ubg.copy()

    def initial_guess(self, from_velocity_mps: float, target_velocity_mps: float, kind: str) -> np.ndarray:
        """The cold guess (:mod:`.guess`), read-only, made once per speeds and kind."""
        return self._guesses(from_velocity_mps, target_velocity_mps, kind)

    def fingerprint(self, from_velocity_mps: float, target_velocity_mps: float, guess: str) -> str:
        """SHA-256 of everything this problem feeds IPOPT for one target besides its options and warm
        start: the stage function (every cost and constraint term), the problem config (URDF by
        content), parameters, bounds and the cold initial guess."""
        h = hashlib.sha256()
        h.update(self.tr.fingerprint.encode())
        h.update(self.config.problem_json().encode())
        h.update(str(self.n_strides).encode())
        for a in (self.parameters(from_velocity_mps, target_velocity_mps), *self.bounds(from_velocity_mps),
                  self.initial_guess(from_velocity_mps, target_velocity_mps, guess)):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        return h.hexdigest()

    @cached_property
    def _g_fn(self) -> ca.Function:
        return ca.Function("g", [self.tr.nlp.nlp["x"], self.tr.nlp.nlp["p"]], [self.tr.nlp.nlp["g"]])

    def violation(self, w: np.ndarray, P: np.ndarray, bounds: tuple[np.ndarray, ...]) -> float:
        """Largest violation of constraint rows and variable bounds at ``w``."""
        lbx, ubx, lbg, ubg = bounds
        g = np.asarray(self._g_fn(w, P)).reshape(-1)
        viol = [np.max(np.maximum(lbg - g, 0.0), initial=0.0), np.max(np.maximum(g - ubg, 0.0), initial=0.0),
                np.max(np.maximum(lbx - w, 0.0), initial=0.0), np.max(np.maximum(w - ubx, 0.0), initial=0.0)]
        return float(max(viol))

    def extract(self, w: np.ndarray) -> dict[str, np.ndarray]:
        K = len(self.schedule.t)
        W = w.reshape(K, self.n)
        state = W[:, :NX].copy()
        feet = np.asarray(self._contacts.map(K)(state.T)).T.reshape(K, 4, 3)
        board = np.column_stack([W[:, I_BOARD_XY], np.full(K, self.system.board.deck_height_m), state[:, S_RPY][:, 2]])
        return {"t": self.schedule.t.copy(), "state": state, "control": W[:-1, NXA:].copy(),
                "contact": self.schedule.contact.copy(), "foot_pos": feet, "board_pos": board}
