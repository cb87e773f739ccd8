"""The integrator step's Hessian by the chain rule against CasADi's own automatic differentiation
of the whole step: on a toy system with curvature in state, control and their products, and on the
push-off's stage Lagrangian (the SRB-on-a-board dynamics under ETDRK4 in two substeps)."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.ocp.curvature import step_curvature
from skatelib.pipeline.ocp.expressions import StageExpressions
from skatelib.pipeline.ocp.integrators import integrator, steps
from skatelib.pipeline.ocp.shooting import exact_rows, window_stage
from skatelib.pipeline.ocp.stagewise import stage_functions


def _toy() -> tuple[ca.Function, np.ndarray]:
    """A damped pendulum on a cart with a stiff linear part: sin, products of state and control."""
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 2)
    xdot = ca.vertcat(x[2], x[3], u[0] * ca.cos(x[1]) - 0.3 * x[2] * x[3] ** 2,
                      -9.81 * ca.sin(x[1]) + u[1] * x[0] - 60.0 * x[1] - 4.0 * x[3] + ca.tanh(u[0] * u[1]))
    L = np.zeros((4, 4))
    L[3, 1], L[3, 3] = -60.0, -4.0
    return ca.Function("f", [x, u], [xdot]), L


def _ad_hessian(F: ca.Function) -> ca.Function:
    x, u, lam = ca.SX.sym("x", F.size1_in(0)), ca.SX.sym("u", F.size1_in(1)), ca.SX.sym("lam", F.size1_out(0))
    return ca.Function("H", [x, u, lam], [ca.hessian(ca.dot(lam, F(x, u)), ca.vertcat(x, u))[0]])


def _largest_relative_gap(A: ca.Function, B: ca.Function, n_points: int = 8) -> float:
    rng = np.random.default_rng(3)
    gaps = []
    for _ in range(n_points):
        args = [rng.normal(size=A.size1_in(i)) for i in range(3)]
        a, b = np.array(A(*args)), np.array(B(*args))
        gaps.append(np.abs(a - b).max() / np.abs(b).max())
    return max(gaps)


def _without_propagation(kind: str, f: ca.Function, dt: float, substeps: int, L: np.ndarray) -> ca.Function:
    """A wrong chain rule: each evaluation weighted only by how the step's end reads it directly,
    not through the evaluations after it (the adjoint recursion cut short)."""
    nx, nu = f.size1_in(0), f.size1_in(1)
    x, u, lam = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("lam", nx)
    inputs: list = []
    steps(kind, lambda v: (inputs.append(v), f(v, u))[1], x, dt, substeps, L)
    symbols = [ca.SX.sym(f"n{i}", nx) for i in range(len(inputs))]
    given = iter(symbols)
    out = steps(kind, lambda v: next(given), x, dt, substeps, L)
    v_sym, weight = ca.SX.sym("v", nx), ca.SX.sym("mu", nx)
    curv = ca.Function("curv", [v_sym, u, weight], [ca.hessian(ca.dot(weight, f(v_sym, u)), ca.vertcat(v_sym, u))[0]])
    w, H = ca.vertcat(x, u), ca.SX(nx + nu, nx + nu)
    for v, n in zip(inputs, symbols, strict=True):
        T = ca.jacobian(ca.vertcat(v, u), w)
        H += T.T @ curv(v, u, ca.jacobian(out, n).T @ lam) @ T
    return ca.Function("wrong", [x, u, lam], [H])


@pytest.mark.parametrize(("kind", "substeps"), [("rk4", 1), ("rk4", 3), ("etdrk4", 1), ("etdrk4", 2)])
def test_the_chain_rule_gives_the_steps_hessian(kind, substeps):
    """Equal to CasADi's forward-over-reverse Hessian of the whole step to rounding; the same sum
    with the adjoints cut short (each evaluation weighted only as the step's end reads it) differs
    from it by a tenth or more: the toy's evaluations do feed each other."""
    f, L = _toy()
    F = integrator(kind, f, 0.04, substeps, L)
    assert _largest_relative_gap(step_curvature(kind, f, 0.04, substeps, L), _ad_hessian(F)) < 1e-12
    assert _largest_relative_gap(_without_propagation(kind, f, 0.04, substeps, L), _ad_hessian(F)) > 1e-3


def test_the_push_off_stage_hessian_is_the_same_with_the_chain_rule(cfg):
    """The push-off's stage Lagrangian Hessian with the dynamics rows' given Hessian equals the one
    CasADi differentiates from the rows, at guess-like windows with random multipliers, and keeps
    every entry that one has (a few more, zero: the structural pattern of the whole)."""
    from skatelib.library.channels import NU
    from skatelib.pipeline.quadruped.problem.knots import N_PARAMS, NXA
    from skatelib.pipeline.quadruped.problem.problem import PushoffProblem

    interp = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))
    prob = PushoffProblem(interp, 1)
    z, p, stage = window_stage((NXA, NU, N_PARAMS), interp.optimization.dt_s)
    cost = sum((c.cost(stage) for c in prob.costs), ca.SX(0))
    rows = [t.rows(stage) for t in prob.constraints]
    cons = ca.vertcat(*rows)
    exact = exact_rows(z, p, stage, prob.constraints, rows)
    assert [(e.start, e.stop, e.tag) for e in exact] == [(0, NXA, "step chain rule")]
    chain = stage_functions(StageExpressions(z, p, cost, cons, exact)).hess
    plain = stage_functions(StageExpressions(z, p, cost, cons)).hess
    sp_chain, sp_plain = chain.sparsity_out(0), plain.sparsity_out(0)
    assert sp_chain.nnz() - sp_plain.nnz() < 0.02 * sp_plain.nnz()
    assert (sp_chain + sp_plain) == sp_chain  # every entry CasADi keeps is kept
    rng = np.random.default_rng(5)
    W = prob.initial_guess(0.0, 0.4, "ramp").reshape(-1, prob.n)
    P = prob.parameters(0.0, 0.4).reshape(-1, N_PARAMS)
    for k in range(0, len(W) - 1, 9):
        args = (np.concatenate([W[k], W[k + 1]]) + 0.03 * rng.normal(size=2 * prob.n), P[k], 0.8,
                rng.normal(size=cons.shape[0]))
        a, b = np.array(chain(*args)), np.array(plain(*args))
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
