"""The linear MPC of Sec. V-B: Eq. (18) over N steps, cost Eq. (19), contact constraints, solved as
a QP by a real solver and warm-started between updates.

Cost: sum_k |X(k+1) - X_ref(k+1)|_Q + |U(k) - U_ref(k)|_R. Eq. (19) penalizes |U| itself; here the
library's forces and joint velocities are the feed-forward, so the controller pays for leaving
them, not for holding the robot up (with |U| the weight would pull every force toward zero).

Constraints per step and leg, from the schedule of the reference window:
* a swinging leg: zero force;
* a leg in contact: normal force in [f_min, f_max] along the surface normal (deck normal R_B e_z,
  or world z on the ground) and a 4-facet pyramid |f_t1|, |f_t2| <= mu_mpc / sqrt(2) f_n, which is
  inside Coulomb's cone of mu_mpc;
* |qd| <= the joint-velocity limit.

Two formulations and solvers, chosen by measurement (``make bench``):
* ``proxqp``: condensed (states eliminated), dense, ProxSuite's ProxQP, warm-started;
* ``osqp``: sparse multiple-shooting form (states kept, dynamics as equalities), OSQP, warm-started.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from skatelib.control.linear_model import Discretizer, Feedback, board_rotation, continuous_model
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, I_BOARD_ROLL, NU, NX, SWING

SOLVERS = ("proxqp", "osqp")


@dataclass(frozen=True)
class MpcConfig:
    """MPC settings.

    Attributes:
        rate_hz: Update rate (the paper: 30 Hz).
        horizon: Steps N (the paper's MIT-Cheetah lineage: 10).
        mu: Friction coefficient the MPC assumes (its pyramid is inside this cone).
        f_min_N / f_max_N: Normal force bounds of a loaded foot.
        q_weights / r_weights: Diagonals of Q (28) and R (24).
        solver: ``proxqp`` or ``osqp``.
    """

    rate_hz: float = 30.0
    horizon: int = 10
    mu: float = 0.45
    f_min_N: float = 0.0
    f_max_N: float = 120.0
    solver: str = "proxqp"
    q_weights: tuple[float, ...] = field(default_factory=lambda: (
        (4e4, 4e4, 4e4) + (4e3, 4e3, 2e3) + (300.0, 300.0, 300.0) + (20.0, 20.0, 20.0) + (1.0,) * 12
        + (2e3, 2e3) + (2e3, 5.0)))
    r_weights: tuple[float, ...] = field(default_factory=lambda: (1e-2,) * 12 + (1e-2,) * 12)

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz


@dataclass(frozen=True)
class MpcProblem:
    """One update's QP in condensed form: min 1/2 u'Hu + g'u, l <= Cu <= u, lb <= u <= ub,
    and the prediction X = Sx x0 + Su U + Sc (for the sparse form and for checks)."""

    H: np.ndarray
    g: np.ndarray
    C: np.ndarray
    l: np.ndarray
    u: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    Ad: list[np.ndarray]
    Bd: list[np.ndarray]
    cd: list[np.ndarray]
    x0: np.ndarray
    x_ref: np.ndarray
    u_ref: np.ndarray


def _legs_rows(p: SkateParams, cfg: MpcConfig, x0: np.ndarray,
               contact: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of the friction pyramid and normal bounds for one step's forces (12 columns)."""
    mu_f = cfg.mu / np.sqrt(2.0)
    R_B = board_rotation(x0[I_BOARD_ROLL], x0[5])
    rows, lo, hi = [], [], []
    for i in range(4):
        if contact[i] == SWING:
            continue
        frame = R_B if contact[i] == BOARD else board_rotation(0.0, x0[5])
        t1, t2, n = frame[:, 0], frame[:, 1], frame[:, 2]
        for a in (t1 - mu_f * n, -t1 - mu_f * n, t2 - mu_f * n, -t2 - mu_f * n):
            r = np.zeros(12)
            r[3 * i:3 * i + 3] = a
            rows.append(r)
            lo.append(-np.inf)
            hi.append(0.0)
        r = np.zeros(12)
        r[3 * i:3 * i + 3] = n
        rows.append(r)
        lo.append(cfg.f_min_N)
        hi.append(cfg.f_max_N)
    return np.array(rows).reshape(-1, 12), np.array(lo), np.array(hi)


def build_problem(p: SkateParams, cfg: MpcConfig, disc: Discretizer, fb: Feedback, x_ref: np.ndarray,
                  u_ref: np.ndarray, contact: np.ndarray, accelerating: np.ndarray) -> MpcProblem:
    """The QP of one update.

    Args:
        x_ref: (N, 28) X_ref(k+1), k = 0..N-1.
        u_ref: (N, 24) feed-forward controls.
        contact: (N, 4) codes of step k.
        accelerating: (N,) bool, the acceleration mode at step k (see :func:`continuous_model`).
    """
    N = cfg.horizon
    Ad_l, Bd_l, cd_l = [], [], []
    cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for k in range(N):
        key = contact[k].tobytes() + bytes([bool(accelerating[k])])
        if key not in cache:
            cache[key] = disc(*continuous_model(p, fb, contact[k], bool(accelerating[k])))
        Ad, Bd, cd = cache[key]
        Ad_l.append(Ad)
        Bd_l.append(Bd)
        cd_l.append(cd)
    # Condensing: X(k+1) = Phi_k x0 + sum_j G_kj U_j + s_k.
    Su = np.zeros((N * NX, N * NU))
    Sx = np.zeros((N * NX, NX))
    sc = np.zeros(N * NX)
    Phi = np.eye(NX)
    s = np.zeros(NX)
    for k in range(N):
        rk = slice(k * NX, (k + 1) * NX)
        Phi = Ad_l[k] @ Phi
        s = Ad_l[k] @ s + cd_l[k]
        Sx[rk] = Phi
        sc[rk] = s
        if k > 0:
            Su[rk, :k * NU] = Ad_l[k] @ Su[(k - 1) * NX:k * NX, :k * NU]
        Su[rk, k * NU:(k + 1) * NU] = Bd_l[k]
    q = np.tile(np.asarray(cfg.q_weights, float), N)
    r = np.tile(np.asarray(cfg.r_weights, float), N)
    free = Sx @ fb.x + sc - x_ref.reshape(-1)
    SuQ = Su.T * q
    H = SuQ @ Su + np.diag(r)
    g = SuQ @ free - r * u_ref.reshape(-1)
    H = 0.5 * (H + H.T)
    lb = np.full(N * NU, -np.inf)
    ub = np.full(N * NU, np.inf)
    blocks, lo, hi = [], [], []
    for k in range(N):
        base = k * NU
        lb[base + 12: base + 24] = -p.joint_velocity_limit_radps
        ub[base + 12: base + 24] = p.joint_velocity_limit_radps
        for i in range(4):
            if contact[k, i] == SWING:
                lb[base + 3 * i: base + 3 * i + 3] = 0.0
                ub[base + 3 * i: base + 3 * i + 3] = 0.0
        rows, l_k, h_k = _legs_rows(p, cfg, fb.x, contact[k])
        full = np.zeros((len(rows), N * NU))
        full[:, base: base + 12] = rows
        blocks.append(full)
        lo.append(l_k)
        hi.append(h_k)
    C = np.vstack(blocks)
    return MpcProblem(H=H, g=g, C=C, l=np.concatenate(lo), u=np.concatenate(hi), lb=lb, ub=ub,
                      Ad=Ad_l, Bd=Bd_l, cd=cd_l, x0=fb.x, x_ref=x_ref, u_ref=u_ref)


class QpSolveFailed(RuntimeError):
    """The QP solver did not return a solution."""


class ProxQpSolver:
    """The condensed QP with ProxSuite's dense ProxQP, warm-started from the previous update's
    solution shifted by one step."""

    def __init__(self, n: int):
        self.n = n
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        import proxsuite

        n_in = qp.C.shape[0]
        solver = proxsuite.proxqp.dense.QP(self.n, 0, n_in, True)
        solver.settings.eps_abs = 1e-6
        solver.settings.eps_rel = 0.0
        solver.settings.verbose = False
        lb = np.where(np.isfinite(qp.lb), qp.lb, -1e20)
        ub = np.where(np.isfinite(qp.ub), qp.ub, 1e20)
        lo = np.where(np.isfinite(qp.l), qp.l, -1e20)
        hi = np.where(np.isfinite(qp.u), qp.u, 1e20)
        solver.init(qp.H, qp.g, None, None, qp.C, lo, hi, lb, ub)
        solved = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
        if self.prev is not None:
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
            solver.solve(self.prev, None, None)
        if self.prev is None or solver.results.info.status != solved:  # cold start (again)
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS
            solver.solve()
        status = solver.results.info.status
        if status != solved:
            self.prev = None
            raise QpSolveFailed(f"ProxQP: {status}")
        x = np.array(solver.results.x)
        self.prev = np.concatenate([x[NU:], x[-NU:]])
        return x


class OsqpSolver:
    """The sparse multiple-shooting QP with OSQP: variables (U_0, X_1, U_1, ..., X_N), dynamics as
    equalities; warm-started from the previous solution shifted by one step."""

    def __init__(self, n: int, q_weights: np.ndarray, r_weights: np.ndarray):
        self.n = n
        self.q_weights, self.r_weights = q_weights, r_weights
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        import osqp
        import scipy.sparse as sp

        N = len(qp.Ad)
        nz = N * (NU + NX)
        col_u = [k * (NU + NX) for k in range(N)]
        col_x = [c + NU for c in col_u]
        P = np.zeros(nz)
        q = np.zeros(nz)
        for k in range(N):
            P[col_u[k]:col_u[k] + NU] = self.r_weights
            q[col_u[k]:col_u[k] + NU] = -self.r_weights * qp.u_ref[k]
            P[col_x[k]:col_x[k] + NX] = self.q_weights
            q[col_x[k]:col_x[k] + NX] = -self.q_weights * qp.x_ref[k]
        # Dynamics: X_{k+1} - A X_k - B U_k = c (X_0 = x0 is known).
        dyn = sp.lil_matrix((N * NX, nz))
        rhs = np.zeros(N * NX)
        for k in range(N):
            r = slice(k * NX, (k + 1) * NX)
            dyn[r, col_x[k]:col_x[k] + NX] = np.eye(NX)
            dyn[r, col_u[k]:col_u[k] + NU] = -qp.Bd[k]
            if k == 0:
                rhs[r] = qp.Ad[0] @ qp.x0 + qp.cd[0]
            else:
                dyn[r, col_x[k - 1]:col_x[k - 1] + NX] = -qp.Ad[k]
                rhs[r] = qp.cd[k]
        sel = sp.lil_matrix((N * NU, nz))  # contact rows and bounds act on the controls only
        for k in range(N):
            sel[k * NU:(k + 1) * NU, col_u[k]:col_u[k] + NU] = sp.identity(NU)
        sel = sel.tocsc()
        A = sp.vstack([dyn.tocsc(), sp.csc_matrix(qp.C) @ sel, sel]).tocsc()
        lo = np.concatenate([rhs, qp.l, qp.lb])
        hi = np.concatenate([rhs, qp.u, qp.ub])
        solver = osqp.OSQP()
        solver.setup(sp.diags(P).tocsc(), q, A, lo, hi, verbose=False, eps_abs=1e-7, eps_rel=1e-7,
                     max_iter=20000, polishing=True)
        if self.prev is not None:
            solver.warm_start(x=self.prev)
        res = solver.solve()
        if res.info.status not in ("solved", "solved inaccurate"):
            raise QpSolveFailed(f"OSQP: {res.info.status}")
        z = np.asarray(res.x)
        self.prev = np.concatenate([z[NU + NX:], z[-(NU + NX):]])
        return np.concatenate([z[c:c + NU] for c in col_u])


def make_solver(cfg: MpcConfig) -> ProxQpSolver | OsqpSolver:
    """The QP solver named in the config."""
    n = cfg.horizon * NU
    if cfg.solver == "proxqp":
        return ProxQpSolver(n)
    if cfg.solver == "osqp":
        return OsqpSolver(n, np.asarray(cfg.q_weights, float), np.asarray(cfg.r_weights, float))
    raise ValueError(f"unknown QP solver {cfg.solver!r}; choose one of {', '.join(SOLVERS)}")


def predict(qp: MpcProblem, U: np.ndarray) -> np.ndarray:
    """(N, 28) predicted states X(1..N) under controls U (N * 24) with the QP's model."""
    x = qp.x0
    out = []
    for k, (A, B, c) in enumerate(zip(qp.Ad, qp.Bd, qp.cd, strict=True)):
        x = A @ x + B @ U[k * NU:(k + 1) * NU] + c
        out.append(x)
    return np.array(out)


def qp_objective(qp: MpcProblem, U: np.ndarray) -> float:
    """0.5 U'HU + g'U of the condensed QP (equal for both formulations up to a constant)."""
    return float(0.5 * U @ qp.H @ U + qp.g @ U)
