"""The whole-body controller (the paper's WBC, as a weighted task QP): every tick, on the
floating-base multibody model (:mod:`skatelib.control.multibody`), one QP in the joint
accelerations qdd (18) and the stance feet's contact forces f (3 each), the joint torques
following from them:

    min  sum_k w_k |A_k x - b_k|^2          x = (qdd, f)     the tasks (wbc_tasks)
    s.t. lo_j <= C_j x <= up_j                                the constraints (wbc_constraints)

The tasks (:mod:`skatelib.control.wbc_tasks`): the model COM point's acceleration, the trunk's
angular acceleration, each swinging foot's acceleration, the contact forces toward the MPC's, and a
posture term; the constraints (:mod:`skatelib.control.wbc_constraints`): the floating base's
dynamics with the torque limits, the stance feet's accelerations, the normal bounds and friction
pyramids. Their targets come from :mod:`skatelib.control.wbc_targets`. This module sums the tasks
and stacks the constraints into one solver-neutral :class:`~skatelib.control.qp.QpProblem`, solved
by DAQP (dense dual active set) by default, chosen in ``make bench`` against the other backends.
With the default tasks and constraints the assembly runs in C (:mod:`skatelib.control.wbc_native`)
unless ``WbcSettings(compiled=False)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.control.multibody import DynamicsTerms
from skatelib.control.qp import QpProblem, QpSolveFailed, solve_qp
from skatelib.control.wbc_constraints import (
    NONE,
    Constraint,
    FloatingBaseDynamics,
    RowBlock,
    SurfaceForces,
    default_constraints,
)
from skatelib.control.wbc_native import CompiledAssembly, wbc_library
from skatelib.control.wbc_settings import NV, WbcSettings
from skatelib.control.wbc_targets import StanceSet, WbcTargets
from skatelib.control.wbc_tasks import Task, default_tasks


@dataclass
class WbcOutput:
    """One tick's solution: the torques (12,) [N m] in channel order, the contact forces (3, 4) [N]
    (zero for swinging feet), qdd (18,) and the backend's iterations."""

    tau: np.ndarray
    forces: np.ndarray
    qdd: np.ndarray
    iterations: int


class _Layout:
    """The QP's arrays for one stance set, their fixed parts filled once: the dense tasks' stacked
    rows and square-root weights, the Hessian's diagonal (the regularization and the selecting
    tasks' weights), each constraint's block of rows and its fixed bounds.

    Rows: the constraints' blocks in order (the generalized forces' 18 rows first)."""

    def __init__(self, stance: StanceSet, tasks: list[Task], constraints: list[Constraint], s: WbcSettings):
        self.stance = stance
        n = NV + stance.n_forces
        dense = [t for t in tasks if t.columns(stance) is None]
        sizes = [t.size(stance) for t in dense]
        ends = np.cumsum([0, *sizes])
        self.A, self.b = np.zeros((ends[-1], NV)), np.zeros(ends[-1])  # the dense tasks' rows over qdd
        self.dense = [(t, self.A[a:z], self.b[a:z]) for t, a, z in zip(dense, ends[:-1], ends[1:], strict=True)]
        self.w = np.sqrt(np.concatenate([np.full(k, t.weight) for t, k in zip(dense, sizes, strict=True)]))
        diagonal = np.full(n, s.regularization)
        self.selecting: list[tuple[Task, slice | np.ndarray]] = []  # (task, its columns)
        for t in tasks:
            columns = t.columns(stance)
            if columns is not None:
                diagonal[columns] += t.weight
                self.selecting.append((t, columns))
        self.q_diag = diagonal[:NV]
        self.H = np.diag(diagonal)
        self.g = np.zeros(n)
        sizes = [c.size(stance) for c in constraints]
        ends = np.cumsum([0, *sizes])
        m = int(ends[-1])
        self.rows = np.zeros((m, n))
        self.up, self.lo = np.full(m, NONE), np.full(m, -NONE)
        self.equality = np.zeros(m, dtype=bool)
        self.blocks = [(c, RowBlock(self.rows[a:z], self.lo[a:z], self.up[a:z], self.equality[a:z]))
                       for c, a, z in zip(constraints, ends[:-1], ends[1:], strict=True)]
        for c, block in self.blocks:
            c.fixed(block, stance)
        self.legs = np.ascontiguousarray(stance.legs, dtype=np.int32)  # for the C assembly
        self.addresses = tuple(a.ctypes.data for a in (self.legs, self.H, self.g, self.rows, self.lo, self.up))


class WholeBodyController:
    """One QP per tick (module docstring): ``tasks`` summed, ``constraints`` stacked (by default the
    paper's: :func:`~skatelib.control.wbc_tasks.default_tasks`,
    :func:`~skatelib.control.wbc_constraints.default_constraints`)."""

    def __init__(self, joint_columns: np.ndarray, torque_limit_Nm: float, mu: float,
                 settings: WbcSettings | None = None, tasks: list[Task] | None = None,
                 constraints: list[Constraint] | None = None):
        self.s = settings or WbcSettings()
        self.joints = np.asarray(joint_columns)
        contiguous = np.array_equal(self.joints, np.arange(6, NV))  # pinocchio's order: views, not copies
        self._j: slice | np.ndarray = slice(6, NV) if contiguous else self.joints
        self.mu = mu
        self.tasks = default_tasks(self.s, self._j) if tasks is None else tasks
        self.constraints = default_constraints(torque_limit_Nm, mu, self.s) if constraints is None else constraints
        self._torque = next((c for c in self.constraints if isinstance(c, FloatingBaseDynamics)), None)
        self._layouts: dict[bytes, _Layout] = {}
        self._native = self._compiled() if tasks is None and constraints is None and self.s.compiled else None

    def _compiled(self) -> CompiledAssembly | None:
        """The C assembly of the default tasks and constraints, or None without the compiled code."""
        lib = wbc_library()
        if lib is None:
            return None
        surface = next(c for c in self.constraints if isinstance(c, SurfaceForces))
        probe = self._layout(np.ones(4, dtype=bool))  # the cost's fixed diagonal over qdd is any layout's
        joints = np.arange(6, NV) if isinstance(self._j, slice) else self._j
        return CompiledAssembly(lib, self.s, probe.q_diag, surface.coefficients, joints)

    @property
    def tau_max(self) -> float:
        """The joints' torque limit [N m] (infinite without a :class:`FloatingBaseDynamics` constraint)."""
        return np.inf if self._torque is None else self._torque.limit_Nm

    @tau_max.setter
    def tau_max(self, limit_Nm: float) -> None:
        if self._torque is None:
            raise ValueError("this whole-body QP has no FloatingBaseDynamics constraint to set")
        self._torque.set_limit(limit_Nm)

    def problem(self, T: DynamicsTerms, tg: WbcTargets) -> QpProblem:
        """This tick's QP (its arrays are the controller's own, overwritten by the next tick)."""
        L = self._assemble(T, tg)
        return QpProblem(L.H, L.g, L.rows, L.lo, L.up, equality=L.equality)

    def solve(self, T: DynamicsTerms, tg: WbcTargets) -> WbcOutput:
        """Torques of this tick.

        Raises:
            QpSolveFailed: The backend found no solution (the caller records a fall).
        """
        L = self._assemble(T, tg)
        try:
            solution = solve_qp(QpProblem(L.H, L.g, L.rows, L.lo, L.up, equality=L.equality), self.s.qp_solver)
        except QpSolveFailed as e:
            raise QpSolveFailed(f"whole-body QP: {e}") from e
        x = solution.x
        tau = (L.rows[:NV] @ x + T.h)[self._j]  # the first 18 rows: M qdd - J_c^T f (wbc_constraints)
        forces = np.zeros((3, 4))
        forces[:, L.stance.legs] = x[NV:].reshape(-1, 3).T
        return WbcOutput(tau=tau, forces=forces, qdd=x[:NV], iterations=solution.iterations)

    def _assemble(self, T: DynamicsTerms, tg: WbcTargets) -> _Layout:
        """The tasks summed and the constraints stacked into the stance set's arrays."""
        L = self._layout(tg.stance)
        if self._native is not None:
            assert self._torque is not None
            self._native((T.M.ravel(), T.h, T.J_feet.ravel(), T.dJv_feet.ravel(), T.J_com.ravel(), T.dJv_com,
                          tg.stance_acc.ravel(), tg.com_acc, tg.angular_acc, tg.swing_acc.ravel(), tg.posture_acc,
                          tg.forces.ravel(), tg.deck_R.ravel(), tg.on_deck, (self._torque.limit_Nm,)),
                         L.addresses[0], len(L.stance.legs), L.addresses[1:])
            return L
        stance = L.stance
        # Cost: the dense tasks' weighted rows A x = b over qdd stacked, A'A formed once; the
        # selecting tasks on the diagonal (fixed) and the gradient.
        A, b, w = L.A, L.b, L.w
        for task, task_A, task_b in L.dense:
            task_A[:] = task.jacobian(T, stance)
            task_b[:] = task.target(T, tg, stance)
        A *= w[:, None]
        Hq = A.T @ A
        Hq.flat[::NV + 1] += L.q_diag
        L.H[:NV, :NV] = Hq
        g = L.g
        g[:NV] = -(A.T @ (w * b))
        g[NV:] = -0.0  # -0.0 - x is -x to the bit, signed zeros too: the force task's -w f as written alone
        for task, columns in L.selecting:
            g[columns] -= task.weight * task.target(T, tg, stance)
        Jc = T.J_feet[stance.legs].reshape(-1, NV)  # stacked stance Jacobians
        for c, block in L.blocks:
            c.fill(block, T, tg, stance, Jc)
        return L

    def _layout(self, stance: np.ndarray) -> _Layout:
        key = np.asarray(stance, dtype=bool).tobytes()
        out = self._layouts.get(key)
        if out is None:
            out = self._layouts[key] = _Layout(StanceSet.of(stance), self.tasks, self.constraints, self.s)
        return out
