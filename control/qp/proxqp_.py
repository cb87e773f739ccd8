"""ProxSuite's dense ProxQP on the condensed force QP, warm-started."""

from __future__ import annotations

import numpy as np
from skatelib.control.mpc import NF, MpcProblem, controls
from skatelib.control.qp import QpSolveFailed


class Solver:
    """The condensed force QP with ProxSuite's dense ProxQP, warm-started from the previous
    update's solution shifted by one step."""

    def __init__(self) -> None:
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        import proxsuite

        mask, H, g, C, lb, ub = qp.loaded()
        n, n_in = len(g), C.shape[0]
        solver = proxsuite.proxqp.dense.QP(n, 0, n_in, True)
        solver.settings.eps_abs = 1e-6
        solver.settings.eps_rel = 0.0
        solver.settings.verbose = False
        # Zero forces always satisfy the rows (f_min 0): ProxQP's default infeasibility threshold
        # (1e-4) called two updates of the bench's v0.50_s2 infeasible; 1e-8 solves them.
        solver.settings.eps_primal_inf = 1e-8
        solver.settings.eps_dual_inf = 1e-8

        def finite(a: np.ndarray, fill: float) -> np.ndarray:
            return np.where(np.isfinite(a), a, fill)

        solver.init(H, g, None, None, C, finite(qp.l, -1e20), finite(qp.u, 1e20), finite(lb, -1e20),
                    finite(ub, 1e20))
        solved = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
        if self.prev is not None and len(self.prev) == len(qp.g):
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
            solver.solve(self.prev[mask], None, None)
        if self.prev is None or solver.results.info.status != solved:  # cold start (again)
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS
            solver.solve()
        status = solver.results.info.status
        if status != solved:
            self.prev = None
            raise QpSolveFailed(f"ProxQP: {status}")
        f = np.zeros(len(qp.g))
        f[mask] = solver.results.x
        self.prev = np.concatenate([f[NF:], f[-NF:]])
        return controls(qp, f)
