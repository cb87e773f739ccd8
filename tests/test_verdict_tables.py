"""The closed-loop verdict tables (``pipeline/views/verdict_tables.py``): the steering maneuver's
table counts in the units of the plant that ran it, and its legend says so."""

from __future__ import annotations

import io
from typing import Any

import pytest
from rich.console import Console
from skatelib.pipeline.views import verdict_tables
from skatelib.proving.steer import SteerResult

FIGURES: dict[str, Any] = dict(target_velocity_mps=0.5, duration_s=9.0, roll_rms_error_rad=0.0134, max_roll_rad=0.152,
               max_lateral_shift_m=0.072, min_normal_N=3.77, unloaded_steps=0, slips=1, mpc_median_ms=2.0,
               fall="", passed=False, reasons="1 stances slipped up to 1.3 cm on the deck (limit 1 cm)")


def _printed(results: list, monkeypatch: pytest.MonkeyPatch) -> tuple[int, str]:
    """What :func:`steer_table` returns and prints (a console wide enough for every column)."""
    out = Console(width=300, file=io.StringIO(), record=True)
    monkeypatch.setattr(verdict_tables, "console", out)
    failed = verdict_tables.steer_table(results, "default")
    return failed, " ".join(out.export_text().split())


def test_the_twins_steering_table_counts_ticks_and_stances(monkeypatch):
    """The twin's maneuver: feet off the deck in 2 ms ticks, slips as stances beyond 1 cm with the
    largest slip in cm, floor contact and wheel lift in ticks, and a legend that says so (not the
    model plant's plant steps and force cone); the failure is counted and its reason printed."""
    pytest.importorskip("mujoco")
    from skatelib.proving.twin.steer import TwinSteerResult

    r = TwinSteerResult(**FIGURES, max_slip_m=0.013, floor_touch_ticks=2, wheel_lift_ticks=7, max_wheel_lift_ms=23.0)
    failed, text = _printed([r], monkeypatch)
    assert failed == 1
    for header in ("off deck [ticks]", "slip max [cm]", "slips [stances]", "floor [ticks]", "wheel lift [ticks]"):
        assert header in text, header
    assert "1.30" in text and "ticks (2 ms) with a foot touching nothing" in text, text
    assert "stances that slipped more than 1 cm" in text and "plant steps" not in text and "cone" not in text
    assert "0.50 m/s: 1 stances slipped up to 1.3 cm" in text


def test_the_model_plants_steering_table_keeps_its_units(monkeypatch):
    """The model plant's maneuver: unloaded feet and slips in plant steps, slips as forces outside
    the cone; no column of the twin's."""
    failed, text = _printed([SteerResult(**FIGURES)], monkeypatch)
    assert failed == 1
    assert "unloaded [steps]" in text and "slips [steps]" in text and "outside the cone" in text
    assert "ticks" not in text and "slip max" not in text


def test_a_ride_stage_the_run_never_reached_says_so(monkeypatch):
    """A chained ride that fell in its first stage: each stage after the fall reads 'not reached'
    (its speed is NaN), not a speed 'off its target', and the delivered speed 'not measured'."""
    from types import SimpleNamespace as Ns

    out = Console(width=300, file=io.StringIO(), record=True)
    monkeypatch.setattr(verdict_tables, "console", out)
    stages = [Ns(from_velocity_mps=0.0, target_velocity_mps=0.5, keys=("v0.50_s2",), t_end_s=2.4,
                 momentum_at_end_mps=float("nan"), passed=False),
              Ns(from_velocity_mps=0.5, target_velocity_mps=0.0, keys=("v0.50-0.00_s1",), t_end_s=3.9,
                 momentum_at_end_mps=float("nan"), passed=False)]
    run = Ns(key="ride", reasons="fall: trunk 0.099 m above the deck at t = 1.92 s", delivered_mps=float("nan"),
             max_deck_roll_rad=0.081)
    assert verdict_tables.ride_table(Ns(stages=stages, run=run, passed=False), "mu=0.3") is False
    text = " ".join(out.export_text().split())
    assert text.count("not reached") == 3 and "off its target" not in text and "nan" not in text, text
    assert "stage 0 -> 0.5, 0.5 -> 0 not reached (the run stopped)" in text and "delivered not measured" in text
