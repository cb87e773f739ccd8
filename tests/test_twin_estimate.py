"""The controller on the robot's own estimate in full physics: an entry ridden on the MuJoCo twin
fed by the estimator on the twin's IMU and encoders, the estimator's error against the twin's
truth within its bounds; the classical estimator (every stance foot stays put) as the negative
control shows a large velocity error on the deck."""

from __future__ import annotations

import math
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from skatelib.control.estimator.deck import DeckSettings
from skatelib.control.estimator.estimator import EstimatorSettings
from skatelib.control.estimator.native import tick_library
from skatelib.control.estimator.odometry import OdometrySettings
from skatelib.control.params import SkateParams
from skatelib.library import schema
from skatelib.library.channels import BOARD
from skatelib.library.rotations import yaw_of
from skatelib.proving.setup import ClosedLoop
from skatelib.proving.twin.estimate import EstimatedFeedback, start_state
from skatelib.proving.twin.loop import TwinLoop, TwinLoopSettings, entry_ride
from skatelib.proving.twin.steer import SteerRun, steer_twin
from skatelib.proving.twin.verdict import twin_result
from skatelib.runtime import MotionLibrary
from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION, parse_twin_perturbation
from skatelib.sim.figures import TwinFigures
from skatelib.sim.plant import TwinPlant

from tests.test_twin_loop import _solve

pytestmark = pytest.mark.slow  # make test-fast leaves this module out


@pytest.fixture(scope="module")
def lib_path(tiny_v04) -> Path:
    """The tiny config's 0.4 m/s one-stride start-up (the session's)."""
    return tiny_v04.path


@pytest.fixture(scope="module")
def two_stride_path(tmp_path_factory) -> Path:
    return _solve(tmp_path_factory.mktemp("est2"), tmp_path_factory.mktemp("cache2"), "two", 0.5, 2)


def _ride(path: Path, settings: EstimatorSettings | None = None):
    """The library's first entry on the estimate under the default model and sensor errors."""
    lib = MotionLibrary.open(path)
    key = lib.keys()[0]
    p = SkateParams.from_library(lib)
    errors = parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu)
    plant = TwinPlant(TwinFigures.from_library(lib), errors)
    loop = TwinLoop(lib, key, ClosedLoop(p, p), plant,
                    TwinLoopSettings(state="estimate", sensor_errors=errors.sensors, estimator=settings))
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


@pytest.mark.xfail(strict=True, reason="measured: this 1-stride 0.4 m/s entry ends 16.4 % short on the estimate "
                                       "under the default model errors; docs/estimator.md")
def test_an_entry_passes_on_the_estimate(estimated):
    """The entry passes the twin's verdict with the controller on the estimate."""
    assert estimated.passed, estimated.reasons


def test_a_kept_run_records_estimate_and_truth(lib_path, estimated, tmp_path):
    """A run on the estimate kept for a recording (`track --save`) rides as one not kept (the same
    verdict to the last digit, the controllers' times aside) and records at each MPC update the
    twin's true state and, beside it, the estimate the controller was fed: their board speeds differ
    by about what the estimator's error says (sampled at every tick), and the recording plots the
    estimate's board speed and deck roll in the entry's tab. Negative control: a run on the true
    state records no estimate."""
    from skatelib.library.margins import forward_speed
    from skatelib.pipeline.views.rerun_inspect import save_closed_loop
    from skatelib.proving.twin.record import ESTIMATE_STATE

    from tests.test_inspect_rerun import _columns

    lib = MotionLibrary.open(lib_path)
    key = lib.keys()[0]
    p = SkateParams.from_library(lib)
    errors = parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu)

    def ride(state: str):
        plant = TwinPlant(TwinFigures.from_library(lib), errors)
        loop = TwinLoop(lib, key, ClosedLoop(p, p), plant,
                        TwinLoopSettings(state=state, sensor_errors=errors.sensors), keep=True)
        run = loop.ride()
        return run, run.record.as_entry(key, float(lib[key].attrs[schema.A_TARGET_VELOCITY]))

    run, entry = ride("estimate")
    kept = twin_result(key, float(lib[key].attrs[schema.A_TARGET_VELOCITY]), run)
    timings = ("wbc_median_ms", "mpc_median_ms")
    assert {k: v for k, v in kept.as_dict().items() if k not in timings} == \
        {k: v for k, v in estimated.as_dict().items() if k not in timings}
    est = entry.arrays[ESTIMATE_STATE]
    assert est.shape == entry.state.shape
    off = float(np.sqrt(np.mean((forward_speed(est) - forward_speed(entry.state)) ** 2)))
    assert 0.5 * estimated.est_board_speed_rms < off < 2.0 * estimated.est_board_speed_rms, (off, estimated)
    out = tmp_path / "run.rrd"
    roots = save_closed_loop(lib, [(key, entry)], out)
    assert f"/{key}/estimate" in roots
    cols = _columns(out)
    plotted = [v[0] for v in cols[f"/{key}/estimate/plots/board_speed/estimate"]["Scalars:scalars"]]
    assert np.allclose(plotted, forward_speed(est))
    assert cols[f"/{key}/estimate/plots/board_roll"]["SeriesLines:names"][0][0] == "estimate deck roll [rad]"
    _, true_entry = ride("true")
    assert ESTIMATE_STATE not in true_entry.arrays


def test_feet_assumed_put_misread_the_velocity(lib_path):
    """Negative control: the classical estimator (a deck foot stays put) reads the robot's velocity
    several times worse on the rolling deck."""
    classical = replace(EstimatorSettings(), odometry=OdometrySettings(moving_deck=False))
    r = _ride(lib_path, classical)
    assert not r.est_trunk_v_rms <= 0.1, r.est_trunk_v_rms


@pytest.fixture(scope="module")
def two_strides(two_stride_path):
    """The 0.5 m/s two-stride entry on the estimate, and on the classical estimator."""
    classical = replace(EstimatorSettings(), odometry=OdometrySettings(moving_deck=False))
    return _ride(two_stride_path), _ride(two_stride_path, classical)


def test_a_two_stride_entry_passes_on_the_estimate(two_strides):
    """A 0.5 m/s two-stride entry passes the twin's verdict with the controller on the estimate
    (default model and sensor errors), the estimator within the issue's bounds of the truth."""
    r, _ = two_strides
    assert r.passed, r.reasons
    assert r.est_trunk_v_rms <= 0.03 and r.est_board_speed_rms <= 0.03 and r.est_board_roll_rms <= 0.012, r


def test_feet_assumed_put_fail_the_entry(two_strides):
    """Negative control: the same entry on the classical estimator (every stance foot stays put)
    fails, its velocity error on the deck ten times the moving deck's."""
    r, classical = two_strides
    assert not classical.passed
    assert classical.est_trunk_v_rms > 10 * r.est_trunk_v_rms, (classical.est_trunk_v_rms, r.est_trunk_v_rms)


# --- The sensors' errors (``--perturb`` keys): estimators on the same ride --------------------------

class _Side:
    """An estimator riding along on its own sensors while the controller is fed the truth: its
    errors (:class:`EstimatorErrors`) and the trunk's attitude error, tilt and heading [rad]; with
    ``python``, the same estimator on its Python tick beside it on the same readings and the
    largest gap between their states (``python_gap``)."""

    def __init__(self, feedback: EstimatedFeedback, python: EstimatedFeedback | None = None):
        self.fb, self.tilt, self.yaw, self.over_deck, self.height = feedback, [], [], [], []
        self.python, self.python_gap = python, 0.0

    def __call__(self, true) -> None:
        est = self.last = self.fb(true)
        if self.python is not None:
            ref = self.python(true)
            self.python_gap = max(self.python_gap, *(float(np.max(np.abs(getattr(est, f.name) - getattr(ref, f.name))))
                                                     for f in fields(est)))
        self.tilt.append(math.acos(min(1.0, float(est.trunk_R[:, 2] @ true.trunk_R[:, 2]))))
        self.yaw.append(math.remainder(yaw_of(est.trunk_R) - yaw_of(true.trunk_R), math.tau))
        # the trunk's place on the deck (deck frame): what the feet's kinematics carry
        self.over_deck.append(float(np.linalg.norm(est.deck_R.T @ (est.trunk_pos - est.deck_pos)
                                                   - true.deck_R.T @ (true.trunk_pos - true.deck_pos))))
        # the trunk's height over the deck's top (what places the body and the push foot over the floor)
        self.height.append(float(est.deck_R[:, 2] @ (est.trunk_pos - est.deck_pos)
                                 - true.deck_R[:, 2] @ (true.trunk_pos - true.deck_pos)))

    def summary(self) -> dict[str, float]:
        estimator = self.fb.estimator
        estimator.sync()  # the C tick's state back in the Python parts
        synced = max(float(np.max(np.abs(estimator.odometry.v - self.last.trunk_v))),
                     float(np.max(np.abs(estimator.deck.R - self.last.deck_R))))
        return {**self.fb.errors.summary(), "tilt_mean": float(np.mean(self.tilt)), "sync_gap": synced,
                "python_gap": self.python_gap, "compiled": float(estimator.native is not None),
                "yaw_end": abs(self.yaw[-1]), "on_deck_mean": float(np.mean(self.over_deck)),
                "height_mean": float(np.mean(self.height))}


PAIRED = ("default", "imu_tilt_unaligned", "default_rigid_feet", "default_tilt_on_reading", "gyro_bias_unestimated",
          "default_classical", "default_level_deck")
SENSOR_CASES = {
    "clean": "gyro_bias=0,imu_noise=1,encoder_offset=0,imu_tilt=0,sensor_delay=0",
    "default": "",
    "gyro_bias": "gyro_bias=0.05,encoder_offset=0,imu_tilt=0,sensor_delay=0",
    "accel_bias": "accel_bias=0.3,encoder_offset=0,imu_tilt=0,sensor_delay=0",
    "imu_noise": "imu_noise=10,encoder_offset=0,imu_tilt=0,sensor_delay=0",
    "encoder_offset": "encoder_offset=0.03,imu_tilt=0,sensor_delay=0",
    "imu_tilt": "imu_tilt=0.05,encoder_offset=0,sensor_delay=0",
    "sensor_delay": "sensor_delay=0.01,encoder_offset=0,imu_tilt=0",
}


@pytest.fixture(scope="module")
def sensor_runs(lib_path):
    """One ride with the controller on the twin's truth, an estimator per sensor case beside it
    (each on its own sensors, the same seed), one with the gyroscope bias of ``gyro_bias`` not
    estimated (its standstill calibration undone), and three that take the IMU's axes for the
    trunk's (no mounting from the legs)."""
    lib = MotionLibrary.open(lib_path)
    key = lib.keys()[0]
    p = SkateParams.from_library(lib)
    plant = TwinPlant(TwinFigures.from_library(lib), parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu))
    loop = TwinLoop(lib, key, ClosedLoop(p, p), plant)
    on_deck = loop.ref.contact(loop.ref.t0) == BOARD
    ride = entry_ride(lib, key, loop.loop, loop.kin.foot_radius_m)
    start = start_state(ride.x0, ride.board0, ride.from_velocity_mps, on_deck, p.com_offset_m)

    def feedback_of(text: str, settings: EstimatorSettings | None) -> EstimatedFeedback:
        errors = parse_twin_perturbation(text, p.mu).sensors
        return EstimatedFeedback(plant, lib, p, loop.contacts.at, start, loop.tick_s, errors, 0, settings)

    def side(name: str, text: str, settings: EstimatorSettings | None = None) -> _Side:
        """The case ``name``'s estimator, beside it on its Python tick when it is in PAIRED."""
        twin = feedback_of(text, replace(settings or EstimatorSettings(), compiled=False)) if name in PAIRED else None
        sides[name] = _Side(feedback_of(text, settings), twin)
        return sides[name]

    def both(side: _Side) -> list[EstimatedFeedback]:
        return [side.fb] + ([side.python] if side.python is not None else [])

    sides: dict[str, _Side] = {}
    for name, text in SENSOR_CASES.items():
        side(name, text)
    unaligned = EstimatorSettings(mount_from_legs=False)
    for name in ("clean", "imu_tilt", "accel_bias"):
        side(f"{name}_unaligned", SENSOR_CASES[name], unaligned)
    for fb in both(side("default_rigid_feet", SENSOR_CASES["default"])):
        fb.estimator.body = None  # no give of the feet under load
    side("default_tilt_on_reading", SENSOR_CASES["default"], EstimatorSettings(tilt_from_velocity=False))
    for fb in both(side("gyro_bias_unestimated", SENSOR_CASES["gyro_bias"])):
        fb.estimator.attitude.gyro_bias = np.zeros(3)
    # the compiled tick's other branches, against the Python tick's (their verdicts are other tests')
    side("default_classical", "", EstimatorSettings(odometry=OdometrySettings(moving_deck=False)))
    side("default_level_deck", "", EstimatorSettings(deck=DeckSettings(roll=False)))
    truth = loop.feedback

    def feedback(true):
        for s in sides.values():
            s(true)
        return truth(true)

    loop.feedback = feedback
    run = loop.ride()
    assert not run.fall, run.fall
    return {name: s.summary() for name, s in sides.items()}


def test_the_compiled_tick_is_the_python_tick(sensor_runs):
    """The estimator's tick in C (:mod:`skatelib.control.estimator.native`) gives the Python tick's
    state at every tick of the ride to 1e-9 (rounding), for each setting and sensor case it was
    paired with (each of the tick's branches: the deck moving or level or the classical filter,
    the IMU's mounting turned or not, the feet's give or rigid feet, the tilt reference, an error
    the calibration does not take out): every field of the state, the touch codes among them."""
    if tick_library() is None:
        pytest.skip("no C compiler: the estimator runs its Python tick")
    paired = {name: r for name, r in sensor_runs.items() if name in PAIRED}
    assert len(paired) == len(PAIRED)
    for name, r in paired.items():
        assert r["compiled"] == 1.0, name  # the C tick ran (else Python met Python)
        assert r["python_gap"] < 1e-9, (name, r["python_gap"])
        assert r["sync_gap"] == 0.0, name


def test_sensor_errors_degrade_the_estimate_as_they_should(sensor_runs):
    """Each sensor key's error shows in the estimate as its physics says, against the clean
    sensors' estimate on the same ride: ten times the IMU's noise and 10 ms of delay make the
    velocities worse; a hip zeroed 0.03 rad off puts its foot about 6 mm (0.03 x the hip-to-foot
    0.2 m) from where the estimator has it, and the deck's pose, fitted to three or four feet,
    carries a share of it into the trunk's place on the deck; a constant gyroscope bias of
    0.05 rad/s, calibrated at standstill, leaves the heading within 0.01 rad."""
    r = sensor_runs
    clean = r["clean"]
    assert clean["tilt_mean"] < 0.005, clean
    assert r["imu_noise"]["trunk_v_rms"] > 1.2 * clean["trunk_v_rms"], (r["imu_noise"], clean)
    assert r["sensor_delay"]["trunk_v_rms"] > 1.2 * clean["trunk_v_rms"], (r["sensor_delay"], clean)
    assert r["encoder_offset"]["on_deck_mean"] > clean["on_deck_mean"] + 5e-4, (r["encoder_offset"], clean)
    assert r["gyro_bias"]["yaw_end"] < 0.01, r["gyro_bias"]


def test_the_imu_mounting_from_the_legs(sensor_runs):
    """An IMU mounted 0.05 rad rolled, and an accelerometer bias of 0.3 m/s^2 on each axis (which
    turns gravity's reading by |b_xy| / g = 0.043 rad), taken for the trunk's axes tilt the
    trunk's attitude by those angles and the deck's roll with the mount's (it is read through the
    trunk's attitude); with the mounting from the legs at the standstill both tilts are gone
    (within 5 mrad, the clean sensors' 1 mrad aside)."""
    r = sensor_runs
    assert r["imu_tilt_unaligned"]["tilt_mean"] == pytest.approx(0.05, abs=0.01), r["imu_tilt_unaligned"]
    assert r["imu_tilt_unaligned"]["board_roll_rms"] == pytest.approx(0.05, abs=0.01), r["imu_tilt_unaligned"]
    assert r["accel_bias_unaligned"]["tilt_mean"] == pytest.approx(math.hypot(0.3, 0.3) / 9.81, abs=0.01)
    assert r["clean_unaligned"]["tilt_mean"] < 0.005, r["clean_unaligned"]
    for name in ("imu_tilt", "accel_bias"):
        assert r[name]["tilt_mean"] < 0.005, (name, r[name])
    assert r["imu_tilt"]["board_roll_rms"] < r["clean"]["board_roll_rms"] + 0.002, (r["imu_tilt"], r["clean"])


def test_the_feet_give_under_load(sensor_runs):
    """Against the twin's truth on the same ride: with each stance foot's give under its static
    share of the weight taken out, the trunk's height over the deck is within 1 mm and the deck's
    roll within 0.005 rad RMS. Negative control: the feet taken for rigid spheres read the height
    more than 2 mm high (the twin's loaded feet sink 1.4-3.6 mm) and the roll more than 0.007 rad
    RMS off (three deck feet loaded unequally give unequally and tilt the plane through them)."""
    given, rigid = sensor_runs["default"], sensor_runs["default_rigid_feet"]
    assert abs(given["height_mean"]) < 0.001, given
    assert given["board_roll_rms"] < 0.005, given
    assert rigid["height_mean"] > 0.002, rigid
    assert rigid["board_roll_rms"] > 0.007, rigid


def test_the_tilt_reference_less_the_known_acceleration(sensor_runs):
    """Against the twin's truth on the same ride: the attitude's tilt reference taken as the
    accelerometer's reading less the trunk's acceleration as the position filter has it keeps the
    trunk's tilt within 0.75 of its error with the reading itself as the reference (negative
    control: 1.0 mrad on average there, the board's accelerations read as gravity; 0.5 mrad
    with the acceleration taken out)."""
    known, reading = sensor_runs["default"], sensor_runs["default_tilt_on_reading"]
    assert known["tilt_mean"] < 0.75 * reading["tilt_mean"], (known, reading)


def test_an_unestimated_gyro_bias_drifts(sensor_runs):
    """Negative control: the same 0.05 rad/s gyroscope bias with the calibration's estimate of it
    undone turns the heading by about 0.05 rad/s times the ride's length (4 s), tilts the trunk
    (the accelerometer's correction, 50 s slow, does not hold it) and with it misreads gravity as
    acceleration: the velocities go wrong by more than 0.1 m/s RMS."""
    r = sensor_runs["gyro_bias_unestimated"]
    assert r["yaw_end"] > 0.08, r
    assert r["tilt_mean"] > 0.03, r
    assert r["trunk_v_rms"] > 0.1, r


# --- The steering maneuver on the estimate --------------------------------------------------------

def _steer(path: Path, deck: DeckSettings):
    lib = MotionLibrary.open(path)
    p = SkateParams.from_library(lib)
    plant = TwinPlant(TwinFigures.from_library(lib), parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu))
    settings = TwinLoopSettings(state="estimate", estimator=EstimatorSettings(deck=deck))
    return steer_twin(lib, ClosedLoop(p, p), plant, 0.5, SteerRun(loop=settings))


def test_the_steering_maneuver_on_the_estimate(lib_path):
    """At 0.5 m/s the four-leg steering maneuver (deck roll 0.1 rad, 3 s period) on the estimate
    tracks the roll within 0.03 rad RMS, the twin's roll against the reference."""
    r = _steer(lib_path, DeckSettings())
    assert r.passed, r.reasons


def test_a_board_taken_as_level_fails_the_steering_maneuver(lib_path):
    """Negative control: the estimator with the deck's roll taken as zero (no roll from the deck
    feet) misleads the controller: the maneuver fails (measured: the robot tips over 1.07 s in,
    the roll error 0.067 rad RMS by then)."""
    r = _steer(lib_path, DeckSettings(roll=False))
    assert not r.passed and (r.fall or r.roll_rms_error_rad > 0.03), r

