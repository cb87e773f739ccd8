"""What a run on a multibody plant measures, tick by tick, from the plant's true state (not the
controller's estimate): slip of every stance at its contact point, floor contacts the plan has no
place for, wheels off the floor, torque saturation, the speeds the verdict needs.

Slip is the contact point's material velocity relative to the surface under it (the foot sphere's
centre velocity plus its spin times the lever to the contact, less the deck point's velocity),
integrated over each stance: a rolling foot does not slip, a sliding one does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.feedback import ON_DECK, ON_FLOOR
from skatelib.library.channels import GROUND

WHEEL_LIFT_TICKS = 5  # a wheel without load for this many ticks in a row has lifted off
CONTACT_GRACE_S = 0.03  # a foot on the floor this close to a planned stance on the floor is not unplanned
CRAB_MIN_MPS = 0.1  # the crab angle is measured above this speed (slower, its direction is noise)


@dataclass
class TwinMeasures:
    """Running figures of one run."""

    slips_m: list[float] = field(default_factory=list)  # one per finished stance
    floor_touch_ticks: int = 0
    floor_touch_first: str = ""
    wheel_lift_ticks: int = 0
    max_wheel_lift_ms: float = 0.0
    min_wheel_load_N: float = float("inf")
    saturated_ticks: int = 0
    ticks: int = 0
    max_torque_Nm: float = 0.0
    max_deck_roll_rad: float = 0.0
    friction_loss_Ns: float = 0.0
    momentum_at_end_mps: float = float("nan")
    momentum_after_1s_mps: float = float("nan")
    stage_speeds_mps: list[float] = field(default_factory=list)  # a ride's: the momentum speed at each stage's end
    heading_at_end_rad: float = float("nan")
    lateral_at_end_m: float = float("nan")
    heading_at_stop_rad: float = float("nan")
    system_mass_kg: float = float("nan")
    max_crab_rad: float = 0.0  # the deck's velocity from its heading, while it rolls faster than CRAB_MIN_MPS

    def max_slip_m(self) -> float:
        return max(self.slips_m, default=0.0)


class Meter:
    """Updates :class:`TwinMeasures` from each tick's true state."""

    def __init__(self, tick_s: float, torque_limit_Nm: float, stage_ends: tuple[float, ...] = (),
                 axle_below_deck_m: float = 0.0):
        self.m = TwinMeasures()
        self.axle = np.array([0.0, 0.0, -axle_below_deck_m])  # in the deck frame: where the wheels roll
        self.stage_ends = stage_ends
        self.tick_s = tick_s
        self.limit = torque_limit_Nm
        self.slip = np.zeros((3, 4))  # the open stances' integrated slip
        self.slip_max = np.zeros(4)
        self.touching = np.zeros(4, dtype=bool)
        self.unloaded = np.zeros(4, dtype=int)

    def tick(self, st: Any, tau_cmd: np.ndarray, planned_near: np.ndarray) -> None:
        """One tick: ``planned_near`` (4,) whether each foot has a planned floor stance within the
        grace time."""
        m = self.m
        m.ticks += 1
        top = float(np.max(np.abs(tau_cmd)))
        m.max_torque_Nm = max(m.max_torque_Nm, min(top, self.limit))
        m.saturated_ticks += int(top >= self.limit * 0.999)
        m.max_deck_roll_rad = max(m.max_deck_roll_rad, abs(st.deck_roll))
        self._slips(st)
        wrong_feet = [i for i in range(4) if st.foot_touch[i] == ON_FLOOR and not planned_near[i]]
        if st.floor_touches or wrong_feet:
            m.floor_touch_ticks += 1
            if not m.floor_touch_first:
                what = ", ".join(st.floor_touches) or f"foot {wrong_feet[0]}"
                m.floor_touch_first = f"{what} at t = {st.t:.2f} s"
        loads = st.wheel_load_N
        m.min_wheel_load_N = min(m.min_wheel_load_N, float(np.min(loads)))
        self.unloaded = np.where(loads <= 0.0, self.unloaded + 1, 0)
        if np.any(self.unloaded >= WHEEL_LIFT_TICKS):
            m.wheel_lift_ticks += 1
        m.max_wheel_lift_ms = max(m.max_wheel_lift_ms, 1e3 * self.tick_s * float(np.max(self.unloaded)))

    def _slips(self, st: Any) -> None:
        touch = st.foot_touch > 0
        if touch.any():
            # every foot's contact point velocity at once (elementwise: the same figures as foot by foot)
            p = st.contact_points
            v = st.foot_velocities + _cross(st.foot_spins, p - st.foot_centres)
            deck = st.foot_touch == ON_DECK
            if deck.any():
                under = st.deck_v[:, None] + _cross(st.deck_omega[:, None], p - st.deck_pos[:, None])
                v = np.where(deck, v - under, v)
        for i in range(4):
            if touch[i]:
                if not self.touching[i]:
                    self.slip[:, i] = 0.0
                    self.slip_max[i] = 0.0
                self.slip[:, i] += v[:, i] * self.tick_s
                self.slip_max[i] = max(self.slip_max[i], float(np.linalg.norm(self.slip[:, i])))
            elif self.touching[i]:
                self.m.slips_m.append(float(self.slip_max[i]))
        self.touching = touch

    def finish(self) -> None:
        self.m.slips_m += [float(s) for s, t in zip(self.slip_max, self.touching, strict=True) if t]

    def speeds(self, st: Any, t: float, t_end: float, heading: np.ndarray) -> None:
        """Momentum speed at the entry's end and one second later; rolling losses in between."""
        m = self.m
        m.system_mass_kg = st.system_mass_kg
        if t_end <= t < t_end + 1.0:
            m.friction_loss_Ns -= float(st.wheel_force_N[0:2] @ heading) * self.tick_s
        if np.isnan(m.momentum_at_end_mps) and t >= t_end:
            m.momentum_at_end_mps = float(st.system_v[0:2] @ heading)
        if np.isnan(m.momentum_after_1s_mps) and t >= t_end + 1.0:
            m.momentum_after_1s_mps = float(st.system_v[0:2] @ heading)
        if len(m.stage_speeds_mps) < len(self.stage_ends) and t >= self.stage_ends[len(m.stage_speeds_mps)] - 1e-9:
            m.stage_speeds_mps.append(float(st.system_v[0:2] @ heading))
        # At the axles, not the deck's top: a rolling deck's top swings sideways over the wheels.
        v_axle = st.deck_v + _cross(st.deck_omega, st.deck_R @ self.axle)
        forward = float(v_axle[0:2] @ heading)
        if abs(forward) > CRAB_MIN_MPS:
            across = float(v_axle[1] * heading[0] - v_axle[0] * heading[1])
            m.max_crab_rad = max(m.max_crab_rad, abs(float(np.arctan2(across, abs(forward)))))


    def drift(self, st: Any, t: float, t_end: float, board_end: np.ndarray) -> None:
        """The board's heading and lateral position against the plan's (x, y, z, yaw at the
        entry's end) when the entry ends, and the heading since."""
        m = self.m
        yaw_error = float(st.deck_yaw - board_end[3])
        if np.isnan(m.heading_at_end_rad) and t >= t_end:
            m.heading_at_end_rad = yaw_error
            lateral = np.array([-np.sin(board_end[3]), np.cos(board_end[3])])
            m.lateral_at_end_m = float((st.deck_pos[0:2] - board_end[0:2]) @ lateral)
        m.heading_at_stop_rad = yaw_error


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors, or column by column of (3, n) arrays (np.cross costs ten times as
    much on these)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def planned_floor_near(contact_at: Any, t: float) -> np.ndarray:
    """(4,) whether each foot is planned on the floor at ``t`` or within the grace time."""
    return np.asarray((contact_at(t - CONTACT_GRACE_S) == GROUND) | (contact_at(t) == GROUND)
                      | (contact_at(t + CONTACT_GRACE_S) == GROUND))
