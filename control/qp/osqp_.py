"""OSQP (ADMM on sparse matrices), warm-started when given a start point; tight tolerances and
polishing, for the MPC's sparse multiple-shooting form."""

from __future__ import annotations

import numpy as np
from skatelib.control.qp import QpProblem, QpSolution, QpSolveFailed


def solve(problem: QpProblem, warm_start: np.ndarray | None = None) -> QpSolution:
    """Bounds as identity rows; equality rows are rows with equal bounds (OSQP's own form)."""
    import osqp
    import scipy.sparse as sp

    A, lower, upper = sp.csc_matrix(problem.A), problem.lower, problem.upper
    if problem.equality is not None:
        lower = np.where(problem.equality, upper, lower)
    if problem.lb is not None or problem.ub is not None:
        n = len(problem.g)
        A = sp.vstack([A, sp.identity(n, format="csc")]).tocsc()
        lower = np.concatenate([lower, np.full(n, -np.inf) if problem.lb is None else problem.lb])
        upper = np.concatenate([upper, np.full(n, np.inf) if problem.ub is None else problem.ub])
    solver = osqp.OSQP()
    try:
        solver.setup(sp.csc_matrix(problem.H), problem.g, A, lower, upper, verbose=False, eps_abs=1e-9, eps_rel=1e-9,
                     max_iter=20000, polishing=True)
    except Exception as e:  # OSQP's own exception type carries only a code
        raise QpSolveFailed(f"OSQP: setup refused the problem ({type(e).__name__} {e}): a cost that is not "
                            "convex, or data it cannot factor") from e
    if warm_start is not None and len(warm_start) == len(problem.g):
        solver.warm_start(x=warm_start)
    res = solver.solve(raise_error=False)  # the status is checked below
    if res.info.status not in ("solved", "solved inaccurate"):
        raise QpSolveFailed(f"OSQP: {res.info.status}")
    return QpSolution(np.asarray(res.x), int(res.info.iter))
