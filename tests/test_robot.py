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


def test_damped_newton_settles_at_the_nearest_reachable_point(system):
    """Toward a foot target out of the leg's reach, with the knee at its limit on the way (the
    cold guess's held push foot as the trunk rides on), the damped Newton ends at the point of the
    joint box nearest the target (a fine grid over the box, searched independently, finds none
    nearer) and does not move when its start moves by 1e-12 rad. The plain clipped Newton step
    (the negative control) bounces between the limit and the far side and stops twice as far;
    where it stops follows the last bits of its 3 x 3 solves, which differ between BLAS kernels
    (the cold guess's push leg differed by up to 0.45 rad between OpenBLAS's Haswell and Prescott
    kernels)."""
    import casadi as ca
    from skatelib.pipeline.quadruped.model.ik import DampedNewton
    from skatelib.pipeline.quadruped.model.robot import foot_position_leg

    p = system.push_index
    leg = slice(3 * p, 3 * p + 3)
    q_sym = ca.SX.sym("q", 3)
    pos = foot_position_leg(system.robot.chains[p], q_sym)
    fk = ca.Function("fk", [q_sym], [pos, ca.jacobian(pos, q_sym)])
    lo, hi = system.robot.lower_limits[leg], system.robot.upper_limits[leg]
    q0 = np.asarray(system.stance.q_push[leg], float)
    home = np.asarray(fk(q0)[0]).reshape(-1)
    goal = np.array([-0.3602, home[1], -0.2369])  # behind the hip, out of reach (a guess knot's)
    newton = DampedNewton(damping=1e-6, tol=1e-9, max_iter=20)
    q, residual = newton.solve(fk, goal, q0, (lo, hi))
    q_b, _ = newton.solve(fk, goal, q0 + 1e-12, (lo, hi))
    assert np.abs(q - q_b).max() < 1e-6
    grid = np.stack(np.meshgrid(*(np.linspace(a, b, 41) for a, b in zip(lo, hi, strict=True)), indexing="ij"), -1)
    reach = np.asarray(ca.Function("p", [q_sym], [pos]).map(grid.size // 3)(grid.reshape(-1, 3).T)).T
    nearest = float(np.min(np.linalg.norm(reach - goal, axis=1)))
    assert residual > 0.02  # really out of reach
    assert residual <= nearest + 1e-4, (residual, nearest)

    def plain(start: np.ndarray) -> np.ndarray:
        qq = start.copy()
        for _ in range(20):
            f, J = (np.asarray(v) for v in fk(qq))
            qq = np.clip(qq + np.linalg.solve(J.T @ J + 1e-6 * np.eye(3), J.T @ (goal - f.reshape(-1))), lo, hi)
        return qq

    far = float(np.linalg.norm(np.asarray(fk(plain(q0))[0]).reshape(-1) - goal))
    assert far > residual + 0.01, (far, residual)


def test_buffered_evaluation_gives_the_functions_values_to_the_bit(system):
    """``Evaluated`` (the guess's leg kinematics through CasADi's buffer) returns what the function's
    own call returns, to the last bit, on 200 random poses, as new arrays each call; a function with
    a sparse output is refused (its buffer would hold the nonzeros only)."""
    import casadi as ca
    from skatelib.pipeline.quadruped.model.ik import Evaluated
    from skatelib.pipeline.quadruped.model.robot import foot_position_leg

    q = ca.SX.sym("q", 3)
    pos = foot_position_leg(system.robot.chains[0], q)
    fn = ca.Function("fk", [q], [pos, ca.densify(ca.jacobian(pos, q))])
    fast = Evaluated(fn)
    rng = np.random.default_rng(1)
    first = fast(np.zeros(3))
    for _ in range(200):
        x = rng.uniform(-2.0, 2.0, 3)
        got, want = fast(x), [np.asarray(v) for v in fn(x)]
        assert all(g.shape == w.shape and np.array_equal(g, w) for g, w in zip(got, want, strict=True))
    assert np.array_equal(first[0], np.asarray(fn(np.zeros(3))[0]))  # not overwritten by later calls
    with pytest.raises(ValueError, match="dense outputs"):
        Evaluated(ca.Function("sparse", [q], [ca.jacobian(pos, q)]))
