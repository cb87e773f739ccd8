"""The planned motion's feed-forward joint torques (inverse dynamics with the soles' wrenches
shared by the planned ZMP) against the twin: fed to the position servos they hold the robot's
first posture where the servos alone let it sag."""

from __future__ import annotations

import numpy as np
import pytest
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference
from skatelib.control.humanoid_torques import PlannedTorques, support_shares
from skatelib.proving.humanoid.loop import figures_for
from skatelib.runtime import MotionLibrary

mujoco = pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def walk(hrp2_walk_path):
    lib = MotionLibrary.open(hrp2_walk_path)
    key = next(e.key for e in lib if e.success)
    f = figures_for(lib, key)
    ref = HumanoidReference(lib[key], lib.humanoid_model)
    return f, ref, PlannedTorques(HumanoidKinematics(lib.urdf, f.joint_names), ref)


def _sag(f, tau):
    from skatelib.sim.humanoid.plant import HumanoidPlant

    plant = HumanoidPlant(f)
    plant.step(f.q0_rad, 1000, np.zeros(len(f.q0_rad)), tau)
    return np.abs(plant.d.qpos[plant.qadr] - f.q0_rad).max(), plant


def test_the_fed_forward_torques_hold_the_first_posture_where_the_servos_alone_sag(walk):
    """With the torques fed forward the joints stay within 1 mrad of their targets after 1 s of
    standing, and the twin's motors carry the predicted torques within 3 N m; without, the knees
    sag by more than 10 mrad (3000 N m/rad against a 45 N m knee torque)."""
    f, _, torques = walk
    held, plant = _sag(f, torques.tau[0])
    assert held < 1e-3
    assert plant.d.actuator_force[plant.act] == pytest.approx(torques.tau[0], abs=3.0)
    sagged, _ = _sag(f, None)
    assert sagged > 1e-2


def test_after_the_motion_the_robot_holds_still_with_its_zmp_under_its_com(walk):
    """The static hold past the entry's end: no joint speed, no COM motion, the reference ZMP the
    COM's ground point, and the hold's torques the last posture's static ones."""
    _, ref, torques = walk
    qd, tau = torques.sample(ref.duration_s + 0.5)
    s = ref.sample(ref.duration_s + 0.5)
    assert not qd.any() and not s.com_vel.any() and not s.com_acc.any()
    assert s.zmp == pytest.approx(ref.com[-1, 0:2])
    assert tau == pytest.approx(torques.hold)


def test_double_support_shares_follow_the_zmp_and_single_support_takes_all():
    """A ZMP a quarter of the way from the right sole to the left: 3/4 of the force on the right."""
    soles = np.array([[0.0, -0.1, 0.0], [0.0, 0.1, 0.0]])
    both = np.array([True, True])
    assert support_shares(both, soles, np.array([0.0, -0.05])) == pytest.approx([0.75, 0.25])
    assert support_shares(np.array([False, True]), soles, np.array([0.0, -0.05])) == pytest.approx([0.0, 1.0])


def test_a_swing_sole_loaded_near_its_touchdown_lands_early_and_not_elsewhere(walk):
    """The landing rule: a swing sole within 1 cm of the ground in the plan carrying 50 N supports;
    the same load higher in the swing (a stumble) or a light touch does not."""
    _, ref, _ = walk
    swing = next(t for t in ref.t if not ref.sample(t).support.all())  # the first single support
    s = ref.sample(swing)
    up = int(np.flatnonzero(~s.support)[0])
    load = np.zeros(2)
    load[up] = 200.0
    assert s.soles[up, 2] < 0.01 and s.with_landed(load, 50.0, 0.01).support.all()
    assert not s.with_landed(load / 10, 50.0, 0.01).support.all()
    high = ref.sample(swing + 0.3)
    assert high.soles[up, 2] > 0.01 and not high.with_landed(load, 50.0, 0.01).support[up]
