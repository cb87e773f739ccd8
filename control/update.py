"""The MPC's update at 30 Hz, as the paper's Fig. 3 draws it between the estimator and the
whole-body controller: the disturbance observer (what the model predicted for the last update
against what the feedback shows), the coast observer (the rolling deceleration while coasting),
the entry reference's horizon from the measured board and speed, one QP.

The controller (:class:`skatelib.control.controller.SkateController`) and the proving ground's
model loop (:mod:`skatelib.proving.loop`) both update through it; they differ in what they feed
it (the sensed multibody state, or the model plant's) and in the forces they tell it were
applied (the whole-body QP's, or the MPC's own).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from skatelib.control.linear_model import Discretizer, Feedback
from skatelib.control.mpc import Bias, HorizonRef, MpcConfig, MpcProblem, build_problem
from skatelib.control.mpc_solvers import make_solver
from skatelib.control.observers import CoastObserver, DisturbanceObserver
from skatelib.control.params import SkateParams
from skatelib.control.reference import Reference
from skatelib.control.steering import LineKeeper
from skatelib.library.margins import forward_speed, momentum_speed


@dataclass(frozen=True)
class MpcStep:
    """One update's outcome: the QP's solution (forces of the four feet, then joint velocities), the
    horizon it tracked, and the time its problem and QP took [s]."""

    U: np.ndarray
    horizon: HorizonRef
    solve_s: float

    @property
    def forces(self) -> np.ndarray:
        """(3, 4) the feet's forces of the first step."""
        return np.asarray(self.U[:12].reshape(4, 3).T)


class MpcUpdate:
    """The MPC with its observers on one reference, updated every ``dt`` [s]."""

    def __init__(self, ref: Reference, model: SkateParams, cfg: MpcConfig, dt: float):
        self.ref, self.p, self.cfg, self.dt = ref, model, cfg, dt
        self.disc = Discretizer(model, dt)
        self.solver = make_solver(cfg.solver)
        self.observer = DisturbanceObserver(cfg.disturbance_gain)
        self.coast = CoastObserver(cfg.coast_gain, fit=cfg.coast_fit)
        self.qp: MpcProblem | None = None  # the last update's
        self.keeper: LineKeeper | None = None  # steers the board onto the plan's line (the controller updates it)

    def __call__(self, t: float, fb: Feedback, board_xy: np.ndarray, applied: np.ndarray | None,
                 on_floor: bool = False) -> MpcStep:
        """The update at ``t`` on the feedback ``fb`` (the board's origin at ``board_xy``), after the
        forces ``applied`` since the last update (12 values, foot by foot; None: none to compare);
        ``on_floor``: a foot is sensed on the floor (the plan's coast or not, the coast observer
        then takes no sample: a foot landing early brakes robot and board, which is no rolling
        friction).

        Raises:
            QpSolveFailed: The QP has no solution.
        """
        x, ref, cfg = fb.x, self.ref, self.cfg
        v_ride = float(forward_speed(x))
        if self.qp is not None and applied is not None:
            self.observer.predict(self.qp, applied)
        bias = self.observer.update(v_ride, self.dt, float(x[8]))
        ref.observe(t, x, board_xy)
        speed = float(momentum_speed(x, self.p.mass_kg, self.p.board_mass_kg))
        measured = self.coast.update(ref.coasting(t) and not on_floor, speed, self.dt)
        coast = ref.prior_coast_mps2(t) if measured is None else measured
        horizon = ref.horizon(t, cfg.horizon, self.dt, board_xy, v_ride, coast if cfg.coast_compensation else None)
        if self.keeper is not None:
            horizon = self.keeper.steer(horizon)
        t0 = time.perf_counter()
        qp = build_problem(self.p, cfg, self.disc, fb, horizon, Bias(bias, self.observer.vertical_mps2))
        U = self.solver.solve(qp)
        self.qp = qp
        return MpcStep(U, horizon, time.perf_counter() - t0)
