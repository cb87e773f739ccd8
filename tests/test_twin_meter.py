"""The twin's meter measures a chunk of ticks at once: its figures against a plain tick-by-tick
reference written here (slips summed stance by stance, wheels' unloaded runs counted tick by tick,
the first unplanned floor contact, speeds at the entry's end and at a ride's stage ends), on
synthetic states whose stances, wheel lifts and stage ends straddle the chunks' boundaries."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest
from skatelib.library.channels import GROUND
from skatelib.proving.twin import metrics
from skatelib.proving.twin.metrics import Meter, MeterPlan, TwinMeasures
from skatelib.sim.twin_state import TwinState

TICK_S = 0.002
N = 1000  # 2 s: past the entry's end (0.9 s) and a second after it
LIMIT_NM = 5.0
AXLE_Z = -0.07


def _states(seed: int, rolling_mps: float = 0.5, nan: bool = False) -> list[TwinState]:
    """Stances opening and closing at random ticks (two ending on one tick), a wheel off the floor
    across the first chunk's end, the deck rolling at ``rolling_mps`` along its heading; with
    ``nan`` a NaN in a wheel load, the system's velocity and the deck's attitude on single ticks."""
    rng = np.random.default_rng(seed)
    out = []
    touch = np.zeros(4, dtype=np.int8)
    for k in range(N):
        if rng.random() < 0.05:
            i = rng.integers(4)
            touch[i] = 0 if touch[i] else rng.integers(1, 3)
        if k == 290:
            touch[1], touch[2] = 1, 2
        if k == 300:
            touch[1] = touch[2] = 0  # two stances end on one tick
        yaw, roll = 0.3 * math.sin(k / 90), 0.05 * math.sin(k / 13)
        cz, sz, cr, sr = math.cos(yaw), math.sin(yaw), math.cos(roll), math.sin(roll)
        R = np.array([[cz, -sz * cr, sz * sr], [sz, cz * cr, -cz * sr], [0.0, sr, cr]])
        loads = np.maximum(rng.normal(5.0, 4.0, 4), 0.0) * (rng.random(4) > 0.1)
        loads[1] *= not 505 <= k < 521  # a wheel off the floor across the first chunk's end
        loads[3] *= not 100 <= k < 104  # one unloaded for four ticks: not a lift
        deck_v = np.array([rolling_mps * cz, rolling_mps * sz, 0.0]) + rng.normal(0.0, 0.01, 3)
        system_v = rng.normal(0.5, 0.1, 3)
        if nan and k in (200, 449, 949):
            loads[2] = system_v[0] = math.nan
            loads[0] = -1.0  # below every other load, on a tick passed over
        if nan and k in (449, 700):
            R = R * math.nan
        out.append(TwinState(
            t=k * TICK_S, trunk_pos=rng.normal(size=3), trunk_R=np.eye(3), trunk_v=np.zeros(3),
            trunk_omega=np.zeros(3), q=np.zeros(12), qd=np.zeros(12), deck_pos=rng.normal(size=3), deck_R=R,
            deck_v=deck_v, deck_omega=rng.normal(0.0, 0.01, 3), foot_centres=rng.normal(size=(3, 4)),
            foot_velocities=rng.normal(0.0, 0.01, (3, 4)), foot_touch=touch.copy(),
            contact_points=rng.normal(size=(3, 4)),
            foot_spins=rng.normal(0.0, 0.01, (3, 4)), foot_load_N=rng.normal(10, 3, 4), wheel_load_N=loads,
            wheel_force_N=rng.normal(size=3), system_v=system_v, system_mass_kg=10.0,
            floor_touches=("knee",) if k in (611, 650) else ()))
    return out


def _codes(t: np.ndarray) -> np.ndarray:
    """Foot 0 planned on the floor from 0.4 to 0.6 s, the others never."""
    codes = np.zeros((len(t), 4), dtype=np.int8)
    codes[(t >= 0.4) & (t < 0.6), 0] = GROUND
    return codes


PLAN = MeterPlan(t_end=0.9, board_end=np.array([0.1, -0.2, 0.0, 0.05]), floor_codes=_codes,
                 stage_ends=(0.2995, 0.3, 0.8))  # two ends within one tick: one each tick


def _taus() -> np.ndarray:
    taus = np.random.default_rng(1).normal(0.0, 2.0, (N, 12))
    taus[50, 3] = LIMIT_NM  # saturated
    return taus


def _metered(states: list[TwinState]) -> Meter:
    meter = Meter(TICK_S, LIMIT_NM, PLAN, axle_below_deck_m=-AXLE_Z)
    for st, tau in zip(states, _taus(), strict=True):
        meter.tick(st.t + TICK_S, st, tau)
    meter.finish()
    return meter


def _slips(states: list[TwinState]) -> list[float]:
    """Each stance's largest integrated slip, in the order the stances end (by foot within a tick)."""
    slip, peak, touching = np.zeros((3, 4)), np.zeros(4), np.zeros(4, dtype=bool)
    slips: list[float] = []
    for st in states:
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
    return slips + [float(s) for s, t in zip(peak, touching, strict=True) if t]


def _reference(states: list[TwinState]) -> TwinMeasures:
    """The figures tick by tick, written plainly with Python's max and min (which pass over a NaN
    on their right)."""
    m = TwinMeasures(slips_m=_slips(states))
    unloaded, at_end = np.zeros(4, dtype=int), PLAN.t_end
    for st, tau in zip(states, _taus(), strict=True):
        t = st.t + TICK_S
        m.ticks += 1
        top = float(np.max(np.abs(tau)))
        m.max_torque_Nm = max(m.max_torque_Nm, min(top, LIMIT_NM))
        m.saturated_ticks += top >= LIMIT_NM * 0.999
        m.max_deck_roll_rad = max(m.max_deck_roll_rad, abs(st.deck_roll))
        planned = any(bool((_codes(np.array([t + d])) == GROUND)[0, 0]) for d in (-0.03, 0.0, 0.03))
        wrong = [i for i in range(4) if st.foot_touch[i] == metrics.ON_FLOOR and not (i == 0 and planned)]
        if st.floor_touches or wrong:
            m.floor_touch_ticks += 1
            if not m.floor_touch_first:
                m.floor_touch_first = f"{', '.join(st.floor_touches) or f'foot {wrong[0]}'} at t = {st.t:.2f} s"
        m.min_wheel_load_N = min(m.min_wheel_load_N, float(np.min(st.wheel_load_N)))
        unloaded = np.where(st.wheel_load_N <= 0.0, unloaded + 1, 0)
        m.wheel_lift_ticks += bool(np.any(unloaded >= metrics.WHEEL_LIFT_TICKS))
        m.max_wheel_lift_ms = max(m.max_wheel_lift_ms, 1e3 * TICK_S * float(np.max(unloaded)))
        heading = np.array([math.cos(st.deck_yaw), math.sin(st.deck_yaw)])
        along = float(st.system_v[0] * heading[0] + st.system_v[1] * heading[1])
        m.system_mass_kg = st.system_mass_kg
        if at_end <= t < at_end + 1.0:
            m.friction_loss_Ns -= float(st.wheel_force_N[0] * heading[0] + st.wheel_force_N[1] * heading[1]) * TICK_S
        if math.isnan(m.momentum_at_end_mps) and t >= at_end:
            m.momentum_at_end_mps = along
        if math.isnan(m.momentum_after_1s_mps) and t >= at_end + 1.0:
            m.momentum_after_1s_mps = along
        if len(m.stage_speeds_mps) < len(PLAN.stage_ends) and t >= PLAN.stage_ends[len(m.stage_speeds_mps)] - 1e-9:
            m.stage_speeds_mps.append(along)
        v_axle = st.deck_v + np.cross(st.deck_omega, st.deck_R[:, 2] * AXLE_Z)
        forward = float(v_axle[0] * heading[0] + v_axle[1] * heading[1])
        if abs(forward) > metrics.CRAB_MIN_MPS:
            across = float(v_axle[1] * heading[0] - v_axle[0] * heading[1])
            m.max_crab_rad = max(m.max_crab_rad, abs(math.atan2(across, abs(forward))))
        error = st.deck_yaw - PLAN.board_end[3]
        if math.isnan(m.heading_at_end_rad) and t >= at_end:
            m.heading_at_end_rad = error
            side = np.array([-math.sin(PLAN.board_end[3]), math.cos(PLAN.board_end[3])])
            m.lateral_at_end_m = float((st.deck_pos[0:2] - PLAN.board_end[0:2]) @ side)
        m.heading_at_stop_rad = error
    return m


@functools.cache
def _case(nan: bool) -> tuple[list[TwinState], TwinMeasures]:
    """The states of seed 3 and their reference figures (computed once a run)."""
    states = _states(3, nan=nan)
    return states, _reference(states)


def _assert_close(m: TwinMeasures, ref: TwinMeasures) -> None:
    for f in dataclasses.fields(TwinMeasures):
        a, b = getattr(m, f.name), getattr(ref, f.name)
        if isinstance(a, str):
            assert a == b, f.name
        else:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15, err_msg=f.name)


@pytest.mark.parametrize("chunk", [1, 7, 64, metrics.CHUNK])
@pytest.mark.parametrize("nan", [False, True])
def test_the_meter_measures_as_tick_by_tick(monkeypatch: pytest.MonkeyPatch, chunk: int, nan: bool) -> None:
    """Every figure against the plain reference, with NaN ticks passed over as tick by tick."""
    monkeypatch.setattr(metrics, "CHUNK", chunk)
    states, ref = _case(nan)
    assert len(ref.slips_m) > 15 and ref.wheel_lift_ticks > 0 and ref.floor_touch_first and ref.saturated_ticks
    assert ref.max_crab_rad > 0 and not math.isnan(ref.momentum_after_1s_mps) and len(ref.stage_speeds_mps) == 3
    assert not math.isnan(ref.heading_at_end_rad) and ref.floor_touch_ticks > 2
    _assert_close(_metered(states).m, ref)


def test_the_chunks_do_not_change_the_figures(monkeypatch: pytest.MonkeyPatch) -> None:
    """Measured one tick at a time or 512 at once: the same figures and per-tick table to the bit."""
    states = _states(5)
    whole = _metered(states)
    monkeypatch.setattr(metrics, "CHUNK", 1)
    single = _metered(states)
    for f in dataclasses.fields(TwinMeasures):
        a, b = getattr(whole.m, f.name), getattr(single.m, f.name)
        assert a == b if isinstance(a, str) else np.array_equal(a, b, equal_nan=True), f.name
    assert np.array_equal(whole.table, single.table) and whole.table.shape == (N, 5)


def test_a_doctored_slip_is_seen() -> None:
    """One stance's foot sliding 5 mm per tick shows as a slip of that stance's length."""
    states = _states(3, rolling_mps=0.0)
    plain = max(_metered(states).m.slips_m)
    k = next(k for k, st in enumerate(states) if st.foot_touch[2] and not states[k - 1].foot_touch[2])
    n = 0
    while states[k + n].foot_touch[2]:
        states[k + n].foot_velocities[0, 2] += 2.5  # 2.5 m/s x 2 ms
        n += 1
    doctored = max(_metered(states).m.slips_m)
    assert doctored > plain and doctored == pytest.approx(0.005 * n, rel=0.2)
