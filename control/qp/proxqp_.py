"""ProxSuite's dense ProxQP, warm-started when given a start point."""

from __future__ import annotations

import numpy as np
from skatelib.control.qp import QpProblem, QpSolution, QpSolveFailed

INFINITY = 1e20  # ProxQP's


def _finite(a: np.ndarray, fill: float) -> np.ndarray:
    return np.where(np.isfinite(a), a, fill)


def solve(problem: QpProblem, warm_start: np.ndarray | None = None) -> QpSolution:
    """Equality rows as ProxQP's equalities, the others as its inequalities, bounds as its box."""
    import proxsuite

    eq = np.zeros(len(problem.upper), dtype=bool) if problem.equality is None else problem.equality
    A, b = (problem.A[eq], problem.upper[eq]) if eq.any() else (None, None)
    C, u, l = problem.A[~eq], problem.upper[~eq], problem.lower[~eq]
    n, box = len(problem.g), problem.lb is not None or problem.ub is not None
    solver = proxsuite.proxqp.dense.QP(n, int(eq.sum()), C.shape[0], box)
    solver.settings.eps_abs = 1e-6
    solver.settings.eps_rel = 0.0
    solver.settings.verbose = False
    # Zero forces always satisfy the MPC's rows (f_min 0): ProxQP's default infeasibility threshold
    # (1e-4) called two updates of the bench's v0.50_s2 infeasible; 1e-8 solves them.
    solver.settings.eps_primal_inf = 1e-8
    solver.settings.eps_dual_inf = 1e-8
    bounds: tuple[np.ndarray, ...] = ()
    if box:
        lb = np.full(n, -INFINITY) if problem.lb is None else _finite(problem.lb, -INFINITY)
        ub = np.full(n, INFINITY) if problem.ub is None else _finite(problem.ub, INFINITY)
        bounds = (lb, ub)
    solver.init(problem.H, problem.g, A, b, C, _finite(l, -INFINITY), _finite(u, INFINITY), *bounds)
    solved = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
    if warm_start is not None and len(warm_start) == n:
        solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
        solver.solve(warm_start, None, None)
    if warm_start is None or solver.results.info.status != solved:  # cold start (again)
        solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS
        solver.solve()
    status = solver.results.info.status
    if status != solved:
        raise QpSolveFailed(f"ProxQP: {status}")
    return QpSolution(np.asarray(solver.results.x), int(solver.results.info.iter))
