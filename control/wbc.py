"""The whole-body controller (the paper's WBC, as a weighted task QP): every tick, on the
floating-base multibody model (:mod:`skatelib.control.multibody`), one QP in the joint
accelerations qdd (18) and the stance feet's contact forces f (3 each), the joint torques
following from them:

    min  sum_k w_k |A_k x - b_k|^2          x = (qdd, f)
    s.t. (M qdd + h - J_c^T f)_base = 0      floating-base dynamics (6 rows)
         J_i qdd + Jdot_i v = a_i            each stance foot moves with its deck point or the ground
         |f_t| <= mu f_n (4-facet pyramid),  f_min <= f_n <= f_max
         |(M qdd + h - J_c^T f)_joints| <= tau_max

Tasks: the model COM point's acceleration (the MPC's force sum over the mass, plus PD to the
reference), the trunk's angular acceleration (PD to the reference attitude), each swinging foot's
acceleration (PD along its path), the contact forces toward the MPC's, and a posture term. The
QP is DAQP's (dense dual active set), chosen in ``make bench`` against the other backends.
"""

from __future__ import annotations

import math
from ctypes import c_int
from dataclasses import dataclass

import numpy as np
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.qp import QpSolveFailed

NV = 18
EQUALITY = 5  # DAQP's sense of a row held at equality (active and immutable)


@dataclass(frozen=True)
class WbcSettings:
    """Gains [1/s^2, 1/s], weights and bounds of the whole-body QP.

    Attributes:
        stance_gain: The stance feet's velocity feedback toward their deck point's [1/s].
        friction_rows: Hold the forces in the friction pyramid (False only for the negative
            control that shows the rows matter).
    """

    kp_com: float = 100.0
    kd_com: float = 20.0
    kp_attitude: float = 100.0
    kd_attitude: float = 20.0
    kp_swing: float = 400.0
    kd_swing: float = 40.0
    kp_posture: float = 50.0
    kd_posture: float = 5.0
    stance_gain: float = 10.0
    w_com: float = 1.0
    w_attitude: float = 1.0
    w_swing: float = 1.0
    w_force: float = 1e-1  # per N^2
    w_posture: float = 1e-3
    regularization: float = 1e-6
    normal_min_N: float = 1.0
    normal_max_N: float = 150.0
    friction_rows: bool = True


@dataclass
class WbcTargets:
    """What one tick asks (world frame; legs FL FR RL RR).

    Attributes:
        stance: (4,) feet held on their surface.
        normals: (3, 4) the surface normal under each stance foot.
        stance_acc: (3, 4) the stance feet's accelerations (their deck point's, with feedback).
        com_acc / angular_acc: The model COM point's acceleration; the trunk's angular
            acceleration in the trunk frame.
        swing_acc: (3, 4) the swinging feet's accelerations.
        forces: (3, 4) the MPC's contact forces.
        posture_acc: (12,) joint accelerations toward the posture, channel order.
    """

    stance: np.ndarray
    normals: np.ndarray
    stance_acc: np.ndarray
    com_acc: np.ndarray
    angular_acc: np.ndarray
    swing_acc: np.ndarray
    forces: np.ndarray
    posture_acc: np.ndarray


@dataclass
class WbcOutput:
    tau: np.ndarray  # (12,) channel order
    forces: np.ndarray  # (3, 4) the QP's contact forces (zero for swinging feet)
    qdd: np.ndarray  # (18,)
    iterations: int


def pyramid(normal: np.ndarray, mu: float) -> np.ndarray:
    """(4, 3) rows r with r . f <= 0 inside the 4-facet pyramid of ``mu`` about ``normal`` (a unit
    vector away from the y axis: a floor's or a deck's)."""
    x, y, z = (float(c) for c in normal)
    s = math.hypot(x, z)  # t1 = normal x e_y / |..| = (-z, 0, x) / s; t2 = normal x t1
    t1 = np.array([-z / s, 0.0, x / s])
    t2 = np.array([y * x / s, -(z * z + x * x) / s, y * z / s])
    n = np.asarray(normal, dtype=float)
    return np.array([t1 - mu * n, -t1 - mu * n, t2 - mu * n, -t2 - mu * n])


class WholeBodyController:
    """One QP per tick (module docstring)."""

    def __init__(self, joint_columns: np.ndarray, torque_limit_Nm: float, mu: float,
                 settings: WbcSettings | None = None):
        self.s = settings or WbcSettings()
        self.joints = np.asarray(joint_columns)
        self.tau_max = torque_limit_Nm
        self.mu = mu
        self._pyramids: dict[bytes, np.ndarray] = {}

    def solve(self, T: DynamicsTerms, tg: WbcTargets) -> WbcOutput:
        """Torques of this tick.

        Raises:
            QpSolveFailed: DAQP found no solution (the caller records a fall).
        """
        import daqp

        s = self.s
        legs = np.nonzero(tg.stance)[0]
        nf = 3 * len(legs)
        n = NV + nf
        Jc = T.J_feet[legs].reshape(nf, NV)  # stacked stance Jacobians
        # Cost: weighted least squares over x = (qdd, f), block by block.
        H = s.regularization * np.eye(n)
        g = np.zeros(n)
        Hq, gq = H[:NV, :NV], g[:NV]
        Hq += s.w_com * (T.J_com.T @ T.J_com)
        gq -= s.w_com * (T.J_com.T @ (tg.com_acc - T.dJv_com))
        Hq[3:6, 3:6] += s.w_attitude * np.eye(3)
        gq[3:6] -= s.w_attitude * tg.angular_acc
        j = self.joints
        Hq[j, j] += s.w_posture
        gq[j] -= s.w_posture * tg.posture_acc
        swing = np.nonzero(~tg.stance)[0]
        if len(swing):
            Js = T.J_feet[swing].reshape(-1, NV)
            Hq += s.w_swing * (Js.T @ Js)
            gq -= s.w_swing * (Js.T @ (tg.swing_acc[:, swing] - T.dJv_feet[swing].T).T.reshape(-1))
        if nf:
            H[NV:, NV:] += s.w_force * np.eye(nf)
            g[NV:] -= s.w_force * tg.forces[:, legs].T.reshape(-1)
        rows, upper, lower, sense = self._constraints(T, tg, legs, Jc, n)
        x, _, flag, info = daqp.solve(H, g, rows, upper, lower, sense)
        if flag != 1:
            raise QpSolveFailed(f"whole-body QP: DAQP exit flag {flag}")
        qdd, f = x[:NV], x[NV:]
        tau = (T.M[j] @ qdd + T.h[j] - Jc[:, j].T @ f)
        forces = np.zeros((3, 4))
        forces[:, legs] = f.reshape(-1, 3).T
        return WbcOutput(tau=tau, forces=forces, qdd=qdd, iterations=int(info["iterations"]))

    def _constraints(self, T: DynamicsTerms, tg: WbcTargets, legs: np.ndarray, Jc: np.ndarray, n: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        s, nf, j = self.s, Jc.shape[0], self.joints
        per_leg = 1 + 4 * s.friction_rows
        m = 6 + nf + per_leg * len(legs) + 12
        rows = np.zeros((m, n))
        up = np.full(m, 1e30)
        lo = np.full(m, -1e30)
        rows[:6, :NV] = T.M[:6]  # floating base: M qdd + h - Jc^T f = 0
        rows[:6, NV:] = -Jc[:, :6].T
        up[:6] = lo[:6] = -T.h[:6]
        rows[6:6 + nf, :NV] = Jc  # stance feet
        up[6:6 + nf] = lo[6:6 + nf] = (tg.stance_acc[:, legs] - T.dJv_feet[legs].T).T.reshape(-1)
        r = 6 + nf
        for k, leg in enumerate(legs):
            cols = slice(NV + 3 * k, NV + 3 * k + 3)
            nrm = tg.normals[:, leg]
            rows[r, cols] = nrm
            up[r], lo[r] = s.normal_max_N, s.normal_min_N
            if s.friction_rows:
                rows[r + 1:r + 5, cols] = self._pyramid(nrm)
                up[r + 1:r + 5] = 0.0
            r += per_leg
        rows[r:, :NV] = T.M[j]  # joint torques within the limit
        rows[r:, NV:] = -Jc[:, j].T
        up[r:] = self.tau_max - T.h[j]
        lo[r:] = -self.tau_max - T.h[j]
        sense = np.zeros(m, dtype=c_int)
        sense[:6 + nf] = EQUALITY
        return rows, up, lo, sense

    def _pyramid(self, normal: np.ndarray) -> np.ndarray:
        key = normal.tobytes()
        out = self._pyramids.get(key)
        if out is None:
            if len(self._pyramids) > 64:  # the deck's normal changes every tick: keep the floor's
                self._pyramids.clear()
            out = self._pyramids[key] = pyramid(normal, self.mu)
        return out
