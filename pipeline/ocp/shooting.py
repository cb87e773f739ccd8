"""Direct multiple shooting (Bock and Plitt 1984): one stage per interval; the continuity term
integrates inside it (the push-off's ``DynamicsDefect``: ETDRK4 or RK4 in ``substeps`` steps).

The decision vector is ``w = [x_0, u_0, x_1, u_1, ..., x_N, u_N]``; ``u_N`` exists only so every
stage sees the same window ``[x_k, u_k, x_{k+1}, u_{k+1}]`` and is fixed to zero by its bounds.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import casadi as ca
import numpy as np
from skatelib.pipeline.ocp.curvature import ExactRows
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.stagewise import (
    PORTABLE_FLAGS,
    CompileTarget,
    StagewiseNLP,
    build_stagewise_nlp,
    compiled_stage_functions,
    stage_functions,
)
from skatelib.pipeline.ocp.terms import ConstraintTerm, CostTerm, GivenHessian, Stage


@dataclass(frozen=True)
class MultipleShooting:
    """The transcription settings: number of intervals and their length, and the threads the stage
    derivatives are evaluated on (:mod:`skatelib.pipeline.ocp.threads`; the same values on any)."""

    n_intervals: int
    dt: float
    threads: int = 1


@dataclass(frozen=True)
class Transcribed:
    """A transcribed problem: the NLP, its constraint bounds and the stage function's fingerprint."""

    nlp: StagewiseNLP
    lbg: np.ndarray
    ubg: np.ndarray
    fingerprint: str  # SHA-256 of the serialized stage function and the rows with a given Hessian


def window_stage(sizes: tuple[int, int, int], dt: float) -> tuple[ca.SX, ca.SX, Stage]:
    """The symbols of one stage's window ``z = [x_k, u_k, x_{k+1}, u_{k+1}]`` and parameters ``p``,
    and the :class:`Stage` the terms see; ``sizes`` is (state, control, stage parameters)."""
    nx, nu, n_params = sizes
    n = nx + nu
    z = ca.SX.sym("z", 2 * n)
    p = ca.SX.sym("p", n_params)
    return z, p, Stage(x=z[:nx], u=z[nx:n], x_next=z[n:n + nx], u_next=z[n + nx:], p=p, dt=dt)


def transcribe(method: MultipleShooting, sizes: tuple[int, int, int], costs: Sequence[CostTerm],
               constraints: Sequence[ConstraintTerm], compile_dir: Path | None = None, native: bool = True
               ) -> Transcribed:
    """Build the stage function from the terms and assemble the NLP over all intervals; ``sizes``
    is (state, control, stage parameters). With ``compile_dir`` the stage functions are compiled to C
    and kept in that folder (:func:`compiled_stage_functions`; ``native``: for this CPU, else
    portable code); without, they run interpreted."""
    z, p, stage = window_stage(sizes, method.dt)
    cost = sum((c.cost(stage) for c in costs), ca.SX(0))
    rows = [term.rows(stage) for term in constraints]
    cons = ca.vertcat(*rows)
    expressions = StageExpressions(z, p, cost, cons, exact_rows(z, p, stage, constraints, rows))
    if compile_dir is not None:
        target = CompileTarget(compile_dir) if native else CompileTarget(compile_dir, PORTABLE_FLAGS)
        fns = compiled_stage_functions(expressions, target)
    else:
        fns = stage_functions(expressions)
    N = method.n_intervals
    lbs, ubs = zip(*(t.bounds(N) for t in constraints), strict=True)
    lbg = np.concatenate(lbs, axis=1).reshape(-1)
    ubg = np.concatenate(ubs, axis=1).reshape(-1)
    keep = np.isfinite(lbg) | np.isfinite(ubg)  # rows free on both sides never reach the solver
    nlp = build_stagewise_nlp(fns, N, keep=keep, threads=method.threads)
    return Transcribed(nlp=nlp, lbg=lbg[keep], ubg=ubg[keep],
                       fingerprint=hashlib.sha256(expressions.key.encode()).hexdigest())


def exact_rows(z: ca.SX, p: ca.SX, stage: Stage, constraints: Sequence[ConstraintTerm], rows: Sequence[ca.SX]
               ) -> tuple[ExactRows, ...]:
    """The rows of the terms that give their own Lagrangian Hessian
    (:class:`~skatelib.pipeline.ocp.terms.GivenHessian` with a tag, as
    :class:`~skatelib.pipeline.quadruped.problem.terms.DynamicsDefect` with a curvature is)."""
    out, start = [], 0
    for term, r in zip(constraints, rows, strict=True):
        if isinstance(term, GivenHessian) and term.hessian_tag is not None:
            make = partial(_given_hessian, term, z, p, stage, r.shape[0])
            out.append(ExactRows(start, start + r.shape[0], term.hessian_tag, make))
        start += r.shape[0]
    return tuple(out)


def _given_hessian(term: GivenHessian, z: ca.SX, p: ca.SX, stage: Stage, n_rows: int) -> ca.Function:
    """``(z, p, lam) ->`` the term's Hessian over the window: ``J' H J``, J the selection of its
    variables ``v`` from ``z``."""
    lam = ca.SX.sym("lam", n_rows)
    H, v = term.hessian(stage, lam)
    J = ca.jacobian(v, z)
    return ca.Function(f"{getattr(term, 'name', 'term')}_hess", [z, p, lam], [J.T @ H @ J])
