"""The robot side's estimator (``skatelib.control.estimator``) part by part against analytic cases:
a deck rolled and turned by known angles, a deck turning and rolling at known rates, a board
coasting at a known deceleration, a gyroscope with a bias; each with the negative control that
shows the check can fail."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from skatelib.control.estimator.attitude import AttitudeFilter, exp_so3
from skatelib.control.estimator.deck import DeckEstimate, deck_rates, update_deck
from skatelib.control.estimator.odometry import FootMeasure, LegOdometry, OdometrySettings
from skatelib.library.rotations import board_rotations, roll_of, yaw_of

G = 9.81
RHO = 0.02
# Four feet's centres in the deck frame (top centre origin), RHO above the top.
FOOTHOLDS = np.array([[0.12, 0.12, -0.12, -0.12], [0.09, -0.09, 0.09, -0.09], [RHO] * 4])


def _deck(yaw: float, roll: float, pos: np.ndarray) -> np.ndarray:
    return pos[:, None] + board_rotations(yaw, roll) @ FOOTHOLDS


@pytest.mark.parametrize("n_feet", [3, 4])
def test_deck_pose_from_its_feet_on_a_rolled_deck(n_feet):
    """Feet standing on a deck rolled by 0.08 rad and turned by 0.3 rad give its roll, heading and
    top centre (the estimate starts level and straight)."""
    pos = np.array([1.0, -0.4, 0.11])
    centres = _deck(0.3, 0.08, pos)
    on = np.arange(4) < n_feet
    est = update_deck(DeckEstimate(yaw=0.0, roll=0.0, pos=np.zeros(3), footholds=FOOTHOLDS.copy()), on,
                      centres, np.zeros((3, 4)), 0.002)
    assert est.roll == pytest.approx(0.08, abs=1e-9)
    assert est.yaw == pytest.approx(0.3, abs=1e-9)
    assert np.allclose(est.pos, pos, atol=1e-9)
    assert roll_of(est.R) == pytest.approx(0.08, abs=1e-9) and yaw_of(est.R) == pytest.approx(0.3, abs=1e-9)


def test_two_feet_do_not_see_the_roll():
    """Negative control: with two deck feet (no plane) the roll is carried on from the last estimate
    (here level), so it misses the deck's 0.08 rad."""
    centres = _deck(0.3, 0.08, np.array([0.0, 0.0, 0.11]))
    est = update_deck(DeckEstimate(yaw=0.0, roll=0.0, pos=np.zeros(3), footholds=FOOTHOLDS.copy()),
                      np.array([True, True, False, False]), centres, np.zeros((3, 4)), 0.002)
    assert abs(est.roll - 0.08) > 0.07


def test_deck_rates_from_the_feet_velocities():
    """Feet on a deck riding at 0.7 m/s while it turns at 0.2 rad/s and rolls at 0.5 rad/s (about
    its axle line 0.08 m below the top): the rates from their velocities."""
    yaw, roll, depth = 0.4, 0.05, 0.08
    R = board_rotations(yaw, roll)
    pos = np.array([0.3, 0.1, 0.11])
    centres = _deck(yaw, roll, pos)
    omega = 0.2 * np.array([0.0, 0.0, 1.0]) + 0.5 * R[:, 0]
    axis = pos - depth * R[:, 2]
    v = 0.7 * R[:, 0][:, None] + np.cross(omega, (centres - axis[:, None]).T).T
    rates = deck_rates(centres, v, R[:, 0], np.zeros(2), 1e-6)
    assert rates == pytest.approx([0.2, 0.5], abs=1e-9)
    # Two feet one behind the other see the turning but not the roll (the prior's zero stays).
    behind = deck_rates(centres[:, [0, 2]], v[:, [0, 2]], R[:, 0], np.zeros(2), 1e-3)
    assert behind[0] == pytest.approx(0.2, abs=1e-3) and abs(behind[1]) < 0.05


def _coast(settings: OdometrySettings, seconds: float = 2.0, dt: float = 1 / 510) -> tuple[float, float]:
    """A robot standing still on a board that coasts from 0.6 m/s at 0.1 m/s^2 along x (three feet
    on the deck, the trunk level): the filter's trunk and board speed errors at the end."""
    decel, u0 = 0.1, 0.6
    odo = LegOdometry(np.array([0.0, 0.0, 0.3]), np.array([u0, 0.0, 0.0]), u0, settings)
    h = np.array([1.0, 0.0, 0.0])
    specific = np.array([-decel, 0.0, G])  # what a level accelerometer reads
    t = 0.0
    for _ in range(round(seconds / dt)):
        odo.predict(np.eye(3), specific, dt, G)
        t += dt
        feet = [FootMeasure(True, np.zeros(3), np.zeros(3), h, -0.3 + RHO, 0.13) for _ in range(3)]
        odo.correct(feet)
    truth = u0 - decel * t
    return float(odo.v[0] - truth), odo.u - truth


def test_a_coasting_board_keeps_its_speed():
    """The deck feet move with the deck: the trunk's and board's speed follow the coast (the
    deceleration the IMU reads) within 5 mm/s after 2 s."""
    dv, du = _coast(OdometrySettings())
    assert abs(dv) < 0.005 and abs(du) < 0.005


def test_feet_assumed_put_stop_the_robot_on_a_coasting_board():
    """Negative control: the classical assumption (every stance foot stays put) pulls the trunk's
    velocity to zero while it rides at 0.4-0.6 m/s."""
    dv, _ = _coast(OdometrySettings(moving_deck=False, gate=1e9))
    assert dv < -0.3


def _creep_then_coast(bias_sd: float | None, dt: float = 1 / 510) -> float:
    """A trunk standing still on one floor foot for 0.3 s, the foot creeping back at a rate
    growing to 10 mm/s (a push's foot under load; its row reads the trunk that fast), then 2 s
    with no foot (a coast): the velocity's drift over the coast [m/s]."""
    odo = LegOdometry(np.array([0.0, 0.0, 0.3]), np.zeros(3), 0.0, OdometrySettings())
    if bias_sd is not None:
        odo.horizontal_bias_known(bias_sd)
    still, h = np.array([0.0, 0.0, G]), np.array([1.0, 0.0, 0.0])
    n = round(0.3 / dt)
    for k in range(n):
        odo.predict(np.eye(3), still, dt, G)
        odo.correct([FootMeasure(False, np.array([-0.01 * k / n, 0.0, 0.0]), np.zeros(3), h, -0.3 + RHO, RHO)])
    v0 = float(odo.v[0])
    for _ in range(round(2.0 / dt)):
        odo.predict(np.eye(3), still, dt, G)
    return float(odo.v[0]) - v0


def test_a_creeping_floor_foot_does_not_drift_the_coast():
    """The accelerometer's horizontal bias known to 1 mm/s^2 (the mounting holds it): the creep
    the row reads stays an offset, and the velocity drifts by less than 0.1 mm/s over the coast
    after; with the bias state's wide prior (negative control) the creep's ramp is read as a bias
    of 2.5 mm/s^2 and the coast drifts by more than 4 mm/s."""
    assert abs(_creep_then_coast(1e-3)) < 1e-4
    assert _creep_then_coast(None) > 4e-3


def test_gyro_bias_calibrated_at_standstill():
    """A gyroscope bias of 0.02 rad/s: averaged away at standstill, the attitude of a trunk held
    still stays within 1 mrad over 10 s; not estimated (negative control), it drifts by 0.2 rad
    about the vertical, which no accelerometer sees."""
    bias = np.array([0.0, 0.0, 0.02])
    R0 = exp_so3(np.array([0.02, -0.01, 0.5]))
    accel = R0.T @ np.array([0.0, 0.0, G])
    for calibrated, bound in ((True, 1e-3), (False, None)):
        f = AttitudeFilter(R0)
        if calibrated:
            f.calibrate([bias] * 100, [accel] * 100)
        for _ in range(5100):
            f.update(bias, accel, 1 / 510)
        err = float(np.linalg.norm(np.array([f.R[1, 0] - R0[1, 0], f.R[0, 0] - R0[0, 0]])))
        if bound is not None:
            assert err < bound
        else:
            assert math.atan2(f.R[1, 0], f.R[0, 0]) - math.atan2(R0[1, 0], R0[0, 0]) == pytest.approx(0.2, abs=0.01)


def test_a_known_deceleration_does_not_tilt_the_attitude():
    """A level trunk slowing down at 0.2 m/s^2 for 10 s with a perfect gyroscope: given the
    deceleration (the position filter's), the attitude stays level within 1e-9 rad; taken for
    gravity (negative control) it tilts towards atan(a / g) = 0.0204 rad at k_P, by
    0.0204 (1 - exp(-k_P 10 s)) = 3.7 mrad (the first-order law of the tilt correction)."""
    a_world = np.array([-0.2, 0.0, 0.0])
    R0 = exp_so3(np.array([0.0, 0.0, 0.3]))
    accel = R0.T @ (a_world + np.array([0.0, 0.0, G]))
    tilts = {}
    for known in (a_world, None):
        f = AttitudeFilter(R0)
        for _ in range(5100):
            f.update(np.zeros(3), accel, 1 / 510, known)
        tilts[known is None] = math.acos(min(1.0, float(f.R[2, 2])))
    assert tilts[False] < 1e-9
    k = AttitudeFilter(R0).s.k_tilt
    assert tilts[True] == pytest.approx(math.atan(0.2 / G) * (1 - math.exp(-k * 10.0)), rel=0.02)


def test_a_tilt_error_is_pulled_back_by_the_known_acceleration():
    """The attitude started 0.01 rad pitched off a level, decelerating trunk, the deceleration
    known: the tilt correction pulls the error back at k_P (0.01 exp(-k_P 10 s) after 10 s),
    as the reading's gravity is the residual once the acceleration is taken out."""
    a_world = np.array([-0.2, 0.0, 0.0])
    accel = a_world + np.array([0.0, 0.0, G])
    f = AttitudeFilter(exp_so3(np.array([0.0, 0.01, 0.0])))
    for _ in range(5100):
        f.update(np.zeros(3), accel, 1 / 510, a_world)
    err = math.acos(min(1.0, float(f.R[2, 2])))
    assert err == pytest.approx(0.01 * math.exp(-f.s.k_tilt * 10.0), rel=0.02)


def test_calibration_levels_the_filter_on_the_accelerometer():
    """Started level on a trunk rolled by 0.05 rad and pitched by -0.03 rad, the standstill
    calibration turns the filter's vertical onto the measured gravity (its heading kept)."""
    R_true = exp_so3(np.array([0.05, -0.03, 0.4]))
    f = AttitudeFilter(exp_so3(np.array([0.0, 0.0, 0.4])))
    f.calibrate([np.zeros(3)], [R_true.T @ np.array([0.0, 0.0, G])])
    assert np.allclose(f.R[2], R_true[2], atol=1e-12)
    assert abs(yaw_of(f.R) - 0.4) < 2e-3


def test_static_loads_by_the_lever_rule():
    """Three feet carry the weight with no moment about the centre of mass (the lever rule, solved
    by hand): at the triangle's centroid a third each; moved halfway to one foot, that foot carries
    two thirds; four feet's least-squares loads still sum to the weight with no moment."""
    from skatelib.control.estimator.loads import static_loads

    feet = np.array([[0.2, 0.2, -0.2], [0.1, -0.1, 0.0]])
    centroid = feet.mean(axis=1)
    assert np.allclose(static_loads(feet, centroid, 150.0), 50.0)
    toward = centroid + 0.5 * (feet[:, 2] - centroid)
    f = static_loads(feet, toward, 150.0)
    assert f[2] == pytest.approx(100.0) and f[0] == pytest.approx(25.0) and f[1] == pytest.approx(25.0)
    four = np.array([[0.2, 0.2, -0.2, -0.2], [0.1, -0.1, 0.1, -0.1]])
    com = np.array([0.03, -0.02])
    f4 = static_loads(four, com, 150.0)
    assert f4.sum() == pytest.approx(150.0)
    assert np.allclose((four - com[:, None]) @ f4, 0.0, atol=1e-9)


def test_static_loads_of_a_thin_triangle_stay_within_the_weight():
    """Three feet 0.34 m apart, the middle one 1 mm off their line, the centre of mass 0.1 m off it
    (outside their triangle): no foot's static share beyond the weight. Negative control: the exact
    solution (the cofactor form, unclipped) asks some 50 times the weight of one foot."""
    from skatelib.control.estimator.loads import _min_norm_loads, static_loads

    feet = np.array([[0.17, 0.0, -0.17], [0.1, 0.101, 0.1]])
    com = np.zeros(2)
    exact = _min_norm_loads(feet, com, 87.0)
    assert exact is not None and exact.max() > 50 * 87.0
    f = static_loads(feet, com, 87.0)
    assert np.all(f >= 0.0) and np.all(f <= 87.0)
