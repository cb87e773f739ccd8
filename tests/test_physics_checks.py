"""The independent physics checks refuse what the optimizer was not told about: each check shown
failing on a real or doctored trajectory (negative controls), and passing on an honest one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from skatelib.library.channels import BOARD
from skatelib.library.margins import friction_margins
from skatelib.library.rotations import board_rotations
from skatelib.pipeline.quadruped.checks.verify import Trajectory, check_trajectory, judge


@pytest.fixture(scope="module")
def honest(pushoff_0p3):
    """The 0.3 m/s one-stride push-off of ``cfg``, solved cold (the session's solve)."""
    return pushoff_0p3


def _check(system, r, **arrays):
    return check_trajectory(system, dataclasses.replace(Trajectory.of(r), **arrays), r.target_velocity_mps)


def test_honest_entry_rides_at_its_label(honest, system):
    """Robot and board end together at the label (momentum speed within 1 %), still, inside every cone."""
    rep = _check(system, honest)
    assert rep.failures(system) == [], rep.as_dict()
    assert rep.momentum_speed_error < 0.01
    assert abs(rep.final_robot_speed_mps - rep.final_board_speed_mps) < 0.01
    assert rep.final_vertical_speed_mps < 0.006 and rep.min_friction_margin_N >= -1e-6


@pytest.fixture(scope="module")
def shove(shove_0p3):
    """Solved the old way: only the board's final speed constrained, no riding end state (the session's)."""
    return shove_0p3


def test_old_terminal_shove_is_refused(cfg, system, shove):
    """The optimizer shoves the deck ahead in the last swing: the board hits the label, the robot
    does not. The checks refuse it."""
    assert shove.success and abs(shove.final_velocity_mps - 0.3) < 0.01  # the optimizer was satisfied
    rep = _check(system, shove)
    assert rep.momentum_speed_error > 0.05
    assert any("momentum speed" in f for f in rep.failures(system))
    judged, _ = judge(cfg, shove)
    assert not judged.success and judged.status.startswith("Physics_Check_Failed")


def test_force_inside_the_pyramid_but_outside_the_cone_is_refused(honest, system):
    """A deck foot's tangential force set to (0.9, 0.9) mu f_n in the deck frame passes the old
    per-axis pyramid test but leaves Coulomb's cone by 27 %: refused."""
    control = honest.control.copy()
    k, i = 5, 0
    assert honest.contact[k, i] == BOARD
    R = board_rotations(honest.state[k:k + 1, 5], honest.state[k:k + 1, 26])[0]
    local = R.T @ control[k, 3 * i:3 * i + 3]
    mu = system.friction_mu
    local[:2] = 0.9 * mu * local[2]
    control[k, 3 * i:3 * i + 3] = R @ local
    assert max(abs(local[0]), abs(local[1])) <= mu * local[2]  # inside the pyramid
    margins, _ = friction_margins(honest.state, control, honest.contact, mu)
    assert margins[k] == pytest.approx(mu * local[2] * (1 - 0.9 * np.sqrt(2)))
    rep = _check(system, honest, control=control)
    assert any("Coulomb cone" in f for f in rep.failures(system))


def test_falling_body_and_slow_robot_at_the_end_are_refused(honest, system):
    """The last knot doctored to a robot 30 % slower than the board and sinking at 0.15 m/s fails
    the momentum, relative-speed and vertical-speed checks."""
    state = honest.state.copy()
    state[-1, 6:8] *= 0.7
    state[-1, 8] = -0.15
    fails = " | ".join(_check(system, honest, state=state).failures(system))
    for words in ("momentum speed", "robot and board differ", "vertically"):
        assert words in fails, fails


def test_swing_foot_through_the_deck_is_refused(honest, system):
    """The swinging push foot moved into the deck (2 cm below its top, over the deck) is refused."""
    p = system.push_index
    k = int(np.flatnonzero(honest.contact[:, p] == 0)[3])
    foot = honest.foot_pos.copy()
    foot[k, p, :2] = honest.board_pos[k, :2]
    foot[k, p, 2] = honest.board_pos[k, 2] - 0.02
    rep = _check(system, honest, foot_pos=foot)
    assert rep.min_swing_clearance_m == pytest.approx(-0.02, abs=1e-3)
    assert any("into the ground or deck" in f for f in rep.failures(system))


def test_braking_push_foot_is_refused(honest, system):
    """A planted push foot whose ground force points backward along the heading is refused."""
    p = system.push_index
    control = honest.control.copy()
    k = 3
    control[k, 3 * p] = -2.0
    rep = _check(system, honest, control=control)
    assert rep.min_push_propulsion_N == pytest.approx(-2.0, abs=0.1)
    assert any("push foot brakes" in f for f in rep.failures(system))


def test_rigid_leg_torques_reduce_to_quasi_static_with_massless_legs(honest, system):
    """With every leg body's mass and inertia removed from the pinocchio model, inverse dynamics of
    the stored motion gives exactly the quasi-static torques -J^T f the TO limits; with the URDF's
    leg masses it differs (the check measures something the TO does not)."""
    import copy

    import pinocchio as pin
    from skatelib.pipeline.quadruped.checks.measures import max_torque as _max_torque
    from skatelib.pipeline.quadruped.model.leg_dynamics import rigid_leg_torques

    r = honest
    full = rigid_leg_torques(system, r.t, r.state, r.control, r.contact, r.foot_pos)
    robot = copy.copy(system.robot)
    robot.model = pin.Model(system.robot.model)
    for j in range(2, robot.model.njoints):  # 0 universe, 1 the free-flyer trunk: keep the trunk
        robot.model.inertias[j] = pin.Inertia.Zero()
    # The quasi-static torques act at the sphere centres; put the contact points there to compare.
    import casadi as ca
    from skatelib.pipeline.quadruped.model.dynamics import foot_centres_world

    x = ca.SX.sym("x", 28)
    centres_fn = ca.Function("c", [x], [foot_centres_world(system, x)])
    centres = np.stack([np.asarray(centres_fn(xk)).T for xk in r.state])
    light = rigid_leg_torques(dataclasses.replace(system, robot=robot), r.t, r.state, r.control, r.contact,
                              centres)
    x_max = _max_torque(system, r.state, r.control)
    assert np.abs(light).max() == pytest.approx(x_max, rel=1e-9)
    assert np.abs(full - light).max() > 0.05


def test_validate_exits_1_on_a_library_holding_the_shove(cfg, system, shove, tmp_path):
    """A library written with the shove stored as a success (as format 1.0 builds did) makes
    `skatelib validate` name the entry's failed checks and exit 1."""
    import os
    import subprocess
    import sys

    from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library

    path = write_quadruped_library(tmp_path / "shove.h5", cfg, system, [entry_from_result(shove)], {})
    r = subprocess.run([sys.executable, "-c", "from skatelib.pipeline.cli.app import main; main()", "validate",
                        str(path)], capture_output=True, text=True, env={**os.environ, "COLUMNS": "300"})
    assert r.returncode == 1, r.stdout + r.stderr
    assert "v0.30_s1" in r.stdout and "momentum speed" in r.stdout


def test_closed_loop_fails_the_shove_on_speed_and_passes_the_honest_entry(cfg, system, shove, honest,
                                                                            tmp_path):
    """`skatelib track`'s verdict on the same push-off solved both ways, exact plant: the honest
    entry delivers its label; the shove (board at the label, robot slow and sinking) ends the push-off
    with the system's momentum far short of the label and fails."""
    pytest.importorskip("daqp")
    from skatelib.control.params import SkateParams
    from skatelib.control.settings import TrackSettings
    from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library
    from skatelib.proving.closed_loop import track_entry
    from skatelib.proving.setup import ClosedLoop
    from skatelib.runtime import MotionLibrary

    verdicts = {}
    for name, r in (("honest", honest), ("shove", shove)):
        path = write_quadruped_library(tmp_path / f"{name}.h5", cfg, system, [entry_from_result(r)], {})
        lib = MotionLibrary.open(path)
        p = SkateParams.from_library(lib)
        verdicts[name], _ = track_entry(lib, "v0.30_s1", ClosedLoop(p, p, settings=TrackSettings(ride_s=1.2)))
    assert verdicts["honest"].passed, verdicts["honest"].reasons
    assert abs(verdicts["honest"].momentum_at_end_mps - 0.3) < 0.05 * 0.3
    assert not verdicts["shove"].passed and "delivered speed" in verdicts["shove"].reasons
    assert verdicts["shove"].momentum_at_end_mps < 0.85 * 0.3


def test_the_checks_functions_go_with_their_system(honest, system):
    """The re-integration and torque functions the checks build are kept per system while it lives
    (a second check builds nothing) and go with it (a process that makes many systems keeps none)."""
    import gc

    from skatelib.pipeline.quadruped.checks import measures

    copy = dataclasses.replace(system)  # another system, the same figures
    first = check_trajectory(copy, Trajectory.of(honest), honest.target_velocity_mps)
    mine = {k for k in measures._BUILT if k[0] == id(copy)}
    assert {k[1] for k in mine} == {"fine", "tau"}
    again = check_trajectory(copy, Trajectory.of(honest), honest.target_velocity_mps)
    assert again == first and {k for k in measures._BUILT if k[0] == id(copy)} == mine
    assert first == check_trajectory(system, Trajectory.of(honest), honest.target_velocity_mps)
    del copy
    gc.collect()
    assert not mine & set(measures._BUILT)
