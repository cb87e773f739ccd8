"""The lifted push-off NLP that ``make bench`` hands to fatrop (benchmarks/fatrop.py) is the same
problem as the production NLP: at the production optimum it has the same objective and every row
holds; a point off the dynamics breaks its gap-closing rows."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.problem import pushoff

from benchmarks.fatrop import lift
from tests.helpers import TINY


@pytest.fixture(scope="module")
def solved(pushoff_0p3):
    """The 0.3 m/s one-stride push-off of tests/configs/tiny.toml (the session's solve) and its config."""
    cfg = load_config(TINY)
    cfg = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))
    return cfg, pushoff_0p3


def _evaluate(lifted, w):
    fg = ca.Function("fg", [lifted.nlp["x"]], [lifted.nlp["f"], lifted.nlp["g"]])
    f, g = (np.asarray(v).ravel() for v in fg(w))
    b = lifted.bounds
    viol = max(np.max(b["lbg"] - g, initial=0), np.max(g - b["ubg"], initial=0),
               np.max(b["lbx"] - w, initial=0), np.max(w - b["ubx"], initial=0))
    return float(f[0]), float(viol)


def test_lifted_nlp_is_the_production_problem(solved):
    cfg, r = solved
    lifted = lift(pushoff.problem_for(cfg, 1), 0.3)
    knots = np.vstack([np.hstack([r.state, r.board_pos[:, :2], np.vstack([r.control, np.zeros(24)])])])
    w = lifted.point(knots)
    assert np.array_equal(lifted.knots(w), knots)
    f, viol = _evaluate(lifted, w)
    assert f == pytest.approx(r.objective, rel=1e-9)
    assert viol < 1e-6  # IPOPT's tolerance
    s = lifted.structure
    assert len(w) == sum(s["nx"]) + sum(s["nu"]) and lifted.nlp["g"].numel() == sum(s["nx"][1:]) + sum(s["ng"])
    doctored = knots.copy()
    doctored[10, 6] += 0.05  # COM velocity jumps at one knot
    assert _evaluate(lifted, lifted.point(doctored))[1] > 1e-3
