"""One-interval integrators for multiple shooting, as CasADi functions ``x_next = F(x, u)``.

* ``rk4``: classic Runge-Kutta, ``substeps`` equal steps per interval.
* ``etdrk4``: the exponential time-differencing RK4 of Cox and Matthews (J. Comput. Phys. 176,
  2002) for ``dx/dt = L x + N(x, u)``. The stiff linear part ``L`` (here the deck's roll
  spring-damper, Eq. 6-7, eigenvalues near -64 1/s with the default board) is integrated exactly through matrix
  phi-functions; the rest is fourth order. Where ``L`` is zero it is exactly classic RK4, so it
  costs the same four evaluations of the dynamics per step.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg


def rk4(f: Callable[[Any], Any], x: Any, h: float, substeps: int = 1) -> Any:
    """Classic fourth-order Runge-Kutta of ``dx/dt = f(x)`` over ``h`` seconds in ``substeps`` steps."""
    dt = h / substeps
    for _ in range(substeps):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def phi_functions(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``exp(A)`` and ``phi_1..3(A)`` with ``phi_k(A) = A^-1 (phi_{k-1}(A) - I/(k-1)!)``, from one
    matrix exponential of an augmented block matrix (exact also for singular ``A``)."""
    n = A.shape[0]
    M = np.zeros((4 * n, 4 * n))
    M[:n, :n] = A
    for k in range(3):
        M[k * n:(k + 1) * n, (k + 1) * n:(k + 2) * n] = np.eye(n)
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:2 * n], E[:n, 2 * n:3 * n], E[:n, 3 * n:]


def _const(M: np.ndarray) -> ca.DM:
    """A constant matrix with exact zeros made structural, so SX products skip them."""
    M = np.where(np.abs(M) < 1e-300, 0.0, M)
    return ca.sparsify(ca.DM(M))


def etdrk4_step(f: Callable[[Any], Any], L: np.ndarray, x: Any, h: float) -> Any:
    """One ETDRK4 step of ``dx/dt = f(x)`` over ``h``, treating ``L x`` exactly."""
    e_full, P1, P2, P3 = phi_functions(h * L)
    e_half, q_half, _, _ = phi_functions(h / 2 * L)
    Lc = _const(L)

    def nonlinear(v: Any) -> Any:
        return f(v) - Lc @ v

    E, E2, Q1 = _const(e_full), _const(e_half), _const(q_half)
    B1, B2, B4 = _const(P1 - 3 * P2 + 4 * P3), _const(2 * P2 - 4 * P3), _const(4 * P3 - P2)
    Nx = nonlinear(x)
    a = E2 @ x + h / 2 * (Q1 @ Nx)
    Na = nonlinear(a)
    b = E2 @ x + h / 2 * (Q1 @ Na)
    Nb = nonlinear(b)
    c = E2 @ a + h / 2 * (Q1 @ (2 * Nb - Nx))
    Nc = nonlinear(c)
    return E @ x + h * (B1 @ Nx + B2 @ (Na + Nb) + B4 @ Nc)


def steps(kind: str, f: Callable[[Any], Any], x: Any, dt: float, substeps: int, L: np.ndarray | None = None) -> Any:
    """``x`` advanced over ``dt`` in ``substeps`` steps of the named scheme for ``dx/dt = f(x)``;
    ``f`` is called once per evaluation of the dynamics, in the order the scheme evaluates them.

    Raises:
        ValueError: For an unknown scheme, or ``etdrk4`` without a linear part.
    """
    if kind == "rk4":
        return rk4(f, x, dt, substeps)
    if kind != "etdrk4":
        raise ValueError(f"unknown integrator {kind!r}; use 'rk4' or 'etdrk4'")
    if L is None:
        raise ValueError("etdrk4 needs the linear part L")
    for _ in range(substeps):
        x = etdrk4_step(f, L, x, dt / substeps)
    return x


def integrator(kind: str, f: ca.Function, dt: float, substeps: int, L: np.ndarray | None = None) -> ca.Function:
    """``x_next = F(x, u)`` over ``dt`` in ``substeps`` steps of the named scheme (:func:`steps`),
    for the dynamics ``f(x, u)`` (its input sizes are the state's and the control's)."""
    x, u = ca.SX.sym("x", f.size1_in(0)), ca.SX.sym("u", f.size1_in(1))
    return ca.Function(kind, [x, u], [steps(kind, lambda v: f(v, u), x, dt, substeps, L)])
