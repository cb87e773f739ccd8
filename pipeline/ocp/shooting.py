"""Direct multiple shooting (Bock and Plitt 1984): one stage per interval; the continuity term
integrates inside it (the push-off's ``DynamicsDefect``: RK4 in ``substeps`` steps).

The decision vector is ``w = [x_0, u_0, x_1, u_1, ..., x_N, u_N]``; ``u_N`` exists only so every
stage sees the same window ``[x_k, u_k, x_{k+1}, u_{k+1}]`` and is fixed to zero by its bounds.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np
from skatelib.pipeline.ocp.stagewise import (
    StagewiseNLP,
    build_stagewise_nlp,
    compiled_stage_functions,
    stage_functions,
)
from skatelib.pipeline.ocp.terms import ConstraintTerm, CostTerm, Stage


@dataclass(frozen=True)
class MultipleShooting:
    """The transcription settings: number of intervals and their length."""

    n_intervals: int
    dt: float


@dataclass(frozen=True)
class Transcribed:
    """A transcribed problem: the NLP, constraint bounds and the row layout of each term."""

    nlp: StagewiseNLP
    lbg: np.ndarray
    ubg: np.ndarray
    row_slices: dict[str, slice]
    rows_per_stage: int
    fingerprint: str  # SHA-256 of the serialized stage function: changes with any cost or constraint term

    def row(self, stage: int, term: str, offset: int = 0) -> int:
        """Index into g (and lbg/ubg) of one row of a term at a stage.

        Raises:
            KeyError: When that row was left out as free.
        """
        full = stage * self.rows_per_stage + self.row_slices[term].start + offset
        pos = int(np.searchsorted(self.nlp.kept_rows, full))
        if pos >= len(self.nlp.kept_rows) or self.nlp.kept_rows[pos] != full:
            raise KeyError(f"row {term}[{offset}] of stage {stage} is free and not in the NLP")
        return pos


def transcribe(method: MultipleShooting, sizes: tuple[int, int, int], costs: Sequence[CostTerm],
               constraints: Sequence[ConstraintTerm], compile_c: bool = False) -> Transcribed:
    """Build the stage function from the terms and assemble the NLP over all intervals; ``sizes``
    is (state, control, stage parameters)."""
    nx, nu, n_params = sizes
    n = nx + nu
    z = ca.SX.sym("z", 2 * n)
    p = ca.SX.sym("p", n_params)
    stage = Stage(x=z[:nx], u=z[nx:n], x_next=z[n:n + nx], u_next=z[n + nx:], p=p, dt=method.dt)
    cost = sum((c.cost(stage) for c in costs), ca.SX(0))
    rows, slices, at = [], {}, 0
    for term in constraints:
        r = term.rows(stage)
        rows.append(r)
        slices[term.name] = slice(at, at + r.shape[0])
        at += r.shape[0]
    cons = ca.vertcat(*rows)
    fns = compiled_stage_functions(z, p, cost, cons) if compile_c else stage_functions(z, p, cost, cons)
    N = method.n_intervals
    lbs, ubs = zip(*(t.bounds(N) for t in constraints), strict=True)
    lbg = np.concatenate(lbs, axis=1).reshape(-1)
    ubg = np.concatenate(ubs, axis=1).reshape(-1)
    keep = np.isfinite(lbg) | np.isfinite(ubg)  # rows free on both sides never reach the solver
    oracle = ca.Function("stage_value", [z, p], [cost, cons])
    nlp = build_stagewise_nlp(fns, N, oracle_value=oracle, keep=keep)
    fingerprint = hashlib.sha256(oracle.serialize().encode()).hexdigest()
    return Transcribed(nlp=nlp, lbg=lbg[keep], ubg=ubg[keep], row_slices=slices,
                       rows_per_stage=cons.shape[0], fingerprint=fingerprint)

