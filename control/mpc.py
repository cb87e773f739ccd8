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
(and by a bounded solve only when a joint-velocity bound is active). Part (a) by one of the
backends of :mod:`skatelib.control.qp`, chosen by measurement (``make bench``):
* ``daqp``: condensed (states eliminated), dense, DAQP's dual active-set method on the loaded
  legs' forces in least-distance form, the default: fastest in ``make bench``; solved cold;
* ``proxqp``: the same condensed QP with ProxSuite's ProxQP, warm-started;
* ``osqp``: sparse multiple-shooting form (states kept, dynamics as equalities), OSQP, warm-started.

Offset-free: :class:`skatelib.control.observers.DisturbanceObserver` estimates the board's forward acceleration and the
robot's vertical one that the model misses (rolling friction and masses differ on the robot) and
the prediction carries them.
"""

# No postponed annotations here: pdoc (make docs) resolves a NamedTuple's field types only when
# they are evaluated at class creation.

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from skatelib.control.contact_rows import NF, step_constraints
from skatelib.control.joint_qp import solve_joints
from skatelib.control.linear_model import Discretizer, Feedback, continuous_model
from skatelib.control.mpc_config import MpcConfig
from skatelib.control.params import SkateParams
from skatelib.library.channels import NU, NX, S_Q, S_VEL, SWING

REDUCED = np.r_[0:S_Q.start, S_Q.stop:NX]  # the 16 states the forces drive (all but the joint angles)
BOARD_V_REDUCED = slice(S_Q.start, S_Q.start + 2)  # board_vx, board_vy among them
ROBOT_VZ_REDUCED = S_VEL.start + 2  # the robot's vertical speed (before the joint angles: same index)


def board_heading(x: np.ndarray) -> np.ndarray:
    """(2,) the board's forward direction in the world (its yaw is the robot's)."""
    return np.array([np.cos(x[5]), np.sin(x[5])])


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
        one iteration less per fixed variable."""
        mask = ~((self.lb == 0.0) & (self.ub == 0.0))
        return (mask, self.H[np.ix_(mask, mask)], self.g[mask], self.C[:, mask], self.lb[mask],
                self.ub[mask])


class HorizonRef(NamedTuple):
    """What the reference gives an update over its N steps.

    Attributes:
        x_ref: (N, 28) X_ref(k+1), k = 0..N-1.
        u_ref: (N, 24) feed-forward controls.
        contact: (N, 4) codes of step k.
        accelerating: (N,) bool, the acceleration mode at step k (see :func:`continuous_model`).
    """

    x_ref: np.ndarray
    u_ref: np.ndarray
    contact: np.ndarray
    accelerating: np.ndarray


class Bias(NamedTuple):
    """Constant accelerations the model misses (offset-free MPC, from the disturbance observer).

    Attributes:
        board_mps2: The board's forward acceleration (rolling friction, mass errors), added to
            every step.
        vertical_mps2: The robot's vertical acceleration (a mass error).
    """

    board_mps2: float = 0.0
    vertical_mps2: float = 0.0


def build_problem(p: SkateParams, cfg: MpcConfig, disc: Discretizer, fb: Feedback, ref: HorizonRef,
                  bias: Bias | None = None) -> MpcProblem:
    """The QP of one update (its joint part solved) over the reference ``ref``, with the
    observer's ``bias``."""
    x_ref, u_ref, contact, accelerating = ref
    board_bias_mps2, vertical_bias_mps2 = bias if bias is not None else Bias()
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
    C, lo, hi, step_rows = step_constraints(p, cfg, fb, contact, disc.dt)
    qd = solve_joints(fb.x[S_Q], x_ref[:, S_Q], u_ref[:, NF:], (w_all[S_Q], r_all[NF:]), disc.dt,
                      p.joint_velocity_limit_radps)
    return MpcProblem(H=H, g=g, C=C, l=lo, u=hi, lb=lb, ub=ub,
                      Ad=Ad_l, Bd=Bd_l, cd=cd_l, x0=fb.x[S], x0_full=fb.x, x_ref=xr, f_ref=fr, q_weights=w_all[S],
                      f_weights=r_all[:NF], qd=qd, step_rows=step_rows)


def controls(qp: MpcProblem, forces: np.ndarray) -> np.ndarray:
    """The full N x 24 control vector from the solved forces and the joint part."""
    N = len(qp.qd)
    return np.hstack([forces.reshape(N, NF), qp.qd]).reshape(-1)


def qp_objective(qp: MpcProblem, U: np.ndarray) -> float:
    """0.5 f'Hf + g'f of the condensed force QP at the forces of U (N x 24, flattened)."""
    f = U.reshape(len(qp.qd), NU)[:, :NF].reshape(-1)
    return float(0.5 * f @ qp.H @ f + qp.g @ f)
