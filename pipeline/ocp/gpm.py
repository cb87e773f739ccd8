"""Gauss pseudospectral transcription (Benson et al. 2006; humanoid paper Sec. III-A, Eq. 1-9).

Time t in [t0, tf] maps to tau in [-1, 1] (Eq. 2). The state is a Lagrange polynomial through
tau_0 = -1 and the N Legendre-Gauss (LG) nodes tau_1..tau_N (Eq. 4-5); the control lives on the
LG nodes. Dynamics are collocated at the LG nodes with the differentiation matrix D (Eq. 8-9),
and the terminal state follows by Gauss quadrature (Eq. 6-7), exact for polynomials of degree
2N - 1. Any problem of the pipeline can use it: :func:`collocation_defects` and
:func:`terminal_state` take CasADi or numpy arrays.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.polynomial import legendre as npleg


def lg_nodes(n: int) -> np.ndarray:
    """The N Legendre-Gauss nodes: roots of P_N (Eq. 3), ascending."""
    if n < 1:
        raise ValueError(f"need at least one node, got {n}")
    coeffs = np.zeros(n + 1)
    coeffs[n] = 1.0
    roots = np.sort(npleg.legroots(coeffs).real)
    # One Newton polish on P_N for full double precision.
    dcoeffs = npleg.legder(coeffs)
    return roots - npleg.legval(roots, coeffs) / npleg.legval(roots, dcoeffs)


def lg_weights(nodes: np.ndarray) -> np.ndarray:
    """Gauss quadrature weights w_i = 2 / ((1 - tau_i^2) P_N'(tau_i)^2) (Eq. 7)."""
    n = len(nodes)
    coeffs = np.zeros(n + 1)
    coeffs[n] = 1.0
    dp = npleg.legval(nodes, npleg.legder(coeffs))
    return 2.0 / ((1.0 - nodes**2) * dp**2)


def lagrange_basis(points: np.ndarray, tau: np.ndarray | float) -> np.ndarray:
    """L_i(tau) for the polynomials through ``points`` (Eq. 5): shape (len(tau), len(points))."""
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    m = len(points)
    out = np.ones((len(tau), m))
    for i in range(m):
        for j in range(m):
            if j != i:
                out[:, i] *= (tau - points[j]) / (points[i] - points[j])
    return out


def differentiation_matrix(points: np.ndarray, at: np.ndarray) -> np.ndarray:
    """D_ki = dL_i/dtau(at_k) for the Lagrange basis through ``points`` (Eq. 9)."""
    m = len(points)
    D = np.zeros((len(at), m))
    for k, t in enumerate(at):
        for i in range(m):
            total = 0.0
            for l in range(m):
                if l == i:
                    continue
                prod = 1.0 / (points[i] - points[l])
                for j in range(m):
                    if j not in (i, l):
                        prod *= (t - points[j]) / (points[i] - points[j])
                total += prod
            D[k, i] = total
    return D


@dataclass(frozen=True)
class GaussPseudospectral:
    """The GPM with N LG nodes: nodes, weights, state support points and D."""

    n_nodes: int

    @cached_property
    def tau(self) -> np.ndarray:
        """LG nodes tau_1..tau_N."""
        return lg_nodes(self.n_nodes)

    @cached_property
    def weights(self) -> np.ndarray:
        return lg_weights(self.tau)

    @cached_property
    def support(self) -> np.ndarray:
        """State support points tau_0 = -1, tau_1..tau_N."""
        return np.concatenate([[-1.0], self.tau])

    @cached_property
    def D(self) -> np.ndarray:  # noqa: N802 - the paper's name
        """(N, N+1) differentiation matrix at the LG nodes (Eq. 9)."""
        return differentiation_matrix(self.support, self.tau)

    def times(self, t0: float, tf: float, tau: np.ndarray | None = None) -> np.ndarray:
        """Physical times of ``tau`` (the LG nodes by default), Eq. (2)."""
        tau = self.tau if tau is None else tau
        return (tf - t0) / 2.0 * np.asarray(tau) + (tf + t0) / 2.0

    def to_tau(self, t: np.ndarray, t0: float, tf: float) -> np.ndarray:
        return (2.0 * np.asarray(t) - (tf + t0)) / (tf - t0)

    def interpolate_state(self, X: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """State at ``tau`` from its values at the support points, Eq. (4). X: (N+1, nx)."""
        return lagrange_basis(self.support, tau) @ X

    def interpolate_control(self, U: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Control at ``tau`` from its values at the LG nodes (degree N-1 polynomial)."""
        return lagrange_basis(self.tau, tau) @ U


def collocation_defects(gpm: GaussPseudospectral, X: Any, F: Any, t0: Any, tf: Any) -> Any:
    """Eq. (8): D X - (tf - t0)/2 F at the LG nodes. X: (N+1, nx) at the support points,
    F: (N, nx) dynamics at the LG nodes."""
    return gpm.D @ X - (tf - t0) / 2.0 * F


def terminal_state(gpm: GaussPseudospectral, x0: Any, F: Any, t0: Any, tf: Any) -> Any:
    """Eq. (6): X_f = X_0 + (tf - t0)/2 sum_k w_k f(X_k, U_k). F: (N, nx); x0: (1, nx)."""
    return x0 + (tf - t0) / 2.0 * (gpm.weights.reshape(1, -1) @ F)
