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

from dataclasses import dataclass

import numpy as np
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.qp import QpProblem, QpSolveFailed, solve_qp

NV = 18

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
    qp_solver: str = "daqp"  # a backend of skatelib.control.qp.SOLVERS


@dataclass
class WbcTargets:
    """What one tick asks (world frame; legs FL FR RL RR).

    Attributes:
        stance: (4,) feet held on their surface.
        on_deck: (4,) feet on (or bound for) the deck; the others' surface is the floor.
        deck_R: (3, 3) the deck's rotation (its z axis the normal; the friction pyramid's facets
            face its x and y axes).
        stance_acc: (3, 4) the stance feet's accelerations (their deck point's, with feedback).
        com_acc / angular_acc: The model COM point's acceleration; the trunk's angular
            acceleration in the trunk frame.
        swing_acc: (3, 4) the swinging feet's accelerations.
        forces: (3, 4) the MPC's contact forces.
        posture_acc: (12,) joint accelerations toward the posture, channel order.
    """

    stance: np.ndarray
    on_deck: np.ndarray
    deck_R: np.ndarray
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


def surface_coefficients(mu: float, friction_rows: bool = True) -> np.ndarray:
    """(1 + 4, 3) a stance foot's rows on a surface of rotation R, as ``coefficients @ R.T``: its
    normal (R's z axis), then (with ``friction_rows``) the 4-facet pyramid of ``mu`` about it, facing
    R's x and y axes (r . f <= 0 inside)."""
    facets = [[1.0, 0.0, -mu], [-1.0, 0.0, -mu], [0.0, 1.0, -mu], [0.0, -1.0, -mu]]
    return np.array([[0.0, 0.0, 1.0], *(facets if friction_rows else [])])


def pyramid(frame: np.ndarray, mu: float) -> np.ndarray:
    """(4, 3) rows r with r . f <= 0 inside the 4-facet pyramid of ``mu`` about the z axis of the
    rotation ``frame``."""
    return surface_coefficients(mu)[1:] @ frame.T


class _Layout:
    """The QP's arrays for one stance set, their fixed parts filled once: the cost's diagonal
    (regularization, attitude, posture and force weights), the constraint matrix's zeros, the
    bounds of the normal, friction and equality rows, and where each stance foot's surface rows go.

    Rows: the 18 rows of M qdd + h - J_c^T f (the base's 6 held at zero, the joints' 12 within the
    torque limit), the stance feet's accelerations, then each stance foot's normal and facets."""

    def __init__(self, legs: np.ndarray, joints: np.ndarray, s: WbcSettings):
        self.legs, self.swing = legs, np.setdiff1d(np.arange(4), legs)
        nf = 3 * len(legs)
        n = NV + nf
        self.q_diag = np.full(NV, s.regularization)
        self.q_diag[3:6] += s.w_attitude
        self.q_diag[joints] += s.w_posture
        self.H = np.diag(np.r_[self.q_diag, np.full(nf, s.regularization + s.w_force)])
        self.g = np.zeros(n)
        self.A, self.b = np.zeros((3 + 3 * len(self.swing), NV)), np.zeros(3 + 3 * len(self.swing))  # task rows
        self.w = np.sqrt([s.w_com] * 3 + [s.w_swing] * 3 * len(self.swing))  # their square-root weights
        per_leg = 1 + 4 * s.friction_rows
        self.surface = NV + nf  # the first normal row
        m = self.surface + per_leg * len(legs)
        self.rows = np.zeros((m, n))
        self.up, self.lo = np.full(m, 1e30), np.full(m, -1e30)
        self.equality = np.zeros(m, dtype=bool)
        self.equality[:6] = self.equality[NV:self.surface] = True
        k = np.arange(len(legs))
        r = self.surface + per_leg * k  # each leg's normal row, then its facets
        self.up[r], self.lo[r] = s.normal_max_N, s.normal_min_N
        for facet in range(1, per_leg):
            self.up[r + facet] = 0.0
        # Where (k, per_leg, 3) blocks go in rows.ravel(): each foot's normal, then its facets.
        r_idx = r[:, None, None] + np.arange(per_leg)[None, :, None] + np.zeros((1, 1, 3), dtype=int)
        c_idx = NV + 3 * k[:, None, None] + np.zeros((1, per_leg, 1), dtype=int) + np.arange(3)
        self.flat = np.ravel_multi_index((r_idx.ravel(), c_idx.ravel()), self.rows.shape)


class WholeBodyController:
    """One QP per tick (module docstring)."""

    def __init__(self, joint_columns: np.ndarray, torque_limit_Nm: float, mu: float,
                 settings: WbcSettings | None = None):
        self.s = settings or WbcSettings()
        self.joints = np.asarray(joint_columns)
        contiguous = np.array_equal(self.joints, np.arange(6, NV))  # pinocchio's order: views, not copies
        self._j: slice | np.ndarray = slice(6, NV) if contiguous else self.joints
        self.tau_max = torque_limit_Nm  # (sets the dynamics rows' bounds)
        self.mu = mu
        self._layouts: dict[bytes, _Layout] = {}
        self._coefficients = surface_coefficients(mu, self.s.friction_rows)
        self._floor_rows = self._coefficients.copy()  # on the floor R = I

    @property
    def tau_max(self) -> float:
        """The joints' torque limit [N m]."""
        return self._tau_max

    @tau_max.setter
    def tau_max(self, limit_Nm: float) -> None:
        self._tau_max = limit_Nm
        self._band = np.r_[np.zeros(6), np.full(NV - 6, limit_Nm)]  # the dynamics rows' bounds, less h

    def solve(self, T: DynamicsTerms, tg: WbcTargets) -> WbcOutput:
        """Torques of this tick.

        Raises:
            QpSolveFailed: The backend found no solution (the caller records a fall).
        """
        L = self._layout(tg.stance)
        legs, swing, s, j = L.legs, L.swing, self.s, self._j
        Jc = T.J_feet[legs].reshape(-1, NV)  # stacked stance Jacobians
        JcT = Jc.T
        # Cost: the COM and swing-foot tasks as weighted rows A x = b over qdd, the rest diagonal.
        A, b, w = L.A, L.b, L.w
        A[:3] = T.J_com
        A[3:] = T.J_feet[swing].reshape(-1, NV)
        b[:3] = tg.com_acc - T.dJv_com
        b[3:] = (tg.swing_acc[:, swing] - T.dJv_feet[swing].T).T.ravel()
        A *= w[:, None]
        Hq = A.T @ A
        Hq.flat[::NV + 1] += L.q_diag
        L.H[:NV, :NV] = Hq
        g = L.g
        g[:NV] = -(A.T @ (w * b))
        g[3:6] -= s.w_attitude * tg.angular_acc
        g[j] -= s.w_posture * tg.posture_acc
        g[NV:] = -s.w_force * tg.forces[:, legs].T.ravel()
        self._constraints(L, T, tg, JcT)
        try:
            solution = solve_qp(QpProblem(L.H, g, L.rows, L.lo, L.up, equality=L.equality), s.qp_solver)
        except QpSolveFailed as e:
            raise QpSolveFailed(f"whole-body QP: {e}") from e
        x = solution.x
        tau = (L.rows[:NV] @ x + T.h)[j]
        forces = np.zeros((3, 4))
        forces[:, legs] = x[NV:].reshape(-1, 3).T
        return WbcOutput(tau=tau, forces=forces, qdd=x[:NV], iterations=solution.iterations)

    def _layout(self, stance: np.ndarray) -> _Layout:
        key = np.asarray(stance, dtype=bool).tobytes()
        out = self._layouts.get(key)
        if out is None:
            out = self._layouts[key] = _Layout(np.nonzero(stance)[0], self.joints, self.s)
        return out

    def _constraints(self, L: _Layout, T: DynamicsTerms, tg: WbcTargets, JcT: np.ndarray) -> None:
        """This tick's rows and bounds into ``L``'s arrays (``JcT``: the stance feet's stacked
        Jacobians, transposed)."""
        rows, up, lo, legs = L.rows, L.up, L.lo, L.legs
        rows[:NV, :NV] = T.M  # M qdd + h - Jc^T f: zero on the base, within the limit on the joints
        rows[:NV, NV:] = -JcT
        np.subtract(self._band, T.h, out=up[:NV])
        np.subtract(-self._band, T.h, out=lo[:NV])
        s = L.surface
        rows[NV:s, :NV] = JcT.T  # stance feet
        up[NV:s] = lo[NV:s] = (tg.stance_acc[:, legs] - T.dJv_feet[legs].T).T.ravel()
        if len(legs):
            deck = self._coefficients @ tg.deck_R.T
            blocks = np.where(tg.on_deck[legs, None, None], deck, self._floor_rows)
            rows.reshape(-1)[L.flat] = blocks.ravel()
