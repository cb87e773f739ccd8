"""Push-off TO end to end: a small problem really solved, then checked by independent code."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from skatelib.library.channels import CONTROL_NAMES, GROUND, LEGS, S_BOARD_V, STATE_NAMES
from skatelib.pipeline.ocp.terms import Box, variable_bounds
from skatelib.pipeline.quadruped.checks.verify import Trajectory, check_trajectory
from skatelib.pipeline.quadruped.problem.knots import NXA
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, problem_for, solve, warm_point

from tests import reference_model as ref


@pytest.fixture(scope="module")
def solved(pushoff_0p3):
    """The 0.3 m/s one-stride push-off of ``cfg``, solved cold (the session's solve)."""
    return pushoff_0p3


def test_solve_converges_to_target_speed(solved):
    """IPOPT converges and the board ends within 2 % of the target speed."""
    assert solved.success, solved.status
    assert solved.status == "Solve_Succeeded"
    assert solved.final_velocity_error < 0.02
    assert solved.max_constraint_violation < 1e-6
    assert solved.state.shape == (41, 28) and solved.control.shape == (40, 24)


def test_fine_step_numpy_reintegration_matches_every_interval(solved, system):
    """Re-integrating each shooting interval with a 20-step RK4 of the numpy reference model
    (pinocchio kinematics) lands within 1e-3 of the next knot."""
    from skatelib.pipeline.quadruped.model.dynamics import modes_for

    mode = modes_for(system.push_leg)["accelerating"]
    worst = 0.0
    for k in range(len(solved.t) - 1):
        x, u = solved.state[k].copy(), solved.control[k]
        h = (solved.t[k + 1] - solved.t[k]) / 20
        for _ in range(20):
            k1 = ref.xdot(system, mode, x, u, system.stance.cr)
            k2 = ref.xdot(system, mode, x + h / 2 * k1, u, system.stance.cr)
            k3 = ref.xdot(system, mode, x + h / 2 * k2, u, system.stance.cr)
            k4 = ref.xdot(system, mode, x + h * k3, u, system.stance.cr)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        worst = max(worst, float(np.abs(x - solved.state[k + 1]).max()))
    assert worst < 1e-3, worst


def test_solved_trajectory_respects_contact_and_limits(solved, system):
    """Friction, no slip on ground or deck, joint/torque/speed limits, all measured on the arrays."""
    rep = check_trajectory(system, Trajectory.of(solved), solved.target_velocity_mps)
    assert rep.failures(system) == [], rep.as_dict()
    assert rep.max_defect < 1e-3


def test_push_foot_really_pushes(solved, system):
    """The board gains speed only while the push foot is on the ground and pushes backward on it."""
    p = LEGS.index(system.push_leg)
    on_ground = solved.contact[:-1, p] == GROUND
    fx = solved.control[:, 3 * p]
    assert on_ground.sum() == 18
    assert fx[on_ground].mean() > 0.5  # the ground pushes the foot forward
    assert np.all(solved.control[~on_ground, 3 * p: 3 * p + 3] == 0.0)


def test_warm_start_cuts_iterations(cfg, solved):
    """A solve warm-started from the 0.3 m/s solution needs at most 2/3 of a cold solve's iterations."""
    cold = solve(PushoffSpec(cfg, 0.35, 1))
    warm = solve(PushoffSpec(cfg, 0.35, 1, warm=solved.warm))
    assert cold.success and warm.success
    assert warm.iterations <= (2 * cold.iterations) // 3, (warm.iterations, cold.iterations)
    assert abs(warm.final_velocity_mps - cold.final_velocity_mps) < 0.01


def test_a_warm_start_is_moved_along_the_guesses(cfg, solved):
    """With ``warm_predictor`` the warm start of the 0.3 m/s solution towards 0.4 m/s starts from the
    solution plus the change of the cold guess: its board ends 0.1 m/s faster, its first knot is
    still the start state; without, it is the solution itself. The solution records its speeds."""
    warm = solved.warm
    assert (warm.from_velocity_mps, warm.target_velocity_mps) == (0.0, 0.3)
    assert cfg.optimization.warm_predictor
    prob = problem_for(cfg, 1)
    K = len(prob.schedule.t)
    moved = warm_point(prob, PushoffSpec(cfg, 0.4, 1, warm=warm), warm).reshape(K, -1)
    before = warm.w.reshape(K, -1)
    np.testing.assert_allclose(moved[-1, S_BOARD_V.start] - before[-1, S_BOARD_V.start], 0.1, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(moved[0, :NXA], prob.start_state(0.0))
    off = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, warm_predictor=False))
    assert warm_point(prob, PushoffSpec(off, 0.4, 1, warm=warm), warm) is warm.w


def test_a_warm_start_carries_its_guess_for_its_own_problem_only(cfg, solved, monkeypatch):
    """The solution carries its problem's cold guess at its speeds: the predictor reads it instead
    of making it again (the same point to the bit), and makes it again for another problem (a
    guess carried from another config is not read)."""
    from skatelib.pipeline.quadruped.problem import pushoff

    warm = solved.warm
    assert warm.guess is not None and warm.guess_of == pushoff.problem_key(cfg, 1, pushoff.START_UP)
    prob = problem_for(cfg, 1)
    np.testing.assert_array_equal(warm.guess, prob.initial_guess(0.0, 0.3, "ramp"))
    bare = dataclasses.replace(warm, guess=None)
    spec = PushoffSpec(cfg, 0.4, 1, warm=warm)
    made = []
    real = type(prob).initial_guess
    monkeypatch.setattr(type(prob), "initial_guess", lambda self, *a: made.append(a) or real(self, *a))
    np.testing.assert_array_equal(warm_point(prob, spec, warm), warm_point(prob, spec, bare))
    assert made.count((0.0, 0.3, "ramp")) == 1  # only for the solution without its guess
    other = dataclasses.replace(warm, guess=warm.guess + 1.0, guess_of="another problem")
    np.testing.assert_array_equal(warm_point(prob, spec, other) - other.w, warm_point(prob, spec, bare) - warm.w)


def test_mumps_workspace_changes_time_not_iterates(cfg, solved):
    """MUMPS's workspace (``mumps_mem_percent``: the solver's 100, IPOPT's own 1000, and 1, hardly
    more than MUMPS's own estimate) leaves every iterate as it is: the same solution to the bit."""
    from skatelib.pipeline.quadruped.problem.pushoff import MUMPS_MEM_PERCENT, solver_options

    assert solver_options(PushoffSpec(cfg, 0.3, 1))["mumps_mem_percent"] == MUMPS_MEM_PERCENT == 100
    for percent in (1000, 1):
        other = solve(PushoffSpec(cfg, 0.3, 1, ipopt=(("mumps_mem_percent", percent),)))
        assert other.iterations == solved.iterations
        np.testing.assert_array_equal(other.warm.w, solved.warm.w)


def test_a_solve_on_two_threads_is_the_serial_solve_to_the_bit(cfg, monkeypatch):
    """The stage derivatives on 2 threads (``OMP_NUM_THREADS``) give the serial solve's iterates exactly."""
    from skatelib.pipeline.quadruped.problem import pushoff

    runs, maps = [], []
    for threads in ("1", "2"):
        monkeypatch.setenv("OMP_NUM_THREADS", threads)
        monkeypatch.setattr(pushoff, "_PROBLEMS", {})  # built again, on these threads
        runs.append(solve(PushoffSpec(cfg, 0.3, 1)))
        hess = problem_for(cfg, 1).tr.nlp.options["hess_lag"]
        maps.append([f.name() for f in hess.find_functions() if f.class_name() == "ThreadMap"])
    assert maps[0] == [] and len(maps[1]) == 1 and maps[1][0].startswith("threadmap2_")
    serial, threaded = runs
    assert serial.success and threaded.iterations == serial.iterations
    for a, b in ((serial.warm.w, threaded.warm.w), (serial.warm.lam_g, threaded.warm.lam_g)):
        assert np.array_equal(a, b)


def test_solution_sits_in_every_named_bound(cfg, solved):
    """Each bound term names its channels; the solved knots (state, board position, control) read
    back by those names lie inside each term's box, e.g. the riding end's trunk height at the last knot."""
    prob = problem_for(cfg, 1)
    K = len(solved.t)
    by_name = {n: solved.state[:, i] for i, n in enumerate(STATE_NAMES)}
    by_name |= {"board_x": solved.board_pos[:, 0], "board_y": solved.board_pos[:, 1]}
    control = np.vstack([solved.control, np.zeros((1, len(CONTROL_NAMES)))])  # u_N, a placeholder held at 0
    by_name |= {n: control[:, i] for i, n in enumerate(CONTROL_NAMES)}
    names = list(by_name)
    for term in prob.bound_terms(0.0):
        lo, hi = term.bounds(K)
        cols = np.column_stack([by_name[n] for n in names[term.columns]])
        # IPOPT widens every variable bound by bound_relax_factor (1e-8) times max(1, |bound|) and
        # may return a point that far outside it (honor_original_bounds = no).
        slack_lo = 1e-7 + 1e-8 * np.maximum(1.0, np.abs(np.where(np.isfinite(lo), lo, 0.0)))
        slack_hi = 1e-7 + 1e-8 * np.maximum(1.0, np.abs(np.where(np.isfinite(hi), hi, 0.0)))
        assert np.all(cols >= lo - slack_lo) and np.all(cols <= hi + slack_hi), term.name
    end = next(t for t in prob.bound_terms(0.0) if t.name == "end_height")
    assert end.columns == slice(2, 3) and np.isfinite(end.bounds(K)[0][-1]).all()
    assert not np.isfinite(end.bounds(K)[0][:-1]).any()


def test_conflicting_bound_terms_are_named():
    lo, hi = variable_bounds([Box("a", slice(0, 2), -1.0, 1.0), Box("b", slice(1, 2), 0.5, 2.0)], 3, 2)
    assert lo.reshape(3, 2)[:, 1].tolist() == [0.5] * 3 and hi.reshape(3, 2)[:, 1].tolist() == [1.0] * 3
    with pytest.raises(ValueError, match="'c' leaves no value at knots \\[2\\]"):
        variable_bounds([Box("a", slice(0, 2), -1.0, 1.0), Box("c", slice(0, 1), 2.0, 3.0, knots=slice(2, 3))], 3, 2)
