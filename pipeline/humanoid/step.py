"""Humanoid COM steps by Gauss pseudospectral optimization (Takasugi et al., Sec. III-B to III-E).

Per step: state X = [P_COM, V_COM] at tau_0 and the N LG nodes, control U = A_COM at the nodes
(Eq. 12), cost the integral of |A_COM|^2 by quadrature (Eq. 13-14). Forces and moments per unit
mass about the representative contact point P0: F = A + [0, 0, g] (Eq. 15), N = (P - P0) x F
(Eq. 16), imposed at the nodes: unilateral F_z >= 0 (17), ZMP inside the support polygon (18),
linearized static friction (19) with a zero coefficient along a skating direction (20), leg reach
r_min <= |P - P0| <= r_max (21). Boundary: X_0 fixed to the previous step's X_f (22); the last
step stops, P_f = P_ref, V_f = V_ref (23-24); otherwise the divergent component of motion ends on
the next support, P_f + b (V_f - V_step) = P_step + [0, 0, dz], b = sqrt(dz / g) (25-27), with
the terminal friction condition |x_f - p_step| <= mu z_f along the walking direction (30), or, at
a push-to-slide transition, d (P_f - P_step) = 0 (31), zero terminal acceleration along d (the
intent of Eq. 32: no jump of acceleration into the frictionless slide) and zero vertical COM
speed (Sec. V-B). On a rolling board nothing pushes along it, so there the DCM and stop
conditions act across the board only (along it they follow from the dynamics, and imposing them
again would make the constraints degenerate).

P0 may move at constant velocity (a foot on a rolling skateboard); the constraints are written in
that inertial frame, where accelerations are unchanged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from skatelib.pipeline.build import interrupt
from skatelib.pipeline.humanoid.constraints import Rows, StepSymbols, node_rows, terminal_rows
from skatelib.pipeline.humanoid.geometry import MAX_EDGES, Support, edges
from skatelib.pipeline.ocp.gpm import GaussPseudospectral, collocation_defects, terminal_state

TERMINALS = ("walk", "skate", "dcm_on_board", "none", "stop", "stop_on_board")


@dataclass(frozen=True)
class StepSpec:
    """One step: duration, contact segments, boundary conditions."""

    name: str
    duration_s: float
    segments: tuple[tuple[float, Support], ...]  # (start time within the step [s], support)
    terminal: str  # walk | skate | dcm_on_board | none | stop | stop_on_board
    p_step: tuple[float, float, float] = (0.0, 0.0, 0.0)  # next support point (walk, skate) or P_ref (stop)
    v_step: tuple[float, float, float] = (0.0, 0.0, 0.0)  # next support velocity / V_ref
    dz_vrp_m: float = 0.8
    mu_next: float = 0.5


@dataclass(frozen=True)
class StepModel:
    """What every step of a motion shares: LG node count, gravity [m/s^2], leg reach [m] (Eq. 21)
    and the NLP solver."""

    n_nodes: int
    g: float
    rmin: float
    rmax: float
    solver: str = "ipopt"


@dataclass(frozen=True)
class StepResult:
    """A solved step: node values, solver outcome, and the per-node contact data used."""

    spec: StepSpec
    t0: float
    success: bool
    status: str
    iterations: int
    solve_time_s: float
    objective: float
    max_violation: float
    X: np.ndarray  # (N+1, 6) at tau_0..tau_N
    U: np.ndarray  # (N, 3) at the LG nodes
    Xf: np.ndarray  # (6,)
    P0: np.ndarray  # (N, 3) representative contact point at the nodes
    supports: tuple[Support, ...] = field(repr=False, default=())


SOLVER_OPTIONS: dict[str, tuple[str, dict[str, Any]]] = {
    "ipopt": ("ipopt", {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-9,
                        "ipopt.max_iter": 200}),
    "sqp": ("sqpmethod", {"print_time": False, "print_header": False, "print_iteration": False,
                          "print_status": False, "qpsol": "qrqp",
                          "qpsol_options": {"print_iter": False, "print_header": False, "error_on_fail": False},
                          "tol_pr": 1e-9, "tol_du": 1e-9, "max_iter": 100, "error_on_fail": False}),
}


class StepProblem:
    """The NLP of one step for a node count and terminal kind; parameters carry everything else.

    Parameters (per solve): x0 (6), duration, P0 at the nodes (N x 3), edges (N x MAX_EDGES x 3),
    friction (N x 2), p_step (3), v_step (3), b (1), mu_next (1), r_min, r_max, g.
    """

    def __init__(self, n_nodes: int, terminal: str, solver: str = "ipopt"):
        if terminal not in TERMINALS:
            raise ValueError(f"terminal {terminal!r}; use one of {TERMINALS}")
        if solver not in SOLVER_OPTIONS:
            raise ValueError(f"solver {solver!r}; use 'ipopt' or 'sqp'")
        self.gpm = gpm = GaussPseudospectral(n_nodes)
        N = n_nodes
        s = StepSymbols.make(N)
        params = s.params()
        self.param_sizes = [int(p.numel()) for p in params]
        F_dyn = ca.horzcat(s.X[1:, 3:6], s.U)  # [V, A] at the nodes
        eq: list[Any] = [ca.vec(collocation_defects(gpm, s.X, F_dyn, 0.0, s.T)),  # Eq. (12)
                         ca.vec(s.Xf - terminal_state(gpm, s.X[0, :], F_dyn, 0.0, s.T)),  # Eq. (6)
                         ca.vec(s.X[0, :] - s.x0)]  # Eq. (22)
        rows = Rows()
        for k in range(N):
            node_rows(s, k, rows)
        eq += terminal_rows(s, terminal, gpm, rows)
        J = s.T / 2 * ca.dot(ca.DM(gpm.weights), ca.sum2(s.U**2))  # Eq. (14)
        geq = ca.vertcat(*eq)
        gin = ca.vertcat(*rows.exprs)
        self.n_eq = geq.numel()
        self.lbg = np.concatenate([np.zeros(self.n_eq), *rows.lo])
        self.ubg = np.concatenate([np.zeros(self.n_eq), *rows.hi])
        w = ca.vertcat(ca.vec(s.X), ca.vec(s.U), ca.vec(s.Xf))
        self.n_w = w.numel()
        nlp = {"x": w, "p": ca.vertcat(*params), "f": J, "g": ca.vertcat(geq, gin)}
        plugin, opts = SOLVER_OPTIONS[solver]
        self.solver = ca.nlpsol(f"com_step_{terminal}", plugin, nlp, opts)
        self.nlp = nlp
        self.N = N

    def parameters(self, spec: StepSpec, x0: np.ndarray, g: float, rmin: float, rmax: float
                   ) -> tuple[np.ndarray, np.ndarray, tuple[Support, ...]]:
        """Parameter vector, node contact points and the support at each node."""
        t_nodes = self.gpm.times(0.0, spec.duration_s)
        P0 = np.zeros((self.N, 3))
        E = np.zeros((self.N, 3 * MAX_EDGES))
        MU = np.zeros((self.N, 2))
        sup = []
        for k, t in enumerate(t_nodes):
            start, s = [seg for seg in spec.segments if seg[0] <= t][-1]
            P0[k] = np.asarray(s.p0) + np.asarray(s.velocity) * (t - start)
            E[k] = edges(s.polygon).reshape(-1)
            MU[k] = (s.mu_x, s.mu_y)
            sup.append(s)
        b = np.sqrt(spec.dz_vrp_m / g)
        parts = [x0, [spec.duration_s], P0.reshape(-1, order="F"), E.reshape(-1, order="F"),
                 MU.reshape(-1, order="F"), spec.p_step, spec.v_step, [b], [spec.mu_next], [rmin], [rmax], [g]]
        return np.concatenate([np.asarray(p, dtype=float).reshape(-1) for p in parts]), P0, tuple(sup)

    def initial_guess(self, x0: np.ndarray, spec: StepSpec) -> np.ndarray:
        """Hold the initial state, drifting at its velocity (never random)."""
        N = self.N
        t = self.gpm.times(0.0, spec.duration_s, self.gpm.support)
        X = np.tile(x0, (N + 1, 1))
        X[:, 0:3] += np.outer(t, x0[3:6])
        Xf = x0.copy()
        Xf[0:3] += spec.duration_s * x0[3:6]
        return np.concatenate([X.reshape(-1, order="F"), np.zeros(3 * N), Xf])


_PROBLEMS: dict[tuple[int, str, str], StepProblem] = {}


def step_problem(n_nodes: int, terminal: str, solver: str = "ipopt") -> StepProblem:
    """Cached per process: building costs milliseconds, solving is what repeats."""
    key = (n_nodes, terminal, solver)
    if key not in _PROBLEMS:
        _PROBLEMS[key] = StepProblem(n_nodes, terminal, solver)
    return _PROBLEMS[key]


def solve_step(spec: StepSpec, x0: np.ndarray, t0: float, model: StepModel) -> StepResult:
    """Solve one step from ``x0``; a failure is returned with its status, never raised."""
    prob = step_problem(model.n_nodes, spec.terminal, model.solver)
    p, P0, sup = prob.parameters(spec, x0, model.g, model.rmin, model.rmax)
    tic = time.perf_counter()
    sol = prob.solver(x0=prob.initial_guess(x0, spec), p=p, lbg=prob.lbg, ubg=prob.ubg)
    interrupt.check()  # CasADi turns Ctrl-C into a failed solve; it stops the command
    dt = time.perf_counter() - tic
    st = prob.solver.stats()
    w = np.asarray(sol["x"]).reshape(-1)
    N = model.n_nodes
    X = w[: 6 * (N + 1)].reshape(N + 1, 6, order="F")
    U = w[6 * (N + 1): 6 * (N + 1) + 3 * N].reshape(N, 3, order="F")
    Xf = w[6 * (N + 1) + 3 * N:]
    g_val = np.asarray(sol["g"]).reshape(-1)
    viol = float(max(np.max(prob.lbg - g_val, initial=0.0), np.max(g_val - prob.ubg, initial=0.0)))
    return StepResult(spec=spec, t0=t0, success=bool(st.get("success", False)),
                      status=str(st.get("return_status", "unknown")), iterations=int(st.get("iter_count", -1)),
                      solve_time_s=dt, objective=float(sol["f"]), max_violation=viol, X=X, U=U, Xf=Xf, P0=P0,
                      supports=sup)


def solve_sequence(steps: list[StepSpec], x0: np.ndarray, model: StepModel) -> list[StepResult]:
    """Solve steps one after another, each starting from the previous final state (Eq. 22)."""
    out, t0, x = [], 0.0, np.asarray(x0, dtype=float)
    for spec in steps:
        r = solve_step(spec, x, t0, model)
        out.append(r)
        if not r.success:
            break
        x, t0 = r.Xf.copy(), t0 + spec.duration_s
    return out
