"""The controller's quadratic programs (the MPC's and the whole-body QP's) as one solver-neutral
problem, solved by the backend a name picks from one table (as ``qpsolvers`` does; its own layer
measured 2.3x the direct DAQP call on the whole-body QP, about 10 % of a whole-body update, so the
table calls the solvers directly).

A backend module (``daqp_``, ``proxqp_``, ``osqp_``) has ``solve(problem, warm_start) ->
QpSolution`` and is imported when first used, so the table costs nothing to read (the command
line lists its names)."""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # OSQP's problems come sparse; scipy is imported by the backends that use it
    from scipy.sparse import sparray, spmatrix

SOLVERS: dict[str, str] = {
    "daqp": "skatelib.control.qp.daqp_",
    "proxqp": "skatelib.control.qp.proxqp_",
    "osqp": "skatelib.control.qp.osqp_",
}


class QpSolveFailed(RuntimeError):
    """The QP solver did not return a solution, or the problem had none to give: data that are not
    finite, bounds that cross, or an answer outside its own rows (a solver that reports success on
    an infeasible problem)."""


# How far a solution may lie outside a row's bounds: solvers stop at about 1e-6 (DAQP's primal
# tolerance); a force or torque off by more than a tenth of a millinewton is no solution.
ROW_TOLERANCE = 1e-4


@dataclass
class QpProblem:
    """min 1/2 x'Hx + g'x  s.t.  lower <= A x <= upper,  lb <= x <= ub.

    Attributes:
        H: (n, n) the cost's Hessian, symmetric positive definite (dense; or a scipy sparse
            matrix for ``osqp``).
        g: (n,) the cost's gradient.
        A: (m, n) the constraints' rows (dense, or scipy sparse for ``osqp``).
        lower, upper: (m,) their bounds (+-inf or +-1e30: none).
        lb, ub: (n,) the variables' bounds, or None.
        equality: (m,) rows held at ``upper`` (== ``lower``), or None: none.
    """

    H: np.ndarray | spmatrix | sparray
    g: np.ndarray
    A: np.ndarray | spmatrix | sparray
    lower: np.ndarray
    upper: np.ndarray
    lb: np.ndarray | None = None
    ub: np.ndarray | None = None
    equality: np.ndarray | None = None


@dataclass(frozen=True)
class QpSolution:
    """The minimizer and the backend's iteration count."""

    x: np.ndarray
    iterations: int


@functools.cache
def backend(name: str) -> ModuleType:
    """The backend module of ``name``.

    Raises:
        ValueError: An unknown name (the known ones are listed).
    """
    if name not in SOLVERS:
        raise ValueError(f"unknown QP solver {name!r}; choose one of {', '.join(SOLVERS)}")
    return importlib.import_module(SOLVERS[name])


def solve_qp(problem: QpProblem, solver: str = "daqp", warm_start: np.ndarray | None = None) -> QpSolution:
    """Solve ``problem`` with the backend ``solver`` (from ``warm_start`` where the backend uses one).

    Raises:
        QpSolveFailed: The data are not finite or bounds cross (before any solve), the backend
            returned no solution (its status in the message), or its answer leaves its rows by more
            than :data:`ROW_TOLERANCE` (relative beyond 1).
        ValueError: An unknown solver name.
    """
    _check_data(problem, solver)
    solution: QpSolution = backend(solver).solve(problem, warm_start)
    _check_solution(problem, solution.x, solver)
    return solution


def _values(M: Any) -> np.ndarray:
    """A dense matrix's entries, or a sparse one's stored ones."""
    return M if isinstance(M, np.ndarray) else np.asarray(M.data)


def _check_data(p: QpProblem, solver: str) -> None:
    """Refuse a problem no solver should be given: it would hang (ProxQP on NaN), drop a row (a NaN
    bound reads as none) or report a solution of nothing. A few microseconds on the good path."""
    if not np.isfinite(np.concatenate([_values(p.H), p.g, _values(p.A)], axis=None)).all():
        raise QpSolveFailed(f"{solver}: the QP's cost or rows are not finite (a NaN or inf in the state, the "
                            "targets or the model); nothing was solved")
    for name, lo, up in (("rows", p.lower, p.upper), ("variables", p.lb, p.ub)):
        if lo is not None and up is not None and not (lo <= up).all():  # NaN compares False
            bad = int(np.flatnonzero(~(lo <= up))[0])
            raise QpSolveFailed(f"{solver}: the bounds of the QP's {name} cross or are NaN (index {bad}: "
                                f"{lo[bad]} > {up[bad]}): check the limits in the settings and the model")


def _check_solution(p: QpProblem, x: np.ndarray, solver: str) -> None:
    """Refuse an answer that is not finite or lies outside its own rows (by more than
    :data:`ROW_TOLERANCE`, relative beyond 1 to the largest row or variable)."""
    if not np.isfinite(x).all():
        raise QpSolveFailed(f"{solver}: the solution is not finite")
    for name, v, lo, up in (("row", p.A @ x, p.lower, p.upper), ("variable", x, p.lb, p.ub)):
        if lo is None or up is None or not len(v):
            continue
        out = np.maximum(lo - v, v - up)
        if out.max() > ROW_TOLERANCE * (1.0 + np.abs(v).max()):
            i = int(np.argmax(out))
            raise QpSolveFailed(f"{solver}: the answer leaves its {name} {i} ({v[i]:.6g} outside [{lo[i]:.6g}, "
                                f"{up[i]:.6g}]): the QP has no solution (limits that cannot all be met)")
