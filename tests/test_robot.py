"""Robot description: CasADi kinematics against pinocchio, SRB figures, stance IK."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from skatelib.library.errors import ModelError
from skatelib.pipeline.quadruped.model.dynamics import foot_centres_world
from skatelib.pipeline.quadruped.model.robot import Quadruped

from tests.reference_model import foot_centres_world as pin_feet


def test_foot_positions_match_pinocchio_on_random_configurations(system):
    """CasADi foot positions equal pinocchio.forwardKinematics within 1e-9 m on 200 random poses."""
    import casadi as ca

    x_sym = ca.SX.sym("x", 28)
    fk = ca.Function("fk", [x_sym], [foot_centres_world(system, x_sym)])
    rng = np.random.default_rng(0)
    lo, hi = system.robot.lower_limits, system.robot.upper_limits
    worst = 0.0
    for _ in range(200):
        x = np.zeros(28)
        x[0:3] = rng.uniform(-2, 2, 3)
        x[3:6] = rng.uniform([-np.pi, -1.4, -np.pi], [np.pi, 1.4, np.pi])
        x[12:24] = rng.uniform(lo, hi)
        ours = np.asarray(fk(x)).T
        worst = max(worst, float(np.abs(ours - pin_feet(system, x)).max()))
    assert worst < 1e-9, worst


def test_trunk_frame_kinematics_match_pinocchio_directly(system):
    """Foot positions in the trunk frame equal pinocchio's with the base at the origin."""
    robot = system.robot
    data = robot.model.createData()
    rng = np.random.default_rng(1)
    for _ in range(100):
        q = rng.uniform(robot.lower_limits, robot.upper_limits)
        pin.framesForwardKinematics(robot.model, data, robot.pin_configuration(np.zeros(3), np.eye(3), q))
        expected = np.array([data.oMf[robot.model.getFrameId(f)].translation for f in robot.foot_frames]).T
        assert np.abs(np.asarray(robot.foot_positions_body(q)) - expected).max() < 1e-9


def test_srb_mass_is_the_sum_of_urdf_link_masses(system):
    """The single rigid body's mass is the URDF's total (8.5184 kg with the 12 rotors)."""
    assert system.srb.mass_kg == pytest.approx(4.03 + 4 * (0.354 + 0.482 + 0.116) + 12 * 0.0567, abs=1e-9)


def test_srb_inertia_is_pinocchio_composite_inertia(system):
    """SRB inertia equals the sum of link inertias moved to the COM (parallel-axis), computed by hand."""
    robot = system.robot
    data = robot.model.createData()
    qp = robot.pin_configuration(np.zeros(3), np.eye(3), system.stance.q_board)
    pin.forwardKinematics(robot.model, data, qp)
    com = system.srb.com_offset_m
    total = np.zeros((3, 3))
    for j in range(1, robot.model.njoints):
        Y = robot.model.inertias[j]
        M = data.oMi[j]
        c = M.act(Y.lever)
        Ic = M.rotation @ Y.inertia @ M.rotation.T
        d = c - com
        total += Ic + Y.mass * (d @ d * np.eye(3) - np.outer(d, d))
    assert np.allclose(total, system.srb.inertia_kgm2, atol=1e-12)
    assert np.allclose(np.linalg.eigvalsh(total) > 0, True)


def test_stance_ik_places_feet_on_the_deck(system, cfg):
    """The nominal stance puts every foot centre one radius above its deck point."""
    feet = np.asarray(system.robot.foot_positions_body(system.stance.q_board)).T
    h = cfg.stance.base_height_above_deck_m
    for i in range(4):
        target = [
            system.stance.cr[0, i] - cfg.stance.base_x_offset_m,
            system.stance.cr[1, i],
            -h + cfg.robot.foot_radius_m,
        ]
        assert np.allclose(feet[i], target, atol=1e-9)


def test_missing_foot_frame_is_a_clear_error(cfg):
    """A foot frame that the URDF lacks raises ModelError listing the frames."""
    with pytest.raises(ModelError, match="no frame 'FL_toe'"):
        Quadruped(Path(cfg.urdf_path), cfg.robot.joint_names, ("FL_toe", "FR_foot", "RL_foot", "RR_foot"))
