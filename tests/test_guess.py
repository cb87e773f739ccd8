"""The cold initial guess of the push-off NLP ends where the NLP's last knot is bounded to be: in the
riding stance, inside every bound and end row, its joints moved by its own joint speeds. A guess
outside those narrow end bands has IPOPT's first steps cut to a few per cent by the fraction to the
boundary (docs/design-notes.md); the doctored guesses below show each check failing. A warm start
moves along the guesses to its new target."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest
from skatelib.library.channels import NU, S_BOARD_V, S_Q, U_QD
from skatelib.pipeline.ocp.shooting import window_stage
from skatelib.pipeline.quadruped.problem.knots import N_PARAMS, NXA
from skatelib.pipeline.quadruped.problem.problem import transition_window
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, problem_for, warm_point

END_ROWS = ("riding_end", "final_speed", "push_foot")


@pytest.fixture(scope="module", params=["start-up", "transition"])
def case(request, cfg):
    """A one-stride start-up to 0.3 m/s, and a transition from 0.5 to 0.8 m/s: problem, start and
    target speeds, and the cold guess as knots (K, NXA + NU)."""
    if request.param == "start-up":
        prob, v0, v = problem_for(cfg, 1), 0.0, 0.3
    else:
        v0, v = 0.5, 0.8
        prob = problem_for(cfg, 1, transition_window(cfg, v0, v, 1.0))
    return prob, v0, v, prob.initial_guess(v0, v, "ramp").reshape(len(prob.schedule.t), -1)


def bound_violations(prob, v0: float, knots: np.ndarray) -> dict[str, float]:
    """Per bound term, the largest amount by which ``knots`` lies outside its box (0 inside)."""
    K = len(knots)
    out = {}
    for term in prob.bound_terms(v0):
        lo, hi = term.bounds(K)
        cols = knots[:, term.columns]
        out[term.name] = float(np.max(np.maximum(lo - cols, cols - hi), initial=0.0))
    return out


def end_row_violations(prob, v0: float, v: float, knots: np.ndarray) -> dict[str, float]:
    """Per end term (:data:`END_ROWS`), how far the last interval's window lies outside its rows'
    bounds, each term's rows evaluated on their own (not through the assembled NLP)."""
    N = prob.schedule.n_intervals
    z, p, stage = window_stage((NXA, NU, N_PARAMS), prob.config.optimization.dt_s)
    P = prob.parameters(v0, v).reshape(N, N_PARAMS)
    window = np.concatenate([knots[N - 1], knots[N]])
    out = {}
    for term in prob.constraints:
        if term.name in END_ROWS:
            rows = np.asarray(ca.Function("rows", [z, p], [term.rows(stage)])(window, P[N - 1])).reshape(-1)
            lo, hi = (b[N - 1] for b in term.bounds(N))
            out[term.name] = float(np.max(np.maximum(lo - rows, rows - hi), initial=0.0))
    return out


def test_the_guess_lies_inside_every_bound(case):
    """Joint limits (with the plan's margin), the end's height, attitude, joints and joint speeds:
    every variable bound of the NLP holds at the guess, at every knot."""
    prob, v0, _, knots = case
    assert bound_violations(prob, v0, knots) == dict.fromkeys(bound_violations(prob, v0, knots), 0.0)


def test_the_guess_ends_on_the_end_rows(case):
    """The riding end's centre of mass over the deck, the final speeds and the push foot's clearance
    hold at the guess's last interval."""
    prob, v0, v, knots = case
    assert end_row_violations(prob, v0, v, knots) == dict.fromkeys(END_ROWS, 0.0)


def test_the_guess_joint_speeds_move_its_joints(case):
    """q_{k+1} = q_k + dt qd_k, the transcription's joint kinematics integrated exactly (the speeds
    are held over an interval)."""
    prob, _, _, knots = case
    dt = np.diff(prob.schedule.t)[:, None]
    q, qd = knots[:, S_Q], knots[:-1, NXA + U_QD.start:NXA + U_QD.stop]
    np.testing.assert_allclose(q[1:], q[:-1] + dt * qd, rtol=0, atol=1e-12)


def test_each_check_fails_on_a_doctored_guess(case):
    """Negative controls: the deck legs left in the four-leg stance at the end (the end's joint
    band), the trunk not moved over the deck (the riding end's rows), a joint moved without its
    speed."""
    prob, v0, v, knots = case
    legs = [i for i in range(4) if i != prob.system.push_index]
    stood = knots.copy()
    for i in legs:
        stood[-2:, S_Q.start + 3 * i:S_Q.start + 3 * i + 3] = prob.system.stance.q_board[3 * i:3 * i + 3]
    assert bound_violations(prob, v0, stood)["end_joints"] > 0.1
    behind = knots.copy()
    behind[-1, 0] -= 0.05
    assert end_row_violations(prob, v0, v, behind)["riding_end"] > 0.03
    jolted = knots.copy()
    jolted[5, S_Q.start] += 0.01
    dt = np.diff(prob.schedule.t)[:, None]
    q, qd = jolted[:, S_Q], jolted[:-1, NXA + U_QD.start:NXA + U_QD.stop]
    assert np.max(np.abs(q[1:] - q[:-1] - dt * qd)) > 0.009


def test_a_warm_start_is_moved_along_the_guesses(cfg, pushoff_0p3):
    """With ``warm_predictor`` the warm start of the 0.3 m/s solution towards 0.4 m/s starts from the
    solution plus the change of the cold guess: its board ends 0.1 m/s faster, its first knot is
    still the start state; without, it is the solution itself. The solution records its speeds."""
    warm = pushoff_0p3.warm
    assert (warm.from_velocity_mps, warm.target_velocity_mps) == (0.0, 0.3)
    assert cfg.optimization.warm_predictor
    prob = problem_for(cfg, 1)
    K = len(prob.schedule.t)
    moved = warm_point(prob, PushoffSpec(cfg, 0.4, 1, warm=warm)).reshape(K, -1)
    before = warm.w.reshape(K, -1)
    np.testing.assert_allclose(moved[-1, S_BOARD_V.start] - before[-1, S_BOARD_V.start], 0.1, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(moved[0, :NXA], prob.start_state(0.0))
    off = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, warm_predictor=False))
    assert warm_point(prob, PushoffSpec(off, 0.4, 1, warm=warm)) is warm.w
