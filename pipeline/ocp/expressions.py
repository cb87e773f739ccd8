"""One stage's cost and constraint rows as CasADi expressions: what every stage function is
derived from (:mod:`skatelib.pipeline.ocp.stagewise`), and what the compiled code's cache key and
a problem's fingerprint are made of."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
from skatelib.pipeline.ocp.curvature import ExactRows


@dataclass(frozen=True, eq=False)
class StageExpressions:
    """The stage's window ``z`` and parameters ``p`` (symbols), its cost and constraint rows (SX
    expressions of them), and the rows whose Lagrangian Hessian is given (``exact``)."""

    z: ca.SX
    p: ca.SX
    cost: ca.SX
    cons: ca.SX
    exact: tuple[ExactRows, ...] = ()

    @cached_property
    def serialized(self) -> str:
        """The stage value function ``(z, p) -> (cost, cons)`` serialized, made once (some 6 ms for
        the push-off's stage): what determines every stage function, derivatives included."""
        return ca.Function("stage_value", [self.z, self.p], [self.cost, self.cons]).serialize()

    @property
    def key(self) -> str:
        """What the stage's functions and their values depend on: :attr:`serialized`, then which rows
        have a given Hessian and how it is formed (:meth:`ExactRows.key`; formed otherwise, it rounds
        otherwise and gives other iterates). A problem's fingerprint hashes it, and the compiled
        code's cache key starts with it."""
        return self.serialized + "".join(f"|{e.key()}" for e in self.exact)
