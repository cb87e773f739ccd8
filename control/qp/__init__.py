"""The MPC's QP backends behind one table: a name -> the module whose ``Solver`` solves an
:class:`skatelib.control.mpc.MpcProblem` (its force part; the joint part comes solved). A module
is imported when its solver is made, so the table costs nothing to read (the command line lists
its names)."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from skatelib.control.mpc import MpcProblem

SOLVERS: dict[str, str] = {
    "daqp": "skatelib.control.qp.daqp_",
    "proxqp": "skatelib.control.qp.proxqp_",
    "osqp": "skatelib.control.qp.osqp_",
}


class QpSolveFailed(RuntimeError):
    """The QP solver did not return a solution."""


class QpSolver(Protocol):
    """A backend: the controls U (N x 24, flattened) of one update's problem."""

    def solve(self, qp: MpcProblem) -> np.ndarray: ...


def make_solver(name: str) -> QpSolver:
    """A new solver of the backend ``name`` (one per closed loop: some keep warm starts).

    Raises:
        ValueError: An unknown name (the known ones are listed).
    """
    if name not in SOLVERS:
        raise ValueError(f"unknown QP solver {name!r}; choose one of {', '.join(SOLVERS)}")
    solver: QpSolver = importlib.import_module(SOLVERS[name]).Solver()
    return solver
