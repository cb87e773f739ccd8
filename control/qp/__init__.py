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
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # OSQP's problems come sparse; scipy is imported by the backends that use it
    from scipy.sparse import sparray, spmatrix

SOLVERS: dict[str, str] = {
    "daqp": "skatelib.control.qp.daqp_",
    "proxqp": "skatelib.control.qp.proxqp_",
    "osqp": "skatelib.control.qp.osqp_",
}


class QpSolveFailed(RuntimeError):
    """The QP solver did not return a solution."""


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
        QpSolveFailed: The backend returned no solution (its status in the message).
        ValueError: An unknown solver name.
    """
    solution: QpSolution = backend(solver).solve(problem, warm_start)
    return solution
