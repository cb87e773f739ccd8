"""Four-leg balancing and steering (Sec. VI-A, Fig. 5): the MPC rolls the deck along a sine
(0.1 rad amplitude, 3 s period) by shifting the torso sideways, at rest and while riding.

The reference: the robot stands on the deck points in the library's four-leg stance (height and
joint angles of the library's last knot and stance), its COM over the deck's centre line shifted
sideways so that the feet's weight holds the deck at the reference roll against the trucks'
spring, K_B phi = -m g y_COM (Eq. 6-7 in equilibrium), and the feed-forward normal forces split
between the two sides in that ratio. A shift of 0.091 m holds 0.1 rad: the far feet then carry
about 17 % of their share, which is why the paper saw forces approach zero.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from skatelib.control.mpc import HorizonRef
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, I_BOARD_ROLL, I_BOARD_ROLL_RATE, NU, NX
from skatelib.proving.loop import simulate
from skatelib.proving.plant import NB
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.verdict import slip_reason
from skatelib.runtime import MotionLibrary

ROLL_RMS_LIMIT_RAD = 0.03  # deck-roll tracking error below this, RMS
SHIFT_LIMIT = 0.85  # the torso's sideways shift at most this fraction of the feet's half-width


@dataclass(frozen=True)
class SteerResult:
    """One steering run.

    Attributes:
        target_velocity_mps: The riding speed the maneuver holds [m/s] (0: at rest).
        roll_rms_error_rad: RMS of deck roll minus its reference over the run (after the first second).
        max_lateral_shift_m: Largest torso (COM) shift from the deck's centre line after the first second.
        min_normal_N: Lowest normal force of a foot on the deck.
        unloaded_steps: Plant steps in which a deck foot carried no load (it would lift off).
    """

    target_velocity_mps: float
    duration_s: float
    roll_rms_error_rad: float
    max_roll_rad: float
    max_lateral_shift_m: float
    min_normal_N: float
    unloaded_steps: int
    slips: int
    mpc_median_ms: float
    fall: str
    passed: bool
    reasons: str

    def as_dict(self) -> dict[str, float | str | bool | int]:
        return asdict(self)


@dataclass(frozen=True)
class RollWave:
    """The deck roll the experiment asks for: ``amplitude_rad sin(2 pi t / period_s)``."""

    amplitude_rad: float = 0.1
    period_s: float = 3.0


class SteerReference:
    """Four legs on the deck, deck roll following ``amplitude sin(2 pi t / period)``."""

    def __init__(self, lib: MotionLibrary, p: SkateParams, target_velocity_mps: float, duration_s: float,
                 adapt_stiffness: bool = True, wave: RollWave | None = None):
        last = np.asarray(lib.select(target_velocity_mps, clamp=True).state[-1], dtype=np.float64)
        self.p = p
        self.t0, self.t_end, self.t_stop = 0.0, 0.0, duration_s
        self.stage_ends: tuple[float, ...] = ()
        self.speed = target_velocity_mps
        wave = wave or RollWave()
        self.amplitude, self.period = wave.amplitude_rad, wave.period_s
        self.deck_z = lib.quadruped_model.board.deck_height_m  # the board origin is on the deck's top
        self.height = float(last[2]) - self.deck_z
        self.rel_x = float(np.mean(p.deck_points_m[0]))  # the COM over the middle of the feet
        self.q = lib.quadruped_model.arrays.stance_q_board_rad
        feet = np.vstack([p.deck_points_m, np.zeros(4)]) - np.array([[self.rel_x], [0.0], [self.height]])
        self.max_reach = float(np.max(np.linalg.norm(feet, axis=0))) + 0.05  # room for the sideways shift
        self.foot_y = float(np.mean(np.abs(p.deck_points_m[1])))
        self.kb_estimate = p.kb_Nm_per_rad  # the trucks' stiffness as measured (:meth:`observe`)
        self.adapt_stiffness = adapt_stiffness

    def observe(self, t: float, x: np.ndarray, board_xy: np.ndarray) -> None:
        """Measure the trucks' stiffness from the feedback: with the deck rolled by phi and the
        COM y off the centre line, the feet's weight holds the deck, K_B phi = -m g y (the roll
        is slow: its inertia and damping terms are a few per cent). Samples only beyond 0.03 rad,
        filtered with 0.05 per update."""
        phi = float(x[I_BOARD_ROLL])
        if not self.adapt_stiffness or abs(phi) < 0.03:
            return
        yaw = float(x[5])
        y = -np.sin(yaw) * (x[0] - board_xy[0]) + np.cos(yaw) * (x[1] - board_xy[1])
        sample = -self.p.mass_kg * self.p.gravity_mps2 * y / phi
        if sample > 0:
            self.kb_estimate += 0.05 * (sample - self.kb_estimate)

    def coasting(self, t: float) -> bool:
        return False  # four legs on the deck throughout: no push to compensate

    def prior_coast_mps2(self, t: float) -> float:
        return 0.0

    def roll(self, t: float) -> tuple[float, float]:
        w = 2.0 * np.pi / self.period
        return self.amplitude * np.sin(w * t), self.amplitude * w * np.cos(w * t)

    def lateral_shift(self, roll: float) -> float:
        """COM offset from the centre line that holds the deck at ``roll`` (see the module docstring)."""
        # The COM over the roll axis that balances the trucks (their torque at the measured stiffness,
        # the deck's weight included): m g y = roll_torque.
        torque = self.p.roll_torque(roll, 0.0) * self.kb_estimate / self.p.kb_Nm_per_rad
        y = torque / (self.p.mass_kg * self.p.gravity_mps2)
        limit = SHIFT_LIMIT * self.foot_y  # beyond it the far feet would lift: roll less instead
        return float(np.clip(y, -limit, limit))

    def initial_state(self) -> np.ndarray:
        s = np.zeros(NB)
        s[0:3] = [self.rel_x, 0.0, self.deck_z + self.height]
        s[6] = self.speed
        s[12:24] = self.q
        s[24] = self.speed
        s[NX:NX + 3] = [0.0, 0.0, self.deck_z]
        return s

    def contact(self, t: float) -> np.ndarray:
        return np.full(4, BOARD, dtype=np.int8)

    def initial_ground(self) -> np.ndarray:
        return np.zeros((3, 4))

    def board_xy(self, t: float) -> np.ndarray:
        return np.array([self.speed * t, 0.0])

    def touchdown_point(self, t: float, leg: int) -> np.ndarray:
        raise AssertionError("no foot touches the ground while steering")

    def horizon(self, t: float, n: int, dt: float, board_xy: np.ndarray, v_ride: float,
                coast_mps2: float | None = None) -> HorizonRef:
        x_ref = np.zeros((n, NX))
        u_ref = np.zeros((n, NU))
        mg = self.p.mass_kg * self.p.gravity_mps2
        for k in range(n):
            tk = t + (k + 1) * dt
            phi, phi_dot = self.roll(tk)
            y = self.lateral_shift(phi)
            x_ref[k, 0:3] = [board_xy[0] + v_ride * (k + 1) * dt + self.rel_x, board_xy[1] + y,
                             self.deck_z + self.height]
            x_ref[k, 6] = v_ride
            x_ref[k, 7] = self.lateral_shift(phi_dot)  # linear in the roll
            x_ref[k, 12:24] = self.q
            x_ref[k, 24] = v_ride
            x_ref[k, I_BOARD_ROLL], x_ref[k, I_BOARD_ROLL_RATE] = phi, phi_dot
            share = y / self.foot_y  # +1: all weight on the left feet
            for i in range(4):
                side = np.sign(self.p.deck_points_m[1, i])
                u_ref[k, 3 * i + 2] = mg / 4 * (1.0 + side * share)
        return HorizonRef(x_ref, u_ref, np.full((n, 4), BOARD, dtype=np.int8), np.ones(n, dtype=bool))


def steer(lib: MotionLibrary, loop: ClosedLoop, target_velocity_mps: float, duration_s: float = 9.0,
          adapt_stiffness: bool = True) -> SteerResult:
    """Run the steering experiment and judge it: deck-roll error below 0.03 rad RMS, no foot
    unloading from the deck, no fall, no slip. ``adapt_stiffness``: the torso shift follows the
    trucks' stiffness as measured while rolling (False: the model's K_B throughout)."""
    ref = SteerReference(lib, loop.model, target_velocity_mps, duration_s, adapt_stiffness=adapt_stiffness)
    run = simulate(ref, ref.initial_state(), loop)
    t = np.array([u[0] for u in run.updates])
    states = np.array([u[1] for u in run.updates]).reshape(-1, NB)
    settled = t >= 1.0
    roll_ref = np.array([ref.roll(tt)[0] for tt in t])
    err = states[:, I_BOARD_ROLL] - roll_ref if len(t) else np.array([np.nan])
    rms = float(np.sqrt(np.mean(err[settled] ** 2))) if np.any(settled) else float("nan")
    lateral = np.abs(states[:, 1] - states[:, NX + 1])
    shift = float(np.max(lateral[settled], initial=0.0)) if len(t) else float("nan")  # as the RMS: after 1 s
    unloaded = run.plant.log.unloaded_steps
    reasons = []
    if not np.isfinite(rms) or rms > ROLL_RMS_LIMIT_RAD:
        reasons.append(f"deck roll error {rms:.4f} rad RMS (limit {ROLL_RMS_LIMIT_RAD})")
    if unloaded:
        reasons.append(f"a deck foot carried no load in {unloaded} plant steps (it would leave the deck)")
    if run.fall:
        reasons.append(f"fall: {run.fall}")
    if run.plant.log.slips:
        reasons.append(slip_reason(run.plant))
    return SteerResult(
        target_velocity_mps=target_velocity_mps, duration_s=duration_s, roll_rms_error_rad=rms,
        max_roll_rad=run.max_roll_rad,
        max_lateral_shift_m=shift, min_normal_N=float(run.plant.log.min_normal_N), unloaded_steps=unloaded,
        slips=run.plant.log.slips, mpc_median_ms=float(np.median(run.times_s) * 1e3) if run.times_s else float("nan"),
        fall=run.fall, passed=not reasons, reasons="; ".join(reasons),
    )
