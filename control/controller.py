"""The controller a robot runs on an entry, at its two rates (the paper's Fig. 3 without the plant):
the linear MPC at 30 Hz on the sensed state, fed from the entry's reference (with the
disturbance and coast observers), and the whole-body controller at every tick (510 Hz by
default), whose tasks follow the entry's body plan and whose contact forces aim at the MPC's.

A tick reads the robot's state (:class:`skatelib.control.feedback.MultibodyState`: from the
robot's estimator, or a plant's state in the proving ground) and returns the joint torques. The
loop that calls it at its rates, the plant and the verdicts belong to the proving ground
(:mod:`skatelib.proving`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from skatelib.control.body_plan import Plan
from skatelib.control.feedback import ON_FLOOR, MultibodyState, StateError, check_state, mpc_state
from skatelib.control.kinematics import LegKinematics
from skatelib.control.linear_model import Feedback
from skatelib.control.mpc import MpcConfig
from skatelib.control.multibody import DynamicsTerms, RobotDynamics
from skatelib.control.params import SkateParams
from skatelib.control.reference import Reference
from skatelib.control.steering import LineKeeper, SteeredPlan
from skatelib.control.update import MpcUpdate
from skatelib.control.wbc import WbcOutput, WholeBodyController
from skatelib.control.wbc_settings import WbcSettings
from skatelib.control.wbc_targets import ContactTable, TargetMaker
from skatelib.library.margins import forward_speed
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.runtime import MotionLibrary


@dataclass(frozen=True)
class Rates:
    """The controller's rates: a whole-body tick every ``tick_s`` [s], an MPC update every
    ``ticks_per_update`` ticks (2/1020 s x 17 = 1/30 s)."""

    tick_s: float = 2 / 1020
    ticks_per_update: int = 17

    @property
    def update_s(self) -> float:
        return self.tick_s * self.ticks_per_update


@dataclass
class Tick:
    """What one tick gives: the whole-body QP's output (torques, contact forces), the MPC's state
    at an update (else None), and the time the tick's whole-body part (pinocchio's terms, the
    tasks, the QP) and the MPC's problem and QP took [s]."""

    out: WbcOutput
    x: np.ndarray | None
    wbc_s: float
    mpc_s: float | None


class SkateController:
    """The MPC over the whole-body controller on one entry of a quadruped library.

    Args:
        lib: The library (its robot, its model figures).
        ref: The entry's reference (:class:`skatelib.control.reference.EntryReference`, or a
            maneuver's).
        plan: The whole-body controller's body plan of the same motion
            (:class:`skatelib.control.body_plan.BodyPlan`).
        model: The controller's model (``SkateParams.from_library``).
        mpc: The MPC's settings.
        wbc: The whole-body QP's settings.
        rates: The ticks' and updates' periods.
        keeper: Steers the board onto the plan's line through the deck's roll
            (:class:`skatelib.control.steering.LineKeeper`); None: the plan's roll as it is.
    """

    def __init__(self, lib: MotionLibrary, ref: Reference, plan: Plan, model: SkateParams,  # noqa: PLR0913
                 mpc: MpcConfig, wbc: WbcSettings, rates: Rates, keeper: LineKeeper | None = None):
        self.ref, self.p, self.mpc, self.rates = ref, model, mpc, rates
        self.keeper = keeper
        self.kin = LegKinematics.from_library(lib)
        self.dyn = RobotDynamics.from_library(lib)
        self.contacts = ContactTable(ref.contact, ref.t0, ref.t_stop, rates.tick_s)
        self.targets = TargetMaker(plan if keeper is None else SteeredPlan(plan, keeper), self.contacts, model, wbc)
        self.wbc = WholeBodyController(self.dyn.v_index, self.kin.torque_limit_Nm, model.mu_plan, wbc)
        self.mpc_update = MpcUpdate(ref, model, mpc, rates.update_s)
        self.mpc_update.keeper = keeper
        self.forces = np.zeros((3, 4))  # the MPC's, held over an update
        self._applied = np.zeros((3, 4))  # the whole-body QP's forces summed over this update's ticks
        self._ticks = 0
        self.solve_s = 0.0  # the last update's problem and QP [s]

    def applied_forces(self) -> np.ndarray | None:
        """(3, 4) the whole-body QP's forces averaged over the ticks since the last update (None before any)."""
        return self._applied / self._ticks if self.mpc_update.qp is not None and self._ticks else None

    def update(self, t: float, st: MultibodyState, T: DynamicsTerms) -> np.ndarray:
        """One MPC update at ``t`` on the sensed state (and pinocchio's terms at it): the forces the
        next ticks aim at. Returns the MPC's state (28 channels).

        Raises:
            QpSolveFailed: The MPC's QP has no solution.
        """
        x = mpc_state(st, T.com, T.com_v)
        fb = Feedback(x=x, r_robot=np.array(st.contact_points) - x[0:3, None],
                      r_board=self.p.moment_arms(board_rotations(x[5], x[26])),
                      torque_maps=self.kin.torque_maps(x[12:24], rpy_matrices(x[3:6])))
        # The observer compares the feedback with the model's prediction under the forces the
        # whole-body QP applied, not the MPC's request: the board weighs 2 kg, and a newton of
        # difference would read as a disturbance of 0.5 m/s^2.
        applied = self.applied_forces()
        if self.keeper is not None:
            self.keeper.update(t, st.deck_pos[0:2], st.deck_yaw, float(forward_speed(x)), self.rates.update_s)
        self._applied, self._ticks = np.zeros((3, 4)), 0
        step = self.mpc_update(t, fb, st.deck_pos[0:2], None if applied is None else applied.T.reshape(-1),
                               bool(np.any(st.foot_touch == ON_FLOOR)))
        self.solve_s = step.solve_s
        self.forces = step.forces
        return x

    def tick(self, t: float, st: MultibodyState, update: bool = False) -> Tick:
        """One whole-body tick at ``t`` on the sensed state, after an MPC ``update`` when asked: the
        torques (not yet clipped at the motors' limit) and the contact forces.

        Raises:
            StateError: The state breaks a field's shape, holds a NaN or an inf, or a touch code is
                unknown (:func:`~skatelib.control.feedback.check_state`), or ``t`` is not finite:
                nothing of the controller's own state has changed. A ``ValueError``.
            ValueError: A tick without ``update`` before the first update.
            QpSolveFailed: The MPC's or the whole-body QP has no solution.
        """
        t0 = time.perf_counter()
        if not math.isfinite(t):
            raise StateError(f"tick(t): t must be a finite time in seconds, got {t!r}")
        check_state(st)
        if not update and self.mpc_update.qp is None:
            raise ValueError("tick(update=False) before the MPC's first update: its forces are not there yet (the "
                             "whole-body QP would aim at none); pass update=True on the first tick")
        qp, vp = self.dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
        T = self.dyn.terms(qp, vp)
        t_terms = time.perf_counter() - t0
        x, mpc_s = None, None
        if update:
            x = self.update(t, st, T)
            mpc_s = self.solve_s
        t1 = time.perf_counter()
        feet_v = (T.J_feet @ vp).T
        out = self.wbc.solve(T, self.targets(t, st, T, feet_v, self.forces))
        wbc_s = t_terms + time.perf_counter() - t1
        self._applied += out.forces
        self._ticks += 1
        return Tick(out, x, wbc_s, mpc_s)
