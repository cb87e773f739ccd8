"""The controller on the robot's own estimate in full physics: an entry ridden on the MuJoCo twin
fed by the estimator on the twin's IMU and encoders, the estimator's error against the twin's
truth within its bounds; the classical estimator (every stance foot stays put) as the negative
control shows a large velocity error on the deck."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from skatelib.control.estimator.estimator import EstimatorSettings
from skatelib.control.estimator.odometry import OdometrySettings
from skatelib.control.params import SkateParams
from skatelib.library import schema
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.twin.loop import TwinLoop, TwinLoopSettings
from skatelib.proving.twin.verdict import twin_result
from skatelib.runtime import MotionLibrary
from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION, parse_twin_perturbation
from skatelib.sim.figures import TwinFigures
from skatelib.sim.plant import TwinPlant

from tests.test_twin_loop import _solve


@pytest.fixture(scope="module")
def lib_path(tmp_path_factory) -> Path:
    return _solve(tmp_path_factory.mktemp("est"), tmp_path_factory.mktemp("cache"), "one", 0.4, 1)


def _ride(path: Path, settings: EstimatorSettings | None = None):
    lib = MotionLibrary.open(path)
    key = lib.keys()[0]
    p = SkateParams.from_library(lib)
    plant = TwinPlant(TwinFigures.from_library(lib), parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu))
    loop = TwinLoop(lib, key, ClosedLoop(p, p), plant, TwinLoopSettings(state="estimate"))
    if settings is not None:
        est = loop.feedback.estimator  # type: ignore[attr-defined]
        est.s = settings
        est.odometry.s = settings.odometry
    run = loop.ride()
    return twin_result(key, float(lib[key].attrs[schema.A_TARGET_VELOCITY]), run)


@pytest.fixture(scope="module")
def estimated(lib_path):
    return _ride(lib_path)


def test_the_estimate_against_the_twin(estimated):
    """On the estimate, the estimator's trunk velocity and board speed within 0.03 m/s RMS of the
    twin's, its deck roll within 0.012 rad RMS."""
    r = estimated
    assert r.est_trunk_v_rms <= 0.03 and r.est_board_speed_rms <= 0.03, r
    assert r.est_board_roll_rms <= 0.012, r


@pytest.mark.xfail(strict=True, reason="measured: this 1-stride 0.4 m/s entry ends 19.5 % short on the estimate "
                                       "under the default model errors; docs/estimator.md")
def test_an_entry_passes_on_the_estimate(estimated):
    """The entry passes the twin's verdict with the controller on the estimate."""
    assert estimated.passed, estimated.reasons


def test_feet_assumed_put_misread_the_velocity(lib_path):
    """Negative control: the classical estimator (a deck foot stays put) reads the robot's velocity
    several times worse on the rolling deck."""
    classical = replace(EstimatorSettings(), odometry=OdometrySettings(moving_deck=False))
    r = _ride(lib_path, classical)
    assert not r.est_trunk_v_rms <= 0.1, r.est_trunk_v_rms
