"""The cold initial guess of the push-off NLP ends where the NLP's last knot is bounded to be: in the
riding stance, inside every bound and end row, its joints moved by its own joint speeds. A guess
outside those narrow end bands has IPOPT's first steps cut to a few per cent by the fraction to the
boundary (docs/design-notes.md); the doctored guesses below show each check failing."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from skatelib.library.channels import NU, S_Q
from skatelib.pipeline.ocp.shooting import window_stage
from skatelib.pipeline.quadruped.problem.knots import N_PARAMS, NXA
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, problem_for

END_ROWS = ("riding_end", "final_speed", "push_foot")


# (start speed, target speed, strides): start-ups slow and fast, a speed-up, a brake and a stop
CELLS = [(0.0, 0.3, 1), (0.0, 1.0, 2), (0.5, 0.8, 1), (1.0, 0.5, 2), (0.8, 0.0, 1)]


@pytest.fixture(scope="module", params=CELLS, ids=lambda c: f"{c[0]}-{c[1]}x{c[2]}")
def case(request, cfg):
    """A problem of the default config, its start and target speeds, and its cold guess as knots
    (K, NXA + NU)."""
    v0, v, n = request.param
    prob = problem_for(cfg, n, PushoffSpec(cfg, v, n, from_velocity_mps=v0).window)
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


def term_rows(prob, v0: float, v: float, knots: np.ndarray, name: str, k: int) -> np.ndarray:
    """The rows of constraint term ``name`` on interval ``k``'s window of ``knots``, the term
    evaluated on its own (not through the assembled NLP)."""
    N = prob.schedule.n_intervals
    z, p, stage = window_stage((NXA, NU, N_PARAMS), prob.config.optimization.dt_s)
    term = next(t for t in prob.constraints if t.name == name)
    P = prob.parameters(v0, v).reshape(N, N_PARAMS)
    rows = ca.Function("rows", [z, p], [term.rows(stage)])(np.concatenate([knots[k], knots[k + 1]]), P[k])
    return np.asarray(rows).reshape(-1)


def end_row_violations(prob, v0: float, v: float, knots: np.ndarray) -> dict[str, float]:
    """Per end term (:data:`END_ROWS`), how far the last interval's rows lie outside their bounds."""
    N = prob.schedule.n_intervals
    out = {}
    for term in prob.constraints:
        if term.name in END_ROWS:
            rows = term_rows(prob, v0, v, knots, term.name, N - 1)
            lo, hi = (b[N - 1] for b in term.bounds(N))
            out[term.name] = float(np.max(np.maximum(lo - rows, rows - hi), initial=0.0))
    return out


def joint_defects(prob, v0: float, v: float, knots: np.ndarray) -> np.ndarray:
    """The largest joint-angle row of the multiple-shooting defect (the transcription's own
    integrator from x_k, u_k against x_{k+1}) per interval [rad]."""
    return np.array([np.max(np.abs(term_rows(prob, v0, v, knots, "dynamics", k)[S_Q]))
                     for k in range(prob.schedule.n_intervals)])


def test_the_guess_lies_inside_every_bound(case):
    """Joint limits (with the plan's margin), the end's height, attitude, joints and joint speeds:
    every variable bound of the NLP holds at the guess, at every knot."""
    prob, v0, _, knots = case
    violations = bound_violations(prob, v0, knots)
    assert violations == dict.fromkeys(violations, 0.0)


def test_the_guess_ends_on_the_end_rows(case):
    """The riding end's centre of mass over the deck, the final speeds and the push foot's clearance
    hold at the guess's last interval."""
    prob, v0, v, knots = case
    assert end_row_violations(prob, v0, v, knots) == dict.fromkeys(END_ROWS, 0.0)


def test_the_guess_joint_speeds_move_its_joints(case):
    """The transcription's dynamics carry every joint of the guess from knot to knot: the defect's
    joint rows vanish on every interval."""
    prob, v0, v, knots = case
    assert np.max(joint_defects(prob, v0, v, knots)) < 1e-12


def test_each_check_fails_on_a_doctored_guess(case):
    """Negative controls: the deck legs left in the four-leg stance at the end (the end's joint
    band), the trunk not moved over the deck (the riding end's rows), a joint moved without its
    speed (the defect on the intervals before and after it)."""
    prob, v0, v, knots = case
    stood = knots.copy()
    for i in (i for i in range(4) if i != prob.system.push_index):
        stood[-2:, S_Q.start + 3 * i:S_Q.start + 3 * i + 3] = prob.system.stance.q_board[3 * i:3 * i + 3]
    assert bound_violations(prob, v0, stood)["end_joints"] > 0.1
    behind = knots.copy()
    behind[-1, 0] -= 0.05
    assert end_row_violations(prob, v0, v, behind)["riding_end"] > 0.03
    jolted = knots.copy()
    jolted[5, S_Q.start] += 0.01
    defects = joint_defects(prob, v0, v, jolted)
    assert defects[4] > 0.009 and defects[5] > 0.009
