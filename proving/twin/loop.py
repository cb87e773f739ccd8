"""The full-physics closed loop: the MPC at 30 Hz (fed from ``MotionLibrary.window()`` through the
entry's reference, with the model loop's observers) and the whole-body controller at 510 Hz
(:mod:`skatelib.control.wbc`, its tasks from :mod:`skatelib.control.wbc_tasks`) drive a
multibody plant (the MuJoCo twin) stepping at its own timestep: 2 plant steps per whole-body tick
and 17 ticks per MPC update (1/30 s) at the twin's 1/1020 s.

Each tick: the sensed state (:mod:`skatelib.control.feedback`), pinocchio's terms of the
library's robot at it; on the first tick of each update the MPC's update on the same state and
terms (the centre of mass is the whole robot's), the observers, the horizon, one QP; then the
tasks on the measured board, one whole-body QP, the torques (clipped at the limit, as the motors
do). The plant's true state feeds the measures
(:mod:`skatelib.proving.twin.metrics`) and the fall checks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.body_plan import BodyPlan
from skatelib.control.feedback import MultibodyState, mpc_state, quat_wxyz
from skatelib.control.kinematics import LegKinematics
from skatelib.control.linear_model import Discretizer, Feedback
from skatelib.control.mpc import Bias, MpcProblem, build_problem
from skatelib.control.multibody import DynamicsTerms, RobotDynamics
from skatelib.control.observers import CoastObserver, DisturbanceObserver
from skatelib.control.qp import QpSolveFailed, make_solver
from skatelib.control.reference import EntryReference
from skatelib.control.wbc import WbcSettings, WholeBodyController
from skatelib.control.wbc_tasks import ContactTable, TaskMaker
from skatelib.library.channels import BOARD
from skatelib.library.margins import forward_speed, momentum_speed
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.twin.metrics import Meter, TwinMeasures, planned_floor_near
from skatelib.proving.twin.record import TwinRecord
from skatelib.proving.twin.sensors import MultibodyPlant, SensedState, Sensors

PRELOAD_M = 2e-4  # the deck feet start this far into the deck (a foot above it would start in the air)
FALL_HEIGHT_M = 0.10  # trunk this close above the deck's top: fallen
FALL_TILT_RAD = 0.6


@dataclass(frozen=True)
class TwinLoopSettings:
    """Rates, sensors and the whole-body QP's settings of a full-physics run."""

    steps_per_tick: int = 2  # plant steps per whole-body tick
    ticks_per_update: int = 17  # whole-body ticks per MPC update
    sensors: Sensors = field(default_factory=Sensors)
    wbc: WbcSettings = field(default_factory=WbcSettings)


@dataclass(frozen=True)
class Ride:
    """What a run follows: the MPC's reference, the whole-body controller's body plan, where the
    plant starts (the model state, the board's x, y, z, yaw; ``speed_mps`` forward) and the plan's
    board at the end (for the drift)."""

    ref: Any  # a skatelib.control.reference.Reference
    plan: Any  # has .at(t) -> BodyTargets
    x0: np.ndarray
    board0: np.ndarray
    board_end: np.ndarray
    speed_mps: float = 0.0


def entry_ride(lib: Any, key: str | Any, loop: ClosedLoop, foot_radius_m: float) -> Ride:
    """An entry (by key, or an entry made of the library's: a chained ride), its transfer and the
    ride after it; a transition starts rolling at its start speed."""
    entry = lib[key] if isinstance(key, str) else key
    ref = EntryReference(lib, entry, loop.model, loop.settings)
    return Ride(ref, BodyPlan(ref, foot_radius_m), np.asarray(entry.state[0], dtype=np.float64),
                np.asarray(entry.board_pos[0], dtype=np.float64), np.asarray(entry.board_pos[-1], dtype=np.float64),
                speed_mps=entry.from_velocity_mps)


@dataclass
class TwinRun:
    """One run's outcome: the measures, why it stopped early (``fall``), the controllers' times
    and, for a kept run, the plant's configurations and the record at each MPC update."""

    measures: TwinMeasures
    fall: str = ""
    wbc_times_s: list[float] = field(default_factory=list)
    mpc_times_s: list[float] = field(default_factory=list)
    qpos: list[np.ndarray] = field(default_factory=list)
    record: TwinRecord = field(default_factory=TwinRecord)
    # Per tick: t, deck roll, the trunk's offset from the deck's centre line, feet touching, the
    # smallest foot normal force.
    ticks: list[tuple[float, float, float, int, float]] = field(default_factory=list)


class TwinLoop:
    """One ride on a multibody plant: an entry's (``key``: its key, or an entry made of the library's,
    a chained ride; :func:`entry_ride`) or a :class:`Ride`."""

    def __init__(self, lib: Any, key: Any, loop: ClosedLoop, plant: MultibodyPlant,
                 settings: TwinLoopSettings | None = None, keep: bool = False):
        self.loop, self.plant, self.keep = loop, plant, keep
        self.cfg = settings or TwinLoopSettings()
        self.p = p = loop.model
        self.kin = LegKinematics.from_library(lib)
        ride = key if isinstance(key, Ride) else entry_ride(lib, key, loop, self.kin.foot_radius_m)
        self.ref = ride.ref
        self.dyn = RobotDynamics.from_library(lib)
        self.tick_s = plant.timestep_s * self.cfg.steps_per_tick
        self.contacts = ContactTable(self.ref.contact, self.ref.t0, self.ref.t_stop, self.tick_s)
        self.tasks = TaskMaker(ride.plan, self.contacts, p, self.cfg.wbc)
        self.wbc = WholeBodyController(self.dyn.v_index, self.kin.torque_limit_Nm, p.mu_plan, self.cfg.wbc)
        self.dt = self.tick_s * self.cfg.ticks_per_update
        self.disc = Discretizer(p, self.dt)
        self.solver = make_solver(loop.mpc.solver)
        self.observer = DisturbanceObserver(loop.mpc.disturbance_gain)
        self.coast = CoastObserver(loop.mpc.coast_gain)
        self.sensed = SensedState(self.cfg.sensors, self.tick_s, loop.settings.seed)
        self.meter = Meter(self.tick_s, self.kin.torque_limit_Nm, self.ref.stage_ends)
        self.run = TwinRun(self.meter.m)
        self.forces = np.zeros((3, 4))  # the MPC's, held over an update
        self._qp: MpcProblem | None = None
        self._applied = np.zeros((3, 4))  # the whole-body QP's forces summed over this update's ticks
        self._ticks = 0
        self.board_end = ride.board_end
        self._start(ride)

    def _start(self, ride: Ride) -> None:
        """The plant at the ride's first state, its deck feet on the deck's top, rolling at its speed."""
        x0, board0 = ride.x0, ride.board0
        R = rpy_matrices(x0[3:6])
        self.plant.place(x0[0:3] - R @ self.p.com_offset_m, quat_wxyz(R), x0[12:24],
                         np.array([board0[0], board0[1], board0[3]]))
        if ride.speed_mps:
            self.plant.launch(ride.speed_mps)
        on_deck = self.ref.contact(self.ref.t0) == BOARD
        deck_top = float(self.plant.state().deck_pos[2])
        high = float(np.max(self.plant.foot_centres()[2, on_deck]))  # every deck foot touching, 0.2 mm pressed
        self.plant.shift_robot(deck_top + self.kin.foot_radius_m - high - PRELOAD_M)
        self.t = self.ref.t0
        self._true = self.plant.state()  # the plant now; each tick reads it and leaves the next

    def ride(self) -> TwinRun:
        """The entry, the transfer and the ride; stops at a fall."""
        for _ in range(round((self.ref.t_stop - self.ref.t0) / self.dt)):
            try:
                for k in range(self.cfg.ticks_per_update):
                    self.tick(update=k == 0)
                    if self.run.fall:
                        break
            except QpSolveFailed as e:
                self.run.fall = f"a QP failed at t = {self.t:.2f} s ({e})"
            if self.run.fall:
                break
        self.meter.finish()
        return self.run

    def update(self, st: MultibodyState, T: DynamicsTerms) -> None:
        """One MPC update on the sensed state (and pinocchio's terms at it): the forces the next
        ticks aim at."""
        x = mpc_state(st, T.com, T.com_v)
        t, ref, cfg = self.t, self.ref, self.loop.mpc
        fb = Feedback(x=x, r_robot=np.array(st.contact_points) - x[0:3, None],
                      r_board=self.p.moment_arms(board_rotations(x[5], x[26])),
                      torque_maps=self.kin.torque_maps(x[12:24], rpy_matrices(x[3:6])))
        v_ride = float(forward_speed(x))
        if self._qp is not None and self._ticks:
            # The observer compares the feedback with the model's prediction under the forces the
            # whole-body QP applied, not the MPC's request: the board weighs 2 kg, and a newton
            # of difference would read as a disturbance of 0.5 m/s^2.
            self.observer.predict(self._qp, (self._applied / self._ticks).T.reshape(-1))
            if self.keep:
                self.run.record.applied(self._applied / self._ticks)
        self._applied, self._ticks = np.zeros((3, 4)), 0
        bias = self.observer.update(v_ride, self.dt, float(x[8]))
        board_xy = st.deck_pos[0:2]
        ref.observe(t, x, board_xy)
        measured = self.coast.update(ref.coasting(t), float(momentum_speed(x, self.p.mass_kg, self.p.board_mass_kg)),
                                     self.dt)
        coast = ref.prior_coast_mps2(t) if measured is None else measured
        horizon = ref.horizon(t, cfg.horizon, self.dt, board_xy, v_ride, coast if cfg.coast_compensation else None)
        t0 = time.perf_counter()
        self._qp = build_problem(self.p, cfg, self.disc, fb, horizon, Bias(bias, self.observer.vertical_mps2))
        U = self.solver.solve(self._qp)
        self.run.mpc_times_s.append(time.perf_counter() - t0)
        self.forces = U[:12].reshape(4, 3).T
        if self.keep:
            self.run.qpos.append(np.array(self.plant.qpos()))
            self.run.record.add(t, x, st)

    def tick(self, update: bool = False) -> None:
        """One whole-body tick (after the MPC's ``update`` on its first) and its plant steps."""
        st = self.sensed(self._true)
        t0 = time.perf_counter()
        qp, vp = self.dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
        T = self.dyn.terms(qp, vp)
        t_terms = time.perf_counter() - t0
        if update:
            self.update(st, T)
        t1 = time.perf_counter()
        feet_v = (T.J_feet @ vp).T
        out = self.wbc.solve(T, self.tasks(self.t, st, T, feet_v, self.forces))
        self.run.wbc_times_s.append(t_terms + time.perf_counter() - t1)
        self._applied += out.forces
        self._ticks += 1
        self.plant.step(np.clip(out.tau, -self.kin.torque_limit_Nm, self.kin.torque_limit_Nm), self.cfg.steps_per_tick)
        self.t += self.tick_s
        after = self._true = self.plant.state()
        self.meter.tick(after, out.tau, planned_floor_near(self.contacts.at, self.t))
        self.meter.speeds(after, self.t, self.ref.t_end, np.array([np.cos(after.deck_yaw), np.sin(after.deck_yaw)]))
        self.meter.drift(after, self.t, self.ref.t_end, self.board_end)
        side = np.array([-np.sin(after.deck_yaw), np.cos(after.deck_yaw)])
        self.run.ticks.append((self.t, after.deck_roll, float(side @ (after.trunk_pos[0:2] - after.deck_pos[0:2])),
                               int(np.sum(after.foot_touch > 0)), float(np.min(after.foot_load_N))))
        self.run.fall = self._fall(after)

    def _fall(self, st: Any) -> str:
        height = float(st.trunk_pos[2] - st.deck_pos[2])
        tilt = float(np.arccos(np.clip(st.trunk_R[2, 2], -1.0, 1.0)))
        if height < FALL_HEIGHT_M:
            return f"trunk {height:.3f} m above the deck at t = {self.t:.2f} s"
        if tilt > FALL_TILT_RAD:
            return f"trunk tilted {tilt:.2f} rad at t = {self.t:.2f} s"
        if st.floor_touches:
            return f"{', '.join(st.floor_touches)} on the floor at t = {self.t:.2f} s"
        return ""
