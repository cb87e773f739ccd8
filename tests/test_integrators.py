"""Integrators: ETDRK4 is exact on linear systems, equals RK4 without a linear part, and is
fourth order on the full skateboard dynamics."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import scipy.linalg
from skatelib.pipeline.ocp.integrators import integrator, phi_functions
from skatelib.pipeline.quadruped.model.dynamics import dynamics_function, modes_for, rk4_step


def test_phi_functions_satisfy_their_recurrence():
    """phi_1 = A^-1 (e^A - I), phi_2 = A^-1 (phi_1 - I), phi_3 = A^-1 (phi_2 - I/2) for invertible A."""
    A = np.array([[0.0, 0.03], [-250.0, -5.5]])
    E, p1, p2, p3 = phi_functions(A)
    I = np.eye(2)
    assert np.allclose(E, scipy.linalg.expm(A))
    assert np.allclose(A @ p1, E - I) and np.allclose(A @ p2, p1 - I) and np.allclose(A @ p3, p2 - I / 2)


def test_etdrk4_is_exact_for_a_forced_linear_oscillator():
    """x' = L x + b (constant b): one ETDRK4 step of 0.03 s equals the closed-form solution."""
    L = np.array([[0.0, 1.0], [-8421.0, -183.5]])
    bvec = np.array([0.0, 120.0])
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u", 0)
    f = ca.Function("f", [x, u], [ca.DM(L) @ x + ca.DM(bvec)])
    F = integrator("etdrk4", f, 0.03, 1, L)
    x0 = np.array([0.05, -1.0])
    E, p1, _, _ = phi_functions(0.03 * L)
    exact = E @ x0 + 0.03 * p1 @ bvec
    assert np.allclose(np.asarray(F(x0, [])).reshape(-1), exact, atol=1e-12)


def test_etdrk4_without_linear_part_is_classic_rk4(system):
    """With L = 0 the scheme reduces to classic RK4 (Cox-Matthews)."""
    f = dynamics_function(system, modes_for(system.push_leg)["accelerating"])
    x, u = ca.SX.sym("x", 28), ca.SX.sym("u", 24)
    fx = ca.Function("fx", [x, u], [f(x, u, ca.DM(system.stance.cr))])
    E = integrator("etdrk4", fx, 0.03, 1, np.zeros((28, 28)))
    R = integrator("rk4", fx, 0.03, 1)
    rng = np.random.default_rng(5)
    x0 = np.concatenate([[0, 0, 0.3], rng.uniform(-0.2, 0.2, 9), system.stance.q_board, [0.3, 0, 0.01, 0.1]])
    u0 = rng.uniform(-20, 20, 24)
    assert np.allclose(np.asarray(E(x0, u0)), np.asarray(R(x0, u0)), atol=1e-12)


@pytest.mark.parametrize("kind", ["etdrk4"])
def test_fourth_order_convergence_on_skateboard_dynamics(system, kind):
    """Halving the step divides the error against a 400-step RK4 reference by about 16."""
    f = dynamics_function(system, modes_for(system.push_leg)["accelerating"])
    cr = ca.DM(system.stance.cr)
    x, u = ca.SX.sym("x", 28), ca.SX.sym("u", 24)
    fx = ca.Function("fx", [x, u], [f(x, u, cr)])
    L = system.stiff_linear_part(28)
    x0 = np.concatenate([[0, 0, 0.3], [0.05, -0.03, 0.1], [0.2, 0, 0], [0.3, -0.2, 0.1],
                         system.stance.q_board, [0.3, 0, 0.02, 0.3]])
    u0 = np.concatenate([[3, 1, 25, -2, 1, 20, 0, 0, 0, 1, -1, 30], np.full(12, 0.5)])
    T = 0.12
    ref = np.asarray(rk4_step(f, ca.DM(x0), ca.DM(u0), cr, T, 400)).reshape(-1)
    errs = [float(np.abs(np.asarray(integrator(kind, fx, T, n, L)(x0, u0)).reshape(-1) - ref).max())
            for n in (2, 4)]
    assert 10 < errs[0] / errs[1] < 24, errs
