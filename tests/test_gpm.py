"""Gauss pseudospectral transcription: nodes, weights, D, quadrature and an analytic optimum."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.pipeline.ocp.gpm import GaussPseudospectral, collocation_defects, terminal_state


@pytest.mark.parametrize("n", [1, 2, 5, 10, 20])
def test_nodes_and_weights_match_numpy_leggauss(n):
    """Roots of P_N and Eq. (7) weights equal numpy's Gauss-Legendre rule."""
    g = GaussPseudospectral(n)
    x, w = np.polynomial.legendre.leggauss(n)
    assert np.allclose(g.tau, x, atol=1e-14) and np.allclose(g.weights, w, atol=1e-14)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 14), seed=st.integers(0, 10_000))
def test_quadrature_is_exact_to_degree_2n_minus_1(n, seed):
    """sum w_k p(tau_k) = integral of p over [-1, 1] for random polynomials of degree 2N - 1."""
    g = GaussPseudospectral(n)
    c = np.random.default_rng(seed).normal(size=2 * n)
    p = np.polynomial.Polynomial(c)
    exact = p.integ()(1.0) - p.integ()(-1.0)
    assert abs(g.weights @ p(g.tau) - exact) < 1e-11 * max(1.0, np.abs(c).sum())


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 14), seed=st.integers(0, 10_000))
def test_differentiation_matrix_is_exact_to_degree_n(n, seed):
    """D applied to p at the support points gives p' at the LG nodes for degree-N polynomials."""
    g = GaussPseudospectral(n)
    p = np.polynomial.Polynomial(np.random.default_rng(seed).normal(size=n + 1))
    assert np.allclose(g.D @ p(g.support), p.deriv()(g.tau), atol=1e-9)


@pytest.mark.parametrize("n", [4, 6, 10])
def test_minimum_acceleration_double_integrator_matches_analytic(n):
    """min int a^2 dt, x(0) = v(0) = 0, x(T) = 1, v(T) = 0: the GPM optimum equals the cubic
    x(t) = 3 (t/T)^2 - 2 (t/T)^3 to 1e-9 at every node, and the cost equals 12 / T^3."""
    g = GaussPseudospectral(n)
    T = 1.3
    X = ca.SX.sym("X", n + 1, 2)
    U = ca.SX.sym("U", n, 1)
    F = ca.horzcat(X[1:, 1], U)
    xf = terminal_state(g, X[0, :], F, 0.0, T)
    g_eq = ca.vertcat(ca.vec(collocation_defects(g, X, F, 0.0, T)), X[0, :].T, xf.T - ca.DM([1.0, 0.0]))
    J = T / 2 * ca.dot(ca.DM(g.weights), U**2)
    w = ca.vertcat(ca.vec(X), U)
    solver = ca.nlpsol("s", "ipopt", {"x": w, "f": J, "g": g_eq},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "ipopt.tol": 1e-14})
    sol = solver(x0=0, lbg=0, ubg=0)
    Xs = np.asarray(sol["x"][: 2 * (n + 1)]).reshape(2, n + 1).T
    s = g.times(0.0, T, g.support) / T
    assert np.allclose(Xs[:, 0], 3 * s**2 - 2 * s**3, atol=1e-9)
    assert np.allclose(Xs[:, 1], (6 * s - 6 * s**2) / T, atol=1e-9)
    assert float(sol["f"]) == pytest.approx(12 / T**3, rel=1e-9)
