"""Exact Lagrangian Hessians of integrator steps, by the chain rule over the dynamics' evaluations.

A step ``x_next = F(x, u)`` of an explicit scheme (:func:`~skatelib.pipeline.ocp.integrators.steps`)
is linear in ``x`` and in the values ``n_i = f(v_i, u)`` of its evaluations of the dynamics, and
each input ``v_i`` is linear in ``x`` and the earlier values. So the only curvature is the
dynamics' own, and the Hessian of ``lam' F`` with respect to ``w = (x, u)`` is

    H = sum_i T_i' (Hessian of mu_i' f at (v_i, u)) T_i,

``T_i`` the Jacobian of ``(v_i, u)`` with respect to ``w`` and ``mu_i`` the adjoint of ``n_i``
(the reverse sweep: ``mu_i = (dF/dn_i)' lam + sum_{j > i} (dv_j/dn_i)' (df/dv at v_j)' mu_j``).
The same matrix CasADi's forward-over-reverse ``hessian`` of the whole step gives, in about a
fifth fewer operations for the push-off's ETDRK4 in two substeps (docs/design-notes.md); the
stage Hessian is most of an IPOPT iteration's evaluations and of the stage code's compile.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from skatelib.pipeline.ocp.integrators import steps


def step_curvature(kind: str, f: ca.Function, dt: float, substeps: int, L: np.ndarray | None = None) -> ca.Function:
    """``(x, u, lam) -> H``: the Hessian of ``lam' F(x, u)`` with respect to ``(x, u)`` for the step
    ``F`` that :func:`~skatelib.pipeline.ocp.integrators.integrator` builds from the same arguments
    (module docstring), as a symmetric matrix."""
    nx, nu = f.size1_in(0), f.size1_in(1)
    x, u, lam = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("lam", nx)
    inputs: list[Any] = []  # v_i as expressions of (x, u)
    steps(kind, _recording(inputs, lambda v: f(v, u)), x, dt, substeps, L)
    values = [ca.SX.sym(f"n{i}", nx) for i in range(len(inputs))]
    linear_inputs: list[Any] = []  # v_i as (linear) expressions of x and the n_j before it
    given = iter(values)
    out = steps(kind, _recording(linear_inputs, lambda v: next(given)), x, dt, substeps, L)
    v_sym = ca.SX.sym("v", nx)
    f_v = ca.Function("f_v", [v_sym, u], [ca.jacobian(f(v_sym, u), v_sym)])
    mu: list[Any] = [None] * len(values)
    for i in reversed(range(len(values))):
        m = ca.jacobian(out, values[i]).T @ lam
        for j in range(i + 1, len(values)):
            m += ca.jacobian(linear_inputs[j], values[i]).T @ (f_v(inputs[j], u).T @ mu[j])
        mu[i] = m
    weight = ca.SX.sym("mu", nx)
    curv = ca.Function("f_curv", [v_sym, u, weight], [ca.hessian(ca.dot(weight, f(v_sym, u)), ca.vertcat(v_sym, u))[0]])
    w = ca.vertcat(x, u)
    H = ca.SX(nx + nu, nx + nu)
    for v_i, mu_i in zip(inputs, mu, strict=True):
        T = ca.jacobian(ca.vertcat(v_i, u), w)
        H += T.T @ curv(v_i, u, mu_i) @ T
    return ca.Function(f"{kind}_curvature", [x, u, lam], [H], ["x", "u", "lam"], ["hess"])


def _recording(log: list[Any], f: Callable[[Any], Any]) -> Callable[[Any], Any]:
    """``f`` that first appends its argument to ``log``."""

    def call(v: Any) -> Any:
        log.append(v)
        return f(v)

    return call


# Part of the compiled stage code's cache key where a term's rows have a given Hessian: bump when
# the way it is formed changes (the rows themselves are in the key already).
CURVATURE_VERSION = "1"


@dataclass(frozen=True)
class ExactRows:
    """Rows ``[start, stop)`` of a stage's constraints whose Lagrangian Hessian is given. ``make()``
    builds the function ``(z, p, lam) -> H``, H the Hessian of ``lam' cons[start:stop]`` with
    respect to the window ``z``; it is called only where the stage functions are differentiated (a
    build that loads compiled code never calls it). ``tag`` says how H is formed, for the cache keys."""

    start: int
    stop: int
    tag: str
    make: Callable[[], ca.Function]

    def key(self) -> str:
        """What the compiled code depends on besides the rows: which rows, and how."""
        return f"{self.start}:{self.stop}:{self.tag}:{CURVATURE_VERSION}"


def lagrangian_hessian(z: ca.SX, p: ca.SX, lag: tuple[ca.SX, ca.SX], lam: ca.SX, exact: Sequence[ExactRows] = ()
                       ) -> ca.SX:
    """The Hessian of ``sigma cost + lam' cons`` (``lag = (sigma cost, cons)``) with respect to ``z``:
    CasADi's ``hessian`` of all rows but the ``exact`` ones, to which their given Hessians are added,
    on the structural sparsity of the whole (CasADi's propagation through its gradient: a few entries
    more than its ``hessian`` keeps, zero there; the sum's own pattern holds many more). Without
    ``exact``: CasADi's ``hessian`` of the whole, on its own pattern."""
    weighted, cons = lag
    whole = weighted + ca.dot(lam, cons)
    if not exact:
        return ca.hessian(whole, z)[0]
    mask = np.ones(cons.shape[0], dtype=bool)
    for e in exact:
        mask[e.start:e.stop] = False
    rest = np.flatnonzero(mask).tolist()
    H = ca.hessian(weighted + ca.dot(lam[rest], cons[rest]), z)[0]
    for e in exact:
        H += e.make()(z, p, lam[e.start:e.stop])
    return ca.project(H, ca.jacobian_sparsity(ca.gradient(whole, z), z))
