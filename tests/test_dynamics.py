"""Mode dynamics against an independent numpy implementation, plus analytic special cases."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.quadruped.model.dynamics import (
    dynamics_function,
    joint_torques,
    modes_for,
    numeric,
    rk4_step,
)

from tests import reference_model as ref


def _random_state(system, rng):
    x = np.zeros(28)
    x[0:3] = rng.uniform(-1, 1, 3) + np.array([0.0, 0.0, 0.3])
    x[3:6] = rng.uniform([-0.4, -0.4, -np.pi], [0.4, 0.4, np.pi])
    x[6:12] = rng.uniform(-1, 1, 6)
    x[12:24] = rng.uniform(system.robot.lower_limits, system.robot.upper_limits)
    x[24:26] = rng.uniform(-1, 1, 2)
    x[26] = rng.uniform(-0.2, 0.2)
    x[27] = rng.uniform(-2, 2)
    return x


@pytest.mark.parametrize("mode_name", ["four_leg", "three_leg", "accelerating"])
def test_mode_matches_independent_numpy_model(system, mode_name):
    """Each mode's CasADi dynamics equal the numpy re-implementation on 50 random (x, u)."""
    mode = modes_for(system.push_leg)[mode_name]
    f = dynamics_function(system, mode)
    rng = np.random.default_rng(int.from_bytes(mode_name.encode()) % 2**32)  # not hash(): salted per process
    for _ in range(50):
        x = _random_state(system, rng)
        u = rng.uniform(-40, 40, 24)
        cr = rng.uniform(-0.3, 0.3, (2, 4))
        ours = numeric(f, x, u, cr)
        theirs = ref.xdot(system, mode, x, u, cr)
        assert np.allclose(ours, theirs, rtol=1e-9, atol=1e-9), np.abs(ours - theirs).max()


@pytest.mark.parametrize("mode_name", ["four_leg", "three_leg", "accelerating"])
def test_zero_forces_give_ballistic_flight(system, mode_name):
    """Without contact forces the COM follows p0 + v0 t - g t^2 / 2 exactly (RK4 is exact on it)."""
    f = dynamics_function(system, modes_for(system.push_leg)[mode_name])
    x0 = np.zeros(28)
    x0[0:3] = [0.1, -0.2, 0.5]
    x0[6:9] = [0.7, 0.3, 1.5]
    x0[9:12] = [0.2, -0.1, 0.3]
    x0[12:24] = system.stance.q_board
    u = np.zeros(24)
    x, T, n = x0.copy(), 0.6, 600
    for _ in range(n):
        x = np.asarray(rk4_step(f, ca.DM(x), ca.DM(u), ca.DM(system.stance.cr), T / n)).reshape(-1)
    g = system.gravity_mps2
    expected = x0[0:3] + x0[6:9] * T + np.array([0, 0, -0.5 * g * T**2])
    assert np.allclose(x[0:3], expected, atol=1e-9)
    assert np.allclose(x[6:9], x0[6:9] + np.array([0, 0, -g * T]), atol=1e-9)
    # Torque-free rotation conserves the angular momentum in the world: R I omega.
    I = system.srb.inertia_kgm2
    L0 = ref.rpy_matrix(*x0[3:6]) @ I @ x0[9:12]
    L1 = ref.rpy_matrix(*x[3:6]) @ I @ x[9:12]
    assert np.allclose(L0, L1, atol=1e-8)


def test_free_board_roll_is_the_analytic_damped_oscillator(system):
    """With no feet on it and a small roll, the deck follows I phi'' + B phi' + K phi = 0 in closed
    form, K the trucks' stiffness less the deck's own weight about the roll axis (m_deck g h)."""
    f = dynamics_function(system, modes_for(system.push_leg)["four_leg"])
    b = system.board
    K = b.roll_stiffness_Nm_per_rad - b.deck_mass_kg * system.gravity_mps2 * b.roll_axis_depth_m
    B, I = b.roll_damping_Nms_per_rad, b.roll_inertia_kgm2
    x0 = np.zeros(28)
    x0[12:24] = system.stance.q_board
    phi0, psi0 = 1e-4, -5e-4  # small: the trucks' kinematics are linear to 1e-8 there
    x0[26], x0[27] = phi0, psi0
    times = np.linspace(0, 0.15, 301)
    x = ca.DM(x0)
    sim = [x0[26]]
    for k in range(len(times) - 1):
        x = rk4_step(f, x, ca.DM.zeros(24), ca.DM(system.stance.cr), times[k + 1] - times[k], substeps=4)
        sim.append(float(x[26]))
    r1, r2 = np.roots([I, B, K])  # the characteristic roots (complex when underdamped)
    c2 = (psi0 - r1 * phi0) / (r2 - r1)
    analytic = np.real((phi0 - c2) * np.exp(r1 * times) + c2 * np.exp(r2 * times))
    assert np.abs(np.array(sim) - analytic).max() < 1e-10


def test_board_roll_calibration_reproduces_paper_fig5(system, cfg):
    """All the robot's weight on its left feet holds the deck at about -0.12 rad (paper Fig. 5)."""
    f = dynamics_function(system, modes_for(system.push_leg)["four_leg"])
    w = system.srb.mass_kg * system.gravity_mps2
    u = np.zeros(24)
    u[2] = u[8] = w / 2  # FL and RL carry the weight; FR and RR unloaded
    x = ca.DM(np.concatenate([np.zeros(12), system.stance.q_board, np.zeros(4)]))
    for _ in range(2000):
        x = rk4_step(f, x, ca.DM(u), ca.DM(system.stance.cr), 1e-3)
    assert float(x[26]) == pytest.approx(-cfg.board.calibration_roll_rad, rel=1e-6)
    assert abs(float(x[27])) < 1e-9
    # Static stability bound (docs/sources.md): K_B above m g h.
    h = cfg.stance.base_height_above_deck_m
    assert system.board.roll_stiffness_Nm_per_rad > system.srb.mass_kg * system.gravity_mps2 * h


def test_steering_eq14_agrees_with_truck_geometry_eq13(system):
    """Eq. (14) equals the yaw rate that solves Eq. (13a-b) for both trucks with Eq. (11) angles."""
    b = system.board
    rng = np.random.default_rng(3)
    for _ in range(50):
        phi, v = rng.uniform(-0.2, 0.2), rng.uniform(0.05, 2.0)
        d_f, d_r = (float(a) for a in b.steering_angles(phi))
        # Unknowns (v_By, omega): -v tan(d_f) = v_By + omega l_f ; v tan(d_r) = v_By - omega l_r
        A = np.array([[1.0, b.l_front_m], [1.0, -b.l_rear_m]])
        v_by, omega = np.linalg.solve(A, [-v * np.tan(d_f), v * np.tan(d_r)])
        assert abs(v_by) < 1e-12  # C_B is the point with no lateral velocity (Eq. 12)
        assert float(b.steering_residual(phi, v, omega)) == pytest.approx(0.0, abs=1e-12)


def test_joint_torques_match_pinocchio_jacobian(system):
    """Quasi-static torques -J^T R^T f equal pinocchio's frame Jacobian transpose times the force."""
    import pinocchio as pin

    x_sym, u_sym = ca.SX.sym("x", 28), ca.SX.sym("u", 24)
    tau_fn = ca.Function("tau", [x_sym, u_sym], [joint_torques(system, x_sym, u_sym)])
    robot = system.robot
    rng = np.random.default_rng(4)
    data = robot.model.createData()
    for _ in range(20):
        x = _random_state(system, rng)
        u = rng.uniform(-30, 30, 24)
        R = ref.rpy_matrix(*x[3:6])
        qp = robot.pin_configuration(x[0:3] - R @ system.srb.com_offset_m, R, x[12:24])
        pin.computeJointJacobians(robot.model, data, qp)
        pin.framesForwardKinematics(robot.model, data, qp)
        expected = np.zeros(12)
        for i, frame in enumerate(robot.foot_frames):
            J = pin.getFrameJacobian(robot.model, data, robot.model.getFrameId(frame), pin.LOCAL_WORLD_ALIGNED)[:3]
            cols = [robot.model.joints[robot.model.getJointId(n)].idx_v for n in robot.joint_names[3 * i: 3 * i + 3]]
            expected[3 * i: 3 * i + 3] = -J[:, cols].T @ u[3 * i: 3 * i + 3]
        assert np.allclose(numeric(tau_fn, x, u), expected, atol=1e-9)


@pytest.mark.parametrize("mode_name", ["four_leg", "accelerating"])
def test_the_boards_velocity_turns_with_its_heading(system, mode_name):
    """The wheels roll along the heading and do not slide: with no force along it and a constant
    yaw rate r, the board's velocity v0 (cos(r t), sin(r t)) rotates with the yaw (the analytic
    answer): nothing across the heading, the speed kept but for rolling friction. The paper's Eq. (9a) without the
    centripetal term keeps the velocity's direction: 0.1 m/s across after 0.1 rad of yaw at 1 m/s."""
    mode = modes_for(system.push_leg)[mode_name]
    f = dynamics_function(system, mode)
    x0 = np.zeros(28)
    x0[2] = 1.0  # high above the deck: no force, the trunk turns freely about z
    x0[9:12] = [0.0, 0.0, 0.5]  # r = 0.5 rad/s (a symmetric trunk keeps it)
    x0[12:24] = system.stance.q_board
    x0[24] = 1.0
    x, T, n = x0.copy(), 0.2, 200
    u = np.zeros(24)
    for _ in range(n):
        x = np.asarray(rk4_step(f, ca.DM(x), ca.DM(u), ca.DM(system.stance.cr), T / n)).reshape(-1)
    yaw = x[5]
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    along = np.array([np.cos(yaw), np.sin(yaw)]) @ x[24:26]
    assert yaw > 0.09 and abs(left @ x[24:26]) < 1e-9
    # Along: rolling friction slows the accelerating board (mu_roll g, tanh ~ 1); the balancing board
    # follows the free trunk, whose slight pitch (products of inertia) moves it a little.
    slowed = system.board.rolling_coeff * system.gravity_mps2 * T if mode.accelerating else 0.0
    assert along == pytest.approx(1.0 - slowed, abs=1e-3)
