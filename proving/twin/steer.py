"""The four-leg balancing and steering maneuver (Sec. VI-A, Fig. 5) in full physics: the MPC with
the model loop's steering reference (:class:`skatelib.proving.steer.SteerReference`: the deck's
roll along a 0.1 rad sine of 3 s period, held by shifting the body sideways) over the whole-body
controller, on a multibody plant, at rest and riding.

Verdict: deck-roll error at most 0.03 rad RMS after the first second, every foot on the deck
throughout (no tick with one off it), no wheel off the floor, no fall. ``min_normal_N`` is the
smallest normal force of a foot on the deck, ``unloaded_steps`` the ticks with one off it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.body_plan import BodyTargets
from skatelib.library.channels import NX
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.steer import ROLL_RMS_LIMIT_RAD, SteerReference, SteerResult
from skatelib.proving.twin.loop import Ride, TwinLoop, TwinLoopSettings
from skatelib.proving.twin.sensors import MultibodyPlant
from skatelib.proving.twin.verdict import SLIP_LIMIT_M


class SteerPlan:
    """The body plan of the maneuver: four feet on their deck points, the body over the deck's
    centre line shifted by what holds the reference roll, level, the stance's joint angles."""

    def __init__(self, ref: SteerReference, foot_radius_m: float):
        self.ref = ref
        self.feet = np.vstack([ref.p.deck_points_m, np.full(4, foot_radius_m)])

    def at(self, t: float) -> BodyTargets:
        phi, phi_dot = self.ref.roll(t)
        ref = self.ref
        com = np.array([ref.rel_x, ref.lateral_shift(phi), ref.height])
        com_v = np.array([0.0, ref.lateral_shift(phi_dot), 0.0])  # linear in the roll
        zeros = np.zeros((3, 4))
        return BodyTargets(com=com, com_v=com_v, rpy=np.zeros(3), omega=np.zeros(3), feet=self.feet, feet_v=zeros,
                           feet_a=zeros, q=ref.q, board_v=np.array([ref.speed, 0.0, 0.0]))


def steer_ride(lib: Any, loop: ClosedLoop, target_velocity_mps: float, duration_s: float, foot_radius_m: float,
               adapt_stiffness: bool = True) -> Ride:
    ref = SteerReference(lib, loop.model, target_velocity_mps, duration_s, adapt_stiffness=adapt_stiffness)
    x0 = ref.initial_state()[:NX]
    board0 = np.array([0.0, 0.0, ref.deck_z, 0.0])
    return Ride(ref, SteerPlan(ref, foot_radius_m), x0, board0, board0, target_velocity_mps)


@dataclass(frozen=True)
class SteerRun:
    """How long the maneuver runs, and whether the body's shift follows the trucks' stiffness as
    measured while rolling (False: the model's K_B throughout)."""

    duration_s: float = 9.0
    adapt_stiffness: bool = True
    loop: TwinLoopSettings = field(default_factory=TwinLoopSettings)


def steer_twin(lib: Any, loop: ClosedLoop, plant: MultibodyPlant, target_velocity_mps: float,
               run_settings: SteerRun | None = None) -> SteerResult:
    """Run the maneuver on ``plant`` and judge it (module docstring)."""
    from skatelib.control.kinematics import LegKinematics

    cfg = run_settings or SteerRun()
    duration_s = cfg.duration_s
    radius = LegKinematics.from_library(lib).foot_radius_m
    ride = steer_ride(lib, loop, target_velocity_mps, duration_s, radius, cfg.adapt_stiffness)
    loop_ = TwinLoop(lib, ride, loop, plant, cfg.loop)
    run = loop_.ride()
    ticks = run.ticks
    settled = ticks[:, 0] >= 1.0
    steer_ref = ride.ref
    assert isinstance(steer_ref, SteerReference)
    roll_ref = np.array([steer_ref.roll(t)[0] for t in ticks[:, 0]])
    err = ticks[settled, 1] - roll_ref[settled]
    rms = float(np.sqrt(np.mean(err**2))) if len(err) else float("nan")
    off_deck = int(np.sum(ticks[:, 3] < 4))
    m = run.measures
    reasons = []
    if not rms <= ROLL_RMS_LIMIT_RAD:
        reasons.append(f"deck roll error {rms:.4f} rad RMS (limit {ROLL_RMS_LIMIT_RAD})")
    if off_deck:
        reasons.append(f"a foot off the deck in {off_deck} ticks")
    if m.wheel_lift_ticks:
        reasons.append(f"a wheel left the floor for up to {m.max_wheel_lift_ms:.0f} ms")
    if run.fall:
        reasons.append(f"fall: {run.fall}")
    return SteerResult(
        target_velocity_mps=target_velocity_mps, duration_s=duration_s, roll_rms_error_rad=rms,
        max_roll_rad=float(np.max(np.abs(ticks[:, 1]), initial=0.0)),
        max_lateral_shift_m=float(np.max(np.abs(ticks[settled, 2]), initial=0.0)),
        min_normal_N=float(np.min(ticks[:, 4], initial=np.inf)), unloaded_steps=off_deck,
        slips=sum(s > SLIP_LIMIT_M for s in m.slips_m),
        mpc_median_ms=float(np.median(run.mpc_times_s) * 1e3) if run.mpc_times_s else float("nan"),
        fall=run.fall, passed=not reasons, reasons="; ".join(reasons))
