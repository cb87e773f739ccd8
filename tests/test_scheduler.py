"""Contact scheduler: periodic pushes and phase durations on the knots."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.library.channels import BOARD, GROUND, LEGS, SWING
from skatelib.pipeline.quadruped.model.schedule import knot_schedule


@settings(max_examples=60, deadline=None)
@given(strides=st.integers(1, 6), duty_steps=st.integers(2, 38), leg=st.sampled_from(LEGS))
def test_push_runs_have_the_configured_length(cfg, strides, duty_steps, leg):
    """Each stride has exactly one ground run of duty x period and one swing run; others stay on the board."""
    sch = dataclasses.replace(cfg.schedule, push_duty=duty_steps / 40, push_leg=leg)
    ks = knot_schedule(sch, strides, sch.period_s / 40)
    p = LEGS.index(leg)
    assert ks.n_intervals == 40 * strides
    assert ks.stance_intervals(p, GROUND) == [(40 * s, 40 * s + duty_steps) for s in range(strides)]
    swings = ks.stance_intervals(p, SWING)
    assert [b - a for a, b in swings] == [40 - duty_steps] * strides
    others = [i for i in range(4) if i != p]
    assert np.all(ks.contact[:, others] == BOARD)
    assert ks.contact[-1, p] == SWING


def test_default_schedule_matches_paper(cfg):
    """1.2 s period, rear-left pushing 0.54 s per stride at dt 0.03 s (18 intervals)."""
    ks = knot_schedule(cfg.schedule, 2, 0.03)
    assert ks.t[-1] == pytest.approx(2.4)
    assert ks.stance_intervals(LEGS.index("RL"), GROUND) == [(0, 18), (40, 58)]


def test_dt_that_does_not_divide_the_period_is_refused(cfg):
    """A knot spacing that does not divide the period raises ValueError."""
    with pytest.raises(ValueError, match="does not divide"):
        knot_schedule(cfg.schedule, 1, 0.07)
