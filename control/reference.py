"""What the closed loop follows: the reference of one library entry and of what follows it (the
push leg's transfer back onto the deck, then four-leg riding), served by ``skatelib.runtime``, and
the protocol every reference meets (:class:`Reference`; the steering experiment's is another).

The reference positions are re-anchored to the board at every update: the robot controls where
its body is over the deck (what its feet measure), not where the optimization's world frame was.
Its forward speeds are moved by the coast compensation (:meth:`EntryReference.speed_offset`):
only a foot on the ground changes the momentum of robot and board, so each push aims at the
speed that the following coast turns into the plan's, with the coast's rolling deceleration
measured (:class:`skatelib.control.observers.CoastObserver`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from skatelib.control.mpc import HorizonRef, board_heading
from skatelib.control.params import SkateParams
from skatelib.control.settings import TrackSettings
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, NU, SWING
from skatelib.library.margins import momentum_speed
from skatelib.runtime import Entry, MotionLibrary

SETTLE_S = 0.1  # after a foot leaves the ground the body still swings on the deck: no coast sample yet
STAGE_ENDS = "ride_stage_ends_s"  # an entry joined from several (a ride): when each ends [s]


def push_intervals(t: np.ndarray, on_ground: np.ndarray, t_end: float, stage_ends: list[float] | None = None
                   ) -> list[tuple[float, float, float]]:
    """(start, end, end of the coast after it) of each stance of the push foot on the ground; a
    coast ends at the next stance or at the end of the stage (of a ride) the stance belongs to."""
    edges = np.diff(np.r_[0, on_ground.astype(np.int8), 0])
    starts = t[np.nonzero(edges[:-1] == 1)[0]]
    ends = t[np.minimum(np.nonzero(edges[1:] == -1)[0] + 1, len(t) - 1)]
    coast_ends = np.r_[starts[1:], t_end]
    marks = sorted(stage_ends or [t_end])
    coast_ends = [min(c, next((m for m in marks if m >= b - 1e-9), c)) for b, c in zip(ends, coast_ends, strict=True)]
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
        self.q_board = lib.quadruped_model.arrays.stance_q_board_rad
        self.rel_last = self.last[0:3] - self.board_pos[-1, 0:3]
        self.deck_z = float(self.board_pos[-1, 2])
        feet = np.asarray(entry.foot_pos, dtype=np.float64)  # (K, 4, 3)
        self.feet = feet
        contact = np.asarray(entry.contact)
        com = np.asarray(entry.state, dtype=np.float64)[:, None, 0:3]
        loaded = contact != SWING
        self.max_reach = float(np.max(np.linalg.norm((feet - com)[loaded], axis=-1)))
        self.stage_ends = tuple(float(v) for v in np.atleast_1d(entry.attrs.get(STAGE_ENDS, [])))  # a ride's
        self.pushes = push_intervals(self._t, contact[:, p.push_leg] == GROUND, self.t_end, list(self.stage_ends))
        drag = np.tanh(p.tanh_scale_s_per_m * momentum_speed(np.asarray(entry.state), p.mass_kg, p.board_mass_kg))
        self._friction_integral = np.r_[0.0, np.cumsum(0.5 * (drag[1:] + drag[:-1]) * np.diff(self._t))]
        # The push foot's planned normal force, integrated: how much friction (mu f_n) it has to
        # spare is what can change the momentum, so a push's extra impulse follows it.
        control = np.asarray(entry.control, dtype=np.float64)
        push_fn = np.maximum(control[:len(self._t) - 1, 3 * p.push_leg + 2], 0.0)
        self._push_impulse = np.r_[0.0, np.cumsum(push_fn * np.diff(self._t))]

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
        """Nothing to learn from the feedback beyond the loop's observers."""

    def coasting(self, t: float) -> bool:
        """Before the end with no foot on the ground: from the first push's start on (a start-up starts
        at rest), or from the start for a transition (it starts riding, its foot lifted)."""
        start = self.t0 if self.e.from_velocity_mps > 0 else (self.pushes[0][0] if self.pushes else self.t_end)
        settled = not np.any(self.contact(max(t - SETTLE_S, self.t0)) == GROUND)
        return start <= t < self.t_end and settled and not np.any(self.contact(t) == GROUND)

    def speed_offset(self, t: float, coast_mps2: float) -> float:
        """How far the forward speed reference moves at ``t`` so that the entry still ends at its
        label when rolling friction slows robot and board by ``coast_mps2`` (:class:`CoastObserver`)
        instead of the plan's. Only a foot on the ground changes their momentum, so each push aims
        at the speed that the following coast (to the next push, or to the end) turns into the
        plan's; friction acts as tanh(k v) of the plan's speed over that coast. Within a push the
        move grows from nothing at its start to its full size at its end in proportion to the push
        foot's planned normal force so far: momentum changes only as fast as the foot's friction
        allows, so a speed reference that stepped at touch-down would ask for what no force can do."""
        easier = self.plan_coast_mps2 - coast_mps2  # > 0: the board rolls easier than planned
        for start, end, coast_end in self.pushes:
            if t < start:
                return 0.0
            if t < coast_end:
                full = -easier * (self._friction_time(coast_end) - self._friction_time(max(t, end)))
                return full * self._push_share(start, end, t) if t < end else full
        return 0.0

    def _push_share(self, start: float, end: float, t: float) -> float:
        """The share of the push [start, end) done at ``t``: its planned normal-force impulse so far
        over all of it (the share of its time where the plan puts no load on the foot)."""
        total = float(np.interp(end, self._t, self._push_impulse) - np.interp(start, self._t, self._push_impulse))
        if total <= 0.0:
            return (t - start) / (end - start)
        return float(np.interp(t, self._t, self._push_impulse) - np.interp(start, self._t, self._push_impulse)) / total

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
                coast_mps2: float | None = None) -> HorizonRef:
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
        return HorizonRef(x_ref, u_ref, contact, accelerating)


class Reference(Protocol):
    """What the controller (:class:`skatelib.control.controller.SkateController`) and the proving
    ground's loops ask of a reference (an entry's, or the steering experiment's)."""

    t0: float  # start [s]
    t_end: float  # end of the planned motion [s] (speeds are judged from here)
    t_stop: float  # end of the run [s]
    stage_ends: tuple[float, ...]  # a ride's: when each stage ends [s] (empty otherwise)
    deck_z: float  # height of the deck's top [m]
    max_reach: float  # the farthest the plan puts a loaded foot from the COM [m]

    def prior_coast_mps2(self, t: float) -> float: ...  # the coast deceleration before one is measured

    def contact(self, t: float) -> np.ndarray: ...

    def coasting(self, t: float) -> bool: ...

    def observe(self, t: float, x: np.ndarray, board_xy: np.ndarray) -> None: ...  # feedback, each update

    def horizon(self, t: float, n: int, dt: float, board_xy: np.ndarray,
                v_ride: float, coast_mps2: float | None = None) -> HorizonRef: ...

    def board_xy(self, t: float) -> np.ndarray: ...

    def touchdown_point(self, t: float, leg: int) -> np.ndarray: ...

    def initial_ground(self) -> np.ndarray: ...
