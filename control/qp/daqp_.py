"""DAQP (dense dual active set): the default backend, fastest in ``make bench`` on both QPs."""

from __future__ import annotations

import numpy as np
from skatelib.control.qp import QpProblem, QpSolution, QpSolveFailed

EQUALITY = 5  # DAQP's sense of a row held at equality (active and immutable)
# DAQP's exit flags other than 1 (solved), in words (its constants.h, DAQP_EXIT_*).
FLAGS = {2: "soft optimal", -1: "infeasible: limits that cannot all be met", -2: "cycling", -3: "unbounded",
         -4: "iteration limit", -5: "not convex", -6: "initial working set overdetermined", -7: "time limit",
         -8: "unsupported"}


def solve(problem: QpProblem, warm_start: np.ndarray | None = None) -> QpSolution:
    """Solved cold (DAQP takes no start point); simple bounds go first, as DAQP reads them."""
    import daqp

    A, upper, lower = problem.A, problem.upper, problem.lower
    sense = np.zeros(len(upper), dtype=np.intc)
    if problem.equality is not None:
        sense[problem.equality] = EQUALITY
    if problem.lb is not None or problem.ub is not None:
        n = len(problem.g)
        ub = np.full(n, np.inf) if problem.ub is None else problem.ub
        lb = np.full(n, -np.inf) if problem.lb is None else problem.lb
        upper, lower = np.concatenate([ub, upper]), np.concatenate([lb, lower])
        sense = np.concatenate([np.zeros(n, dtype=np.intc), sense])
    x, _, flag, info = daqp.solve(problem.H, problem.g, A, upper, lower, sense)
    if flag != 1:
        raise QpSolveFailed(f"DAQP: exit flag {flag} ({FLAGS.get(flag, 'unknown')})")
    return QpSolution(np.asarray(x), int(info["iterations"]))
