"""Kajita's preview control of the ZMP (Kajita et al., ICRA 2003, the paper's [13]) and the dynamics
filter of the humanoid pipeline (the paper's Fig. 5): the cart-table model, its optimal preview
servo gains, and the correction of a centre-of-mass reference that brings the multibody ZMP of
a whole-body motion to the planned one.

Cart-table, per horizontal axis, with the jerk u as input (time step ``dt``, COM height ``zc``)::

    x_{k+1} = A x_k + B u_k,  x = (c, c', c''),   p_k = C x_k = c_k - zc / g c''_k

The servo (Katayama's form, as Kajita uses it) minimizes sum Qe e_k^2 + dx_k' Qx dx_k + R du_k^2
with e = p - p_ref on the system augmented by the summed error; its Riccati solution P gives

    u_k = -Gi sum_{i<=k} e_i - Gx x_k - sum_{j=1..N} Gd_j p_ref_{k+j}.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CartTable:
    """The discrete cart-table model of one axis."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray

    @staticmethod
    def of(dt: float, zc: float, g: float = 9.81) -> CartTable:
        A = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        B = np.array([[dt**3 / 6], [dt * dt / 2], [dt]])
        return CartTable(A, B, np.array([[1.0, 0.0, -zc / g]]))


@dataclass(frozen=True)
class PreviewGains:
    """Gi (summed error), Gx (state, (3,)), Gd (preview, (N,)) and the Riccati solution P (4, 4)."""

    Gi: float
    Gx: np.ndarray
    Gd: np.ndarray
    P: np.ndarray


def riccati(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, iterations: int = 100_000,
            tol: float = 1e-13) -> np.ndarray:
    """The discrete algebraic Riccati equation's stabilizing solution by fixed-point iteration
    (P = Q + A' P A - A' P B (R + B' P B)^-1 B' P A, from P = Q)."""
    P = Q.copy()
    for _ in range(iterations):
        BP = B.T @ P
        nxt = Q + A.T @ P @ A - A.T @ P @ B @ np.linalg.solve(R + BP @ B, BP @ A)
        if np.max(np.abs(nxt - P)) <= tol * max(1.0, np.max(np.abs(P))):
            return nxt
        P = nxt
    raise RuntimeError("the preview controller's Riccati iteration did not converge")


def preview_gains(model: CartTable, n_preview: int, Qe: float = 1.0, Qx: float = 0.0, R: float = 1e-6) -> PreviewGains:
    """The optimal preview servo's gains for ``n_preview`` steps of the reference ahead."""
    A, B, C = model.A, model.B, model.C
    At = np.block([[np.ones((1, 1)), C @ A], [np.zeros((3, 1)), A]])
    Bt = np.vstack([C @ B, B])
    It = np.array([[1.0], [0.0], [0.0], [0.0]])
    Ft = np.vstack([C @ A, A])
    Q = np.diag([Qe, Qx, Qx, Qx])
    Rm = np.array([[R]])
    P = riccati(At, Bt, Q, Rm)
    K = np.linalg.inv(Rm + Bt.T @ P @ Bt)
    Gi = float((K @ Bt.T @ P @ It)[0, 0])
    Gx = (K @ Bt.T @ P @ Ft)[0]
    Ac = At - Bt @ K @ Bt.T @ P @ At
    X = -Ac.T @ P @ It
    Gd = np.empty(n_preview)
    Gd[0] = -Gi
    for j in range(1, n_preview):
        Gd[j] = float((K @ Bt.T @ X)[0, 0])
        X = Ac.T @ X
    return PreviewGains(Gi, Gx, Gd, P)


def track(model: CartTable, gains: PreviewGains, p_ref: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
    """Run the preview servo along the reference ZMP ``p_ref`` (K,) (held at its last value
    beyond its end): the cart's states (K, 3) (position, velocity, acceleration)."""
    K, N = len(p_ref), len(gains.Gd)
    ahead = np.concatenate([p_ref, np.full(N, p_ref[-1])])
    x = np.zeros(3) if x0 is None else np.asarray(x0, dtype=np.float64).copy()
    out = np.empty((K, 3))
    summed = 0.0
    for k in range(K):
        out[k] = x
        summed += float(model.C[0] @ x) - p_ref[k]
        u = -gains.Gi * summed - gains.Gx @ x - gains.Gd @ ahead[k + 1:k + 1 + N]
        x = model.A @ x + model.B[:, 0] * u
    return out


def track_offset(model: CartTable, gains: PreviewGains, p_ref: np.ndarray) -> np.ndarray:
    """:func:`track` from rest at the constant position that brings the cart's ZMP closest to
    ``p_ref`` (least squares over the run; the servo is linear, so two runs give the fit). A
    servo started at zero under a reference that does not start there must first move its ZMP
    the other way (the cart-table is non-minimum phase), centimetres off at the first samples."""
    free = zmp_of(model, track(model, gains, p_ref))
    unit = zmp_of(model, track(model, gains, np.zeros_like(p_ref), np.array([1.0, 0.0, 0.0])))
    c0 = -float(np.dot(free - p_ref, unit) / np.dot(unit, unit))
    return track(model, gains, p_ref, np.array([c0, 0.0, 0.0]))


def zmp_of(model: CartTable, states: np.ndarray) -> np.ndarray:
    """The cart-table's ZMP along its states (K, 3)."""
    return states @ model.C[0]
