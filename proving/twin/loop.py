"""The full-physics closed loop: the MPC at 30 Hz (fed from ``MotionLibrary.window()`` through the
entry's reference, with the model loop's observers) and the whole-body controller at 510 Hz
(:mod:`skatelib.control.wbc`, its targets from :mod:`skatelib.control.wbc_targets`) drive a
multibody plant (the MuJoCo twin) stepping at its own timestep: 2 plant steps per whole-body tick
and 17 ticks per MPC update (1/30 s) at the twin's 1/1020 s.

Each tick: the sensed state (:mod:`skatelib.proving.twin.sensors`), the controller's tick on it
(:class:`skatelib.control.controller.SkateController`: pinocchio's terms of the library's robot at
it; on the first tick of each update the MPC's update on the same state and terms, the observers,
the horizon, one QP; then the tasks on the measured board, one whole-body QP), the torques
(clipped at the limit, as the motors do), the plant's steps. The plant's true state feeds the measures
(:mod:`skatelib.proving.twin.metrics`) and the fall checks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.body_plan import BodyPlan, Plan
from skatelib.control.controller import Rates, SkateController
from skatelib.control.estimator.estimator import EstimatorSettings
from skatelib.control.estimator.reading import ReadingError
from skatelib.control.feedback import StateError, mpc_state, quat_wxyz
from skatelib.control.kinematics import LegKinematics
from skatelib.control.multibody import RobotDynamics
from skatelib.control.qp import QpSolveFailed
from skatelib.control.reference import EntryReference, Reference
from skatelib.control.steering import BoardPath, LineKeeper, SteeringGains
from skatelib.control.wbc_settings import WbcSettings
from skatelib.control.wbc_targets import ContactTable
from skatelib.library.channels import BOARD
from skatelib.library.rotations import rpy_matrices
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.twin.estimate import EstimatedFeedback, EstimatorErrors, start_state
from skatelib.proving.twin.metrics import Meter, MeterPlan, TwinMeasures
from skatelib.proving.twin.record import TwinRecord
from skatelib.proving.twin.sensors import MultibodyPlant, SensedState, Sensors
from skatelib.runtime import Entry, MotionLibrary
from skatelib.sim.sensors import SensorErrors

PRELOAD_M = 2e-4  # the deck feet start this far into the deck (a foot above it would start in the air)
FALL_HEIGHT_M = 0.10  # trunk this close above the deck's top: fallen
FALL_TILT_RAD = 0.6


@dataclass(frozen=True)
class Shove:
    """An impulse on the trunk: ``impulse_Ns`` (world x, y, z) [N s], spread over the one whole-body
    tick that holds ``t_s`` (the entry's clock) [s]."""

    t_s: float
    impulse_Ns: tuple[float, float, float]


@dataclass(frozen=True)
class TwinLoopSettings:
    """Rates, sensors and the whole-body QP's settings of a full-physics run."""

    steps_per_tick: int = 2  # plant steps per whole-body tick
    ticks_per_update: int = 17  # whole-body ticks per MPC update
    sensors: Sensors = field(default_factory=Sensors)
    wbc: WbcSettings = field(default_factory=WbcSettings)
    steering: SteeringGains | None = field(default_factory=SteeringGains)  # None: no line keeper
    state: str = "true"  # the controller's feedback: "estimate" (the robot's sensors and estimator) or "true"
    sensor_errors: SensorErrors = field(default_factory=SensorErrors)
    estimator: EstimatorSettings | None = None  # the estimator's settings (None: its defaults)
    shove: Shove | None = None


@dataclass(frozen=True)
class Ride:
    """What a run follows: the MPC's reference, the whole-body controller's body plan, where the
    plant starts (the model state, the board's x, y, z, yaw; ``from_velocity_mps`` forward) and the plan's
    board at the end (for the drift)."""

    ref: Reference
    plan: Plan
    x0: np.ndarray
    board0: np.ndarray
    board_end: np.ndarray
    from_velocity_mps: float = 0.0
    path: BoardPath | None = None  # the plan's board, for the line keeper (None: no steering feedback)


def entry_ride(lib: MotionLibrary, key: str | Entry, loop: ClosedLoop, foot_radius_m: float) -> Ride:
    """An entry (by key, or an entry made of the library's: a chained ride), its transfer and the
    ride after it; a transition starts rolling at its start speed."""
    entry = lib[key] if isinstance(key, str) else key
    if entry.board_pos is None:
        raise ValueError(f"{entry.key}: not a quadruped entry (no board)")
    ref = EntryReference(lib, entry, loop.model, loop.settings)
    board = np.asarray(entry.board_pos, dtype=np.float64)
    return Ride(ref, BodyPlan(ref, foot_radius_m), np.asarray(entry.state[0], dtype=np.float64), board[0], board[-1],
                from_velocity_mps=entry.from_velocity_mps, path=BoardPath.from_board_pos(np.asarray(entry.t), board))


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
    # (ticks, 5) per tick: t, deck roll, the trunk's offset from the deck's centre line, feet
    # touching, the smallest foot normal force.
    ticks: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    estimator: EstimatorErrors | None = None  # the estimator's errors against the truth (fed the estimate)


class TwinLoop:
    """One ride on a multibody plant: an entry's (``key``: its key, or an entry made of the library's,
    a chained ride; :func:`entry_ride`) or a :class:`Ride`, by the robot side's controller
    (:class:`skatelib.control.controller.SkateController`) on its sensed states."""

    def __init__(self, lib: MotionLibrary, key: str | Entry | Ride, loop: ClosedLoop, plant: MultibodyPlant,
                 settings: TwinLoopSettings | None = None, keep: bool = False):
        self.loop, self.plant, self.keep = loop, plant, keep
        self.cfg = settings or TwinLoopSettings()
        self.p = p = loop.model
        self.kin = LegKinematics.from_library(lib)
        ride = key if isinstance(key, Ride) else entry_ride(lib, key, loop, self.kin.foot_radius_m)
        self.ref = ride.ref
        self.tick_s = plant.timestep_s * self.cfg.steps_per_tick
        rates = Rates(self.tick_s, self.cfg.ticks_per_update)
        keeper = None if ride.path is None or self.cfg.steering is None else LineKeeper(ride.path, p, self.cfg.steering)
        self.ctrl = SkateController(lib, ride.ref, ride.plan, p, loop.mpc, self.cfg.wbc, rates, keeper)
        self.dt = rates.update_s
        self.sensed = SensedState(self.cfg.sensors, self.tick_s, loop.settings.seed)
        self._start(ride)
        plan = MeterPlan(self.ref.t_end, ride.board_end, self.contacts.at_times, self.ref.stage_ends)
        self.meter = Meter(self.tick_s, self.kin.torque_limit_Nm, plan, plant.axle_below_deck_m)
        self.run = TwinRun(self.meter.m)
        self.feedback: Callable[[Any], Any] = self.sensed
        self._truth_dyn: RobotDynamics | None = None
        if self.cfg.state == "estimate":
            on_deck = self.ref.contact(self.ref.t0) == BOARD
            start = start_state(ride.x0, ride.board0, ride.from_velocity_mps, on_deck, p.com_offset_m)
            estimated = EstimatedFeedback(plant, lib, p, self.contacts.at, start, self.tick_s, self.cfg.sensor_errors,
                                          loop.settings.seed, self.cfg.estimator)
            self.run.estimator = estimated.errors
            self.feedback = estimated
            # a kept run records the plant's true state beside the estimate: the truth's centre of
            # mass by a model of its own (the controller's pinocchio data stay the controller's)
            self._truth_dyn = RobotDynamics.from_library(lib) if keep else None
        elif self.cfg.state != "true":
            raise ValueError(f"state {self.cfg.state!r}: give 'estimate' or 'true'")

    @property
    def contacts(self) -> ContactTable:
        return self.ctrl.contacts

    def _start(self, ride: Ride) -> None:
        """The plant at the ride's first state, its deck feet on the deck's top, rolling at its speed."""
        x0, board0 = ride.x0, ride.board0
        R = rpy_matrices(x0[3:6])
        self.plant.place(x0[0:3] - R @ self.p.com_offset_m, quat_wxyz(R), x0[12:24],
                         np.array([board0[0], board0[1], board0[3]]))
        if ride.from_velocity_mps:
            self.plant.launch(ride.from_velocity_mps)
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
            except (StateError, ReadingError) as e:  # no state to act on (the plant's diverged): the robot stops
                self.run.fall = f"the controller refused its state at t = {self.t:.2f} s ({e})"
            if self.run.fall:
                break
        self.meter.finish()
        self.run.ticks = self.meter.table
        return self.run

    def tick(self, update: bool = False) -> None:
        """One whole-body tick of the controller on the sensed plant (after the MPC's update on its
        first), its plant steps and the measures."""
        st = self.feedback(self._true)
        applied = self.ctrl.applied_forces() if update and self.keep else None
        tick = self.ctrl.tick(self.t, st, update)
        if tick.x is not None:
            self.run.mpc_times_s.append(tick.mpc_s or 0.0)
            if self.keep:
                if applied is not None:
                    self.run.record.applied(applied)
                self.run.qpos.append(np.array(self.plant.qpos()))
                if self.cfg.state == "estimate":
                    self.run.record.add(self.t, self._true_model_state(), self._true)
                    self.run.record.estimated(tick.x)
                else:
                    self.run.record.add(self.t, tick.x, st)
        self.run.wbc_times_s.append(tick.wbc_s)
        limit = self.kin.torque_limit_Nm
        shove = self.cfg.shove
        pushed = shove is not None and self.t <= shove.t_s < self.t + self.tick_s
        if pushed and shove is not None:
            self.plant.push(np.asarray(shove.impulse_Ns) / self.tick_s)
        self.plant.step(np.clip(tick.out.tau, -limit, limit), self.cfg.steps_per_tick)
        if pushed:
            self.plant.push(np.zeros(3))
        self.t += self.tick_s
        after = self._true = self.plant.state()
        self.meter.tick(self.t, after, tick.out.tau)
        self.run.fall = self._fall(after)

    def _true_model_state(self) -> np.ndarray:
        """The MPC's 28 channels of the plant's true state now (a kept run on the estimate)."""
        s, dyn = self._true, self._truth_dyn
        assert dyn is not None
        T = dyn.terms(*dyn.configuration(s.trunk_pos, s.trunk_R, s.q, s.trunk_v, s.trunk_omega, s.qd))
        return mpc_state(s, T.com, T.com_v)

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
