"""The MPC's force QP handed to the QP backends (:mod:`skatelib.control.qp`), each in the form it
solves fastest: DAQP the condensed QP in its least-distance form, ProxQP the condensed QP
warm-started, OSQP the sparse multiple-shooting form warm-started. ``make_solver(name)`` makes the
form of the backend ``name`` (one per closed loop: some keep warm starts)."""

from __future__ import annotations

from typing import Protocol

import numpy as np
from skatelib.control.mpc import NF, MpcProblem, controls
from skatelib.control.qp import SOLVERS, QpProblem, solve_qp

DAQP_INFINITY = 1e30


class MpcSolver(Protocol):
    """The controls U (N x 24, flattened) of one update's problem."""

    def solve(self, qp: MpcProblem) -> np.ndarray: ...


class LeastDistance:
    """The condensed force QP in its least-distance form: with H = R'R (Cholesky) and f = R^-1 z
    the QP is min 1/2 |z|^2 + (R^-T g)'z s.t. l <= C R^-1 z <= u, the transform DAQP would
    otherwise make itself in plain loops (C R^-1 is dense, m n^2 / 2). Here it is a triangular
    inverse and one small product per step (C is block diagonal over the steps, R^-1 upper
    triangular). Solved cold: a start from the previous update's shifted solution needs as many
    iterations."""

    def __init__(self, backend: str = "daqp"):
        self.backend = backend

    def solve(self, qp: MpcProblem) -> np.ndarray:
        from scipy.linalg import solve_triangular

        mask, H, g, C, lb, ub = qp.loaded()
        n = len(g)
        R_inv = solve_triangular(np.linalg.cholesky(H).T, np.eye(n), lower=False, check_finite=False)
        M = np.zeros_like(C)
        row = col = 0
        for k, rows in enumerate(qp.step_rows or (len(C),)):
            width = int(mask[k * NF:(k + 1) * NF].sum()) if qp.step_rows else n
            block = slice(row, row + rows)
            M[block, col:] = C[block, col:col + width] @ R_inv[col:col + width, col:]
            row, col = row + rows, col + width
        bounded = np.isfinite(lb) | np.isfinite(ub)  # simple bounds become rows of R^-1
        M = np.vstack([R_inv[bounded], M])
        upper = np.minimum(np.concatenate([ub[bounded], qp.u]), DAQP_INFINITY)
        lower = np.maximum(np.concatenate([lb[bounded], qp.l]), -DAQP_INFINITY)
        z = solve_qp(QpProblem(np.eye(n), R_inv.T @ g, M, lower, upper), self.backend).x
        f = np.zeros(len(qp.g))
        f[mask] = R_inv @ z
        return controls(qp, f)


class Condensed:
    """The condensed force QP, warm-started from the previous update's solution shifted by one step."""

    def __init__(self, backend: str = "proxqp"):
        self.backend = backend
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        mask, H, g, C, lb, ub = qp.loaded()
        warm = self.prev[mask] if self.prev is not None and len(self.prev) == len(qp.g) else None
        self.prev = None
        x = solve_qp(QpProblem(H, g, C, qp.l, qp.u, lb, ub), self.backend, warm).x
        f = np.zeros(len(qp.g))
        f[mask] = x
        self.prev = np.concatenate([f[NF:], f[-NF:]])
        return controls(qp, f)


class MultipleShooting:
    """The sparse multiple-shooting force QP: variables (F_0, X_1, F_1, ..., X_N) on the 16 reduced
    states, dynamics as equalities; warm-started from the previous solution shifted."""

    def __init__(self, backend: str = "osqp"):
        self.backend = backend
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        import scipy.sparse as sp

        N, ns = len(qp.Ad), len(qp.x0)
        step = NF + ns
        nz = N * step
        col_f = [k * step for k in range(N)]
        col_x = [c + NF for c in col_f]
        P = np.zeros(nz)
        q = np.zeros(nz)
        for k in range(N):
            P[col_f[k]:col_f[k] + NF] = qp.f_weights
            q[col_f[k]:col_f[k] + NF] = -qp.f_weights * qp.f_ref[k]
            P[col_x[k]:col_x[k] + ns] = qp.q_weights
            q[col_x[k]:col_x[k] + ns] = -qp.q_weights * qp.x_ref[k]
        # Dynamics: X_{k+1} - A X_k - B F_k = c (X_0 = x0 is known).
        dyn = sp.lil_matrix((N * ns, nz))
        rhs = np.zeros(N * ns)
        for k in range(N):
            r = slice(k * ns, (k + 1) * ns)
            dyn[r, col_x[k]:col_x[k] + ns] = np.eye(ns)
            dyn[r, col_f[k]:col_f[k] + NF] = -qp.Bd[k]
            if k == 0:
                rhs[r] = qp.Ad[0] @ qp.x0 + qp.cd[0]
            else:
                dyn[r, col_x[k - 1]:col_x[k - 1] + ns] = -qp.Ad[k]
                rhs[r] = qp.cd[k]
        sel = sp.lil_matrix((N * NF, nz))  # contact rows and bounds act on the forces only
        for k in range(N):
            sel[k * NF:(k + 1) * NF, col_f[k]:col_f[k] + NF] = sp.identity(NF)
        sel = sel.tocsc()
        A = sp.vstack([dyn.tocsc(), sp.csc_matrix(qp.C) @ sel, sel]).tocsc()
        lo = np.concatenate([rhs, qp.l, qp.lb])
        hi = np.concatenate([rhs, qp.u, qp.ub])
        warm = self.prev if self.prev is not None and len(self.prev) == nz else None
        z = solve_qp(QpProblem(sp.diags(P).tocsc(), q, A, lo, hi), self.backend, warm).x
        self.prev = np.concatenate([z[step:], z[-step:]])
        return controls(qp, np.concatenate([z[c:c + NF] for c in col_f]))


FORMS: dict[str, type[LeastDistance] | type[Condensed] | type[MultipleShooting]] = {
    "daqp": LeastDistance, "proxqp": Condensed, "osqp": MultipleShooting}


def make_solver(name: str) -> MpcSolver:
    """The MPC's solver on the backend ``name`` (a new one per closed loop).

    Raises:
        ValueError: An unknown name (the known ones are listed).
    """
    if name not in SOLVERS:
        raise ValueError(f"unknown QP solver {name!r}; choose one of {', '.join(SOLVERS)}")
    return FORMS[name](name)
