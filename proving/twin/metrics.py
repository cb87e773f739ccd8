"""What a run on a multibody plant measures from the plant's true state (not the controller's
estimate): slip of every stance at its contact point, floor contacts the plan has no place for,
wheels off the floor, torque saturation, the speeds the verdict needs.

Slip is the contact point's material velocity relative to the surface under it (the foot sphere's
centre velocity plus its spin times the lever to the contact, less the deck point's velocity),
integrated over each stance: a rolling foot does not slip, a sliding one does. The meter keeps
each tick's state and measures a chunk of ticks at once, with the operations (and the NaN rules) of
tick by tick: a small part of what measuring at every tick costs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from skatelib.control.feedback import ON_DECK, ON_FLOOR
from skatelib.library.channels import GROUND

WHEEL_LIFT_TICKS = 5  # a wheel without load for this many ticks in a row has lifted off
CONTACT_GRACE_S = 0.03  # a foot on the floor this close to a planned stance on the floor is not unplanned
CRAB_MIN_MPS = 0.1  # the crab angle is measured above this speed (slower, its direction is noise)
CHUNK = 512  # ticks measured at once


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


@dataclass(frozen=True)
class MeterPlan:
    """What a run's figures are measured against: the entry's end ``t_end`` [s], the plan's board
    at it (x, y, z, yaw), a ride's stage ends [s], and ``floor_codes(t)``: the planned contact
    codes (n, 4) at the times ``t`` (n,)."""

    t_end: float
    board_end: np.ndarray
    floor_codes: Callable[[np.ndarray], np.ndarray]
    stage_ends: tuple[float, ...] = ()


class Meter:
    """Updates :class:`TwinMeasures` from the true state of each tick (:meth:`tick`, then
    :meth:`finish` once), and keeps each tick's row of :attr:`table`."""

    def __init__(self, tick_s: float, torque_limit_Nm: float, plan: MeterPlan, axle_below_deck_m: float = 0.0):
        self.m = TwinMeasures()
        self.plan = plan
        self.axle_z = -axle_below_deck_m  # the axles in the deck frame, (0, 0, axle_z): where the wheels roll
        self.tick_s = tick_s
        self.limit = torque_limit_Nm
        self.slip = np.zeros((3, 4))  # the open stances' integrated slip
        self.slip_max = np.zeros(4)
        self.touching = np.zeros(4, dtype=bool)
        self.unloaded = np.zeros(4, dtype=int)
        self._kept: list[tuple[float, Any, np.ndarray]] = []
        self._tables: list[np.ndarray] = []

    def tick(self, t: float, st: Any, tau_cmd: np.ndarray) -> None:
        """One tick: the run's clock ``t`` [s] after it, the plant's true state, the torques commanded."""
        self._kept.append((t, st, np.array(tau_cmd, dtype=np.float64)))
        if len(self._kept) >= CHUNK:
            self._measure()

    def finish(self) -> None:
        """Measure the ticks kept; the stances still open end here."""
        self._measure()
        self.m.slips_m += [float(s) for s, t in zip(self.slip_max, self.touching, strict=True) if t]

    @property
    def table(self) -> np.ndarray:
        """(ticks, 5) per tick: t, deck roll, the trunk's offset from the deck's centre line, feet
        touching, the smallest foot normal force (after :meth:`finish`)."""
        return np.concatenate(self._tables) if self._tables else np.zeros((0, 5))

    def _measure(self) -> None:
        if not self._kept:
            return
        t = np.array([k[0] for k in self._kept])
        states = [k[1] for k in self._kept]
        tau = np.array([k[2] for k in self._kept])
        self._kept = []
        m = self.m
        m.ticks += len(t)
        top = np.max(np.abs(tau), axis=1)
        m.max_torque_Nm = max(m.max_torque_Nm, min(_top(top), self.limit))
        m.saturated_ticks += int(np.sum(top >= self.limit * 0.999))
        roll = np.array([st.deck_roll for st in states])
        m.max_deck_roll_rad = max(m.max_deck_roll_rad, _top(np.abs(roll)))
        touch = np.array([st.foot_touch for st in states])
        self._slips(states, touch)
        self._floor(t, states, touch)
        self._wheels(np.array([st.wheel_load_N for st in states]))
        yaw = np.array([st.deck_yaw for st in states])
        heading = np.stack([np.cos(yaw), np.sin(yaw)], axis=1)
        self._speeds(t, states, heading)
        self._drift(t, states, yaw)
        offsets = np.array([st.trunk_pos[0:2] - st.deck_pos[0:2] for st in states])
        side = -heading[:, 1] * offsets[:, 0] + heading[:, 0] * offsets[:, 1]
        lowest = np.array([np.min(st.foot_load_N) for st in states])
        self._tables.append(np.column_stack([t, roll, side, np.sum(touch > 0, axis=1), lowest]))

    def _slips(self, states: list[Any], touch: np.ndarray) -> None:
        """Each stance's slip: the contact point's velocity against the surface under it, summed
        tick by tick from the stance's first tick (a stance open at the chunk's start goes on)."""
        p = _stacked(states, "contact_points")
        lever = p - _stacked(states, "foot_centres")
        v = _stacked(states, "foot_velocities") + _cross(_stacked(states, "foot_spins"), lever)
        deck_v = np.array([st.deck_v for st in states]).T[:, :, None]
        deck_w = np.array([st.deck_omega for st in states]).T[:, :, None]
        deck_p = np.array([st.deck_pos for st in states]).T[:, :, None]
        under = deck_v + _cross(deck_w, p - deck_p)
        v = np.where(touch[None] == ON_DECK, v - under, v)  # (3, n, 4)
        ended: list[tuple[int, int, float]] = []
        for i in range(4):
            on = touch[:, i] > 0
            edges = np.flatnonzero(np.diff(np.r_[0, on.astype(np.int8), 0]))
            if self.touching[i] and not on[0]:
                ended.append((0, i, float(self.slip_max[i])))
            for a, b in zip(edges[0::2], edges[1::2], strict=True):
                going_on = a == 0 and self.touching[i]
                start = self.slip[:, i] if going_on else np.zeros(3)
                s = np.cumsum(np.vstack([start, v[:, a:b, i].T * self.tick_s]), axis=0)[1:]
                top = max(float(self.slip_max[i]) if going_on else 0.0, _top(np.sqrt(np.sum(s * s, axis=1))))
                self.slip[:, i], self.slip_max[i] = s[-1], top
                if b < len(on):
                    ended.append((int(b), i, top))
            self.touching[i] = on[-1]
        self.m.slips_m += [s for _, _, s in sorted(ended)]

    def _floor(self, t: np.ndarray, states: list[Any], touch: np.ndarray) -> None:
        """Ticks with a foot on the floor where the plan has none near, or another geom on it."""
        codes = self.plan.floor_codes
        planned = (codes(t - CONTACT_GRACE_S) == GROUND) | (codes(t) == GROUND) | (codes(t + CONTACT_GRACE_S) == GROUND)
        wrong = (touch == ON_FLOOR) & ~planned
        bad = np.array([bool(st.floor_touches) for st in states]) | np.any(wrong, axis=1)
        m = self.m
        m.floor_touch_ticks += int(np.sum(bad))
        if not m.floor_touch_first and bad.any():
            k = int(np.argmax(bad))
            what = ", ".join(states[k].floor_touches) or f"foot {int(np.argmax(wrong[k]))}"
            m.floor_touch_first = f"{what} at t = {states[k].t:.2f} s"

    def _wheels(self, loads: np.ndarray) -> None:
        """The lowest wheel load, and the wheels off the floor: ticks in a row without load."""
        m = self.m
        # tick by tick: a tick whose lowest load is NaN is passed over
        m.min_wheel_load_N = min(m.min_wheel_load_N, float(np.fmin.reduce(np.min(loads, axis=1))))
        n = len(loads)
        idx = np.arange(n)[:, None]
        free = loads <= 0.0
        last_loaded = np.maximum.accumulate(np.where(free, -1, idx), axis=0)
        run = np.where(last_loaded >= 0, idx - last_loaded, idx + 1 + self.unloaded[None, :])
        self.unloaded = run[-1].copy()
        m.wheel_lift_ticks += int(np.sum(np.any(run >= WHEEL_LIFT_TICKS, axis=1)))
        m.max_wheel_lift_ms = max(m.max_wheel_lift_ms, 1e3 * self.tick_s * float(np.max(run)))

    def _speeds(self, t: np.ndarray, states: list[Any], heading: np.ndarray) -> None:
        """Momentum speed at the entry's end, one second later and at a ride's stage ends; rolling
        losses in between; the crab angle."""
        m, t_end = self.m, self.plan.t_end
        m.system_mass_kg = states[-1].system_mass_kg
        system_v = np.array([st.system_v[0:2] for st in states])
        along = system_v[:, 0] * heading[:, 0] + system_v[:, 1] * heading[:, 1]
        wheel = np.array([st.wheel_force_N[0:2] for st in states])
        losses = (wheel[:, 0] * heading[:, 0] + wheel[:, 1] * heading[:, 1]) * self.tick_s
        for x in losses[(t_end <= t) & (t < t_end + 1.0)]:
            m.friction_loss_Ns -= float(x)
        m.momentum_at_end_mps = _first(m.momentum_at_end_mps, t >= t_end, along)
        m.momentum_after_1s_mps = _first(m.momentum_after_1s_mps, t >= t_end + 1.0, along)
        k = 0
        while len(m.stage_speeds_mps) < len(self.plan.stage_ends) and k < len(t):
            reached = np.flatnonzero(t[k:] >= self.plan.stage_ends[len(m.stage_speeds_mps)] - 1e-9)
            if not len(reached):
                break
            k += int(reached[0])
            m.stage_speeds_mps.append(float(along[k]))
            k += 1  # one stage end per tick
        # At the axles, not the deck's top: a rolling deck's top swings sideways over the wheels.
        deck_R = np.array([st.deck_R[:, 2] for st in states]).T * self.axle_z
        v_axle = np.array([st.deck_v for st in states]).T + _cross(np.array([st.deck_omega for st in states]).T, deck_R)
        forward = v_axle[0] * heading[:, 0] + v_axle[1] * heading[:, 1]
        rolling = np.abs(forward) > CRAB_MIN_MPS
        if rolling.any():
            across = v_axle[1] * heading[:, 0] - v_axle[0] * heading[:, 1]
            crab = np.abs(np.arctan2(across[rolling], np.abs(forward[rolling])))
            m.max_crab_rad = max(m.max_crab_rad, _top(crab))

    def _drift(self, t: np.ndarray, states: list[Any], yaw: np.ndarray) -> None:
        """The board's heading and lateral position against the plan's when the entry ends, and
        the heading since."""
        m, board_end = self.m, self.plan.board_end
        yaw_error = yaw - board_end[3]
        at = (t >= self.plan.t_end) & ~np.isnan(yaw_error)  # a NaN is measured again at the next tick
        if np.isnan(m.heading_at_end_rad) and np.any(at):
            k = int(np.argmax(at))
            m.heading_at_end_rad = float(yaw_error[k])
            lateral = np.array([-np.sin(board_end[3]), np.cos(board_end[3])])
            m.lateral_at_end_m = float((states[k].deck_pos[0:2] - board_end[0:2]) @ lateral)
        m.heading_at_stop_rad = float(yaw_error[-1])


def _stacked(states: list[Any], name: str) -> np.ndarray:
    """(3, n, 4): a (3, 4) field of every state, the components first."""
    return np.array([getattr(st, name) for st in states]).transpose(1, 0, 2)


def _first(value: float, reached: np.ndarray, along: np.ndarray) -> float:
    """``value`` if measured, else ``along`` at the first tick ``reached`` where it is a number."""
    at = reached & ~np.isnan(along)
    if not np.isnan(value) or not at.any():
        return value
    return float(along[int(np.argmax(at))])


def _top(values: np.ndarray) -> float:
    """The largest number of ``values`` (NaN if none), as a running ``max`` passes over a NaN."""
    return float(np.fmax.reduce(values, axis=None))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors, or along the first axis of (3, ...) arrays (np.cross costs ten times
    as much on these)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
