"""The twin's meter measures a chunk of ticks at once: its figures against a plain tick-by-tick
reference written here (slips summed stance by stance, wheels' unloaded runs counted tick by tick,
the first unplanned floor contact, speeds at the entry's end and at a ride's stage ends), on
synthetic states whose stances, wheel lifts and stage ends straddle the chunks' boundaries."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from skatelib.library.channels import GROUND
from skatelib.proving.twin import metrics
from skatelib.proving.twin.metrics import Meter, MeterPlan

TICK_S = 0.002
N = 700


@dataclass
class State:
    t: float
    trunk_pos: np.ndarray
    deck_pos: np.ndarray
    deck_R: np.ndarray
    deck_v: np.ndarray
    deck_omega: np.ndarray
    foot_centres: np.ndarray
    foot_velocities: np.ndarray
    foot_touch: np.ndarray
    contact_points: np.ndarray
    foot_spins: np.ndarray
    foot_load_N: np.ndarray
    wheel_load_N: np.ndarray
    wheel_force_N: np.ndarray
    system_v: np.ndarray
    system_mass_kg: float = 10.0
    floor_touches: tuple[str, ...] = field(default=())

    @property
    def deck_yaw(self) -> float:
        return float(np.arctan2(self.deck_R[1, 0], self.deck_R[0, 0]))

    @property
    def deck_roll(self) -> float:
        return float(np.arctan2(self.deck_R[2, 1], self.deck_R[2, 2]))


def _states(seed: int) -> list[State]:
    rng = np.random.default_rng(seed)
    out = []
    touch = np.zeros(4, dtype=np.int8)
    for k in range(N):
        if rng.random() < 0.05:  # stances that open and close at random ticks
            i = rng.integers(4)
            touch[i] = 0 if touch[i] else rng.integers(1, 3)
        yaw, roll = 0.3 * math.sin(k / 90), 0.05 * math.sin(k / 13)
        cz, sz, cr, sr = math.cos(yaw), math.sin(yaw), math.cos(roll), math.sin(roll)
        R = np.array([[cz, -sz * cr, sz * sr], [sz, cz * cr, -cz * sr], [0.0, sr, cr]])
        loads = np.maximum(rng.normal(5.0, 4.0, 4), 0.0) * (rng.random(4) > 0.1)
        loads[1] *= not 505 <= k < 521  # a wheel off the floor across the first chunk's end
        loads[3] *= not 100 <= k < 104  # one unloaded for four ticks: not a lift
        out.append(State(
            t=k * TICK_S, trunk_pos=rng.normal(size=3), deck_pos=rng.normal(size=3), deck_R=R,
            deck_v=rng.normal(0.0, 0.01, 3), deck_omega=rng.normal(0.0, 0.01, 3), foot_centres=rng.normal(size=(3, 4)),
            foot_velocities=rng.normal(0.0, 0.01, (3, 4)), foot_touch=touch.copy(),
            contact_points=rng.normal(size=(3, 4)),
            foot_spins=rng.normal(0.0, 0.01, (3, 4)), foot_load_N=rng.normal(10, 3, 4), wheel_load_N=loads,
            wheel_force_N=rng.normal(size=3), system_v=rng.normal(0.5, 0.1, 3),
            floor_touches=("knee",) if k in (611, 650) else ()))
    return out


def _codes(t: np.ndarray) -> np.ndarray:
    """Foot 0 planned on the floor from 0.4 to 0.6 s, the others never."""
    codes = np.zeros((len(t), 4), dtype=np.int8)
    codes[(t >= 0.4) & (t < 0.6), 0] = GROUND
    return codes


PLAN = MeterPlan(t_end=0.9, board_end=np.array([0.1, -0.2, 0.0, 0.05]), floor_codes=_codes,
                 stage_ends=(0.2995, 0.3, 0.8))  # two ends within one tick: one each tick


def _metered(states: list[State]) -> Meter:
    meter = Meter(TICK_S, 5.0, PLAN, axle_below_deck_m=0.07)
    taus = np.random.default_rng(1).normal(0.0, 3.0, (N, 12))
    for k, st in enumerate(states):
        meter.tick(st.t + TICK_S, st, taus[k])
    meter.finish()
    return meter


def _reference(states: list[State]) -> dict[str, object]:
    """The figures tick by tick, written plainly."""
    slip, peak, touching = np.zeros((3, 4)), np.zeros(4), np.zeros(4, dtype=bool)
    slips: list[float] = []
    unloaded, lift_ticks, lift_max, first = np.zeros(4, dtype=int), 0, 0, ""
    at_end, stages = math.nan, []
    for st in states:
        t = st.t + TICK_S
        for i in range(4):
            if st.foot_touch[i]:
                p = st.contact_points[:, i]
                v = st.foot_velocities[:, i] + np.cross(st.foot_spins[:, i], p - st.foot_centres[:, i])
                if st.foot_touch[i] == metrics.ON_DECK:
                    v = v - st.deck_v - np.cross(st.deck_omega, p - st.deck_pos)
                if not touching[i]:
                    slip[:, i], peak[i] = 0.0, 0.0
                slip[:, i] += v * TICK_S
                peak[i] = max(peak[i], float(np.linalg.norm(slip[:, i])))
            elif touching[i]:
                slips.append(float(peak[i]))
            touching[i] = bool(st.foot_touch[i])
        unloaded = np.where(st.wheel_load_N <= 0.0, unloaded + 1, 0)
        lift_ticks += int(np.any(unloaded >= metrics.WHEEL_LIFT_TICKS))
        lift_max = max(lift_max, int(np.max(unloaded)))
        planned = any(bool((_codes(np.array([t + d])) == GROUND)[0, 0]) for d in (-0.03, 0.0, 0.03))
        wrong = [i for i in range(4) if st.foot_touch[i] == metrics.ON_FLOOR and not (i == 0 and planned)]
        if not first and (st.floor_touches or wrong):
            first = f"{', '.join(st.floor_touches) or f'foot {wrong[0]}'} at t = {st.t:.2f} s"
        heading = np.array([math.cos(st.deck_yaw), math.sin(st.deck_yaw)])
        if math.isnan(at_end) and t >= PLAN.t_end:
            at_end = float(st.system_v[0:2] @ heading)
        if len(stages) < len(PLAN.stage_ends) and t >= PLAN.stage_ends[len(stages)] - 1e-9:
            stages.append(float(st.system_v[0:2] @ heading))
    slips += [float(s) for s, t in zip(peak, touching, strict=True) if t]
    return {"slips": slips, "lift_ticks": lift_ticks, "lift_ms": 1e3 * TICK_S * lift_max, "first": first,
            "at_end": at_end, "stages": stages}


@pytest.mark.parametrize("chunk", [1, 7, 64, metrics.CHUNK])
def test_the_meter_measures_as_tick_by_tick(monkeypatch: pytest.MonkeyPatch, chunk: int) -> None:
    monkeypatch.setattr(metrics, "CHUNK", chunk)
    states = _states(3)
    ref = _reference(states)
    m = _metered(states).m
    assert len(ref["slips"]) > 15 and ref["lift_ticks"] > 0 and ref["first"]  # type: ignore[arg-type]
    np.testing.assert_allclose(m.slips_m, ref["slips"], rtol=1e-12, atol=1e-15)  # type: ignore[arg-type]
    assert m.wheel_lift_ticks == ref["lift_ticks"] and m.max_wheel_lift_ms == pytest.approx(ref["lift_ms"])
    assert m.floor_touch_first == ref["first"]
    assert m.momentum_at_end_mps == pytest.approx(ref["at_end"], rel=1e-12)
    np.testing.assert_allclose(m.stage_speeds_mps, ref["stages"], rtol=1e-12)  # type: ignore[arg-type]
    assert len(m.stage_speeds_mps) == 3 and m.ticks == N


def test_the_chunks_do_not_change_the_figures(monkeypatch: pytest.MonkeyPatch) -> None:
    """Measured one tick at a time or 512 at once: the same figures and per-tick table to the bit."""
    states = _states(5)
    whole = _metered(states)
    monkeypatch.setattr(metrics, "CHUNK", 1)
    single = _metered(states)
    assert whole.m == single.m
    assert np.array_equal(whole.table, single.table) and whole.table.shape == (N, 5)


def test_a_doctored_slip_is_seen() -> None:
    """One stance's foot sliding 5 mm per tick shows as a slip of that stance's length."""
    states = _states(3)
    plain = max(_metered(states).m.slips_m)
    k = next(k for k, st in enumerate(states) if st.foot_touch[2] and not states[k - 1].foot_touch[2])
    n = 0
    while states[k + n].foot_touch[2]:
        states[k + n].foot_velocities[0, 2] += 2.5  # 2.5 m/s x 2 ms
        n += 1
    doctored = max(_metered(states).m.slips_m)
    assert doctored > plain and doctored == pytest.approx(0.005 * n, rel=0.2)
