"""The linear MPC of Sec. V-B: Eq. (18) over N steps, cost Eq. (19), contact constraints, solved as
a QP by a real solver and warm-started between updates.

Cost: sum_k |X(k+1) - X_ref(k+1)|_Q + |U(k) - U_ref(k)|_R. Eq. (19) penalizes |U| itself; here the
library's forces and joint velocities are the feed-forward, so the controller pays for leaving
them, not for holding the robot up (with |U| the weight would pull every force toward zero).

Constraints per step and leg, from the schedule of the reference window:
* a swinging leg: zero force;
* a leg in contact: normal force in [f_min, f_max] along the surface normal (deck normal R_B e_z,
  or world z on the ground) and the pyramid of the polygon with ``facets`` sides inscribed in
  Coulomb's cone of mu_mpc (8 by default, as the optimization plans; 4 is |f_t1|, |f_t2| <=
  mu_mpc / sqrt(2) f_n);
* |qd| <= the joint-velocity limit;
* with the feedback's torque maps, each loaded leg's joint torques -J(q)^T R^T f within the
  torque limit at the measured joint angles, on the first ``torque_steps`` steps (default 1: the
  force that is applied; the joint angles are measured for now, not for later steps).

Structure: the 12 joint angles are pure integrators of the 12 joint velocities (Eq. 17), and
neither enters any other row or constraint, while Q and R are diagonal. So the QP splits exactly
into (a) the forces with the 16 other states and the contact constraints, a QP of 12 N variables,
and (b) one box-constrained least-squares problem of N variables per joint, solved in closed form
(and by a bounded solve only when a joint-velocity bound is active). Part (a), by measurement
(``make bench``), with:
* ``daqp``: condensed (states eliminated), dense, DAQP's dual active-set method on the loaded
  legs' forces in least-distance form (:class:`DaqpSolver`), the default: fastest in ``make bench``;
  cold (7-8 iterations; a start from the previous update's shifted solution needed as many);
* ``proxqp``: the same condensed QP with ProxSuite's ProxQP, warm-started;
* ``osqp``: sparse multiple-shooting form (states kept, dynamics as equalities), OSQP, warm-started.

Offset-free: :class:`DisturbanceObserver` estimates the board's forward acceleration and the
robot's vertical one that the model misses (rolling friction and masses differ on the robot) and
the prediction carries them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from skatelib.control.linear_model import Discretizer, Feedback, continuous_model
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, I_BOARD_ROLL, NU, NX, S_Q, S_VEL, SWING
from skatelib.library.rotations import board_rotations

SOLVERS = ("daqp", "proxqp", "osqp")
NF = 12  # force variables per step
REDUCED = np.r_[0:S_Q.start, S_Q.stop:NX]  # the 16 states the forces drive (all but the joint angles)
BOARD_V_REDUCED = slice(S_Q.start, S_Q.start + 2)  # board_vx, board_vy among them
ROBOT_VZ_REDUCED = S_VEL.start + 2  # the robot's vertical speed (before the joint angles: same index)


def board_heading(x: np.ndarray) -> np.ndarray:
    """(2,) the board's forward direction in the world (its yaw is the robot's)."""
    return np.array([np.cos(x[5]), np.sin(x[5])])


class DisturbanceObserver:
    """Estimates the board's unmodelled forward acceleration (``bias_mps2``) and the robot's
    unmodelled vertical one (``vertical_mps2``: a heavier robot sags) from what the model
    predicted for the last update and what the feedback then showed, low-pass filtered with
    ``gain`` per update."""

    def __init__(self, gain: float):
        self.gain = gain
        self.bias_mps2 = 0.0
        self.vertical_mps2 = 0.0
        self._predicted: tuple[float, float] | None = None

    def update(self, v_forward_measured: float, dt: float, v_vertical_measured: float | None = None) -> float:
        """Returns the board's estimate; the robot's is updated when its vertical speed is given."""
        if self._predicted is not None:
            self.bias_mps2 += self.gain * (v_forward_measured - self._predicted[0]) / dt
            if v_vertical_measured is not None:
                self.vertical_mps2 += self.gain * (v_vertical_measured - self._predicted[1]) / dt
        return self.bias_mps2

    def predict(self, qp: MpcProblem, U: np.ndarray) -> None:
        """Remember the model's forward board speed and the robot's vertical speed one step after
        ``U`` is applied."""
        x1 = qp.Ad[0] @ qp.x0 + qp.Bd[0] @ U[:NF] + qp.cd[0]
        self._predicted = (float(board_heading(qp.x0_full) @ x1[BOARD_V_REDUCED]), float(x1[ROBOT_VZ_REDUCED]))


class CoastObserver:
    """How hard rolling friction slows robot and board together [m/s^2], measured while no foot
    touches the ground: then only rolling friction changes their momentum (m_R v_R + m_B v_B),
    whatever the masses, the deck's stiffness or the feet on the deck do. Samples only above
    ``min_speed_mps``, where friction has its full size (tanh(k v) ~ 1); None until the first."""

    def __init__(self, gain: float, min_speed_mps: float = 0.05):
        self.estimate_mps2: float | None = None
        self.gain = gain
        self.min_speed_mps = min_speed_mps
        self._last: float | None = None

    def update(self, coasting: bool, momentum_speed_mps: float, dt: float) -> float | None:
        usable = coasting and abs(momentum_speed_mps) > self.min_speed_mps
        if usable and self._last is not None:
            sample = -(momentum_speed_mps - self._last) / dt * np.sign(momentum_speed_mps)
            last = sample if self.estimate_mps2 is None else self.estimate_mps2
            self.estimate_mps2 = last + self.gain * (sample - last)
        self._last = momentum_speed_mps if usable else None
        return self.estimate_mps2


@dataclass(frozen=True)
class MpcConfig:
    """MPC settings.

    Attributes:
        rate_hz: Update rate (the paper: 30 Hz).
        horizon: Steps N (the paper's MIT-Cheetah lineage: 10).
        mu: Friction coefficient the MPC assumes (its pyramid is inside this cone); None: the
            one the library was planned with (``friction_mu_plan``, a margin inside ``friction_mu``).
        facets: Sides of the friction pyramid (4 or more).
        f_min_N / f_max_N: Normal force bounds of a loaded foot.
        q_weights / r_weights: Diagonals of Q (28) and R (24).
        solver: ``daqp``, ``proxqp`` or ``osqp`` (module docstring).
        disturbance_gain: Gain of the board-acceleration disturbance observer per update (0: off).
        coast_gain: Gain per update of the coast observer (:class:`CoastObserver`).
        torque_steps: Steps of the horizon with torque rows (1: the applied force only; on the
            default library all 10 gave the same verdicts and torques at 0.2 ms more per update).
        coast_compensation: Move each push's speed reference by what the following coast will
            gain or lose against the plan (measured while coasting; before the first coast, see
            :meth:`EntryReference.prior_coast_mps2`), so that the entry still ends at its label;
            False: track the plan's speeds.
    """

    rate_hz: float = 30.0
    horizon: int = 10
    mu: float | None = None
    facets: int = 8
    f_min_N: float = 0.0
    f_max_N: float = 120.0
    solver: str = "daqp"
    disturbance_gain: float = 0.3
    coast_gain: float = 0.2
    torque_steps: int = 1
    coast_compensation: bool = True
    q_weights: tuple[float, ...] = field(default_factory=lambda: (
        (4e4, 4e4, 4e4) + (4e3, 4e3, 2e3) + (300.0, 300.0, 300.0) + (20.0, 20.0, 20.0) + (1.0,) * 12
        + (2e3, 2e3) + (2e3, 5.0)))
    r_weights: tuple[float, ...] = field(default_factory=lambda: (1e-2,) * 12 + (1e-2,) * 12)

    @property
    def dt(self) -> float:
        return 1.0 / self.rate_hz


@dataclass(frozen=True)
class MpcProblem:
    """One update's QP. Forces: min 1/2 f'Hf + g'f, l <= Cf <= u, lb <= f <= ub over the N x 12
    forces, with the reduced model (``Ad``, ``Bd``, ``cd`` on the 16 states :data:`REDUCED`) for
    the sparse form and for checks. Joints: ``qd`` (N, 12), already solved (see the module
    docstring)."""

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
    x0_full: np.ndarray
    x_ref: np.ndarray
    f_ref: np.ndarray
    q_weights: np.ndarray
    f_weights: np.ndarray
    qd: np.ndarray
    step_rows: tuple[int, ...] = ()  # rows of C per step (C is block diagonal over the steps)

    def loaded(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The force QP without the variables fixed at zero (the swinging legs'): ``(mask, H, g,
        C, lb, ub)`` on the ``mask`` columns. The same optimum (no row of a swinging leg couples to
        the others), at a quarter fewer variables in a swing phase: a dense active-set solver needs
        one iteration less per fixed variable (``make bench``: DAQP 1.13 -> 0.75 ms)."""
        mask = ~((self.lb == 0.0) & (self.ub == 0.0))
        return (mask, self.H[np.ix_(mask, mask)], self.g[mask], self.C[:, mask], self.lb[mask],
                self.ub[mask])


def _legs_rows(p: SkateParams, cfg: MpcConfig, x0: np.ndarray, contact: np.ndarray,
               rolls: tuple[float, ...], torque_maps: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of the friction pyramid and normal bounds for one step's forces (12 columns). A foot on
    the deck gets the pyramid about the deck normal at each of ``rolls`` (the first step's force
    is held while the deck rolls on: its pyramid must hold at both ends of the update). With
    ``torque_maps``, each loaded leg's joint torques at the feedback's joint angles stay within
    the torque limit (the joints are held over the horizon: the linearizable part of the limit)."""
    mu = p.mu_plan if cfg.mu is None else cfg.mu
    angles = np.arange(cfg.facets) * (2.0 * np.pi / cfg.facets)
    directions = np.stack([np.cos(angles), np.sin(angles), np.full(cfg.facets, -mu * np.cos(np.pi / cfg.facets))])

    def pyramid(frame: np.ndarray) -> np.ndarray:  # (facets + 1, 3): facet rows, then the normal
        return np.vstack([directions.T @ frame.T, frame[:, 2]])

    ground = [pyramid(board_rotations(x0[5], 0.0))]
    deck = [pyramid(board_rotations(x0[5], r)) for r in rolls]
    rows: list[np.ndarray] = []
    lo: list[float] = []
    hi: list[float] = []
    for i in range(4):
        if contact[i] == SWING:
            continue
        for j, facets in enumerate(deck if contact[i] == BOARD else ground):
            block = np.zeros((cfg.facets + (j == 0), 12))
            block[:, 3 * i:3 * i + 3] = facets[:len(block)]
            rows.append(block)
            lo.extend((-np.inf,) * cfg.facets + ((cfg.f_min_N,) if j == 0 else ()))
            hi.extend((0.0,) * cfg.facets + ((cfg.f_max_N,) if j == 0 else ()))
        if torque_maps is not None and np.isfinite(p.torque_limit_Nm):
            block = np.zeros((3, 12))
            block[:, 3 * i:3 * i + 3] = torque_maps[i]
            rows.append(block)
            lo.extend((-p.torque_limit_Nm,) * 3)
            hi.extend((p.torque_limit_Nm,) * 3)
    return (np.vstack(rows) if rows else np.zeros((0, 12))), np.array(lo), np.array(hi)


def solve_joints(q0: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray, w_q: np.ndarray, w_qd: np.ndarray,
                 dt: float, limit: float) -> np.ndarray:
    """The joint part of the QP: per joint j, min sum_k w_q (q_k+1 - q_ref_k)^2 + w_qd (qd_k - qd_ref_k)^2
    with q_k+1 = q0 + dt sum_(i<=k) qd_i and |qd_k| <= limit. Returns qd (N, 12).

    Unconstrained: (dt^2 w_q L'L + w_qd I) qd = dt w_q L'(q_ref - q0) + w_qd qd_ref, L lower
    triangular ones; a joint whose solution leaves the bound is solved again with the bound (a
    bounded least-squares problem)."""
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


def build_problem(p: SkateParams, cfg: MpcConfig, disc: Discretizer, fb: Feedback, x_ref: np.ndarray,
                  u_ref: np.ndarray, contact: np.ndarray, accelerating: np.ndarray,
                  board_bias_mps2: float = 0.0, vertical_bias_mps2: float = 0.0) -> MpcProblem:
    """The QP of one update (its joint part solved).

    Args:
        x_ref: (N, 28) X_ref(k+1), k = 0..N-1.
        u_ref: (N, 24) feed-forward controls.
        contact: (N, 4) codes of step k.
        accelerating: (N,) bool, the acceleration mode at step k (see :func:`continuous_model`).
        board_bias_mps2: An estimated constant forward acceleration of the board that the model
            misses (rolling friction, mass errors: :class:`DisturbanceObserver`), added to every
            step (offset-free MPC).
        vertical_bias_mps2: The same for the robot's vertical acceleration (a mass error).
    """
    N = cfg.horizon
    S = REDUCED
    ns = len(S)
    Ad_l, Bd_l, cd_l = [], [], []
    cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    for k in range(N):
        key = contact[k].tobytes() + bytes([bool(accelerating[k])])
        if key not in cache:
            Ad, Bd, cd = disc(*continuous_model(p, fb, contact[k], bool(accelerating[k])))
            cache[key] = (Ad[np.ix_(S, S)], Bd[S, :NF], cd[S])
        Ad, Bd, cd = cache[key]
        if board_bias_mps2 or vertical_bias_mps2:
            cd = cd.copy()
            cd[BOARD_V_REDUCED] += board_heading(fb.x) * board_bias_mps2 * disc.dt  # vB rows: Gamma = dt I
            cd[ROBOT_VZ_REDUCED] += vertical_bias_mps2 * disc.dt
        Ad_l.append(Ad)
        Bd_l.append(Bd)
        cd_l.append(cd)
    # Condensing: X(k+1) = Phi_k x0 + sum_j G_kj F_j + s_k.
    Su = np.zeros((N * ns, N * NF))
    free = np.zeros(N * ns)
    x = fb.x[S]
    for k in range(N):
        rk = slice(k * ns, (k + 1) * ns)
        x = Ad_l[k] @ x + cd_l[k]
        free[rk] = x
        if k > 0:
            Su[rk, :k * NF] = Ad_l[k] @ Su[(k - 1) * ns:k * ns, :k * NF]
        Su[rk, k * NF:(k + 1) * NF] = Bd_l[k]
    w_all = np.asarray(cfg.q_weights, float)
    r_all = np.asarray(cfg.r_weights, float)
    q = np.tile(w_all[S], N)
    r = np.tile(r_all[:NF], N)
    xr = x_ref[:, S]
    fr = u_ref[:, :NF]
    sq = np.sqrt(q)
    W = Su * sq[:, None]  # H = Su' Q Su + R as W'W + R: one product, symmetric
    H = W.T @ W
    H[np.diag_indices_from(H)] += r
    g = W.T @ (sq * (free - xr.reshape(-1))) - r * fr.reshape(-1)
    lb = np.full(N * NF, -np.inf)
    ub = np.full(N * NF, np.inf)
    swing = np.repeat(contact == SWING, 3, axis=1).reshape(-1)
    lb[swing] = 0.0
    ub[swing] = 0.0
    rows_cache: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    per_step = []
    roll, roll_rate = fb.x[I_BOARD_ROLL], fb.x[I_BOARD_ROLL + 1]
    for k in range(N):
        torque = k < cfg.torque_steps
        key = contact[k].tobytes() + bytes([k == 0, torque])
        if key not in rows_cache:
            rolls = (roll, roll + roll_rate * disc.dt) if k == 0 else (roll,)
            rows_cache[key] = _legs_rows(p, cfg, fb.x, contact[k], rolls, fb.torque_maps if torque else None)
        per_step.append(rows_cache[key])
    C = np.zeros((sum(len(rows) for rows, _, _ in per_step), N * NF))  # block diagonal over steps
    at = 0
    for k, (rows, _, _) in enumerate(per_step):
        C[at:at + len(rows), k * NF:(k + 1) * NF] = rows
        at += len(rows)
    lo = [l_k for _, l_k, _ in per_step]
    hi = [h_k for _, _, h_k in per_step]
    qd = solve_joints(fb.x[S_Q], x_ref[:, S_Q], u_ref[:, NF:], w_all[S_Q], r_all[NF:], disc.dt,
                      p.joint_velocity_limit_radps)
    return MpcProblem(H=H, g=g, C=C, l=np.concatenate(lo), u=np.concatenate(hi), lb=lb, ub=ub,
                      Ad=Ad_l, Bd=Bd_l, cd=cd_l, x0=fb.x[S], x0_full=fb.x, x_ref=xr, f_ref=fr, q_weights=w_all[S],
                      f_weights=r_all[:NF], qd=qd, step_rows=tuple(len(rows) for rows, _, _ in per_step))


def _controls(qp: MpcProblem, forces: np.ndarray) -> np.ndarray:
    """The full N x 24 control vector from the solved forces and the joint part."""
    N = len(qp.qd)
    return np.hstack([forces.reshape(N, NF), qp.qd]).reshape(-1)


class QpSolveFailed(RuntimeError):
    """The QP solver did not return a solution."""


class DaqpSolver:
    """The condensed force QP with DAQP (dense dual active set), handed over in its least-distance
    form: with H = R'R (Cholesky) and f = R^-1 z the QP is min 1/2 |z|^2 + (R^-T g)'z s.t.
    l <= C R^-1 z <= u, the transform DAQP would otherwise make itself in plain loops (C R^-1 is
    dense, m n^2 / 2). Here it is a triangular inverse and one small product per step (C is block
    diagonal over the steps, R^-1 upper triangular): 0.75 -> 0.54 ms a solve in one A/B run.
    Cold: DAQP needs 7-8 iterations either way (warm starts from the shifted solution did not
    change that on the bench's updates)."""

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        from ctypes import c_int

        import daqp
        from scipy.linalg import solve_triangular

        mask, H, g, C, lb, ub = qp.loaded()
        n = len(g)
        R_inv = solve_triangular(np.linalg.cholesky(H).T, np.eye(n), lower=False, check_finite=False)
        M = np.zeros_like(C)
        row = col = 0
        for k, rows in enumerate(qp.step_rows or (len(C),)):
            width = int(mask[k * NF:(k + 1) * NF].sum()) if qp.step_rows else n
            block = slice(row, row + rows)
            M[block, col:] = C[block, col:col + width] @ R_inv[col:col + width, col:]
            row, col = row + rows, col + width
        bounded = np.isfinite(lb) | np.isfinite(ub)  # simple bounds become rows of R^-1
        big = 1e30  # DAQP's infinity
        M = np.vstack([R_inv[bounded], M])
        upper = np.minimum(np.concatenate([ub[bounded], qp.u]), big)
        lower = np.maximum(np.concatenate([lb[bounded], qp.l]), -big)
        z, _, flag, _ = daqp.solve(np.eye(n), R_inv.T @ g, M, upper, lower, np.zeros(len(upper), dtype=c_int))
        if flag != 1:
            raise QpSolveFailed(f"DAQP: exit flag {flag}")
        f = np.zeros(len(qp.g))
        f[mask] = R_inv @ z
        return _controls(qp, f)


class ProxQpSolver:
    """The condensed force QP with ProxSuite's dense ProxQP, warm-started from the previous
    update's solution shifted by one step."""

    def __init__(self) -> None:
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        import proxsuite

        mask, H, g, C, lb, ub = qp.loaded()
        n, n_in = len(g), C.shape[0]
        solver = proxsuite.proxqp.dense.QP(n, 0, n_in, True)
        solver.settings.eps_abs = 1e-6
        solver.settings.eps_rel = 0.0
        solver.settings.verbose = False
        # Zero forces always satisfy the rows (f_min 0): ProxQP's default infeasibility threshold
        # (1e-4) called two updates of the bench's v0.50_s2 infeasible; 1e-8 solves them.
        solver.settings.eps_primal_inf = 1e-8
        solver.settings.eps_dual_inf = 1e-8

        def finite(a: np.ndarray, fill: float) -> np.ndarray:
            return np.where(np.isfinite(a), a, fill)

        solver.init(H, g, None, None, C, finite(qp.l, -1e20), finite(qp.u, 1e20), finite(lb, -1e20),
                    finite(ub, 1e20))
        solved = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
        if self.prev is not None and len(self.prev) == len(qp.g):
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START
            solver.solve(self.prev[mask], None, None)
        if self.prev is None or solver.results.info.status != solved:  # cold start (again)
            solver.settings.initial_guess = proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS
            solver.solve()
        status = solver.results.info.status
        if status != solved:
            self.prev = None
            raise QpSolveFailed(f"ProxQP: {status}")
        f = np.zeros(len(qp.g))
        f[mask] = solver.results.x
        self.prev = np.concatenate([f[NF:], f[-NF:]])
        return _controls(qp, f)


class OsqpSolver:
    """The sparse multiple-shooting force QP with OSQP: variables (F_0, X_1, F_1, ..., X_N) on the
    16 reduced states, dynamics as equalities; warm-started from the previous solution shifted."""

    def __init__(self) -> None:
        self.prev: np.ndarray | None = None

    def solve(self, qp: MpcProblem) -> np.ndarray:
        """Controls U (N x 24, flattened) of the update."""
        import osqp
        import scipy.sparse as sp

        N, ns = len(qp.Ad), len(qp.x0)
        step = NF + ns
        nz = N * step
        col_f = [k * step for k in range(N)]
        col_x = [c + NF for c in col_f]
        P = np.zeros(nz)
        q = np.zeros(nz)
        for k in range(N):
            P[col_f[k]:col_f[k] + NF] = qp.f_weights
            q[col_f[k]:col_f[k] + NF] = -qp.f_weights * qp.f_ref[k]
            P[col_x[k]:col_x[k] + ns] = qp.q_weights
            q[col_x[k]:col_x[k] + ns] = -qp.q_weights * qp.x_ref[k]
        # Dynamics: X_{k+1} - A X_k - B F_k = c (X_0 = x0 is known).
        dyn = sp.lil_matrix((N * ns, nz))
        rhs = np.zeros(N * ns)
        for k in range(N):
            r = slice(k * ns, (k + 1) * ns)
            dyn[r, col_x[k]:col_x[k] + ns] = np.eye(ns)
            dyn[r, col_f[k]:col_f[k] + NF] = -qp.Bd[k]
            if k == 0:
                rhs[r] = qp.Ad[0] @ qp.x0 + qp.cd[0]
            else:
                dyn[r, col_x[k - 1]:col_x[k - 1] + ns] = -qp.Ad[k]
                rhs[r] = qp.cd[k]
        sel = sp.lil_matrix((N * NF, nz))  # contact rows and bounds act on the forces only
        for k in range(N):
            sel[k * NF:(k + 1) * NF, col_f[k]:col_f[k] + NF] = sp.identity(NF)
        sel = sel.tocsc()
        A = sp.vstack([dyn.tocsc(), sp.csc_matrix(qp.C) @ sel, sel]).tocsc()
        lo = np.concatenate([rhs, qp.l, qp.lb])
        hi = np.concatenate([rhs, qp.u, qp.ub])
        solver = osqp.OSQP()
        solver.setup(sp.diags(P).tocsc(), q, A, lo, hi, verbose=False, eps_abs=1e-9, eps_rel=1e-9,
                     max_iter=20000, polishing=True)
        if self.prev is not None and len(self.prev) == nz:
            solver.warm_start(x=self.prev)
        res = solver.solve(raise_error=False)  # the status is checked below
        if res.info.status not in ("solved", "solved inaccurate"):
            raise QpSolveFailed(f"OSQP: {res.info.status}")
        z = np.asarray(res.x)
        self.prev = np.concatenate([z[step:], z[-step:]])
        return _controls(qp, np.concatenate([z[c:c + NF] for c in col_f]))


def make_solver(cfg: MpcConfig) -> DaqpSolver | ProxQpSolver | OsqpSolver:
    """The QP solver named in the config."""
    if cfg.solver == "daqp":
        return DaqpSolver()
    if cfg.solver == "proxqp":
        return ProxQpSolver()
    if cfg.solver == "osqp":
        return OsqpSolver()
    raise ValueError(f"unknown QP solver {cfg.solver!r}; choose one of {', '.join(SOLVERS)}")


def qp_objective(qp: MpcProblem, U: np.ndarray) -> float:
    """0.5 f'Hf + g'f of the condensed force QP at the forces of U (N x 24, flattened)."""
    f = U.reshape(len(qp.qd), NU)[:, :NF].reshape(-1)
    return float(0.5 * f @ qp.H @ f + qp.g @ f)
