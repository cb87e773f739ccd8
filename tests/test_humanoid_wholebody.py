"""The humanoid's whole body: the HRP-2-class model's figures, inverse kinematics of the walking
plan checked by forward kinematics computed here, the multibody ZMP against the cart-table's on a
motion that makes them equal, and the dynamics filter bringing the multibody ZMP nearer the plan's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from skatelib.pipeline.humanoid.feet import walking_feet
from skatelib.pipeline.humanoid.wholebody import Humanoid, dynamics_filter

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


@pytest.fixture(scope="module")
def robot():
    return Humanoid((CONFIGS / "robots" / "hrp2_class.urdf").read_text())


@pytest.fixture(scope="module")
def walk(hrp2_walk_motion):
    cfg, m = hrp2_walk_motion
    return cfg, m, walking_feet(m.plan, m.t, 0.05, cfg.humanoid.step_width_m)


def test_the_model_has_hrp2s_figures(robot):
    """58 kg, 12 leg joints, the soles 0.105 m under the ankles; standing straight its COM is above
    the paper's walking COM height (so the plans' heights leave the knees bent)."""
    assert robot.mass_kg == pytest.approx(58.0) and len(robot.joint_names) == 12
    q = robot.standing(0.745, 0.0)
    pin.framesForwardKinematics(robot.model, robot.data, q)
    assert robot.data.oMf[robot.soles[0]].translation[2] == pytest.approx(0.0, abs=1e-12)
    assert pin.centerOfMass(robot.model, robot.data, q)[2] > 0.80


def test_ik_meets_its_targets_by_forward_kinematics(robot, walk):
    """The first 3 s of the walk: COM, both soles' positions and level orientation and the upright
    waist at every knot, by a forward pass computed here; joint limits held."""
    _, m, feet = walk
    K = 300
    ik = robot.solve_ik(m.state[:K, 0:3], feet[:K], robot.standing(0.70, 0.4))
    model, data = robot.model, robot.data
    for k in range(0, K, 7):
        q = ik.q[k]
        pin.framesForwardKinematics(model, data, q)
        assert np.allclose(pin.centerOfMass(model, data, q), m.state[k, 0:3], atol=1e-8)
        for s, f in enumerate(robot.soles):
            assert np.allclose(data.oMf[f].translation, feet[k, s, 0:3], atol=1e-8)
            assert np.allclose(data.oMf[f].rotation, np.eye(3), atol=1e-8)
        assert np.allclose(data.oMf[robot.waist].rotation, np.eye(3), atol=1e-8)
    assert np.all(ik.q[:, 7:] >= robot.lower[7:]) and np.all(ik.q[:, 7:] <= robot.upper[7:])
    assert ik.com_error_m.max() < 1e-8 and ik.feet_error_m.max() < 1e-8


def test_multibody_zmp_equals_the_cart_table_for_a_rigid_translating_body(robot):
    """Joints fixed, the body swaying along x and y without turning: the angular momentum is
    constant, and the multibody ZMP is the cart-table's c - c_z c'' / g (to the finite
    differences' accuracy). Negative control: swinging a leg breaks the equality."""
    dt = 1e-3
    t = np.arange(0.0, 1.0, dt)
    q0 = robot.standing(0.70, 0.4)
    q = np.tile(q0, (len(t), 1))
    sway = np.column_stack([0.05 * np.sin(2 * np.pi * t), 0.03 * np.sin(4 * np.pi * t)])
    q[:, 0:2] += sway
    zmp = robot.zmp(q, dt)
    pin.centerOfMass(robot.model, robot.data, q0)
    c0 = robot.data.com[0]
    acc = np.column_stack([-(2 * np.pi) ** 2 * sway[:, 0], -(4 * np.pi) ** 2 * sway[:, 1]])
    cart = c0[0:2] + sway - c0[2] * acc / 9.81
    inner = slice(5, -5)
    np.testing.assert_allclose(zmp[inner], cart[inner], atol=2e-4)
    kick = q.copy()
    hip = robot.model.joints[robot.model.getJointId("L_hip_pitch")].idx_q
    kick[:, hip] += 0.4 * np.sin(2 * np.pi * t)
    assert np.abs(robot.zmp(kick, dt)[inner] - cart[inner]).max() > 0.01


def test_dynamics_filter_brings_the_zmp_nearer_the_plan(robot, walk):
    """On the walk: the multibody ZMP's RMS error against the plan's ZMP falls by at least half,
    the IK still meets its (corrected) targets, and the COM correction stays within a few cm."""
    cfg, m, feet = walk
    f = dynamics_filter(robot, cfg.gpm.sample_dt_s, (m.state[:, 0:3], feet, m.zmp), robot.standing(0.70, 0.4))
    rms = [float(np.sqrt(np.mean(np.sum((z - m.zmp) ** 2, axis=1)))) for z in (f.zmp_before, f.zmp_after)]
    assert rms[1] < 0.5 * rms[0], rms
    assert f.ik.com_error_m.max() < 1e-8 and f.ik.feet_error_m.max() < 1e-8
    assert np.abs(f.com - m.state[:, 0:3]).max() < 0.03
