"""The symbols and constraint rows of one humanoid step's NLP (Takasugi et al., Eq. 15-32): the
contact conditions at each LG node and the terminal conditions of each step kind; see
:mod:`skatelib.pipeline.humanoid.step` for the whole problem."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.pipeline.humanoid.geometry import MAX_EDGES
from skatelib.pipeline.ocp.gpm import GaussPseudospectral, lagrange_basis


@dataclass(frozen=True)
class StepSymbols:
    """The step NLP's variables (X, U, Xf) and parameters, in the order of ``params()``."""

    X: Any
    U: Any
    Xf: Any
    x0: Any
    T: Any
    P0: Any
    E: Any
    MU: Any
    p_step: Any
    v_step: Any
    b: Any
    mu_next: Any
    rmin: Any
    rmax: Any
    g: Any

    @classmethod
    def make(cls, N: int) -> StepSymbols:
        b, mu_next, rmin, rmax, g = (ca.SX.sym(n) for n in ("b", "mu_next", "rmin", "rmax", "g"))
        return cls(ca.SX.sym("X", N + 1, 6), ca.SX.sym("U", N, 3), ca.SX.sym("Xf", 1, 6), ca.SX.sym("x0", 1, 6),
                   ca.SX.sym("T"), ca.SX.sym("P0", N, 3), ca.SX.sym("E", N, 3 * MAX_EDGES), ca.SX.sym("MU", N, 2),
                   ca.SX.sym("p_step", 1, 3), ca.SX.sym("v_step", 1, 3), b, mu_next, rmin, rmax, g)

    def params(self) -> list[Any]:
        return [ca.vec(self.x0), self.T, ca.vec(self.P0), ca.vec(self.E), ca.vec(self.MU), ca.vec(self.p_step),
                ca.vec(self.v_step), self.b, self.mu_next, self.rmin, self.rmax, self.g]


class Rows:
    """Inequality rows with their bounds, in the order added."""

    def __init__(self) -> None:
        self.exprs: list[Any] = []
        self.lo: list[np.ndarray] = []
        self.hi: list[np.ndarray] = []

    def add(self, expr: Any, lb: float, ub: float) -> None:
        self.exprs.append(expr)
        self.lo.append(np.full(expr.numel(), lb))
        self.hi.append(np.full(expr.numel(), ub))


def node_rows(s: StepSymbols, k: int, rows: Rows) -> None:
    """Eq. (15)-(21) at LG node k: unilateral, ZMP in the support polygon, friction, leg reach."""
    r = s.X[k + 1, 0:3].T - s.P0[k, :].T
    F = s.U[k, :].T + ca.vertcat(0, 0, s.g)  # Eq. (15)
    Nm = ca.cross(r, F)  # Eq. (16)
    rows.add(F[2], 0.0, ca.inf)  # Eq. (17)
    for e in range(MAX_EDGES):
        a_, b_, c_ = s.E[k, 3 * e], s.E[k, 3 * e + 1], s.E[k, 3 * e + 2]
        rows.add(-a_ * Nm[1] + b_ * Nm[0] + c_ * F[2], 0.0, ca.inf)  # Eq. (18)
    for j in range(2):  # Eq. (19), (20): |F_j| <= mu_j F_z
        rows.add(s.MU[k, j] * F[2] - F[j], 0.0, ca.inf)
        rows.add(s.MU[k, j] * F[2] + F[j], 0.0, ca.inf)
    rows.add(ca.sumsqr(r) - s.rmin**2, 0.0, ca.inf)  # Eq. (21)
    rows.add(s.rmax**2 - ca.sumsqr(r), 0.0, ca.inf)


def terminal_rows(s: StepSymbols, terminal: str, gpm: GaussPseudospectral, rows: Rows) -> list[Any]:
    """The terminal conditions of the step's kind: equality rows returned, inequalities added."""
    Pf, Vf = s.Xf[0, 0:3], s.Xf[0, 3:6]
    dcm_error = Pf + s.b * (Vf - s.v_step) - s.p_step - ca.horzcat(0, 0, s.b**2 * s.g)  # Eq. (25)-(27)
    eq: list[Any] = []
    if terminal in ("walk", "skate"):
        eq.append(ca.vec(dcm_error))
    if terminal == "dcm_on_board":
        # Along a frictionless board x follows from the dynamics: the DCM is placed across it only.
        eq.append(ca.vec(dcm_error[1:3]))
    if terminal == "walk":  # Eq. (30) along the walking direction x, relative to the next support
        rows.add(s.mu_next * Pf[2] - (Pf[0] - s.p_step[0]), 0.0, ca.inf)
        rows.add(s.mu_next * Pf[2] + (Pf[0] - s.p_step[0]), 0.0, ca.inf)
    if terminal == "skate":
        eq.append(Pf[0] - s.p_step[0])  # Eq. (31), sliding direction x
        eq.append(Vf[2])  # the paper sets the COM's vertical velocity to 0 at the transition
        u_end = ca.DM(lagrange_basis(gpm.tau, 1.0)) @ s.U  # control interpolant at tau = 1
        eq.append(u_end[0])  # Eq. (32), see the module docstring
    if terminal == "stop":
        eq += [ca.vec(Pf - s.p_step), ca.vec(Vf - s.v_step)]  # Eq. (23), (24)
    if terminal == "stop_on_board":
        # On a rolling board nothing pushes along x (no friction there), so x of P_f and V_f
        # follows from the dynamics; Eq. (23)-(24) are imposed across the board only.
        eq += [ca.vec(Pf[1:3] - s.p_step[1:3]), ca.vec(Vf[1:3] - s.v_step[1:3])]
    return eq
