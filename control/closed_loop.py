"""Closed loop: the MPC fed by ``skatelib.runtime`` drives the plant through one library entry,
then through the push leg's transfer back onto the deck and four-leg riding, and a verdict.

Timeline (Sec. IV-A): the entry's strides; then ``transfer_s`` with the push leg swinging back to
the deck (three legs on the board, its foot on a Bezier curve, which carries no force in the
single-rigid-body plant); then four-leg riding at the speed reached, ``ride_s`` long.

The reference positions are re-anchored to the board at every update: the robot controls where
its body is over the deck (what its feet measure), not where the optimization's world frame was.
Its forward speeds are moved by the coast compensation (:meth:`EntryReference.speed_offset`):
only a foot on the ground changes the momentum of robot and board, so each push aims at the
speed that the following coast turns into the plan's, with the coast's rolling deceleration
measured (:class:`CoastObserver`).

After every update the stance legs' joint angles follow by inverse kinematics from where their
feet touch the plant's deck or ground (:mod:`skatelib.control.kinematics`, the whole-body
controller's share); their torques and joint limits are checked, and the next update's QP holds
the torques within the limit at those angles.

Verdict (fails on any of):
* speed: the speed delivered, one second after the entry ends, more than 5 % from the label.
  Delivered speed = the plant's momentum speed (m_R v_R + m_B v_B) / (m_R + m_B) at that time
  plus the speed that rolling friction took in that second (any coasting board loses it; the
  entry cannot be blamed for it). Both are reported;
* a fall: body height over the deck or roll/pitch beyond limits, a foot farther from the body
  than the entry ever put it (it would leave the deck), deck roll beyond the wheel limit;
* a slip: a commanded force outside the plant's Coulomb cone;
* a stance joint torque above the limit, a stance foot its leg cannot reach, a stance joint
  beyond its limit.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Protocol

import numpy as np
from skatelib.control.kinematics import LegKinematics
from skatelib.control.linear_model import Feedback
from skatelib.control.mpc import (
    CoastObserver,
    Discretizer,
    DisturbanceObserver,
    MpcConfig,
    QpSolveFailed,
    board_heading,
    build_problem,
    make_solver,
)
from skatelib.control.params import Disturbances, SkateParams
from skatelib.control.plant import NB, Plant
from skatelib.library import schema
from skatelib.library.channels import (
    BOARD,
    CONTROL_NAMES,
    GROUND,
    I_BOARD_ROLL,
    LEGS,
    NU,
    NX,
    S_Q,
    STATE_NAMES,
    SWING,
)
from skatelib.library.margins import forward_speed, momentum_speed
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.runtime import Entry, MotionLibrary

SPEED_TOLERANCE = 0.05
HEIGHT_LIMIT_M = 0.05  # body height over the deck may leave its reference by this much
TILT_LIMIT_RAD = 0.35
REACH_MARGIN_M = 0.05
IK_TOLERANCE_M = 0.002  # a stance foot the inverse kinematics cannot put on its contact point


@dataclass(frozen=True)
class TrackSettings:
    """Closed-loop run settings.

    Attributes:
        plant_substeps: Plant RK4 steps per MPC update (30 Hz x 17 = 510 Hz).
        transfer_s: Push leg back onto the deck after the entry [s] (Sec. IV-A: 0.4 s).
        ride_s: Four-leg riding after the transfer [s].
        seed: Random seed of the feedback noise.
        board_mass_always: The MPC models the board with its mass (Eq. 9) also while balancing;
            False uses the paper's balancing model Eq. (5a) there (the board follows the robot),
            with which the default model-error set falls after the push-off (README "Closed loop").
    """

    plant_substeps: int = 17
    board_mass_always: bool = True
    transfer_s: float = 0.4
    ride_s: float = 1.5
    seed: int = 0


@dataclass(frozen=True)
class TrackResult:
    """One entry's closed-loop run (JSON-able numbers; ``trace`` holds the time series)."""

    key: str
    label_mps: float
    speed_after_1s_mps: float
    momentum_after_1s_mps: float
    momentum_at_end_mps: float
    delivered_mps: float
    speed_error: float
    max_deck_roll_rad: float
    max_position_error_m: float
    max_attitude_error_rad: float
    min_normal_N: float
    max_friction_use: float
    min_friction_margin_N: float
    slips: int
    max_joint_torque_Nm: float
    max_ik_residual_m: float
    joint_limit_excess_rad: float
    mpc_median_ms: float
    mpc_max_ms: float
    fall: str
    passed: bool
    reasons: str

    def as_dict(self) -> dict[str, float | str | bool | int]:
        return asdict(self)


@dataclass
class Trace:
    """Time series of a run, per plant step, for plots and Rerun: t (M,), plant state (M, 31),
    reference (M, 28), applied forces (M, 3, 4), joint velocities (M, 12), contact (M, 4) and
    contact points (M, 3, 4)."""

    t: np.ndarray
    state: np.ndarray
    reference: np.ndarray
    forces: np.ndarray
    qd: np.ndarray
    contact: np.ndarray
    feet: np.ndarray

    def as_entry(self, key: str, label_mps: float, stride: int = 1) -> Entry:
        """The run as a library entry (every ``stride``-th plant step; control k acts on
        [t_k, t_k+1), so one row fewer), for the same views as the library's entries."""
        sl = slice(None, None, stride)
        n = len(self.t[sl])
        forces = np.transpose(self.forces[sl], (0, 2, 1)).reshape(n, 12)  # f_<leg>_<axis>, legs in order
        state = self.state[sl]
        arrays = {
            schema.D_T: self.t[sl], schema.D_STATE: state[:, :NX],
            schema.D_CONTROL: np.hstack([forces, self.qd[sl]])[:-1],
            schema.D_CONTACT: self.contact[sl], schema.D_FOOT_POS: np.transpose(self.feet[sl], (0, 2, 1)),
            schema.D_BOARD_POS: np.column_stack([state[:, NX:NX + 3], state[:, 5]]),
        }
        columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES, schema.D_CONTACT: LEGS,
                   schema.D_FOOT_POS: LEGS, schema.D_BOARD_POS: ("board_x", "board_y", "board_z", "board_yaw")}
        attrs = {"target_velocity_mps": label_mps, "n_strides": 0, "success": True, "status": "closed loop"}
        return Entry(key, attrs, arrays, columns)


def push_intervals(t: np.ndarray, on_ground: np.ndarray, t_end: float) -> list[tuple[float, float, float]]:
    """(start, end, end of the coast after it) of each stance of the push foot on the ground."""
    edges = np.diff(np.r_[0, on_ground.astype(np.int8), 0])
    starts = t[np.nonzero(edges[:-1] == 1)[0]]
    ends = t[np.minimum(np.nonzero(edges[1:] == -1)[0] + 1, len(t) - 1)]
    coast_ends = np.r_[starts[1:], t_end]
    return [(float(a), float(b), float(c)) for a, b, c in zip(starts, ends, coast_ends, strict=True)]


def _interp_rows(t: float, ts: np.ndarray, rows: np.ndarray) -> np.ndarray:
    t = min(max(t, float(ts[0])), float(ts[-1]))
    i = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2))
    a = (t - ts[i]) / (ts[i + 1] - ts[i])
    return rows[i] + a * (rows[i + 1] - rows[i])


class EntryReference:
    """The reference of one entry and of what follows it, from the runtime and the library model."""

    def __init__(self, lib: MotionLibrary, entry: Entry, p: SkateParams, settings: TrackSettings):
        self.e = entry
        self.p = p
        self._t = np.asarray(entry.t, dtype=np.float64)
        self.t0 = float(entry.t[0])
        self.t_end = float(entry.t[-1])
        self.transfer_end = self.t_end + settings.transfer_s
        self.board_mass_always = settings.board_mass_always
        self.t_stop = self.transfer_end + settings.ride_s
        self.last = np.array(entry.state[-1], dtype=np.float64)
        self.board_pos = np.asarray(entry.board_pos, dtype=np.float64)
        self.q_board = np.asarray(lib.model_arrays["stance_q_board_rad"], dtype=np.float64).reshape(12)
        self.rel_last = self.last[0:3] - self.board_pos[-1, 0:3]
        self.deck_z = float(self.board_pos[-1, 2])
        feet = np.asarray(entry.foot_pos, dtype=np.float64)  # (K, 4, 3)
        self.feet = feet
        contact = np.asarray(entry.contact)
        com = np.asarray(entry.state, dtype=np.float64)[:, None, 0:3]
        loaded = contact != SWING
        self.max_reach = float(np.max(np.linalg.norm((feet - com)[loaded], axis=-1)))
        self.pushes = push_intervals(self._t, contact[:, p.push_leg] == GROUND, self.t_end)
        drag = np.tanh(p.tanh_scale_s_per_m * momentum_speed(np.asarray(entry.state), p.mass_kg, p.board_mass_kg))
        self._friction_integral = np.r_[0.0, np.cumsum(0.5 * (drag[1:] + drag[:-1]) * np.diff(self._t))]

    @property
    def plan_coast_mps2(self) -> float:
        """The plan's rolling deceleration of robot and board (friction at the planning factor)."""
        return self.p.rolling_plan_N / (self.p.board_mass_kg + self.p.mass_kg)

    def prior_coast_mps2(self, t: float) -> float:
        """The rolling deceleration to aim with before a coast has been measured: a push with
        another one after it aims as planned (the plan's harder rolling), because the next push
        can always push less but not always more (the plan pushes at its friction limit); the
        last push aims at the board as the model has it (the likelier case)."""
        last_start = self.pushes[-1][0] if self.pushes else 0.0
        rolling = self.p.rolling_N if t >= last_start else self.p.rolling_plan_N
        return rolling / (self.p.board_mass_kg + self.p.mass_kg)

    def observe(self, t: float, x: np.ndarray, board_xy: np.ndarray) -> None:
        """Nothing to learn from the feedback beyond the observers of :func:`simulate`."""

    def coasting(self, t: float) -> bool:
        """Between the first push's start and the end, with no foot on the ground."""
        return bool(self.pushes) and self.pushes[0][0] <= t < self.t_end and not np.any(self.contact(t) == GROUND)

    def speed_offset(self, t: float, coast_mps2: float) -> float:
        """How far the forward speed reference moves at ``t`` so that the entry still ends at its
        label when rolling friction slows robot and board by ``coast_mps2`` (:class:`CoastObserver`)
        instead of the plan's. Only a foot on the ground changes their momentum, so each push aims
        at the speed that the following coast (to the next push, or to the end) turns into the
        plan's; friction acts as tanh(k v) of the plan's speed over that coast."""
        easier = self.plan_coast_mps2 - coast_mps2  # > 0: the board rolls easier than planned
        for start, end, coast_end in self.pushes:
            if t < start:
                return 0.0
            if t < coast_end:
                return -easier * (self._friction_time(coast_end) - self._friction_time(max(t, end)))
        return 0.0

    def _friction_time(self, t: float) -> float:
        """integral of tanh(k v_plan) from the start to ``t`` [s] (v_plan: the plan's momentum speed)."""
        return float(np.interp(t, self._t, self._friction_integral))

    def touchdown_point(self, t: float, leg: int) -> np.ndarray:
        """Where the entry puts ``leg`` on the ground for the stance that starts at about ``t``."""
        contact = np.asarray(self.e.contact)
        k = int(np.searchsorted(self._t, t - 1e-6))
        on = np.nonzero(contact[k:, leg] == GROUND)[0]
        k = min(k + int(on[0]) if len(on) else k, len(self._t) - 1)
        return self.feet[k, leg].copy()

    def initial_ground(self) -> np.ndarray:
        """(3, 4) where the feet that start on the ground stand (zeros for the others)."""
        c = self.contact(self.t0)
        return np.where(c[None, :] == GROUND, self.feet[0].T, 0.0)

    def board_xy(self, t: float) -> np.ndarray:
        return _interp_rows(t, self._t, self.board_pos)[0:2]

    def contact(self, t: float) -> np.ndarray:
        if t < self.t_end:
            c = self.e.sample(t).contact
            return np.asarray(c, dtype=np.int8)
        c = np.full(4, BOARD, dtype=np.int8)
        if t < self.transfer_end:
            c[self.p.push_leg] = SWING
        return c

    def _after(self, t: float, board_xy: np.ndarray, t_now: float, v_ride: float) -> tuple[np.ndarray, np.ndarray]:
        x = self.last.copy()
        yaw = x[5]
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        x[0:2] = board_xy + heading * v_ride * (t - t_now) + self.rel_last[0:2]
        x[3:5] = 0.0
        x[6:8] = heading * v_ride
        x[8] = 0.0
        x[9:12] = 0.0
        w = min(max((t - self.t_end) / max(self.transfer_end - self.t_end, 1e-9), 0.0), 1.0)
        x[12:24] = (1 - w) * self.last[12:24] + w * self.q_board
        x[24:26] = heading * v_ride
        x[I_BOARD_ROLL:] = 0.0
        u = np.zeros(NU)
        c = self.contact(t)
        n = max(int(np.sum(c != SWING)), 1)
        for i in range(4):
            if c[i] != SWING:
                u[3 * i + 2] = self.p.mass_kg * self.p.gravity_mps2 / n
        return x, u

    def horizon(self, t: float, n: int, dt: float, board_xy: np.ndarray, v_ride: float,
                coast_mps2: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """X_ref(k+1), U_ref(k), contact(k) and the acceleration mode for k = 0..n-1, positions
        re-anchored to the board, forward speeds moved by :meth:`speed_offset` (None: the plan's)."""
        w = self.e.window(t, n + 1, dt)
        x_ref = np.array(w.state[1:], dtype=np.float64)
        u_ref = np.array(w.control[:n], dtype=np.float64)
        contact = np.array([self.contact(t + k * dt) for k in range(n)], dtype=np.int8)
        shift = board_xy - self.board_xy(t)
        x_ref[:, 0:2] += shift
        ahead = np.zeros(2)  # where the moved speeds take robot and board over the horizon
        for k in range(n):
            tk = t + (k + 1) * dt
            if coast_mps2 is not None and tk <= self.t_end:
                dv = self.speed_offset(tk, coast_mps2) * board_heading(x_ref[k])
                ahead += dv * dt
                x_ref[k, 0:2] += ahead
                x_ref[k, 6:8] += dv
                x_ref[k, 24:26] += dv
            if tk > self.t_end:
                x_ref[k], _ = self._after(tk, board_xy, t, v_ride)
            if t + k * dt >= self.t_end:
                _, u_ref[k] = self._after(t + k * dt, board_xy, t, v_ride)
        accelerating = np.ones(n, dtype=bool) if self.board_mass_always else t + dt * np.arange(n) < self.t_end
        return x_ref, u_ref, contact, accelerating


@dataclass
class Run:
    """What a closed-loop simulation measured (the verdicts are made from it).

    Attributes:
        updates: Per MPC update after its plant steps: time [s], plant state (31,) and the
            reference of the update's first step (28,).
    """

    plant: Plant
    fall: str = ""
    times_s: list[float] = field(default_factory=list)
    max_position_error_m: float = 0.0
    max_attitude_error_rad: float = 0.0
    max_roll_rad: float = 0.0
    max_torque_Nm: float = 0.0  # stance legs, -J^T f at the inverse-kinematics joint angles
    max_ik_residual_m: float = 0.0  # how far a stance foot stayed from where its leg can put it
    max_joint_limit_excess_rad: float = 0.0
    friction_loss_Ns: float = 0.0  # rolling friction's impulse from the end of the plan to 1 s later
    momentum_at_end_mps: float = float("nan")
    speed_after_1s_mps: float = float("nan")
    momentum_after_1s_mps: float = float("nan")
    updates: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)
    trace: Trace | None = None


class Reference(Protocol):
    """What :func:`simulate` asks of a reference (an entry's, or the steering experiment's)."""

    t0: float  # start [s]
    t_end: float  # end of the planned motion [s] (speeds are judged from here)
    t_stop: float  # end of the run [s]
    deck_z: float  # height of the deck's top [m]
    max_reach: float  # the farthest the plan puts a loaded foot from the COM [m]

    def prior_coast_mps2(self, t: float) -> float: ...  # the coast deceleration before one is measured

    def contact(self, t: float) -> np.ndarray: ...

    def coasting(self, t: float) -> bool: ...

    def observe(self, t: float, x: np.ndarray, board_xy: np.ndarray) -> None: ...  # feedback, each update

    def horizon(self, t: float, n: int, dt: float, board_xy: np.ndarray,
                v_ride: float, coast_mps2: float | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...

    def board_xy(self, t: float) -> np.ndarray: ...

    def touchdown_point(self, t: float, leg: int) -> np.ndarray: ...

    def initial_ground(self) -> np.ndarray: ...


def simulate(ref: Reference, x_init: np.ndarray, model: SkateParams, plant_params: SkateParams, dist: Disturbances,
             cfg: MpcConfig, settings: TrackSettings, keep_trace: bool = False,
             kinematics: LegKinematics | None = None) -> Run:
    """Run the MPC against the plant from ``ref.t0`` to ``ref.t_stop``.

    Args:
        ref: The reference (:class:`EntryReference` or the steering experiment's).
        x_init: (31,) initial plant state of the model's COM (28 channels, board origin).
        kinematics: The robot's legs: after every update, the stance legs' joint angles by
            inverse kinematics and the torques of the commanded forces (the whole-body
            controller's job) are measured on the plant's state.

    BLAS runs on one thread meanwhile, as in a controller's real-time loop: the MPC's matrices are
    small (about 100 x 400), and a multi-threaded BLAS made an update 2-4x slower on 2 cores
    (median 5.9 against 1.7 ms on ``v0.50_s2`` with ``skatelib track -j 1``).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        return _simulate(ref, x_init, model, plant_params, dist, cfg, settings, keep_trace, kinematics)


def _simulate(ref: Reference, x_init: np.ndarray, model: SkateParams, plant_params: SkateParams, dist: Disturbances,
              cfg: MpcConfig, settings: TrackSettings, keep_trace: bool, kinematics: LegKinematics | None) -> Run:
    rng = np.random.default_rng(settings.seed)
    com_shift = np.array([0.0, dist.com_offset_m, 0.0])
    plant = Plant(plant_params, com_shift)
    run = Run(plant=plant)
    disc = Discretizer(model, cfg.dt)
    solver = make_solver(cfg)
    observer = DisturbanceObserver(cfg.disturbance_gain)
    coast_observer = CoastObserver(cfg.coast_gain)
    h = cfg.dt / settings.plant_substeps
    s = np.array(x_init, dtype=np.float64)
    s[0:3] += rpy_matrices(s[3:6]) @ com_shift  # the true COM
    s[1] += dist.init_error_m
    s[2] += dist.init_error_m
    ground = ref.initial_ground()
    prev_contact = ref.contact(ref.t0)
    trace_t, trace_s, trace_r, trace_f, trace_qd, trace_c, trace_p = [], [], [], [], [], [], []
    t = ref.t0
    t_1s = ref.t_end + 1.0
    q_legs = np.array(x_init[S_Q], dtype=np.float64)
    for _ in range(round((ref.t_stop - ref.t0) / cfg.dt)):
        # Feedback: what the estimator reports (the model's COM, noise).
        x_fb = s[:NX].copy()
        x_fb[0:3] -= rpy_matrices(x_fb[3:6]) @ com_shift
        if dist.noise_std > 0:
            x_fb[0:6] += rng.normal(0.0, dist.noise_std, 6)
            x_fb[6:12] += rng.normal(0.0, 5 * dist.noise_std, 6)
        pts = plant.contact_points(s, ref.contact(t), ground)
        r_board = board_rotations(x_fb[5], x_fb[I_BOARD_ROLL]) @ np.vstack([model.deck_points_m, np.zeros(4)])
        maps = None if kinematics is None else kinematics.torque_maps(q_legs, rpy_matrices(x_fb[3:6]))
        fb = Feedback(x=x_fb, r_robot=pts - x_fb[0:3, None], r_board=r_board, torque_maps=maps)
        v_ride = float(forward_speed(x_fb))
        bias = observer.update(v_ride, cfg.dt, float(x_fb[8]))
        ref.observe(t, x_fb, s[NX:NX + 2])
        v_momentum = float(momentum_speed(x_fb, model.mass_kg, model.board_mass_kg))
        measured = coast_observer.update(ref.coasting(t), v_momentum, cfg.dt)
        coast = ref.prior_coast_mps2(t) if measured is None else measured
        x_ref, u_ref, contact, accelerating = ref.horizon(
            t, cfg.horizon, cfg.dt, s[NX:NX + 2], v_ride, coast if cfg.coast_compensation else None)
        t_start = time.perf_counter()
        qp = build_problem(model, cfg, disc, fb, x_ref, u_ref, contact, accelerating, bias, observer.vertical_mps2)
        try:
            U = solver.solve(qp)
        except QpSolveFailed as e:
            run.fall = f"the MPC's QP failed at t = {t:.2f} s ({e})"
            break
        observer.predict(qp, U)
        run.times_s.append(time.perf_counter() - t_start)
        forces = U[:12].reshape(4, 3).T
        qd = U[12:24]
        for _sub in range(settings.plant_substeps):
            c = ref.contact(t)
            for i in range(4):
                if c[i] == GROUND and prev_contact[i] != GROUND:  # touch-down where the plan puts it
                    ground[:, i] = ref.touchdown_point(t, i) + np.r_[s[NX:NX + 2] - ref.board_xy(t), 0.0]
            prev_contact = c
            ext = None
            if dist.impulse_Ns and abs(t - dist.impulse_t_s) < h / 2:
                ext = np.array([0.0, dist.impulse_Ns / h, 0.0])
            s_new = plant.step(s, forces, qd, c, ground, h, t, ext)
            if ref.t_end <= t < t_1s:
                v_f = float(forward_speed(s))
                run.friction_loss_Ns += plant_params.rolling_N * np.tanh(plant_params.tanh_scale_s_per_m * v_f) * h
            s = s_new
            t += h
            if np.isnan(run.momentum_at_end_mps) and t >= ref.t_end - 1e-9:
                run.momentum_at_end_mps = plant.momentum_speed(s)
            if np.isnan(run.speed_after_1s_mps) and t >= t_1s - 1e-9:
                run.speed_after_1s_mps = float(forward_speed(s))
                run.momentum_after_1s_mps = plant.momentum_speed(s)
            if keep_trace:
                trace_t.append(t)
                trace_s.append(s.copy())
                trace_r.append(x_ref[0].copy())
                trace_f.append(plant.admissible(s, forces, c, t, record=False))
                trace_qd.append(qd)
                trace_c.append(c.copy())
                trace_p.append(plant.contact_points(s, c, ground))
            run.max_roll_rad = max(run.max_roll_rad, abs(float(s[I_BOARD_ROLL])))
            if not np.all(np.isfinite(s)):
                run.fall = f"the state diverged at t = {t:.2f} s"
                break
        if run.fall:
            break
        run.updates.append((t, s.copy(), x_ref[0].copy()))
        # Errors against the reference of this update's first step (re-anchored).
        pos_err = float(np.linalg.norm(s[0:3] - rpy_matrices(s[3:6]) @ com_shift - x_ref[0, 0:3]))
        run.max_position_error_m = max(run.max_position_error_m, pos_err)
        run.max_attitude_error_rad = max(run.max_attitude_error_rad, float(np.max(np.abs(s[3:6] - x_ref[0, 3:6]))))
        if kinematics is not None:
            q_legs = _whole_body(run, kinematics, model, s, forces, prev_contact, plant.contact_points(s, prev_contact,
                                                                                                       ground),
                                 com_shift, q_legs, x_ref[0, S_Q])
        run.fall = _fall(ref, plant, s, x_ref[0], prev_contact, ground, plant_params.roll_limit_rad, t)
        if run.fall:
            break
    if keep_trace and trace_t:
        run.trace = Trace(np.array(trace_t), np.array(trace_s), np.array(trace_r), np.array(trace_f),
                          np.array(trace_qd), np.array(trace_c), np.array(trace_p))
    return run


def _whole_body(run: Run, kin: LegKinematics, model: SkateParams, s: np.ndarray, forces: np.ndarray,
                contact: np.ndarray, points: np.ndarray, com_shift: np.ndarray, q_prev: np.ndarray,
                q_ref: np.ndarray) -> np.ndarray:
    """Stance legs by inverse kinematics to where their feet touch the plant's deck or ground,
    swinging legs at the reference; records torque, reach and joint-limit figures in ``run``."""
    R = rpy_matrices(s[3:6])
    origin = s[0:3] - R @ (model.com_offset_m + com_shift)  # the trunk frame's origin
    loaded = contact != SWING
    normals = np.where(contact[None, :] == BOARD, board_rotations(s[5], s[I_BOARD_ROLL])[:, 2:3],
                       np.array([[0.0], [0.0], [1.0]]))
    centres = R.T @ (points + kin.foot_radius_m * normals - origin[:, None])
    q0 = np.where(np.repeat(loaded, 3), q_prev, q_ref)
    q, residual = kin.inverse(centres, q0, loaded)
    tau = kin.torques(q, R.T @ forces, loaded)
    run.max_torque_Nm = max(run.max_torque_Nm, float(np.max(np.abs(tau))))
    run.max_ik_residual_m = max(run.max_ik_residual_m, float(np.max(residual)))
    excess = np.maximum(kin.lower_rad - q, q - kin.upper_rad)[np.repeat(loaded, 3)]
    run.max_joint_limit_excess_rad = max(run.max_joint_limit_excess_rad, float(np.max(excess, initial=0.0)))
    return q


def _fall(ref: Reference, plant: Plant, s: np.ndarray, x_ref: np.ndarray, contact: np.ndarray, ground: np.ndarray,
          roll_limit_rad: float, t: float) -> str:
    """Why the robot counts as fallen, or ""."""
    height = s[2] - s[NX + 2]
    ref_height = x_ref[2] - ref.deck_z
    pts = plant.contact_points(s, contact, ground)
    reach = max((float(np.linalg.norm(pts[:, i] - s[0:3])) for i in range(4) if contact[i] != SWING), default=0.0)
    tilt = max(abs(s[3]), abs(s[4]))
    if abs(height - ref_height) > HEIGHT_LIMIT_M:
        return f"body height over the deck {height:.3f} m, reference {ref_height:.3f} m, at t = {t:.2f} s"
    if tilt > TILT_LIMIT_RAD:
        return f"body tilted {tilt:.2f} rad at t = {t:.2f} s"
    if abs(s[I_BOARD_ROLL]) > roll_limit_rad:
        return f"deck roll {s[I_BOARD_ROLL]:.3f} rad beyond the wheel limit at t = {t:.2f} s"
    if reach > ref.max_reach + REACH_MARGIN_M:
        return f"a foot {reach:.3f} m from the COM (the plan at most {ref.max_reach:.3f}) at t = {t:.2f} s"
    return ""


def slip_reason(plant: Plant) -> str:
    log = plant.log
    return (f"{log.slips} slipping plant steps (force up to {log.slip_excess_N:.2f} N outside the cone of mu "
            f"{plant.p.mu:.2f})") if log.slips else ""


def track_entry(lib: MotionLibrary, key: str, model: SkateParams, plant_params: SkateParams,
                dist: Disturbances | None = None, cfg: MpcConfig | None = None,
                settings: TrackSettings | None = None, keep_trace: bool = False
                ) -> tuple[TrackResult, Trace | None]:
    """Run one entry in closed loop and judge it (see the module docstring)."""
    dist = dist or Disturbances()
    cfg = cfg or MpcConfig()
    settings = settings or TrackSettings()
    entry = lib[key]
    ref = EntryReference(lib, entry, model, settings)
    x_init = np.zeros(NB)
    x_init[:NX] = np.asarray(entry.state[0], dtype=np.float64)
    x_init[NX:NX + 3] = ref.board_pos[0, 0:3]
    kin = LegKinematics.from_library(lib)
    run = simulate(ref, x_init, model, plant_params, dist, cfg, settings, keep_trace, kin)
    label = float(entry.attrs[schema.A_TARGET_VELOCITY])
    delivered = run.momentum_after_1s_mps + run.friction_loss_Ns / (plant_params.mass_kg + plant_params.board_mass_kg)
    err = (delivered - label) / label if label else float("nan")
    reasons = []
    if not np.isfinite(err) or abs(err) > SPEED_TOLERANCE:
        reasons.append(f"delivered speed {delivered:.3f} m/s is {100 * err:+.1f} % from the label {label:.2f}")
    if run.fall:
        reasons.append(f"fall: {run.fall}")
    if run.plant.log.slips:
        reasons.append(slip_reason(run.plant))
    if run.max_torque_Nm > kin.torque_limit_Nm:
        reasons.append(f"joint torque {run.max_torque_Nm:.1f} N m above the limit {kin.torque_limit_Nm:.0f}")
    if run.max_ik_residual_m > IK_TOLERANCE_M:
        reasons.append(f"a stance foot {1e3 * run.max_ik_residual_m:.0f} mm beyond where its leg reaches")
    if run.max_joint_limit_excess_rad > 0.0:
        reasons.append(f"a stance joint {run.max_joint_limit_excess_rad:.3f} rad beyond its limit")
    ms = np.array(run.times_s) * 1e3
    result = TrackResult(
        key=key, label_mps=label, speed_after_1s_mps=run.speed_after_1s_mps,
        momentum_after_1s_mps=run.momentum_after_1s_mps, momentum_at_end_mps=run.momentum_at_end_mps,
        delivered_mps=delivered, speed_error=err, max_deck_roll_rad=run.max_roll_rad,
        max_position_error_m=run.max_position_error_m, max_attitude_error_rad=run.max_attitude_error_rad,
        min_normal_N=float(run.plant.log.min_normal_N), max_friction_use=run.plant.log.max_friction_use,
        min_friction_margin_N=float(run.plant.log.min_friction_margin_N),
        slips=run.plant.log.slips, max_joint_torque_Nm=run.max_torque_Nm, max_ik_residual_m=run.max_ik_residual_m,
        joint_limit_excess_rad=run.max_joint_limit_excess_rad,
        mpc_median_ms=float(np.median(ms)) if len(ms) else float("nan"),
        mpc_max_ms=float(np.max(ms)) if len(ms) else float("nan"), fall=run.fall, passed=not reasons,
        reasons="; ".join(reasons),
    )
    return result, run.trace
