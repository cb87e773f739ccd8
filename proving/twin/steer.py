"""The four-leg balancing and steering maneuver (Sec. VI-A, Fig. 5) in full physics: the MPC with
the model loop's steering reference (:class:`skatelib.proving.steer.SteerReference`: the deck's
roll along a 0.1 rad sine of 3 s period, held by shifting the body sideways) over the whole-body
controller, on a multibody plant, at rest and riding.

Verdict (:class:`TwinSteerResult`): deck-roll error at most 0.03 rad RMS after the first second,
every foot on the deck throughout (no tick with one touching nothing, nor one or a link on the
floor), no stance that slipped more than 1 cm on the deck (the model plant's maneuver fails on a
slip too), no wheel off the floor for 10 ms or more, no fall."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.body_plan import BodyTargets
from skatelib.library.channels import NX
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.steer import ROLL_RMS_LIMIT_RAD, SteerReference, SteerResult
from skatelib.proving.twin.loop import Ride, TwinLoop, TwinLoopSettings, TwinRun
from skatelib.proving.twin.metrics import TwinMeasures
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


@dataclass(frozen=True)
class TwinSteerResult(SteerResult):
    """The maneuver on a multibody plant, counted in the twin's own units: ``unloaded_steps`` are
    2 ms controller ticks with a foot touching nothing, ``slips`` the stances that slipped more than
    1 cm at their contact point against the deck, ``min_normal_N`` the smallest normal force of a
    foot as its contact measures it.

    Attributes:
        max_slip_m: The largest slip of a stance at its contact point against the deck [m].
        floor_touch_ticks: Ticks with a foot or another link on the floor (the maneuver plans none).
        wheel_lift_ticks: Ticks in which a wheel had been off the floor for 10 ms (5 ticks) or more.
        max_wheel_lift_ms: The longest time a wheel was off the floor [ms].
    """

    max_slip_m: float
    floor_touch_ticks: int
    wheel_lift_ticks: int
    max_wheel_lift_ms: float


def steer_reasons(rms: float, off_deck: int, m: TwinMeasures, fall: str) -> list[str]:
    """Why the maneuver failed (module docstring), if it did: ``rms`` the deck roll's error [rad RMS],
    ``off_deck`` the ticks with a foot touching nothing, ``m`` the run's measures, ``fall`` why it
    stopped early ("" when it did not)."""
    reasons = []
    if not rms <= ROLL_RMS_LIMIT_RAD:
        reasons.append(f"deck roll error {rms:.4f} rad RMS (limit {ROLL_RMS_LIMIT_RAD})")
    if off_deck:
        reasons.append(f"a foot off the deck in {off_deck} ticks")
    if m.floor_touch_ticks:
        reasons.append(f"a foot or link on the floor ({m.floor_touch_first}; {m.floor_touch_ticks} ticks)")
    slipped = [s for s in m.slips_m if s > SLIP_LIMIT_M]
    if slipped:
        reasons.append(f"{len(slipped)} stances slipped up to {100 * max(slipped):.1f} cm on the deck "
                       f"(limit {100 * SLIP_LIMIT_M:.0f} cm)")
    if m.wheel_lift_ticks:
        reasons.append(f"a wheel left the floor for up to {m.max_wheel_lift_ms:.0f} ms")
    if fall:
        reasons.append(f"fall: {fall}")
    return reasons


def _roll_rms(ride: Ride, run: TwinRun) -> float:
    """The deck roll's RMS error against the reference after the first second [rad] (NaN: no tick there)."""
    ticks = run.ticks
    settled = ticks[:, 0] >= 1.0
    steer_ref = ride.ref
    assert isinstance(steer_ref, SteerReference)
    roll_ref = np.array([steer_ref.roll(t)[0] for t in ticks[settled, 0]])
    err = ticks[settled, 1] - roll_ref
    return float(np.sqrt(np.mean(err**2))) if len(err) else float("nan")


def steer_twin(lib: Any, loop: ClosedLoop, plant: MultibodyPlant, target_velocity_mps: float,
               run_settings: SteerRun | None = None) -> TwinSteerResult:
    """Run the maneuver on ``plant`` and judge it (module docstring)."""
    from skatelib.control.kinematics import LegKinematics

    cfg = run_settings or SteerRun()
    radius = LegKinematics.from_library(lib).foot_radius_m
    ride = steer_ride(lib, loop, target_velocity_mps, cfg.duration_s, radius, cfg.adapt_stiffness)
    run = TwinLoop(lib, ride, loop, plant, cfg.loop).ride()
    ticks, m = run.ticks, run.measures
    settled = ticks[:, 0] >= 1.0
    rms = _roll_rms(ride, run)
    off_deck = int(np.sum(ticks[:, 3] < 4))
    reasons = steer_reasons(rms, off_deck, m, run.fall)
    return TwinSteerResult(
        target_velocity_mps=target_velocity_mps, duration_s=cfg.duration_s, roll_rms_error_rad=rms,
        max_roll_rad=float(np.max(np.abs(ticks[:, 1]), initial=0.0)),
        max_lateral_shift_m=float(np.max(np.abs(ticks[settled, 2]), initial=0.0)),
        min_normal_N=float(np.min(ticks[:, 4], initial=np.inf)), unloaded_steps=off_deck,
        slips=sum(s > SLIP_LIMIT_M for s in m.slips_m),
        mpc_median_ms=float(np.median(run.mpc_times_s) * 1e3) if run.mpc_times_s else float("nan"),
        fall=run.fall, passed=not reasons, reasons="; ".join(reasons), max_slip_m=m.max_slip_m(),
        floor_touch_ticks=m.floor_touch_ticks, wheel_lift_ticks=m.wheel_lift_ticks,
        max_wheel_lift_ms=m.max_wheel_lift_ms)
