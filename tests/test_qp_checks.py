"""``solve_qp`` refuses what no backend should be given (data that are not finite, bounds that
cross) and what a backend gives that is no solution (an answer outside its own rows), with every
backend; a problem with an analytic answer is solved by each to its answer."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("daqp")
pytest.importorskip("proxsuite")
pytest.importorskip("osqp")

from skatelib.control.qp import SOLVERS, QpProblem, QpSolveFailed, solve_qp

INF = np.inf


def _box(lower: float, upper: float, g: float = -2.0) -> QpProblem:
    """min x^2/2 + x'1 g  s.t. lower <= x0 + x1 <= upper: on the row (x = lower / 2 each) when it binds."""
    return QpProblem(np.eye(2), np.array([g, g]), np.array([[1.0, 1.0]]), np.array([lower]), np.array([upper]))


@pytest.mark.parametrize("solver", SOLVERS)
def test_an_analytic_answer_passes(solver):
    x = solve_qp(_box(-INF, 1.0), solver).x  # unconstrained (2, 2) sums to 4 > 1: on the row
    np.testing.assert_allclose(x, [0.5, 0.5], atol=1e-6)


@pytest.mark.parametrize("solver", SOLVERS)
def test_an_infeasible_problem_is_no_solution(solver):
    """x0 + x1 >= 1 and x0 + x1 <= -1 (two rows, neither crossed on its own): no backend's answer
    is taken, whatever its status says."""
    p = QpProblem(np.eye(2), np.zeros(2), np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([1.0, -INF]),
                  np.array([INF, -1.0]))
    with pytest.raises(QpSolveFailed):
        solve_qp(p, solver)


@pytest.mark.parametrize("solver", SOLVERS)
@pytest.mark.parametrize("where", ["g", "H", "A", "upper", "ub"])
def test_data_that_are_not_finite_or_cross_are_refused_before_the_solve(solver, where):
    """A NaN anywhere, or a variable's bounds crossed: refused at once (ProxQP ran for minutes on a
    NaN, DAQP read a NaN bound as none)."""
    p = _box(-INF, 1.0)
    p.lb, p.ub = np.full(2, -5.0), np.full(2, 5.0)
    if where == "ub":
        p.ub = np.array([5.0, -6.0])  # below lb
    else:
        arr = getattr(p, where).astype(float)
        arr.flat[0] = np.nan
        setattr(p, where, arr)
    with pytest.raises(QpSolveFailed, match=r"not finite|cross"):
        solve_qp(p, solver)


def test_daqp_says_in_words_why_it_stopped():
    """An infeasible pair of rows: DAQP's own flag comes with its meaning."""
    p = QpProblem(np.eye(2), np.zeros(2), np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([1.0, -INF]),
                  np.array([INF, -1.0]))
    with pytest.raises(QpSolveFailed, match=r"DAQP: exit flag -1 \(infeasible"):
        solve_qp(p, "daqp")
