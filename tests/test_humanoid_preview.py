"""Kajita's preview controller: its Riccati solution against SciPy's independent solver, the gain
laws that follow from it, and the servo's behaviour on the cart-table (it tracks a staircase
ZMP of steps, moving the COM before each step; without the preview it lags; a reference that does
not start at zero is met from the first sample when the servo starts at its best offset)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are
from skatelib.pipeline.humanoid.preview import CartTable, preview_gains, track, track_offset, zmp_of

DT, ZC = 0.005, 0.814  # Kajita et al. 2003's example: 5 ms, COM at 0.814 m, 1.6 s of preview


@pytest.fixture(scope="module")
def servo():
    model = CartTable.of(DT, ZC)
    return model, preview_gains(model, int(1.6 / DT))


def test_riccati_matches_scipy(servo):
    model, gains = servo
    A, B, C = model.A, model.B, model.C
    At = np.block([[np.ones((1, 1)), C @ A], [np.zeros((3, 1)), A]])
    Bt = np.vstack([C @ B, B])
    P = solve_discrete_are(At, Bt, np.diag([1.0, 0.0, 0.0, 0.0]), np.array([[1e-6]]))
    np.testing.assert_allclose(gains.P, P, rtol=1e-6)
    K = np.linalg.inv(1e-6 + Bt.T @ P @ Bt)
    assert gains.Gi == pytest.approx((K @ Bt.T @ P @ np.array([[1.0], [0], [0], [0]])).item(), rel=1e-6)


def test_preview_gains_decay(servo):
    """Gd starts at -Gi and fades: the far future hardly counts (under 1 % of its peak at 1.6 s)."""
    _, gains = servo
    assert gains.Gd[0] == pytest.approx(-gains.Gi)
    assert abs(gains.Gd[-1]) < 0.01 * np.max(np.abs(gains.Gd))


def test_servo_tracks_a_staircase_of_steps(servo):
    """A ZMP reference stepping 0.3 m every 0.8 s: the cart's ZMP stays within 2 cm of it away from
    the steps' instants, ends on it, and the COM starts moving before the first step; negative
    control: with the preview cut to one step the error is several times larger."""
    model, gains = servo
    t = np.arange(0.0, 7.0, DT)
    p_ref = 0.3 * np.clip(np.floor((t - 2.0) / 0.8) + 1, 0, 5)  # the first step beyond the 1.6 s window
    states = track(model, gains, p_ref)
    err = np.abs(zmp_of(model, states) - p_ref)
    steps = np.nonzero(np.diff(p_ref))[0]
    away = np.ones(len(t), dtype=bool)
    for k in steps:
        away[max(k - 20, 0):k + 40] = False
    assert err[away].max() < 0.02 and err[-1] < 1e-3
    first = steps[0]
    assert states[first - int(0.3 / DT), 0] > 0.01  # anticipates the step by at least 0.3 s
    short = track(model, preview_gains(model, 1), p_ref)
    assert np.abs(zmp_of(model, short) - p_ref)[away].max() > 3 * err[away].max()


def test_a_reference_away_from_zero_is_met_from_the_start(servo):
    """A ZMP reference 2 cm off from the first sample: started at zero the servo first moves its
    ZMP the other way by centimetres (the cart-table is non-minimum phase); started from rest at
    its best offset it meets the reference within 0.2 mm at every sample (the finite preview's
    gains hold a constant reference not quite exactly), and for a reference that settles
    after a start transient its squared error is never above the servo's from zero."""
    model, gains = servo
    const = np.full(600, -0.02)
    from_zero = zmp_of(model, track(model, gains, const))
    assert from_zero[1:20].max() > 0.01  # the wrong way first
    offset = track_offset(model, gains, const)
    np.testing.assert_allclose(zmp_of(model, offset), const, atol=2e-4)
    assert offset[0, 0] == pytest.approx(-0.02, abs=2e-4) and np.all(offset[0, 1:] == 0.0)  # from rest
    settles = np.r_[np.linspace(-0.03, 0.01, 8), np.full(592, 0.01)]
    err = [np.sum((zmp_of(model, x) - settles) ** 2) for x in (track(model, gains, settles),
                                                                track_offset(model, gains, settles))]
    assert err[1] <= err[0]
