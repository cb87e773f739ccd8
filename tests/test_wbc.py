"""The whole-body controller's parts against independent answers: pinocchio's floating-base model of
the library's robot against MuJoCo's compile of the same URDF (the twin), and the whole-body QP
against the physics it must respect (Newton-Euler of the floating base, Coulomb's pyramid, the
torque limit), with a negative control for each row family."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from skatelib.control.multibody import RobotDynamics  # noqa: E402
from skatelib.control.wbc import WholeBodyController  # noqa: E402
from skatelib.control.wbc_constraints import pyramid  # noqa: E402
from skatelib.control.wbc_settings import WbcSettings  # noqa: E402
from skatelib.control.wbc_targets import WbcTargets  # noqa: E402
from skatelib.pipeline.config import load_config  # noqa: E402
from skatelib.pipeline.quadruped.config import QuadrupedConfig  # noqa: E402
from skatelib.pipeline.twin import twin_figures  # noqa: E402
from skatelib.sim.plant import TwinPlant  # noqa: E402
from skatelib.sim.robot import JOINTS  # noqa: E402


@pytest.fixture(scope="module")
def pair():
    cfg = load_config(None, QuadrupedConfig)
    f = twin_figures(cfg)
    dyn = RobotDynamics(f.urdf, list(JOINTS), [f"{leg}_foot" for leg in ("FL", "FR", "RL", "RR")])
    return f, TwinPlant(f), dyn


def _random_state(plant, f, rng, height=0.4):
    q = f.stance_q_rad + 0.1 * rng.normal(size=12)
    quat = rng.normal(size=4)
    plant.place(np.array([0.1, 0.2, height]), quat / np.linalg.norm(quat), q, np.zeros(3))
    d = plant.d
    d.qvel[plant.trunk_v:plant.trunk_v + 6] = rng.normal(size=6)
    d.qvel[plant.dadr] = rng.normal(size=12)
    mujoco.mj_forward(plant.m, d)
    return plant.state()


def test_pinocchio_model_is_the_twins_robot(pair):
    """At random states: the same foot centres and foot velocities, kinetic energy, mass matrix of
    the joints, gravity torques, and the same joint accelerations under random torques in flight
    (ABA against MuJoCo's forward dynamics, joint damping included)."""
    import pinocchio as pin

    f, plant, dyn = pair
    rng = np.random.default_rng(3)
    for _ in range(3):
        st = _random_state(plant, f, rng, height=2.0)
        qp, vp = dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
        T = dyn.terms(qp, vp)
        assert np.allclose(T.feet, st.foot_centres, atol=1e-12)
        assert np.allclose(np.einsum("kij,j->ik", T.J_feet, vp), st.foot_velocities, atol=1e-12)
        M = np.zeros((plant.m.nv, plant.m.nv))
        mujoco.mj_fullM(plant.m, plant.d, M)
        idx = np.r_[plant.trunk_v:plant.trunk_v + 6, plant.dadr]
        v_mj = plant.d.qvel[idx]
        assert 0.5 * v_mj @ M[np.ix_(idx, idx)] @ v_mj == pytest.approx(0.5 * vp @ T.M @ vp, rel=1e-10)
        assert np.allclose(M[np.ix_(plant.dadr, plant.dadr)], T.M[np.ix_(dyn.v_index, dyn.v_index)], atol=1e-12)
        assert T.com == pytest.approx(plant.d.subtree_com[plant.trunk], abs=1e-12)
        tau = rng.normal(size=12)
        plant.d.ctrl[plant.robot_actuators] = tau
        mujoco.mj_forward(plant.m, plant.d)
        gen = np.zeros(18)
        gen[dyn.v_index] = tau - 0.01 * st.qd  # the twin's joint damping
        a = pin.aba(dyn.model, dyn.data, qp, vp, gen)
        assert np.allclose(a[dyn.v_index], plant.d.qacc[plant.dadr], rtol=1e-8, atol=1e-8)
    st = _random_state(plant, f, rng)
    plant.d.qvel[:] = 0.0
    mujoco.mj_forward(plant.m, plant.d)
    st = plant.state()
    T = dyn.terms(*dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd))
    assert np.allclose(T.h[dyn.v_index], plant.d.qfrc_bias[plant.dadr], atol=1e-12)


def test_bias_accelerations_are_the_rate_of_the_jacobians(pair):
    """J-dot v of the feet and of the centre of mass (read from the bias pass of pinocchio's
    computeAllTerms) against a central difference of J(q) v along the motion at zero qdd; a
    doctored term (the feet's without their centripetal part) is caught."""
    import pinocchio as pin

    f, plant, dyn = pair
    rng = np.random.default_rng(5)
    h = 1e-6
    for _ in range(3):
        st = _random_state(plant, f, rng, height=2.0)
        qp, vp = dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
        T = dyn.terms(qp, vp)
        ahead = dyn.terms(pin.integrate(dyn.model, qp, h * vp), vp)
        behind = dyn.terms(pin.integrate(dyn.model, qp, -h * vp), vp)
        rate_feet = (np.einsum("kij,j->ki", ahead.J_feet, vp) - np.einsum("kij,j->ki", behind.J_feet, vp)) / (2 * h)
        assert np.allclose(T.dJv_feet, rate_feet, atol=1e-5)
        assert np.allclose(T.dJv_com, (ahead.J_com @ vp - behind.J_com @ vp) / (2 * h), atol=1e-5)
        assert np.abs(T.dJv_feet).max() > 0.1  # a state where the term matters
        pin.forwardKinematics(dyn.model, dyn.data, qp, vp, np.zeros(18))
        spatial = np.array([pin.getFrameAcceleration(dyn.model, dyn.data, k, pin.LOCAL_WORLD_ALIGNED).linear
                            for k in dyn.feet])
        assert not np.allclose(spatial, rate_feet, atol=1e-3)


MU = 0.2  # low, so that friction binds before the torque limit


def _standing(pair, **wbc):
    """The robot standing on four feet on the floor, at rest, and a whole-body QP whose force task
    hardly counts (the tests ask for accelerations, not forces)."""
    f, _, dyn = pair
    qp, vp = dyn.configuration(np.array([0.0, 0.0, 0.27]), np.eye(3), f.stance_q_rad, np.zeros(3), np.zeros(3),
                               np.zeros(12))
    T = dyn.terms(qp, vp)
    ctl = WholeBodyController(dyn.v_index, f.torque_limit_Nm, MU, WbcSettings(w_force=1e-6, **wbc))
    return T, ctl, dyn


def _targets(com_acc, forces=None):
    return WbcTargets(stance=np.ones(4, dtype=bool), on_deck=np.zeros(4, dtype=bool),
                      deck_R=np.eye(3), stance_acc=np.zeros((3, 4)),
                      com_acc=np.asarray(com_acc, dtype=float), angular_acc=np.zeros(3), swing_acc=np.zeros((3, 4)),
                      forces=np.zeros((3, 4)) if forces is None else forces, posture_acc=np.zeros(12))


def test_wbc_holds_newton_euler_and_the_friction_pyramid(pair):
    """Standing still: the QP's forces carry the weight (sum f = m g) and its torques are
    M qdd + h - J^T f on the joints. Asked for a sideways acceleration of 3 m/s^2 (more than
    mu = 0.2 gives), its forces stay inside the pyramid and the acceleration falls short;
    negative control: without the friction rows it pushes harder, with forces outside the cone."""
    T, ctl, dyn = _standing(pair)
    out = ctl.solve(T, _targets([0.0, 0.0, 0.0]))
    weight = dyn.mass_kg * 9.81
    assert out.forces.sum(axis=1) == pytest.approx([0.0, 0.0, weight], abs=1e-4 * weight)
    Jc = T.J_feet.reshape(12, 18)
    gen = T.M @ out.qdd + T.h - Jc.T @ out.forces.T.reshape(-1)
    assert np.allclose(gen[:6], 0.0, atol=1e-6) and np.allclose(gen[dyn.v_index], out.tau, atol=1e-9)
    ask = [0.0, 3.0, 0.0]
    inside = ctl.solve(T, _targets(ask))
    rows = pyramid(np.eye(3), MU)
    assert np.max(rows @ inside.forces) <= 1e-7
    assert inside.forces[1].sum() <= MU * inside.forces[2].sum() + 1e-6
    assert inside.forces[1].sum() / dyn.mass_kg < 2.5
    T2, free, _ = _standing(pair, friction_rows=False)
    outside = free.solve(T2, _targets(ask))
    assert outside.forces[1].sum() > inside.forces[1].sum() + 0.3
    assert np.max(rows @ outside.forces) > 1.0


def test_wbc_holds_the_torque_limit(pair):
    """Asked to accelerate the body upward at 6 g, the QP's torques stay within the limit (the
    acceleration falls short); negative control: with a limit of 1000 N m it asks for more."""
    T, ctl, _ = _standing(pair)
    out = ctl.solve(T, _targets([0.0, 0.0, 6 * 9.81]))
    assert np.max(np.abs(out.tau)) <= ctl.tau_max + 1e-6
    ctl.tau_max = 1000.0
    free = ctl.solve(T, _targets([0.0, 0.0, 6 * 9.81]))
    assert np.max(np.abs(free.tau)) > 12.0


def test_the_qp_is_the_sum_of_its_tasks_and_the_stack_of_its_constraints(pair):
    """On two stance feet and two swinging ones, with random targets: the assembled Hessian and
    gradient equal the tasks' sum w A'A, -w A'b written out term by term (COM and swinging feet as
    Jacobian rows, attitude, posture and forces as selections, the regularization), and the
    constraint rows are the generalized forces, the stance feet's Jacobians and one normal and
    four facets per stance foot; a second tick with other targets rewrites the arrays, not adds."""
    T, ctl, dyn = _standing(pair)
    s, rng = ctl.s, np.random.default_rng(7)
    stance = np.array([True, False, False, True])
    legs, swing = [0, 3], [1, 2]
    for _ in range(2):
        tg = WbcTargets(stance=stance, on_deck=np.zeros(4, dtype=bool), deck_R=np.eye(3),
                        stance_acc=rng.normal(size=(3, 4)), com_acc=rng.normal(size=3),
                        angular_acc=rng.normal(size=3), swing_acc=rng.normal(size=(3, 4)),
                        forces=rng.normal(size=(3, 4)), posture_acc=rng.normal(size=12))
        qp = ctl.problem(T, tg)
        n = 18 + 6
        H, g = s.regularization * np.eye(n), np.zeros(n)
        rows = [(s.w_com, T.J_com, tg.com_acc - T.dJv_com)]
        rows += [(s.w_swing, T.J_feet[i], tg.swing_acc[:, i] - T.dJv_feet[i]) for i in swing]
        for w, J, b in rows:
            H[:18, :18] += w * J.T @ J
            g[:18] -= w * J.T @ b
        for w, cols, b in [(s.w_attitude, np.arange(3, 6), tg.angular_acc), (s.w_posture, dyn.v_index, tg.posture_acc),
                           (s.w_force, np.arange(18, n), tg.forces[:, legs].T.ravel())]:
            H[cols, cols] += w
            g[cols] -= w * b
        assert np.allclose(qp.H, H, rtol=1e-12, atol=1e-12) and np.allclose(qp.g, g, rtol=1e-12, atol=1e-12)
        Jc = T.J_feet[legs].reshape(6, 18)
        assert np.array_equal(qp.A[:18], np.hstack([T.M, -Jc.T])) and np.array_equal(qp.A[18:24, :18], Jc)
        assert qp.A.shape == (18 + 6 + 5 * 2, n) and qp.equality is not None
        assert qp.equality[:6].all() and not qp.equality[6:18].any() and qp.equality[18:24].all()


@pytest.mark.parametrize("backend", ["proxqp", "osqp"])
def test_every_backend_of_the_table_solves_the_whole_body_qp_alike(pair, backend):
    """The whole-body QP is one solver-neutral problem: ProxQP and OSQP (the MPC's other backends)
    reach DAQP's optimum with the friction and the torque limit binding: the same net force (the
    tasks' outcome; how four feet share it is nearly free at these weights), inside the pyramid and
    the limit, Newton-Euler held on the base."""
    T, daqp_ctl, _ = _standing(pair)
    _, other, _ = _standing(pair, qp_solver=backend)
    rows, Jc = pyramid(np.eye(3), MU), T.J_feet.reshape(12, 18)
    for ask in ([0.0, 3.0, 0.0], [0.0, 0.0, 6 * 9.81]):
        a, b = daqp_ctl.solve(T, _targets(ask)), other.solve(T, _targets(ask))
        assert np.allclose(a.forces.sum(axis=1), b.forces.sum(axis=1), atol=0.05), (ask, a.forces, b.forces)
        assert np.max(rows @ b.forces) <= 1e-4 and np.max(np.abs(b.tau)) <= other.tau_max + 1e-4
        base = (T.M @ b.qdd + T.h - Jc.T @ b.forces.T.reshape(-1))[:6]
        assert np.allclose(base, 0.0, atol=1e-4)


def test_an_unknown_backend_is_refused_with_the_known_ones():
    """In the settings, before any controller is made of them; and by the table itself."""
    from skatelib.control.qp import backend

    with pytest.raises(ValueError, match=r"qp_solver='cvxopt'\): one of daqp, proxqp, osqp"):
        WbcSettings(qp_solver="cvxopt")
    with pytest.raises(ValueError, match="unknown QP solver 'cvxopt'; choose one of daqp, proxqp, osqp"):
        backend("cvxopt")
