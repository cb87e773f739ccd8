"""The closed loop's verdict on an entry (fails on any of):

* speed: the speed delivered, one second after the entry ends, more than 5 % from the label (a
  stop: more than 0.05 m/s).
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

from dataclasses import asdict, dataclass

import numpy as np
from skatelib.control.params import SkateParams
from skatelib.control.reference import Reference
from skatelib.library.channels import I_BOARD_ROLL, NX
from skatelib.proving.plant import Plant
from skatelib.proving.trace import Run

SPEED_TOLERANCE = 0.05
STOP_TOLERANCE_MPS = 0.05  # a stop (target speed 0) delivers at most this speed
HEIGHT_LIMIT_M = 0.05  # body height over the deck may leave its reference by this much
TILT_LIMIT_RAD = 0.35
REACH_MARGIN_M = 0.05
IK_TOLERANCE_M = 0.002  # a stance foot the inverse kinematics cannot put on its contact point


@dataclass(frozen=True)
class TrackResult:
    """One entry's closed-loop run (JSON-able numbers; ``trace`` holds the time series)."""

    key: str
    target_velocity_mps: float
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


def fall_reason(ref: Reference, s: np.ndarray, x_ref: np.ndarray, reach_m: float, roll_limit_rad: float,
                t: float) -> str:
    """Why the robot counts as fallen at plant state ``s`` (``reach_m``: its loaded feet's largest
    distance from the COM), or ""."""
    height = s[2] - s[NX + 2]
    ref_height = x_ref[2] - ref.deck_z
    tilt = max(abs(s[3]), abs(s[4]))
    if abs(height - ref_height) > HEIGHT_LIMIT_M:
        return f"body height over the deck {height:.3f} m, reference {ref_height:.3f} m, at t = {t:.2f} s"
    if tilt > TILT_LIMIT_RAD:
        return f"body tilted {tilt:.2f} rad at t = {t:.2f} s"
    if abs(s[I_BOARD_ROLL]) > roll_limit_rad:
        return f"deck roll {s[I_BOARD_ROLL]:.3f} rad beyond the wheel limit at t = {t:.2f} s"
    if reach_m > ref.max_reach + REACH_MARGIN_M:
        return f"a foot {reach_m:.3f} m from the COM (the plan at most {ref.max_reach:.3f}) at t = {t:.2f} s"
    return ""


def slip_reason(plant: Plant) -> str:
    log = plant.log
    return (f"{log.slips} slipping plant steps (force up to {log.slip_excess_N:.2f} N outside the cone of mu "
            f"{plant.p.mu:.2f})") if log.slips else ""


def speed_verdict(target_velocity_mps: float, delivered: float) -> tuple[float, list[str]]:
    """A delivered speed against the entry's target speed (its label) [m/s]: the error (relative;
    for a stop, the speed left in m/s) and the reason it fails (more than 5 % off, a stop above
    0.05 m/s, no speed at all), if any."""
    v = target_velocity_mps
    err = (delivered - v) / v if v else delivered
    if not np.isfinite(delivered):
        return err, ["delivered speed not measured: the run stopped before a second after the entry's end"]
    if v and (not np.isfinite(err) or abs(err) > SPEED_TOLERANCE):
        return err, [f"delivered speed {delivered:.3f} m/s is {100 * err:+.1f} % from the label {v:.2f}"]
    if not v and not abs(delivered) <= STOP_TOLERANCE_MPS:
        return err, [f"a stop still rides at {delivered:.3f} m/s (at most {STOP_TOLERANCE_MPS})"]
    return err, []


def track_result(key: str, target_velocity_mps: float, run: Run, plant_params: SkateParams,
                 torque_limit_Nm: float) -> TrackResult:
    """The verdict on one entry's run (see the module docstring)."""
    delivered = run.momentum_after_1s_mps + run.friction_loss_Ns / (plant_params.mass_kg + plant_params.board_mass_kg)
    err, reasons = speed_verdict(target_velocity_mps, delivered)
    if run.fall:
        reasons.append(f"fall: {run.fall}")
    if run.plant.log.slips:
        reasons.append(slip_reason(run.plant))
    if run.max_torque_Nm > torque_limit_Nm:
        reasons.append(f"joint torque {run.max_torque_Nm:.1f} N m above the limit {torque_limit_Nm:.0f}")
    if run.max_ik_residual_m > IK_TOLERANCE_M:
        reasons.append(f"a stance foot {1e3 * run.max_ik_residual_m:.0f} mm beyond where its leg reaches")
    if run.max_joint_limit_excess_rad > 0.0:
        reasons.append(f"a stance joint {run.max_joint_limit_excess_rad:.3f} rad beyond its limit")
    ms = np.array(run.times_s) * 1e3
    return TrackResult(
        key=key, target_velocity_mps=target_velocity_mps, speed_after_1s_mps=run.speed_after_1s_mps,
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
