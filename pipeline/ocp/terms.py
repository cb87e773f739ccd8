"""Optimal-control problem statement: a stage context and cost/constraint terms.

A transcription (here :mod:`skatelib.pipeline.ocp.shooting`) gives each term a :class:`Stage`
holding the symbolic state and control of knots k and k+1 and the stage parameters; cost terms
return a scalar, constraint terms a column of expressions plus per-stage bounds. Bound terms box
columns of the knot vector ``(x_k, u_k)``; :func:`variable_bounds` intersects them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

INF = np.inf


@dataclass(frozen=True)
class Stage:
    """Symbols of one stage: knot k (x, u) and knot k+1 (x_next, u_next), and parameters p."""

    x: Any
    u: Any
    x_next: Any
    u_next: Any
    p: Any
    dt: float


class CostTerm(Protocol):
    """A contribution to the stage cost (already multiplied by the stage length)."""

    @property
    def name(self) -> str: ...

    def cost(self, s: Stage) -> Any: ...


class ConstraintTerm(Protocol):
    """Rows of stage constraints with per-stage bounds.

    ``bounds`` returns two (n_stages, rows) arrays: lower and upper bounds per stage.
    """

    @property
    def name(self) -> str: ...

    def rows(self, s: Stage) -> Any: ...

    def bounds(self, n_stages: int) -> tuple[np.ndarray, np.ndarray]: ...


@runtime_checkable
class GivenHessian(Protocol):
    """A constraint term that gives its rows' Lagrangian Hessian (where it has a cheaper form than
    CasADi's differentiation of the rows). ``hessian_tag`` says how it is formed (None: it gives
    none); ``hessian(s, lam)`` returns ``(H, v)``: the Hessian of ``lam' rows(s)`` with respect to
    ``v``, a column of the stage's symbols (the rows linear in the others), e.g. ``(x_k, u_k)``."""

    @property
    def hessian_tag(self) -> str | None: ...

    def hessian(self, s: Stage, lam: Any) -> tuple[Any, Any]: ...


def fixed(n_stages: int, rows: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds that are the same at every stage."""
    return np.full((n_stages, rows), lo), np.full((n_stages, rows), hi)


class BoundTerm(Protocol):
    """Box bounds on a contiguous run of columns of the knot vector ``(x_k, u_k)``.

    ``bounds`` returns two (n_knots, width) arrays; +-inf where the term says nothing.
    """

    @property
    def name(self) -> str: ...

    @property
    def columns(self) -> slice: ...

    def bounds(self, n_knots: int) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class Box:
    """``lo <= w[knots, columns] <= hi``; ``lo``/``hi`` scalars or one value per column."""

    name: str
    columns: slice
    lo: Any
    hi: Any
    knots: slice | None = None  # all knots

    def bounds(self, n_knots: int) -> tuple[np.ndarray, np.ndarray]:
        width = self.columns.stop - self.columns.start
        lo, hi = np.full((n_knots, width), -INF), np.full((n_knots, width), INF)
        at = slice(None) if self.knots is None else self.knots
        lo[at], hi[at] = self.lo, self.hi
        return lo, hi


def variable_bounds(terms: list[Any], n_knots: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The intersection of the bound terms' boxes, flattened knot by knot (row-major (K, width)).

    Raises:
        ValueError: When a term's box does not meet the earlier terms' (names the term and knots).
    """
    lo, hi = np.full((n_knots, width), -INF), np.full((n_knots, width), INF)
    for term in terms:
        t_lo, t_hi = term.bounds(n_knots)
        c = term.columns
        lo[:, c], hi[:, c] = np.maximum(lo[:, c], t_lo), np.minimum(hi[:, c], t_hi)
        empty = np.flatnonzero((lo[:, c] > hi[:, c]).any(axis=1))
        if empty.size:
            raise ValueError(f"bound term {term.name!r} leaves no value at knots {empty.tolist()[:5]} "
                             f"(columns {c.start}:{c.stop}): it conflicts with an earlier bound")
    return lo.reshape(-1), hi.reshape(-1)
