"""The Foot Coordinates Generator against closed forms: the cycloid's and the rest-to-rest minimum
jerk's formulas, boundary conditions of the general quintic, and the feet of the shipped walking
and skating plans at their footholds, touchdowns and board speeds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.pipeline.config import load_config
from skatelib.pipeline.humanoid.feet import (
    LEFT,
    RIGHT,
    ToeOff,
    cycloid,
    evaluate,
    lowest_point,
    minimum_jerk,
    skating_feet,
    sole_poses,
    walking_feet,
)
from skatelib.pipeline.humanoid.motion import skating_steps, walking_steps

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def test_cycloid_closed_form():
    """Progress and height at quarter phases; zero rate at both ends (central differences)."""
    along, up = cycloid(np.array([0.0, 0.25, 0.5, 0.75, 1.0]))
    np.testing.assert_allclose(along, [0.0, 0.25 - 1 / (2 * np.pi), 0.5, 0.75 + 1 / (2 * np.pi), 1.0], atol=1e-15)
    np.testing.assert_allclose(up, [0.0, 0.5, 1.0, 0.5, 0.0], atol=1e-15)
    h = 1e-6
    for s in (h, 1 - h):
        a, u = cycloid(np.array([s - h, s + h]))
        assert abs(np.diff(a)[0]) / (2 * h) < 1e-4 and abs(np.diff(u)[0]) / (2 * h) < 1e-4


def test_rest_to_rest_minimum_jerk_is_the_textbook_quintic():
    tau = np.linspace(0, 1, 11)
    c = minimum_jerk(([0.2], [0.0], [0.0]), ([1.4], [0.0], [0.0]), 2.0)
    np.testing.assert_allclose(evaluate(c, 2.0 * tau)[:, 0], 0.2 + 1.2 * (10 * tau**3 - 15 * tau**4 + 6 * tau**5),
                               atol=1e-14)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-2, 2), min_size=6, max_size=6), st.floats(0.2, 3.0))
def test_minimum_jerk_meets_its_boundary_conditions(values, T):
    p0, v0, a0, p1, v1, a1 = values
    c = minimum_jerk(([p0], [v0], [a0]), ([p1], [v1], [a1]), T)
    d1 = np.array([i * c[i] for i in range(1, 6)])
    d2 = np.array([i * (i - 1) * c[i] for i in range(2, 6)])
    for coeffs, want0, want1 in ((c, p0, p1), (d1, v0, v1), (d2, a0, a1)):
        np.testing.assert_allclose(evaluate(coeffs, np.array([0.0, T]))[:, 0], [want0, want1], atol=1e-9 * (1 + T**5))


def test_walking_feet_follow_the_plan():
    """The swing foot lands on each step's foothold at the end of single support, rising to the
    height midway; the stance foot does not move meanwhile."""
    cfg = load_config(CONFIGS / "hrp2_walk.toml")
    h = cfg.humanoid
    _, plan = walking_steps(cfg, 0.375)
    t = np.round(np.arange(0.0, sum(s.duration_s for s in plan) + 1e-9, 0.01), 10)
    feet = walking_feet(plan, t, 0.05, h.step_width_m)
    t0 = plan[0].duration_s
    for spec in plan[1:-1]:
        single = spec.segments[1][0]
        k0, k1 = np.searchsorted(t, t0 - 1e-9), np.searchsorted(t, t0 + single - 1e-9)
        stance = np.asarray(spec.segments[0][1].p0)
        leg = RIGHT if np.allclose(feet[k0, RIGHT, 0:3], stance) else LEFT
        swing = 1 - leg
        np.testing.assert_allclose(feet[k0:k1 + 1, leg, 0:3], np.tile(stance, (k1 + 1 - k0, 1)), atol=1e-12)
        np.testing.assert_allclose(feet[k1, swing, 0:3], spec.p_step, atol=1e-12)
        assert feet[(k0 + k1) // 2, swing, 2] == pytest.approx(0.05, abs=1e-3)
        t0 += spec.duration_s
    assert np.all(feet[:, :, 2] >= 0.0) and np.all(feet[:, :, 3:5] == 0.0)


def test_skating_feet_follow_the_board():
    """The board foot stands on the deck and ends the push at the step's position and speed; it
    and then the landed pushing foot move at the board speed; the pushing foot stays put on its
    foothold on the ground during the push, leaves it at rest (flat: no toe-off) and lands on the
    deck behind the board foot, on its line."""
    cfg = load_config(CONFIGS / "hrp2_skate.toml")
    h, s = cfg.humanoid, cfg.skate
    v = 1.0
    _, plan = skating_steps(cfg, v)
    dt = 0.001
    t = np.round(np.arange(0.0, s.push_s + s.slide_s + s.stop_s + 1e-9, dt), 10)
    feet = skating_feet(plan, t, 0.05, h.step_width_m, 0.6)
    k1, k2 = round(s.push_s / dt), round((s.push_s + 0.6) / dt)
    np.testing.assert_allclose(feet[k1, RIGHT, 0:3], plan[0].p_step, atol=1e-9)
    rate = np.gradient(feet[:, :, 0], dt, axis=0)
    assert rate[k1, RIGHT] == pytest.approx(v, abs=1e-3) and rate[0, RIGHT] == pytest.approx(0.0, abs=1e-3)
    np.testing.assert_allclose(rate[k1 + 5:, RIGHT], v, atol=1e-6)
    foothold = [s.push_foothold_m, h.step_width_m / 2, 0.0]
    np.testing.assert_allclose(feet[:k1, LEFT, 0:3], np.tile(foothold, (k1, 1)), atol=1e-12)
    np.testing.assert_allclose(rate[k2 + 5:, LEFT], v, atol=1e-6)
    assert rate[k1 + 1, LEFT] == pytest.approx(0.0, abs=2e-3)
    deck = cfg.board.deck_height_m
    np.testing.assert_allclose(feet[:, RIGHT, 2], deck, atol=1e-12)
    assert feet[k2, LEFT, 2] == pytest.approx(deck, abs=1e-12)
    assert feet[(k1 + k2) // 2, LEFT, 2] == pytest.approx(deck + 0.05, abs=1e-6)
    np.testing.assert_allclose(feet[k2:, LEFT, 0] - feet[k2:, RIGHT, 0], -s.landing_behind_m, atol=1e-9)
    np.testing.assert_allclose(feet[k2:, LEFT, 1] - feet[k2:, RIGHT, 1], 0.0, atol=1e-9)  # in a row on the deck


def test_toe_off_pivots_on_the_toe_edge():
    """With the shipped toe-off the pushing sole stays flat until its last toe_off_s, then pitches
    about its toe edge, which does not move, to toe_off_rad at lift-off, with no jump in the sole
    centre's velocity there; in the swing no edge of the sole goes under the ground, and it lands
    flat."""
    cfg = load_config(CONFIGS / "hrp2_skate.toml")
    h, s = cfg.humanoid, cfg.skate
    assert s.toe_off_rad > 0.0 and s.toe_off_s > 0.0
    _, plan = skating_steps(cfg, 1.0)
    dt = 0.001
    t = np.round(np.arange(0.0, s.push_s + s.slide_s + s.stop_s + 1e-9, dt), 10)
    half = h.foot_length_m / 2
    feet = skating_feet(plan, t, 0.05, h.step_width_m, 0.6, ToeOff(s.toe_off_s, s.toe_off_rad, half))
    sole, pitch = feet[:, LEFT, 0:3], feet[:, LEFT, 4]
    toe = sole + half * np.column_stack([np.cos(pitch), np.zeros_like(pitch), -np.sin(pitch)])  # Ry(pitch) (a, 0, 0)
    k0, k1, k2 = round((s.push_s - s.toe_off_s) / dt), round(s.push_s / dt), round((s.push_s + 0.6) / dt)
    np.testing.assert_allclose(toe[:k1 + 1], np.tile([s.push_foothold_m + half, h.step_width_m / 2, 0.0], (k1 + 1, 1)),
                               atol=1e-12)
    assert np.all(pitch[:k0 + 1] == 0.0) and pitch[k1] == pytest.approx(s.toe_off_rad, abs=1e-12)
    assert np.all(np.diff(pitch[k0:k1 + 1]) >= 0.0)  # the heel only rises while pushing
    rate = np.diff(sole, axis=0) / dt
    assert np.abs(rate[k1] - rate[k1 - 1]).max() < 0.01  # no velocity jump at lift-off (m/s)
    assert lowest_point(feet, half)[k1:k2, LEFT].min() > -1e-12
    assert np.all(pitch[k2:] == 0.0) and feet[k2, LEFT, 2] == pytest.approx(cfg.board.deck_height_m, abs=1e-12)


@pytest.mark.parametrize("v", [0.5, 0.75, 1.0])
def test_the_pushing_sole_never_enters_the_deck(v, monkeypatch):
    """With the shipped skate the pushing sole is over the deck only above its top (the deck under
    the board sole, by :func:`deck_failures`); the negative control: a swing that moves across
    as it rises (both over the whole swing) enters the deck."""
    from skatelib.pipeline.humanoid import feet as feet_module
    from skatelib.pipeline.humanoid.body import deck_failures

    cfg = load_config(CONFIGS / "hrp2_skate.toml")
    h, s = cfg.humanoid, cfg.skate
    _, plan = skating_steps(cfg, v)
    t = np.round(np.arange(0.0, s.push_s + s.slide_s + s.stop_s + 1e-9, 0.001), 10)
    toe_off = ToeOff(s.toe_off_s, s.toe_off_rad, h.foot_length_m / 2)
    half = (h.foot_length_m / 2, h.foot_width_m / 2)
    sound = skating_feet(plan, t, 0.05, h.step_width_m, 0.6, toe_off)
    assert deck_failures(t, sound, half, cfg.board) == []
    monkeypatch.setattr(feet_module, "SWING_ACROSS", 0.0)
    monkeypatch.setattr(feet_module, "SWING_RISE", 1.0)
    late = feet_module.skating_feet(plan, t, 0.05, h.step_width_m, 0.6, toe_off)
    fails = deck_failures(t, late, half, cfg.board)
    assert len(fails) == 1 and "enters the deck" in fails[0], fails


def test_a_pitched_sole_is_lowest_at_its_toe_or_heel():
    """A sole centred 1 cm up and pitched 0.3 rad either way reaches 0.12 sin 0.3 below its centre."""
    soles = np.zeros((2, 2, 5))
    soles[:, :, 2] = 0.01
    soles[0, :, 4], soles[1, :, 4] = 0.3, -0.3
    np.testing.assert_allclose(lowest_point(soles, 0.12), 0.01 - 0.12 * np.sin(0.3), atol=1e-15)


def test_soles_of_an_older_file_read_flat():
    """A ``feet`` array from before format 1.5 (K, 8: no pitch) reads as flat soles; a current one
    (K, 10) as stored."""
    old = np.arange(16.0).reshape(2, 8)
    poses = sole_poses(old)
    np.testing.assert_array_equal(poses[:, :, 0:4], old.reshape(2, 2, 4))
    assert np.all(poses[:, :, 4] == 0.0)
    new = np.arange(20.0).reshape(2, 10)
    np.testing.assert_array_equal(sole_poses(new), new.reshape(2, 2, 5))
