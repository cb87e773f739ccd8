"""The estimator refuses a reading it cannot take (a NaN or an inf, a field of another shape, a
time that goes back) before any of its filters integrates it: the estimate after the next good
reading is the one it would have been had the bad one never come, on the C tick and the Python
tick alike. One NaN used to leave every later estimate NaN."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from skatelib.control.estimator.estimator import StateEstimator
from skatelib.control.estimator.reading import ReadingError
from skatelib.control.estimator.settings import BoardGeometry, EstimatorSettings
from skatelib.control.feedback import planned_state
from skatelib.control.kinematics import LegKinematics
from skatelib.control.params import SkateParams
from skatelib.runtime import MotionLibrary

LIBRARY = Path(__file__).resolve().parent / "data" / "tiny-reference.h5"


@dataclasses.dataclass(frozen=True)
class Sample:
    t: float
    gyro: np.ndarray
    accel: np.ndarray
    q: np.ndarray
    qd: np.ndarray


def _estimator(compiled: bool) -> tuple[StateEstimator, list[Sample]]:
    lib = MotionLibrary.open(LIBRARY)
    entry = lib["v0.30_s1"]
    p = SkateParams.from_library(lib)
    start = planned_state(entry, 0, p.com_offset_m)
    geometry = BoardGeometry(deck_height_m=lib.quadruped_model.board.deck_height_m, axis_depth_m=p.roll_axis_depth_m)
    est = StateEstimator(LegKinematics.from_library(lib), geometry, lambda t: entry.sample(t).contact, start,
                         EstimatorSettings(compiled=compiled), p.gravity_mps2)
    still = [Sample(-0.01 * k, np.zeros(3), np.array([0.0, 0.0, p.gravity_mps2]), start.q, np.zeros(12))
             for k in range(5, 0, -1)]
    est.calibrate(still)
    ticks = [Sample(k * 0.002, np.zeros(3), np.array([0.0, 0.0, p.gravity_mps2]), start.q, np.zeros(12))
             for k in range(20)]
    return est, ticks


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize(("field", "bad"), [("gyro", np.array([np.nan, 0.0, 0.0])),
                                            ("accel", np.array([np.inf, 0, 9.8])), ("q", np.zeros(11)),
                                            ("t", -1.0), ("t", float("nan"))])
def test_a_bad_reading_is_refused_and_leaves_the_estimate_as_it_was(compiled, field, bad):
    clean, ticks = _estimator(compiled)
    hit, _ = _estimator(compiled)
    for k, reading in enumerate(ticks):
        want = clean(reading)
        if k == 10:
            with pytest.raises(ReadingError, match=f"reading.{field}"):
                hit(dataclasses.replace(reading, **{field: bad}))
        got = hit(reading)
        assert np.isfinite(got.trunk_v).all()
        np.testing.assert_array_equal(got.trunk_pos, want.trunk_pos)
        np.testing.assert_array_equal(got.trunk_v, want.trunk_v)
        np.testing.assert_array_equal(got.trunk_R, want.trunk_R)


def test_calibration_needs_readings():
    est, _ = _estimator(False)
    with pytest.raises(ReadingError, match="no reading"):
        est.calibrate([])
