"""OSQP on the sparse multiple-shooting form of the force QP, warm-started."""

from __future__ import annotations

import numpy as np
from skatelib.control.mpc import NF, MpcProblem, controls
from skatelib.control.qp import QpSolveFailed


class Solver:
    """The sparse multiple-shooting force QP with OSQP: variables (F_0, X_1, F_1, ..., X_N) on the
    16 reduced states, dynamics as equalities; warm-started from the previous solution shifted."""

    def __init__(self) -> None:
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        import osqp
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
        solver = osqp.OSQP()
        solver.setup(sp.diags(P).tocsc(), q, A, lo, hi, verbose=False, eps_abs=1e-9, eps_rel=1e-9,
                     max_iter=20000, polishing=True)
        if self.prev is not None and len(self.prev) == nz:
            solver.warm_start(x=self.prev)
        res = solver.solve(raise_error=False)  # the status is checked below
        if res.info.status not in ("solved", "solved inaccurate"):
            raise QpSolveFailed(f"OSQP: {res.info.status}")
        z = np.asarray(res.x)
        self.prev = np.concatenate([z[step:], z[-step:]])
        return controls(qp, np.concatenate([z[c:c + NF] for c in col_f]))
