"""The joint part of the MPC's QP: the 12 joint angles are pure integrators of the joint
velocities (Eq. 17) and enter no other row, so each joint is a small least-squares problem of its
own, solved in closed form (and with its bound only where the bound is active)."""

from __future__ import annotations

import numpy as np


def solve_joints(q0: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray, weights: tuple[np.ndarray, np.ndarray],
                 dt: float, limit: float) -> np.ndarray:
    """The joint part of the QP: per joint j, with ``weights`` = (w_q, w_qd),
    min sum_k w_q (q_k+1 - q_ref_k)^2 + w_qd (qd_k - qd_ref_k)^2 with q_k+1 = q0 + dt sum_(i<=k) qd_i
    and |qd_k| <= limit. Returns qd (N, 12).

    Unconstrained: (dt^2 w_q L'L + w_qd I) qd = dt w_q L'(q_ref - q0) + w_qd qd_ref, L lower
    triangular ones; a joint whose solution leaves the bound is solved again with the bound (a
    bounded least-squares problem)."""
    w_q, w_qd = weights
    N = len(q_ref)
    L = np.tril(np.ones((N, N)))
    LtL = L.T @ L
    H = dt * dt * w_q[:, None, None] * LtL[None] + w_qd[:, None, None] * np.eye(N)[None]  # (12, N, N)
    rhs = (dt * w_q[:, None] * ((q_ref - q0).T @ L)) + w_qd[:, None] * qd_ref.T  # (12, N): L'(.) per joint
    qd = np.linalg.solve(H, rhs[:, :, None])[:, :, 0]
    for j in np.nonzero(np.abs(qd).max(axis=1) > limit)[0]:
        from scipy.optimize import lsq_linear

        A = np.vstack([np.sqrt(w_q[j]) * dt * L, np.sqrt(w_qd[j]) * np.eye(N)])
        b = np.concatenate([np.sqrt(w_q[j]) * (q_ref[:, j] - q0[j]), np.sqrt(w_qd[j]) * qd_ref[:, j]])
        qd[j] = lsq_linear(A, b, bounds=(-limit, limit)).x
    return qd.T
