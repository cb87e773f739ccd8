"""The full-physics verdict on an entry ridden on a multibody plant (fails on any of):

* speed: the speed delivered one second after the entry ends more than 5 % from the label (a stop:
  more than 0.05 m/s)
  (the momentum speed of robot and board together, all their bodies', plus what the floor's
  force on the wheels took in that second);
* a fall (the trunk within 0.10 m of the deck, tilted beyond 0.6 rad, a link on the floor) or a
  QP without solution;
* a stance that slipped more than 1 cm at its contact point;
* a floor contact the plan has no place for (a foot on the floor away from a planned stance
  there, or any other geom);
* a wheel off the floor for 5 ticks (10 ms) or more;
* the board's heading at the entry's end more than 0.1 rad from the plan's;
* the board more than 2 cm to the side of the plan's at the entry's end (the line keeper,
  :mod:`skatelib.control.steering`, steers it back through the deck's roll).

Reported besides: the largest crab angle (the velocity at the axles from the heading), the
heading when the run stops, torque saturation, the largest deck roll, the controllers' times, and
with the estimator in the loop its error against the twin's truth (trunk velocity, board speed,
board roll: RMS and worst; not a failure).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from skatelib.proving.twin.loop import TwinRun
from skatelib.proving.verdict import speed_verdict

SLIP_LIMIT_M = 0.01
HEADING_LIMIT_RAD = 0.1
LATERAL_LIMIT_M = 0.02



@dataclass(frozen=True)
class TwinResult:
    """One entry's run on the twin (JSON-able numbers)."""

    key: str
    target_velocity_mps: float
    momentum_at_end_mps: float
    delivered_mps: float
    speed_error: float
    max_slip_m: float
    touchdowns: int
    floor_touch_ticks: int
    wheel_lift_ticks: int
    min_wheel_load_N: float
    heading_error_rad: float
    lateral_drift_m: float
    heading_at_stop_rad: float
    max_crab_rad: float
    max_deck_roll_rad: float
    max_torque_Nm: float
    saturated_share: float
    wbc_median_ms: float
    mpc_median_ms: float
    fall: str
    passed: bool
    reasons: str
    # The estimator's error against the twin's truth (NaN when the controller was fed the truth).
    est_trunk_v_rms: float = float("nan")
    est_trunk_v_worst: float = float("nan")
    est_board_speed_rms: float = float("nan")
    est_board_speed_worst: float = float("nan")
    est_board_roll_rms: float = float("nan")
    est_board_roll_worst: float = float("nan")

    def as_dict(self) -> dict[str, float | str | bool | int]:
        return asdict(self)


def _ms(times: list[float]) -> float:
    return float(np.median(times) * 1e3) if times else float("nan")


def twin_result(key: str, target_velocity_mps: float, run: TwinRun) -> TwinResult:
    """The verdict on one run (module docstring)."""
    m = run.measures
    delivered = m.momentum_after_1s_mps + m.friction_loss_Ns / m.system_mass_kg
    err, reasons = speed_verdict(target_velocity_mps, delivered)
    slip = m.max_slip_m()
    if run.fall:
        reasons.append(f"fall: {run.fall}")
    if slip > SLIP_LIMIT_M:
        reasons.append(f"a stance slipped {100 * slip:.1f} cm")
    if m.floor_touch_ticks:
        reasons.append(f"unplanned floor contact ({m.floor_touch_first}; {m.floor_touch_ticks} ticks)")
    if m.wheel_lift_ticks:
        reasons.append(f"a wheel left the floor for up to {m.max_wheel_lift_ms:.0f} ms")
    if np.isnan(m.heading_at_end_rad) or np.isnan(m.lateral_at_end_m):
        reasons.append("the board's heading and line not measured: the run stopped before the entry's end")
    else:
        if abs(m.heading_at_end_rad) > HEADING_LIMIT_RAD:
            reasons.append(f"heading {m.heading_at_end_rad:+.3f} rad from the plan's at the entry's end")
        if abs(m.lateral_at_end_m) > LATERAL_LIMIT_M:
            reasons.append(f"board {100 * m.lateral_at_end_m:+.1f} cm to the side of the plan's at the entry's end")
    return TwinResult(
        key=key, target_velocity_mps=target_velocity_mps, momentum_at_end_mps=m.momentum_at_end_mps,
        delivered_mps=delivered,
        speed_error=err, max_slip_m=slip, touchdowns=len(m.slips_m), floor_touch_ticks=m.floor_touch_ticks,
        wheel_lift_ticks=m.wheel_lift_ticks, min_wheel_load_N=m.min_wheel_load_N,
        heading_error_rad=m.heading_at_end_rad, lateral_drift_m=m.lateral_at_end_m,
        heading_at_stop_rad=m.heading_at_stop_rad, max_crab_rad=m.max_crab_rad, max_deck_roll_rad=m.max_deck_roll_rad,
        max_torque_Nm=m.max_torque_Nm, saturated_share=m.saturated_ticks / max(m.ticks, 1),
        wbc_median_ms=_ms(run.wbc_times_s), mpc_median_ms=_ms(run.mpc_times_s), fall=run.fall,
        passed=not reasons, reasons="; ".join(reasons),
        **({f"est_{k}": v for k, v in run.estimator.summary().items()} if run.estimator else {}))
