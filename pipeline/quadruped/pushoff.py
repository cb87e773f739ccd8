"""Push-off trajectory optimization (paper Sec. IV-B): from rest on the board to a target speed
by pushing with one leg for a number of 1.2 s strides. Direct multiple shooting + IPOPT.

``solve(spec) -> SolveResult`` is a pure, picklable module-level function; the built NLP and
solver are cached per process (keyed by the config and the stride count), so a worker that
solves a chain of velocities builds once.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.channels import GROUND, NU, NX, S_OMEGA, S_POS, S_Q, S_RPY, S_VEL, SWING, U_QD
from skatelib.pipeline.ocp.integrators import integrator
from skatelib.pipeline.ocp.shooting import MultipleShooting, Transcribed, transcribe
from skatelib.pipeline.ocp.terms import ConstraintTerm, CostTerm
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.dynamics import contact_points_world, dynamics_function, modes_for
from skatelib.pipeline.quadruped.schedule import KnotSchedule, knot_schedule
from skatelib.pipeline.quadruped.system import SkateSystem
from skatelib.pipeline.quadruped.terms import (
    N_PARAMS,
    NXA,
    P_RATE,
    P_TARGET,
    P_TERMINAL,
    P_VDES,
    DynamicsDefect,
    EffortCost,
    FeetOnBoard,
    FinalSpeed,
    FrictionCones,
    Propulsion,
    PushFoot,
    Steering,
    TerminalSpeedCost,
    TorqueLimits,
    TrackingCost,
)


@dataclass(frozen=True)
class WarmStart:
    """A previous solution to start from: primal w and multipliers of g and of the bounds."""

    w: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray


@dataclass(frozen=True)
class PushoffSpec:
    """One push-off problem.

    Attributes:
        config: The validated build config.
        target_velocity_mps: Board speed to reach at the end [m/s].
        n_strides: Number of push cycles.
        warm: Optional warm start (a neighbouring solution of the same stride count).
        guess: Initial-guess kind when cold: ``"ramp"`` (static stance, board speed ramp) or
            ``"hold"`` (static stance at rest), used by the retry ladder.
        ipopt: Extra IPOPT options as (name, value) pairs.
    """

    config: QuadrupedConfig
    target_velocity_mps: float
    n_strides: int
    warm: WarmStart | None = field(default=None, repr=False, compare=False)
    guess: str = "ramp"
    ipopt: tuple[tuple[str, Any], ...] = ()


@dataclass(frozen=True)
class SolveResult:
    """The outcome of one solve, successful or not (a failure carries its IPOPT status)."""

    target_velocity_mps: float
    n_strides: int
    success: bool
    status: str
    iterations: int
    build_time_s: float
    solve_time_s: float
    objective: float
    max_constraint_violation: float
    t: np.ndarray  # (K,) [s]
    state: np.ndarray  # (K, 28)
    control: np.ndarray  # (K-1, 24)
    contact: np.ndarray  # (K, 4) int8
    foot_pos: np.ndarray  # (K, 4, 3) world contact points [m]
    board_pos: np.ndarray  # (K, 4) board origin x, y, z [m] and yaw [rad]
    final_velocity_mps: float
    warm: WarmStart | None = field(default=None, repr=False)
    ipopt_options: dict[str, Any] = field(default_factory=dict)

    @property
    def final_velocity_error(self) -> float:
        """Relative error of the final board speed against the target [-]."""
        return abs(self.final_velocity_mps - self.target_velocity_mps) / self.target_velocity_mps


class PushoffProblem:
    """The transcribed NLP for one config and stride count, reusable across target speeds."""

    def __init__(self, config: QuadrupedConfig, n_strides: int):
        t0 = time.perf_counter()
        self.config = config
        self.n_strides = n_strides
        opt = config.optimization
        self.system = system = SkateSystem.from_config(config)
        self.schedule: KnotSchedule = knot_schedule(config.schedule, n_strides, opt.dt_s)
        N = self.schedule.n_intervals
        self.mode = modes_for(config.schedule.push_leg)["accelerating"]
        f = dynamics_function(system, self.mode)
        xa, ua = ca.SX.sym("x", NXA), ca.SX.sym("u", NU)
        cr = ca.DM(system.stance.cr)
        f_aug = ca.Function("f_aug", [xa, ua], [ca.vertcat(f(xa[:NX], ua, cr), xa[24:26])])
        step = integrator(opt.integrator, f_aug, opt.dt_s, opt.substeps, system.stiff_linear_part(NXA))
        p = system.push_index
        board_legs = tuple(i for i in range(4) if i != p)
        self.x0 = self._initial_state()
        com_rel0 = self.x0[S_POS] - np.array([0.0, 0.0, system.board.deck_height_m])
        q_nom = system.stance.q_board.copy()
        q_nom[3 * p: 3 * p + 3] = system.stance.q_push[3 * p: 3 * p + 3]
        w = opt.weights
        costs: list[CostTerm] = [TrackingCost(system, w, com_rel0, q_nom), EffortCost(w), TerminalSpeedCost(w)]
        mu_plan = opt.friction_margin * system.friction_mu
        term = config.terminal
        self.constraints: list[ConstraintTerm] = [
            DynamicsDefect(step), FeetOnBoard(system, board_legs),
            PushFoot(system, self.schedule, config.stance, term.push_foot_height_m),
            FrictionCones(system, self.schedule, self.mode.board_legs, mu_plan, opt.friction_model),
            Propulsion(system, self.schedule), TorqueLimits(system, self.schedule), Steering(system),
            FinalSpeed(opt.final_velocity_tol, term.relative_speed_tol_mps),
        ]
        self.tr: Transcribed = transcribe(MultipleShooting(N, opt.dt_s), (NXA, NU, N_PARAMS), costs,
                                          self.constraints, compile_c=opt.compile)
        x_sym = ca.SX.sym("x", NX)
        self._contacts = ca.Function("contacts", [x_sym], [contact_points_world(system, x_sym, self.mode.board_legs)])
        self.build_time_s = time.perf_counter() - t0
        self._solvers: dict[tuple[Any, ...], ca.Function] = {}

    @property
    def n(self) -> int:
        return NXA + NU

    def _initial_state(self) -> np.ndarray:
        """Static stance on the board at rest, the push foot on the ground (accelerating mode)."""
        s = self.system
        x = np.zeros(NXA)
        trunk = np.array([self.config.stance.base_x_offset_m, 0.0, s.stance.trunk_height_m])
        x[S_POS] = trunk + s.srb.com_offset_m
        x[S_Q] = s.stance.q_push
        return x

    def solver(self, options: dict[str, Any]) -> ca.Function:
        key = tuple(sorted(options.items()))
        if key not in self._solvers:
            opts = {"print_time": False, "calc_lam_p": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                    **{f"ipopt.{k}": v for k, v in options.items()}, **self.tr.nlp.options}
            self._solvers[key] = ca.nlpsol("pushoff", "ipopt", self.tr.nlp.nlp, opts)
        return self._solvers[key]

    def parameters(self, v_target: float) -> np.ndarray:
        N = self.schedule.n_intervals
        P = np.zeros((N, N_PARAMS))
        P[:, P_VDES] = v_target * self.schedule.t[:N] / self.schedule.t[-1]
        P[:, P_RATE] = 1.0
        P[-1, P_RATE] = 0.0
        P[-1, P_TERMINAL] = 1.0
        P[:, P_TARGET] = v_target
        return P.reshape(-1)  # row-major (N, n_p) == column-major (n_p, N)

    def bounds(self, v_target: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        s, N, n = self.system, self.schedule.n_intervals, self.n
        lbx, ubx = np.full((N + 1, n), -np.inf), np.full((N + 1, n), np.inf)
        lbx[:, 2], ubx[:, 2] = 0.05, 1.0  # trunk height
        lbx[:, 3:5], ubx[:, 3:5] = -0.6, 0.6  # roll, pitch
        margin = self.config.optimization.joint_limit_margin_rad
        lbx[:, S_Q], ubx[:, S_Q] = s.robot.lower_limits + margin, s.robot.upper_limits - margin
        lbx[:, 26], ubx[:, 26] = -s.board.roll_limit_rad, s.board.roll_limit_rad
        fmax = 4.0 * s.srb.mass_kg * s.gravity_mps2
        lbx[:, NXA:NXA + 12], ubx[:, NXA:NXA + 12] = -fmax, fmax
        lbx[:, NXA + 12:], ubx[:, NXA + 12:] = -s.joint_velocity_limit_radps, s.joint_velocity_limit_radps
        for i in range(4):
            swing = self.schedule.contact[:, i] == SWING
            lbx[swing, NXA + 3 * i: NXA + 3 * i + 3] = ubx[swing, NXA + 3 * i: NXA + 3 * i + 3] = 0.0
        lbx[0, :NXA] = ubx[0, :NXA] = self.x0
        lbx[N, NXA:] = ubx[N, NXA:] = 0.0  # u_N is a placeholder
        self._riding_end(lbx[N], ubx[N], lbx[N - 1], ubx[N - 1])
        return lbx.reshape(-1), ubx.reshape(-1), self.tr.lbg.copy(), self.tr.ubg.copy()

    def _riding_end(self, lo: np.ndarray, hi: np.ndarray, lo_u: np.ndarray, hi_u: np.ndarray) -> None:
        """Bounds of the last knot: the body still (vertical speed, angular velocity), level and at
        the riding stance's height, and no joint motion over the last interval."""
        term = self.config.terminal
        z = self.x0[S_POS][2]
        lo[2], hi[2] = z - term.height_tol_m, z + term.height_tol_m
        lo[S_RPY][:2], hi[S_RPY][:2] = -term.attitude_tol_rad, term.attitude_tol_rad
        lo[S_VEL][2], hi[S_VEL][2] = -term.vertical_speed_tol_mps, term.vertical_speed_tol_mps
        lo[S_OMEGA], hi[S_OMEGA] = -term.angular_speed_tol_radps, term.angular_speed_tol_radps
        qd = slice(NXA + U_QD.start, NXA + U_QD.stop)
        lo_u[qd] = np.maximum(lo_u[qd], -term.joint_velocity_tol_radps)
        hi_u[qd] = np.minimum(hi_u[qd], term.joint_velocity_tol_radps)

    def initial_guess(self, v_target: float, kind: str) -> np.ndarray:
        """Static stance riding a board whose speed ramps to the target (``kind="ramp"``) or at rest.

        The push leg is posed by inverse kinematics so that its foot stays where it touched down
        while the trunk rides on, and swings back between pushes; the push force carries the
        momentum the ramp needs (never random).
        """
        s, sch = self.system, self.schedule
        T = sch.t[-1]
        K = len(sch.t)
        guess = np.tile(np.concatenate([self.x0, np.zeros(NU)]), (K, 1))
        a = v_target / T if kind == "ramp" else 0.0
        guess[:, 24] = guess[:, 6] = a * sch.t
        guess[:, 0] += 0.5 * a * sch.t**2
        guess[:, NX] = 0.5 * a * sch.t**2
        p = s.push_index
        q = np.tile(s.stance.q_board, (K, 1))
        runs = sch.stance_intervals(p, GROUND)
        com_off = s.srb.com_offset_m
        for k0, k1 in runs:
            trunk0 = guess[k0, S_POS] - com_off
            foot_world = trunk0 + np.asarray(s.robot.foot_positions_body(s.stance.q_push))[:, p]
            q_leg = s.stance.q_push[3 * p: 3 * p + 3].copy()
            for k in range(k0, k1 + 1):
                q_leg = self._leg_ik(foot_world - (guess[k, S_POS] - com_off), q_leg)
                q[k, 3 * p: 3 * p + 3] = q_leg
        # Swings: joint angles interpolate from lift-off to the next touchdown (or the stance).
        lifts = [k1 for _, k1 in runs]
        downs = [k0 for k0, _ in runs[1:]] + [K - 1]
        for k1, k2 in zip(lifts, downs, strict=True):
            end = q[k2, 3 * p: 3 * p + 3] if k2 < K - 1 else s.stance.q_push[3 * p: 3 * p + 3]
            for k in range(k1 + 1, k2 + (1 if k2 == K - 1 else 0)):
                w = (k - k1) / max(k2 - k1, 1)
                q[k, 3 * p: 3 * p + 3] = (1 - w) * q[k1, 3 * p: 3 * p + 3] + w * end
        guess[:, S_Q] = q
        m_r, m_b = s.srb.mass_kg, s.board.mass_kg
        push_time = sum(k1 - k0 for k0, k1 in runs) * (sch.t[1] - sch.t[0])
        f_push = (m_r + m_b) * v_target / push_time if kind == "ramp" and push_time > 0 else 0.0
        for k in range(K - 1):
            on = [i for i in range(4) if sch.contact[k, i] != SWING]
            for i in on:
                guess[k, NXA + 3 * i + 2] = m_r * s.gravity_mps2 / len(on)
                if i == p:
                    guess[k, NXA + 3 * i] = f_push
                elif sch.contact[k, i] != SWING:
                    guess[k, NXA + 3 * i] = -m_b * a / 3
        guess[-1, NXA:] = 0.0
        return guess.reshape(-1)

    @cached_property
    def _leg_fk(self) -> ca.Function:
        """Push-leg foot position in the trunk frame and its 3x3 Jacobian, from the leg's joints."""
        p = self.system.push_index
        q_leg = ca.SX.sym("q", 3)
        chain = self.system.robot.chains[p]
        from skatelib.pipeline.quadruped.robot import foot_position_leg

        pos = foot_position_leg(chain, q_leg)
        return ca.Function("leg_fk", [q_leg], [pos, ca.jacobian(pos, q_leg)])

    def _leg_ik(self, target: np.ndarray, q0: np.ndarray) -> np.ndarray:
        """Damped Newton on one leg, kept inside the joint limits (a guess, not a constraint)."""
        p = self.system.push_index
        lo = self.system.robot.lower_limits[3 * p: 3 * p + 3]
        hi = self.system.robot.upper_limits[3 * p: 3 * p + 3]
        q = q0.copy()
        for _ in range(20):
            pos, J = (np.asarray(v) for v in self._leg_fk(q))
            err = target - pos.reshape(-1)
            if np.linalg.norm(err) < 1e-9:
                break
            q = np.clip(q + np.linalg.solve(J.T @ J + 1e-6 * np.eye(3), J.T @ err), lo, hi)
        return q

    def fingerprint(self, v_target: float, guess: str) -> str:
        """SHA-256 of everything this problem feeds IPOPT for one target besides its options and warm
        start: the stage function (every cost and constraint term), the problem config (URDF by
        content), parameters, bounds and the cold initial guess."""
        h = hashlib.sha256()
        h.update(self.tr.fingerprint.encode())
        h.update(self.config.problem_json().encode())
        h.update(str(self.n_strides).encode())
        for a in (self.parameters(v_target), *self.bounds(v_target), self.initial_guess(v_target, guess)):
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
        feet = np.stack([np.asarray(self._contacts(state[k])).T for k in range(K)])
        board = np.column_stack([W[:, NX], W[:, NX + 1], np.full(K, self.system.board.deck_height_m), state[:, 5]])
        return {"t": self.schedule.t.copy(), "state": state, "control": W[:-1, NXA:].copy(),
                "contact": self.schedule.contact.copy(), "foot_pos": feet, "board_pos": board}


_PROBLEMS: dict[tuple[str, int], PushoffProblem] = {}


def problem_for(config: QuadrupedConfig, n_strides: int) -> PushoffProblem:
    """The cached problem of this process for (config, strides); built on first use."""
    key = (config.resolved_json(), n_strides)
    if key not in _PROBLEMS:
        _PROBLEMS[key] = PushoffProblem(config, n_strides)
    return _PROBLEMS[key]


def solver_options(spec: PushoffSpec) -> dict[str, Any]:
    """The IPOPT options a solve of ``spec`` uses: the config's, warm-start settings, then ``spec.ipopt``."""
    opt = spec.config.optimization
    options: dict[str, Any] = {"max_iter": opt.max_iter, "tol": opt.tol, "mu_strategy": opt.mu_strategy,
                               "mu_init": opt.mu_init}
    if spec.warm is not None:
        options.update({"warm_start_init_point": "yes", "mu_init": 1e-4, "warm_start_bound_push": 1e-6,
                        "warm_start_mult_bound_push": 1e-6})
    options.update(dict(spec.ipopt))
    return options


def solve(spec: PushoffSpec) -> SolveResult:
    """Solve one push-off problem. Never raises on solver failure: the result says so."""
    t_build = time.perf_counter()
    built_before = (spec.config.resolved_json(), spec.n_strides) in _PROBLEMS
    prob = problem_for(spec.config, spec.n_strides)
    build_time = 0.0 if built_before else time.perf_counter() - t_build
    v = spec.target_velocity_mps
    options = solver_options(spec)
    solver = prob.solver(options)
    P = prob.parameters(v)
    bounds = prob.bounds(v)
    lbx, ubx, lbg, ubg = bounds
    args: dict[str, Any] = {"p": P, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
    if spec.warm is not None:
        args.update(x0=spec.warm.w, lam_g0=spec.warm.lam_g, lam_x0=spec.warm.lam_x)
    else:
        args["x0"] = prob.initial_guess(v, spec.guess)
    t0 = time.perf_counter()
    sol = solver(**args)
    solve_time = time.perf_counter() - t0
    stats = solver.stats()
    w = np.asarray(sol["x"]).reshape(-1)
    arrays = prob.extract(w)
    viol = prob.violation(w, P, bounds)
    final_v = float(np.cos(arrays["state"][-1, 5]) * arrays["state"][-1, 24]
                    + np.sin(arrays["state"][-1, 5]) * arrays["state"][-1, 25])
    status = str(stats.get("return_status", "unknown"))
    return SolveResult(
        target_velocity_mps=v, n_strides=spec.n_strides, success=bool(stats.get("success", False)),
        status=status, iterations=int(stats.get("iter_count", -1)), build_time_s=build_time,
        solve_time_s=solve_time, objective=float(sol["f"]), max_constraint_violation=viol,
        final_velocity_mps=final_v,
        warm=WarmStart(w=w, lam_g=np.asarray(sol["lam_g"]).reshape(-1), lam_x=np.asarray(sol["lam_x"]).reshape(-1)),
        ipopt_options=options, **arrays,
    )
