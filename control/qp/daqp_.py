"""DAQP (dense dual active set) on the condensed force QP: the default, fastest in ``make bench``."""

from __future__ import annotations

import numpy as np
from skatelib.control.mpc import NF, MpcProblem, controls
from skatelib.control.qp import QpSolveFailed


class Solver:
    """The condensed force QP with DAQP (dense dual active set), handed over in its least-distance
    form: with H = R'R (Cholesky) and f = R^-1 z the QP is min 1/2 |z|^2 + (R^-T g)'z s.t.
    l <= C R^-1 z <= u, the transform DAQP would otherwise make itself in plain loops (C R^-1 is
    dense, m n^2 / 2). Here it is a triangular inverse and one small product per step (C is block
    diagonal over the steps, R^-1 upper triangular). Solved cold: a start from the previous
    update's shifted solution needs as many iterations."""

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        from ctypes import c_int

        import daqp
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
        big = 1e30  # DAQP's infinity
        M = np.vstack([R_inv[bounded], M])
        upper = np.minimum(np.concatenate([ub[bounded], qp.u]), big)
        lower = np.maximum(np.concatenate([lb[bounded], qp.l]), -big)
        z, _, flag, _ = daqp.solve(np.eye(n), R_inv.T @ g, M, upper, lower, np.zeros(len(upper), dtype=c_int))
        if flag != 1:
            raise QpSolveFailed(f"DAQP: exit flag {flag}")
        f = np.zeros(len(qp.g))
        f[mask] = R_inv @ z
        return controls(qp, f)
