"""The reference controller against independent references: the linear model against the
nonlinear plant's derivative and finite differences, the exact discretization against a full
matrix exponential, the QP of one solver against the other's, and closed-loop runs on a really
solved entry (tracking with exact parameters; a slippery plant that must be caught)."""

from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest
from skatelib.library.channels import BOARD, GROUND, NU, NX, SWING

pytest.importorskip("proxsuite")
pytest.importorskip("osqp")
pytest.importorskip("daqp")

from scipy.linalg import expm
from skatelib.control.linear_model import Discretizer, Feedback, continuous_model
from skatelib.control.mpc import Bias, HorizonRef, MpcConfig, build_problem, qp_objective
from skatelib.control.mpc_solvers import make_solver
from skatelib.control.params import SkateParams
from skatelib.control.settings import TrackSettings
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.proving.closed_loop import track_entry
from skatelib.proving.perturb import PerturbationError, parse_perturbation
from skatelib.proving.plant import NB, Plant
from skatelib.proving.setup import ClosedLoop
from skatelib.runtime import MotionLibrary

from tests.helpers import CLI


@pytest.fixture(scope="module")
def lib(tiny_v04):
    """One really solved push-off (0.4 m/s, one stride) of the tiny config (the session's)."""
    return MotionLibrary.open(tiny_v04.path)


def _params() -> SkateParams:
    return SkateParams(
        mass_kg=8.9, inertia_kgm2=np.diag([0.05, 0.2, 0.22]), com_offset_m=np.zeros(3), board_mass_kg=2.2,
        roll_inertia_kgm2=0.009, kb_Nm_per_rad=80.0, bb_Nms_per_rad=1.7, rolling_N=1.1, rolling_plan_N=1.1,
        tanh_scale_s_per_m=50.0,
        mu=0.6, gravity_mps2=9.81, deck_points_m=np.array([[0.17, 0.17, -0.17, -0.17], [0.11, -0.11, 0.11, -0.11]]),
        roll_limit_rad=0.2, joint_velocity_limit_radps=31.0, push_leg=2, mu_plan=0.57)


def _state(rng: np.random.Generator) -> np.ndarray:
    s = np.zeros(NB)
    s[0:3] = [0.1, 0.02, 0.27]
    s[3:6] = rng.normal(0, 0.05, 3)
    s[6:9] = [0.5, 0.01, -0.02]
    s[9:12] = 0.0  # the MPC drops [w]x(I w); it vanishes with its derivative at w = 0
    s[24:26] = [0.5 * np.cos(s[5]), 0.5 * np.sin(s[5])]  # fast enough that tanh(k v) = sign(v)
    s[26:28] = [0.03, -0.2]
    s[28:31] = [0.1, 0.0, 0.11]
    return s


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_linear_model_is_the_nonlinear_derivative_with_arms_frozen(seed):
    """In the acceleration mode, A x + B u + C equals the plant's derivative (Eq. 3, 7, 9) at the
    feedback point, and B equals the plant's finite-difference Jacobian in the forces; in the
    balancing mode the board row is Eq. (5a), the robot's acceleration along its own x axis."""
    rng = np.random.default_rng(seed)
    p = _params()
    plant = Plant(p)
    s = _state(rng)
    contact = np.array([BOARD, BOARD, GROUND, BOARD])
    ground = np.zeros((3, 4))
    ground[:, 2] = [-0.15, 0.17, 0.0]
    pts = plant.contact_points(s, contact, ground)
    R_B = board_rotations(s[5], s[26])
    fb = Feedback(x=s[:NX], r_robot=pts - s[0:3, None], r_board=p.moment_arms(R_B))
    A, B, C = continuous_model(p, fb, contact, accelerating=True)
    f = rng.normal(0, 5, (3, 4)) + np.array([[0.0], [0.0], [22.0]])
    u = np.concatenate([f.T.reshape(-1), rng.normal(0, 1, 12)])
    exact = plant.derivative(s, f, u[12:], contact, ground)[:NX]
    np.testing.assert_allclose(A @ s[:NX] + B @ u + C, exact, atol=1e-9)
    eps = 1e-6
    for j in range(12):
        du = np.zeros(12)
        du[j] = eps
        fp = f + du.reshape(4, 3).T
        fd = (plant.derivative(s, fp, u[12:], contact, ground) - plant.derivative(s, f, u[12:], contact, ground))[:NX]
        np.testing.assert_allclose(B[:, j], fd / eps, atol=1e-5)
    contact4 = np.array([BOARD] * 4)
    A4, B4, C4 = continuous_model(p, fb, contact4, accelerating=False)
    xdot = A4 @ s[:NX] + B4 @ u + C4
    acc_local = rpy_matrices(s[3:6]).T @ xdot[6:9]
    np.testing.assert_allclose(xdot[24:26], np.array([np.cos(s[5]), np.sin(s[5])]) * acc_local[0], atol=1e-12)


def test_discretization_is_the_exact_zero_order_hold():
    """A_d, B_d, c_d equal the blocks of expm([[A, B, C], [0, 0, 0]] dt) (computed in full)."""
    p = _params()
    rng = np.random.default_rng(3)
    s = _state(rng)
    fb = Feedback(x=s[:NX], r_robot=rng.normal(0, 0.2, (3, 4)), r_board=rng.normal(0, 0.1, (3, 4)))
    A, B, C = continuous_model(p, fb, np.array([BOARD, SWING, GROUND, BOARD]), accelerating=True)
    dt = 1 / 30
    Ad, Bd, cd = Discretizer(p, dt)(A, B, C)
    M = np.zeros((NX + NU + 1, NX + NU + 1))
    M[:NX, :NX], M[:NX, NX:NX + NU], M[:NX, -1] = A, B, C
    E = expm(M * dt)
    np.testing.assert_allclose(Ad, E[:NX, :NX], atol=1e-12)
    np.testing.assert_allclose(Bd, E[:NX, NX:NX + NU], atol=1e-12)
    np.testing.assert_allclose(cd, E[:NX, -1], atol=1e-12)


def _one_update(e, p: SkateParams, cfg: MpcConfig, t: float, torque_maps: np.ndarray | None = None):
    """The QP of one update fed with the entry's own state at ``t`` (its window and contacts)."""
    x0 = np.asarray(e.sample(t).state, float)
    pts = np.asarray(e.foot_pos[int(np.searchsorted(e.t, t))], float).T
    R_B = board_rotations(x0[5], x0[26])
    fb = Feedback(x=x0, r_robot=pts - x0[0:3, None], r_board=p.moment_arms(R_B),
                  torque_maps=torque_maps)
    w = e.window(t, cfg.horizon + 1, cfg.dt)
    ref = HorizonRef(np.array(w.state[1:]), np.array(w.control[:-1]), np.array(w.contact[:-1]),
                     np.ones(cfg.horizon, bool))
    return build_problem(p, cfg, Discretizer(p, cfg.dt), fb, ref), w


def test_the_two_qp_solvers_agree(lib):
    """The condensed dense QP (DAQP, ProxQP) and the sparse multiple-shooting QP (OSQP) of one real
    update give the same forces and objective."""
    key = lib.keys()[0]
    e = lib[key]
    p = SkateParams.from_library(lib)
    qp, w = _one_update(e, p, MpcConfig(), float(e.t[0]) + 0.3)
    Ub = make_solver("osqp").solve(qp)
    jb = qp_objective(qp, Ub)
    for name in ("daqp", "proxqp"):
        Ua = make_solver(name).solve(qp)
        ja = qp_objective(qp, Ua)
        assert abs(ja - jb) <= 1e-5 * max(1.0, abs(ja)), name
        np.testing.assert_allclose(Ua[:12], Ub[:12], atol=2e-2)  # forces [N]
        np.testing.assert_array_equal(Ua[12:24], Ub[12:24])  # the joint part is solved once, outside
    swing = np.nonzero(np.asarray(w.contact[0]) == SWING)[0]
    for i in swing:
        assert np.all(Ua[3 * i:3 * i + 3] == 0.0)


def test_joint_part_is_the_least_squares_solution():
    """solve_joints against an independent solution: the stacked least-squares problem by
    numpy's lstsq when no bound is active, OSQP with the bounds when one is."""
    import osqp
    import scipy.sparse as sp
    from skatelib.control.mpc import solve_joints

    rng = np.random.default_rng(5)
    N, dt = 10, 1 / 30
    q0, q_ref, qd_ref = rng.normal(0, 0.3, 12), rng.normal(0, 0.3, (N, 12)), rng.normal(0, 1, (N, 12))
    w_q, w_qd = rng.uniform(0.5, 2, 12), rng.uniform(1e-3, 1e-1, 12)
    L = np.tril(np.ones((N, N)))
    for limit in (1e3, 2.0):
        qd = solve_joints(q0, q_ref, qd_ref, (w_q, w_qd), dt, limit)
        for j in range(12):
            A = np.vstack([np.sqrt(w_q[j]) * dt * L, np.sqrt(w_qd[j]) * np.eye(N)])
            b = np.concatenate([np.sqrt(w_q[j]) * (q_ref[:, j] - q0[j]), np.sqrt(w_qd[j]) * qd_ref[:, j]])
            if limit > 100:
                ref = np.linalg.lstsq(A, b, rcond=None)[0]
            else:
                m = osqp.OSQP()
                m.setup(sp.csc_matrix(A.T @ A), -A.T @ b, sp.identity(N, format="csc"), -limit * np.ones(N),
                        limit * np.ones(N), verbose=False, eps_abs=1e-10, eps_rel=1e-10, polishing=True)
                ref = m.solve(raise_error=True).x
            np.testing.assert_allclose(qd[:, j], ref, atol=1e-6)
        assert np.all(np.abs(qd) <= limit + 1e-9)


def test_exact_parameters_track_within_millimetres_and_pass(lib):
    """The MPC with the library's own parameters and no disturbance follows the entry, the
    transfer and the ride within a few millimetres (5 mm) and 0.02 rad of the board-anchored
    reference, without a fall or a slip, and delivers the label within 5 %."""
    p = SkateParams.from_library(lib)
    r, _ = track_entry(lib, lib.keys()[0], ClosedLoop(p, p, settings=TrackSettings(ride_s=1.2)))
    assert r.slips == 0 and not r.fall, r
    assert r.max_position_error_m < 0.005 and r.max_attitude_error_rad < 0.02, r
    assert r.passed, r.reasons


def test_a_slippery_plant_is_caught(lib):
    """A plant with mu 0.2 cannot give the push force: the run counts slips and fails."""
    p = SkateParams.from_library(lib)
    slippery, dist = parse_perturbation("mu=0.2", p)
    r, _ = track_entry(lib, lib.keys()[0], ClosedLoop(p, slippery, dist, settings=TrackSettings(ride_s=1.2)))
    assert r.slips > 0 and not r.passed and "slipping" in r.reasons


def test_disturbance_observer_finds_a_constant_board_acceleration(lib):
    """Feedback that runs ahead of the model's prediction by b dt each update: the estimate
    converges to b (the analytic answer of the filter), and a model that is right leaves it at 0."""
    from skatelib.control.mpc import board_heading
    from skatelib.control.observers import DisturbanceObserver

    e = lib[lib.keys()[0]]
    p = SkateParams.from_library(lib)
    cfg = MpcConfig()
    x0 = np.asarray(e.sample(0.3).state, float)
    fb = Feedback(x=x0, r_robot=np.zeros((3, 4)), r_board=np.zeros((3, 4)))
    w = e.window(0.3, cfg.horizon + 1, cfg.dt)
    disc = Discretizer(p, cfg.dt)

    def problem(bias: float):
        ref = HorizonRef(np.array(w.state[1:]), np.array(w.control[:-1]), np.array(w.contact[:-1]),
                         np.ones(cfg.horizon, bool))
        return build_problem(p, cfg, disc, fb, ref, Bias(bias))

    U = np.zeros(cfg.horizon * NU)
    qp0 = problem(0.0)
    x1 = qp0.Ad[0] @ qp0.x0 + qp0.Bd[0] @ U[:12] + qp0.cd[0]
    truth = float(board_heading(x0) @ x1[12:14])  # the plant: the bias-free model's step ...
    for b in (-0.1, 0.0):
        obs = DisturbanceObserver(0.3)
        for _ in range(80):
            bias = obs.update(truth + b * cfg.dt, cfg.dt)  # no prediction yet: 0
            obs.predict(problem(bias), U)  # ... plus b dt of speed each update
        obs.update(truth + b * cfg.dt, cfg.dt)
        assert obs.bias_mps2 == pytest.approx(b, abs=1e-6)


def test_perturbations_parse_and_refuse():
    p = _params()
    q, d = parse_perturbation("mass=+10%,kb=-20%,rolling=+100%,mu=0.5,com=0.01", p)
    assert q.mass_kg == pytest.approx(9.79) and q.kb_Nm_per_rad == pytest.approx(64.0)
    # rolling doubles the coefficient; the force also follows the heavier robot's weight (Eq. 9b)
    assert q.rolling_N == pytest.approx(2.2 * (9.79 + 2.2) / (8.9 + 2.2)) and q.mu == 0.5 and d.com_offset_m == 0.01
    light, _ = parse_perturbation("mass=-10%", p)
    assert light.rolling_N == pytest.approx(1.1 * (8.01 + 2.2) / (8.9 + 2.2))
    # tanh: the plant's rolling resistance near rest (Eq. 10's k); at 5 mm/s the board's deceleration
    # with nothing on the deck is tanh(k v) f_fri m_B / (m_B + m_R) / m_B (the wheels carry the board
    # alone): a quarter of that at k 50, 99 % of it at k 500
    stiff, _ = parse_perturbation("tanh=500", p)
    s, contact = np.zeros(NB), np.array([SWING] * 4)
    s[24] = 0.005
    for params, share in ((p, np.tanh(0.25)), (stiff, np.tanh(2.5))):
        decel = -Plant(params).derivative(s, np.zeros((3, 4)), np.zeros(12), contact, np.zeros((3, 4)))[24]
        assert decel == pytest.approx(share * 1.1 * (2.2 / (2.2 + 8.9)) / 2.2)
    for bad in ("weight=+10%", "mass", "mass=abc", "mu=nan", "mass=-100%"):
        with pytest.raises(PerturbationError):
            parse_perturbation(bad, p)
    with pytest.raises(PerturbationError, match="mass is given twice"):  # it silently kept the last
        parse_perturbation("mass=+10%,mass=+20%", p)


def test_steering_follows_the_deck_roll_and_its_negative_control(lib):
    """Four-leg steering with exact parameters (shortened to 4.5 s): deck roll within 0.03 rad RMS
    of the 0.1 rad sine, the torso shifted by about the trucks' torque at 0.1 rad over m g, every deck foot
    loaded. A deck with half the trucks' stiffness: the torso shift that follows the stiffness
    measured while rolling keeps the error within the bound with less shift; negative control:
    with the model's K_B throughout it misses the bound."""
    from skatelib.proving.steer import steer

    p = SkateParams.from_library(lib)
    r = steer(lib, ClosedLoop(p, p), 0.0, duration_s=4.5)
    assert r.passed, r.reasons
    assert r.roll_rms_error_rad < 0.03 and r.unloaded_steps == 0
    expected_shift = -p.roll_torque(0.1, 0.0) / (p.mass_kg * p.gravity_mps2)
    assert r.max_lateral_shift_m == pytest.approx(expected_shift, rel=0.1)
    soft, _ = parse_perturbation("kb=-50%", p)
    adapted = steer(lib, ClosedLoop(p, soft), 0.0, duration_s=4.5)
    assert adapted.passed, adapted.reasons
    assert adapted.max_lateral_shift_m < 0.8 * r.max_lateral_shift_m  # a softer deck: less shift
    bad = steer(lib, ClosedLoop(p, soft), 0.0, duration_s=4.5, adapt_stiffness=False)
    assert not bad.passed and "deck roll error" in bad.reasons


def test_validate_closed_loop_stores_each_verdict(lib, tmp_path):
    """`skatelib validate LIB --closed-loop` tracks the entries and stores each verdict in the file
    (the exact plant: the entry passes, exit 0): the rewritten file verifies (new checksum), its
    arrays and earlier attributes are unchanged."""
    import json
    import shutil

    path = tmp_path / "v.h5"
    shutil.copy(lib.path, path)
    r = subprocess.run([*CLI, "validate", str(path), "--closed-loop", "--perturb", "none", "-j", "1"],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"}, timeout=600)
    assert r.returncode == 0 and "stored 1 closed-loop verdicts" in r.stdout, r.stdout + r.stderr
    after = MotionLibrary.open(path)
    key = lib.keys()[0]
    verdict = json.loads(after[key].attrs["closed_loop_json"])
    assert verdict["key"] == key and verdict["passed"] is True
    assert after.attrs["closed_loop_plant"] == "none"
    for name, arr in lib[key].arrays.items():
        np.testing.assert_array_equal(after[key].arrays[name], arr)
    for k, v in lib[key].attrs.items():
        assert after[key].attrs[k] == v
    assert after.attrs["git_commit"] == lib.attrs["git_commit"]
    # info shows the stored verdicts, as a table and in --json
    env = {**os.environ, "COLUMNS": "200"}
    shown = subprocess.run([*CLI, "info", str(path), "--wide"], capture_output=True, text=True, env=env, timeout=120)
    assert "closed loop on the model plant, plant errors none" in shown.stdout and "pass" in shown.stdout
    summary = subprocess.run([*CLI, "info", str(path)], capture_output=True, text=True, env=env, timeout=120)
    assert "closed loop on the model plant: 1 of 1 stored verdict pass (plant errors none" in summary.stdout
    doc = json.loads(subprocess.run([*CLI, "info", str(path), "--json"], capture_output=True, text=True, env=env,
                                    timeout=120).stdout)
    assert doc["closed_loop_plant"] == "none" and doc["entries"][0]["closed_loop"]["passed"] is True
    plain = subprocess.run([*CLI, "info", str(lib.path), "--wide"], capture_output=True, text=True, env=env,
                           timeout=120)
    assert "closed loop on" not in plain.stdout  # negative control: nothing stored, nothing shown


def test_leg_kinematics_agree_with_the_pipelines_chains(lib):
    """The closed loop's leg kinematics (pinocchio on the URDF stored in the library) against the
    pipeline's CasADi chains built from the config's URDF: foot positions and the quasi-static
    torques -J^T R^T f of the optimization; inverse kinematics recovers perturbed joint angles."""
    import casadi as ca
    from skatelib.control.kinematics import LegKinematics
    from skatelib.pipeline.quadruped.kind import system_from_library
    from skatelib.pipeline.quadruped.model.dynamics import joint_torques

    kin = LegKinematics.from_library(lib)
    system = system_from_library(lib)
    e = lib[lib.keys()[0]]
    x, u = np.asarray(e.state[10], float), np.asarray(e.control[10], float)
    q = x[12:24]
    qs = ca.SX.sym("q", 12)
    feet = np.asarray(ca.Function("feet", [qs], [system.robot.foot_positions_body(qs)])(q))
    np.testing.assert_allclose(kin.foot_positions(q), feet, atol=1e-9)
    xs, us = ca.SX.sym("x", NX), ca.SX.sym("u", NU)
    expected = np.asarray(ca.Function("tau", [xs, us], [joint_torques(system, xs, us)])(x, u)).reshape(-1)
    R = rpy_matrices(x[3:6])
    forces = u[:12].reshape(4, 3).T
    np.testing.assert_allclose(kin.torques(q, R.T @ forces, np.ones(4, bool)), expected, atol=1e-9)
    maps = kin.torque_maps(q, R)
    np.testing.assert_allclose(np.concatenate([maps[i] @ forces[:, i] for i in range(4)]), expected, atol=1e-9)
    rng = np.random.default_rng(0)
    q_ik, residual = kin.inverse(feet, q + rng.normal(0, 0.1, 12), np.ones(4, bool))
    np.testing.assert_allclose(q_ik, q, atol=1e-6)
    assert residual.max() < 1e-6  # the Newton iteration stops below 1e-7 m


def test_torque_rows_hold_the_joint_torques(lib):
    """With the legs' torque maps in the feedback, every loaded leg's joint torques stay within the
    limit; a limit low enough to bind changes the solution (negative control: without the rows
    the same QP exceeds it)."""
    import dataclasses

    from skatelib.control.kinematics import LegKinematics

    e = lib[lib.keys()[0]]
    kin = LegKinematics.from_library(lib)
    cfg = MpcConfig()
    t = float(e.t[0]) + 0.3
    x0 = np.asarray(e.sample(t).state, float)
    maps = kin.torque_maps(x0[12:24], rpy_matrices(x0[3:6]))
    for limit, rows in ((12.0, True), (4.0, True), (4.0, False)):
        p = dataclasses.replace(SkateParams.from_library(lib), torque_limit_Nm=limit)
        qp, w = _one_update(e, p, cfg, t, maps if rows else None)
        contact = np.array(w.contact[:-1])
        U = make_solver(cfg.solver).solve(qp)
        f = U[:12].reshape(4, 3)
        tau = max(float(np.abs(maps[i] @ f[i]).max()) for i in range(4) if contact[0, i] != SWING)
        if rows:
            assert tau <= limit + 1e-6
        else:
            assert tau > limit  # the rows above were binding


def test_coast_compensation_delivers_the_label_on_an_easier_board(lib):
    """The library plans against twice the board's rolling resistance; on the board as it is,
    robot and board coast faster than planned. With the coast compensation the push aims lower
    and the entry delivers its label within 5 %; tracking the plan's speeds instead overshoots
    (negative control)."""
    p = SkateParams.from_library(lib)
    assert p.rolling_plan_N == pytest.approx(2.0 * p.rolling_N)
    key = lib.keys()[0]
    settings = TrackSettings(ride_s=1.2)
    good, _ = track_entry(lib, key, ClosedLoop(p, p, settings=settings))
    assert good.passed, good.reasons
    plain, _ = track_entry(lib, key, ClosedLoop(p, p, mpc=MpcConfig(coast_compensation=False), settings=settings))
    assert plain.speed_error > 0.05, plain


def test_a_push_moves_the_speed_reference_as_its_foot_can(lib):
    """The coast compensation's move of the speed reference starts at nothing when the push foot
    touches down and reaches its full size (what the coast after the push gains on the board as it
    is, from the plan's speeds independently integrated) when it lifts, growing with the planned
    normal-force impulse of that foot in between. A move that stepped at touch-down (the negative
    control: its value just after touch-down) asks for a momentum change in no time, which the MPC
    chased with its hardest braking and then overshot."""
    from skatelib.control.reference import EntryReference
    from skatelib.library.margins import momentum_speed

    e = lib[lib.keys()[0]]
    p = SkateParams.from_library(lib)
    ref = EntryReference(lib, e, p, TrackSettings())
    start, end, coast_end = ref.pushes[-1]
    coast = p.rolling_N / (p.mass_kg + p.board_mass_kg)  # the board as it is: half the plan's
    t = np.asarray(e.t, float)
    v = momentum_speed(np.asarray(e.state), p.mass_kg, p.board_mass_kg)
    fine = np.linspace(end, coast_end, 2001)
    drag = np.tanh(p.tanh_scale_s_per_m * np.interp(fine, t, v))
    full = -(ref.plan_coast_mps2 - coast) * float(np.sum(0.5 * (drag[1:] + drag[:-1]) * np.diff(fine)))
    assert full < -0.01  # the easier board keeps more speed: the push aims lower
    assert ref.speed_offset(start, coast) == pytest.approx(0.0, abs=1e-12)
    assert ref.speed_offset(end - 1e-9, coast) == pytest.approx(full, rel=1e-3)
    assert ref.speed_offset(end, coast) == pytest.approx(full, rel=1e-3)
    fn = np.asarray(e.control, float)[:, 3 * p.push_leg + 2]
    k0, k1 = int(np.searchsorted(t, start)), int(np.searchsorted(t, end))
    km = (k0 + k1) // 2
    share = float(np.sum(fn[k0:km] * np.diff(t)[k0:km]) / np.sum(fn[k0:k1] * np.diff(t)[k0:k1]))
    assert 0.05 < share < 0.95
    assert ref.speed_offset(float(t[km]), coast) == pytest.approx(share * full, rel=1e-6)
    moves = [ref.speed_offset(float(tk), coast) for tk in np.linspace(start, end, 50)]
    assert np.all(np.diff(moves) <= 1e-12)  # one way, as the foot pushes
    just_after = ref.speed_offset(start + 1e-3, coast)
    assert abs(just_after) < 0.1 * abs(full)  # a step would be the full move already


@pytest.mark.parametrize("fit", [True, False])
def test_coast_observer_measures_a_constant_deceleration(fit):
    """Momentum speeds falling by a dt each update while coasting: the estimate is a, fitted or
    filtered; updates outside coasts or below the speed floor leave it alone."""
    from skatelib.control.observers import CoastObserver

    obs = CoastObserver(gain=0.2, fit=fit)
    assert obs.update(True, 0.8, 1 / 30) is None  # one sample needs two updates
    v, dt = 0.8, 1 / 30
    for _ in range(60):
        obs.update(True, v, dt)
        v -= 0.25 * dt
    assert obs.estimate_mps2 == pytest.approx(0.25, abs=1e-4)
    for _ in range(10):
        obs.update(False, v, dt)
        v -= 5.0 * dt  # a push or anything else: not a coast
    assert obs.estimate_mps2 == pytest.approx(0.25, abs=1e-4)
    slow = CoastObserver(gain=0.2, fit=fit)
    for k in range(20):
        slow.update(True, 0.01 - 0.001 * k, dt)  # below the floor: tanh(k v) is not 1 there
    assert slow.estimate_mps2 is None


def test_a_foot_on_the_floor_is_no_coast_sample(lib):
    """While the plan coasts, a foot sensed on the floor (one landing early) brakes robot and board:
    the coast observer takes no sample from that update (nor from the next, which has no coasting
    update before it). Taken (the negative control), a landing's 0.02 m/s of braking over one
    update (1/30 s) reads as 0.6 m/s^2 of rolling deceleration on top of the board's."""
    from skatelib.control.reference import EntryReference
    from skatelib.control.update import MpcUpdate
    from skatelib.library.channels import S_BOARD_V, S_VEL
    from skatelib.library.margins import forward_speed

    e = lib[lib.keys()[0]]
    p = SkateParams.from_library(lib)
    cfg = MpcConfig()
    ref = EntryReference(lib, e, p, TrackSettings())
    dt = cfg.dt
    t = next(float(tk) for tk in e.t if ref.coasting(float(tk)) and ref.coasting(float(tk) + dt)
             and forward_speed(np.asarray(e.sample(float(tk)).state)) > 0.1)

    def feedback(tk: float, brake_mps: float) -> Feedback:
        x = np.asarray(e.sample(tk).state, float).copy()
        heading = np.array([np.cos(x[5]), np.sin(x[5])])
        x[S_VEL][0:2] -= brake_mps * heading
        x[S_BOARD_V] -= brake_mps * heading
        pts = np.asarray(e.foot_pos[int(np.searchsorted(e.t, tk))], float).T
        return Feedback(x=x, r_robot=pts - x[0:3, None], r_board=p.moment_arms(board_rotations(x[5], x[26])))

    rolling = p.rolling_N / (p.mass_kg + p.board_mass_kg)
    estimates = {}
    for on_floor in (True, False):
        update = MpcUpdate(EntryReference(lib, e, p, TrackSettings()), p, cfg, dt)
        board = np.asarray(e.board_pos[int(np.searchsorted(e.t, t))], float)[0:2]
        update(t, feedback(t, 0.0), board, None)
        drop = rolling * dt  # the coast's own deceleration over the update
        update(t + dt, feedback(t + dt, 0.02), board, None, on_floor=on_floor)
        update(t + 2 * dt, feedback(t + 2 * dt, 0.02 + drop), board, None, on_floor=False)
        estimates[on_floor] = update.coast.estimate_mps2
    assert estimates[True] is None, estimates
    assert estimates[False] is not None and estimates[False] > rolling + 0.3, (estimates, rolling)
