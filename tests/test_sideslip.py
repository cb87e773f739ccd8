"""The board's wheels roll along its heading and do not slide: the plan's board velocity stays
along the heading at every knot (checked by validate in its own code), a stop ends at rest in
every direction, the MPC's model and the model plant turn the velocity with the yaw, and the
twin reports the board's drift and crab angle. Negative controls: a library
built with the old model (Eq. 9a without the centripetal term: tests/data/old-sideslip.h5, a
speed-up and a stop of the old default library) and doctored entries are refused."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from skatelib.control.linear_model import Feedback, continuous_model
from skatelib.control.params import SkateParams
from skatelib.library.channels import BOARD, S_BOARD_V
from skatelib.pipeline.quadruped.checks.verify import Trajectory, check_trajectory
from skatelib.proving.plant import Plant
from skatelib.proving.twin.loop import TwinRun
from skatelib.proving.twin.metrics import TwinMeasures
from skatelib.proving.twin.verdict import twin_result
from skatelib.runtime import MotionLibrary

DATA = Path(__file__).resolve().parent / "data"


def test_the_reference_library_keeps_its_board_on_its_heading(system):
    """The tiny reference (built with the rolling board) has nothing across the heading at any knot."""
    for e in MotionLibrary.open(DATA / "tiny-reference.h5"):
        report = check_trajectory(system, Trajectory.of(e), e.target_velocity_mps)
        assert report.max_board_lateral_speed_mps < 1e-6, (e.key, report.max_board_lateral_speed_mps)
        assert not report.failures(system), report.failures(system)


def test_a_doctored_sideways_velocity_and_a_stop_still_moving_are_refused(system):
    e = MotionLibrary.open(DATA / "tiny-reference.h5")["v0.30_s1"]
    traj = Trajectory.of(e)
    state = np.array(traj.state)
    yaw = state[20, 5]
    state[20, S_BOARD_V] += 0.05 * np.array([-np.sin(yaw), np.cos(yaw)])  # 5 cm/s across at one knot
    report = check_trajectory(system, dataclasses.replace(traj, state=state), 0.3)
    assert report.max_board_lateral_speed_mps == pytest.approx(0.05, abs=1e-6)
    assert any("slides sideways at 0.050 m/s" in f for f in report.failures(system))
    stop = np.array(traj.state)
    stop[-1, S_BOARD_V] = [0.0, 0.03]  # a "stop" whose board still rolls 3 cm/s (sideways)
    as_stop = check_trajectory(system, dataclasses.replace(traj, state=stop), 0.0, from_velocity_mps=0.3)
    assert any("a stop ends with the board moving 0.030 m/s" in f for f in as_stop.failures(system))


def test_validate_refuses_a_library_built_with_the_sliding_board():
    r = subprocess.run([sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()", "validate",
                        str(DATA / "old-sideslip.h5")], capture_output=True, text=True,
                       env={**os.environ, "COLUMNS": "300"})
    assert r.returncode == 1, r.stdout + r.stderr
    assert "v0.80-1.00_s1" in r.stdout and "the board slides sideways at 0.074 m/s" in r.stdout
    assert "a stop ends with the board moving 0.032 m/s" in r.stdout


def _library_params() -> SkateParams:
    return SkateParams.from_library(MotionLibrary.open(DATA / "tiny-reference.h5"))


def test_the_mpc_model_turns_the_board_velocity_with_the_yaw():
    """Eq. (17)'s board rows with the centripetal term: at forward speed v and yaw rate r the
    board's velocity changes by v r across the heading, and by nothing along it."""
    p = _library_params()
    x = np.zeros(28)
    yaw, v, r = 0.4, 0.8, 0.3
    x[5] = yaw
    x[24:26] = v * np.array([np.cos(yaw), np.sin(yaw)])
    x[11] = r  # level trunk: the yaw rate is omega_z
    fb = Feedback(x=x, r_robot=np.zeros((3, 4)), r_board=np.zeros((3, 4)))
    for accelerating in (True, False):
        A, _, C = continuous_model(p, fb, np.full(4, BOARD), accelerating)
        v_dot = (A @ x + C)[24:26]
        left, heading = np.array([-np.sin(yaw), np.cos(yaw)]), np.array([np.cos(yaw), np.sin(yaw)])
        assert left @ v_dot == pytest.approx(v * r, rel=1e-12)
        if not accelerating:
            assert heading @ v_dot == pytest.approx(0.0, abs=1e-12)


def test_the_model_plant_keeps_the_board_on_its_heading_as_it_yaws():
    """The model plant in the air (no contact force) turning at 0.5 rad/s for 0.4 s at 1 m/s: the
    board's velocity has turned with the yaw (Eq. 9a alone would leave 0.2 m/s across)."""
    p = dataclasses.replace(_library_params(), rolling_N=0.0)
    plant = Plant(p, np.zeros(3))
    s = np.zeros(31)
    s[2], s[11], s[24] = 1.0, 0.5, 1.0
    contact = np.zeros(4, dtype=np.int8)
    for k in range(400):
        s = plant.step(s, _NoForce(), contact, np.zeros((3, 4)), 0.001, k * 0.001)
    yaw = s[5]
    assert yaw > 0.19
    assert abs(np.array([-np.sin(yaw), np.cos(yaw)]) @ s[24:26]) < 1e-9
    assert np.linalg.norm(s[24:26]) == pytest.approx(1.0, abs=1e-9)


class _NoForce:
    forces = np.zeros((3, 4))
    qd = np.zeros(12)
    external_N = None


def test_the_twins_verdict_fails_a_board_off_the_plans_line_and_reports_the_crab_angle():
    """A board more than 2 cm to the side of the plan's at the end fails; within, it passes; the
    crab angle is reported."""
    def result(lateral_m: float):
        m = TwinMeasures(momentum_at_end_mps=0.5, momentum_after_1s_mps=0.49, friction_loss_Ns=0.1,
                         system_mass_kg=10.7, heading_at_end_rad=0.01, lateral_at_end_m=lateral_m, max_crab_rad=0.004)
        return twin_result("v0.50_s2", 0.5, TwinRun(m))

    assert result(-0.019).passed and result(0.019).passed
    far = result(-0.03)
    assert not far.passed and "to the side" in far.reasons
    assert far.max_crab_rad == 0.004 and far.lateral_drift_m == -0.03


def test_a_run_that_stopped_early_says_what_it_did_not_measure():
    """A run that fell before the entry's end fails on its fall; its speed, heading and line are
    said to be unmeasured, not printed as NaN."""
    run = TwinRun(TwinMeasures(system_mass_kg=10.7), fall="trunk 0.099 m above the deck at t = 1.16 s")
    r = twin_result("v0.30", 0.3, run)
    assert not r.passed and r.reasons.startswith("delivered speed not measured") and "fall: trunk" in r.reasons
    assert "heading and line not measured" in r.reasons and "nan" not in r.reasons.lower()
    stop = twin_result("v0.00", 0.0, run)
    assert not stop.passed and "delivered speed not measured" in stop.reasons

