"""Optimal-control problem statement: a stage context and cost/constraint terms.

A transcription (here :mod:`skatelib.pipeline.ocp.shooting`) gives each term a :class:`Stage`
holding the symbolic state and control of knots k and k+1 and the stage parameters; cost terms
return a scalar, constraint terms a column of expressions plus per-stage bounds.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


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


def fixed(n_stages: int, rows: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds that are the same at every stage."""
    return np.full((n_stages, rows), lo), np.full((n_stages, rows), hi)
