"""The coast observer (``skatelib.control.observers.CoastObserver``) on synthetic coasts: robot and
board decelerating at a known rate, shoved or read through noisy feedback, against that rate."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.control.observers import CoastObserver

DT = 1 / 30  # the MPC's update [s]
ROLLING = 0.107  # the twin's board under the default errors [m/s^2] (rolling x1.1 of 0.098)
COAST = 17  # updates of one coast of v0.50_s2 (0.53 s)
TOTAL_KG = 10.7  # robot and board: a shove of J [N s] changes their momentum speed by J / 10.7
STARTS = (0.4, 0.8)  # the two coasts' first momentum speeds [m/s]
# The momentum speed's noise under --perturb noise=0.002 (1 cm/s on the robot's and the board's
# speeds, weighted by their masses) [m/s]: one update's difference spread by 0.35 m/s^2 at 30 Hz.
SIGMA = 0.0083


def coasts(starts_mps: tuple[float, ...], jumps: dict[tuple[int, int], float] | None = None,
           noise: np.ndarray | None = None) -> list[np.ndarray]:
    """Momentum speeds of coasts at ``ROLLING`` from each start, a jump [m/s] added from sample k of
    coast c on (``jumps[c, k]``), plus ``noise`` (one row per coast)."""
    out = []
    for c, v0 in enumerate(starts_mps):
        v = v0 - ROLLING * DT * np.arange(COAST)
        for (cj, k), dv in (jumps or {}).items():
            if cj == c:
                v[k:] += dv
        out.append(v + (0.0 if noise is None else noise[c]))
    return out


def ride(obs: CoastObserver, speeds: list[np.ndarray]) -> list[float | None]:
    """Feed each coast, then a push (updates that are no coast, the speed rising); the estimates at
    each coast's end (what the push after it aims with)."""
    ends = []
    for v in speeds:
        for s in v:
            obs.update(True, float(s), DT)
        ends.append(obs.estimate_mps2)
        for s in np.linspace(v[-1], v[-1] + 0.4, 19):
            obs.update(False, float(s), DT)
    return ends


@settings(max_examples=200, deadline=None)
@given(impulse=st.floats(0.2, 2.0), back=st.booleans(), at=st.integers(1, COAST - 1))
def test_a_shove_is_no_rolling_friction(impulse, back, at):
    """A shove of 0.2-2 N s (the certificate's range) either way at any update of the first of two
    coasts: both coasts' estimates are the board's deceleration (the momentum's changes besides the
    shove's are friction's alone). The low-pass filter of one-update differences took certificate
    draw 3453757713's 0.84 N s backward shove for 2.3 m/s^2 and read 0.335 at that coast's end."""
    dv = (-1.0 if back else 1.0) * impulse / TOTAL_KG
    ends = ride(CoastObserver(gain=0.2, fit=True), coasts(STARTS, {(0, at): dv}))
    assert ends == pytest.approx([ROLLING, ROLLING], rel=1e-6), (dv, at, ends)


def _misses(jumps: dict[tuple[int, int], float], rides: int = 400) -> np.ndarray:
    """The first coast's estimate less the board's deceleration [m/s^2] over noisy rides."""
    rng = np.random.default_rng(0)
    ends = [ride(CoastObserver(gain=0.2, fit=True), coasts(STARTS, jumps, rng.normal(0.0, SIGMA, (2, COAST))))[0]
            for _ in range(rides)]
    return np.array(ends, dtype=float) - ROLLING


def test_noise_is_averaged_over_the_coast():
    """With the feedback's noise on the momentum speed, the estimate at the first coast's end misses
    the board's deceleration by at most 1.5 times (RMS over 400 rides) what a least-squares line
    over the coast's 17 speeds does, its standard error sigma / (dt sqrt(n (n^2 - 1) / 12)) =
    0.012 m/s^2. The low-pass filter of one-update differences missed by 0.05 (4.2 times)."""
    standard_error = SIGMA / (DT * np.sqrt(COAST * (COAST**2 - 1) / 12))
    rms = float(np.sqrt(np.mean(np.square(_misses({})))))
    assert rms < 1.5 * standard_error, (rms, standard_error)


def test_a_shove_in_noise_leaves_the_estimate_unbiased():
    """The 0.84 N s backward shove at 45 % of the first coast, with the feedback's noise: over 400
    rides the estimate at that coast's end is off by less than a fifth of the board's deceleration
    on average (the shove's change is 6-7 standard deviations of the noise's: most rides leave it
    out). The low-pass filter of one-update differences read 0.062 m/s^2 too much on average."""
    mean = float(np.mean(_misses({(0, int(0.45 * COAST)): -0.84 / TOTAL_KG})))
    assert abs(mean) < 0.2 * ROLLING, mean


def test_the_filter_takes_a_shove_for_friction():
    """Without ``fit`` (``MpcConfig(coast_fit=False)``), the low-pass filter of one-update
    differences reads the 0.84 N s backward shove as friction: the first coast's estimate ends 1.7
    times the board's deceleration, eight updates after the shove (what the default fit removes)."""
    dv = -0.84 / TOTAL_KG
    shoved, = ride(CoastObserver(gain=0.2, fit=False), coasts(STARTS[:1], {(0, COAST // 2): dv}))
    assert shoved is not None and shoved > 1.5 * ROLLING, shoved  # 0.186 against 0.107
    plain, = ride(CoastObserver(gain=0.2, fit=False), coasts(STARTS[:1]))
    assert plain == pytest.approx(ROLLING, rel=1e-9)
