"""The line keeper (skatelib.control.steering) against a board that steers by Eq. (14) alone,
integrated finely here: a rolling board whose deck roll follows its reference with a lag. It
brings a lateral offset and a heading error back to the plan's line; negative controls: without it
the offset grows from the heading error, and with the loop's sign turned it diverges."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from skatelib.control.mpc import HorizonRef
from skatelib.control.params import SkateParams
from skatelib.control.steering import BoardPath, LineKeeper, SteeringGains
from skatelib.library.channels import I_BOARD_ROLL, NU, NX
from skatelib.runtime import MotionLibrary

DATA = Path(__file__).resolve().parent / "data"

K_BOARD_M = 0.245
ROLL_LAG_S = 0.15  # the deck's roll follows the MPC's reference with this time constant


@pytest.fixture(scope="module")
def params() -> SkateParams:
    p = SkateParams.from_library(MotionLibrary.open(DATA / "tiny-reference.h5"))
    return dataclasses.replace(p, k_board_m=K_BOARD_M)


def _ride(p: SkateParams, keeper_sign: float | None, y0: float = 0.05, psi0: float = 0.02, v: float = 0.8,
          seconds: float = 6.0) -> np.ndarray:
    """A board along +x at ``v``, started ``y0`` to the left of the plan's line heading ``psi0``
    off it; the keeper (None: none) at 30 Hz, the board at 1 kHz. Returns (lateral, heading) over time."""
    t_plan = np.array([0.0, 100.0])
    path = BoardPath(t_plan, np.array([[0.0, 0.0], [v * 100.0, 0.0]]), np.zeros(2))
    keeper = LineKeeper(path, p, SteeringGains())
    x, y, psi, roll, dt, out = 0.0, y0, psi0, 0.0, 1e-3, []
    for k in range(round(seconds / dt)):
        t = k * dt
        if keeper_sign is not None and k % 33 == 0:
            keeper.update(t, np.array([x, y]), psi, v, 33 * dt)
        target = 0.0 if keeper_sign is None else keeper_sign * keeper.roll_rad
        roll += (target - roll) * dt / ROLL_LAG_S
        psi += -v * math.sin(roll) / K_BOARD_M * dt  # Eq. (14)
        x, y = x + v * math.cos(psi) * dt, y + v * math.sin(psi) * dt
        out.append((y, psi))
    return np.array(out)


def test_the_keeper_brings_the_board_back_onto_the_plans_line(params):
    run = _ride(params, keeper_sign=1.0)
    assert abs(run[-1, 0]) < 0.002 and abs(run[-1, 1]) < 0.002, run[-1]
    assert np.max(np.abs(run[:, 0])) < 0.08  # no wide swing on the way back


def test_without_the_keeper_the_offset_grows_and_with_its_sign_turned_it_diverges(params):
    drift = _ride(params, keeper_sign=None)
    assert drift[-1, 0] > 0.05 + 0.8 * 0.02 * 5.0  # the heading error carries it away
    wrong = _ride(params, keeper_sign=-1.0)
    assert abs(wrong[-1, 0]) > 0.2


def test_the_keeper_is_bounded_and_idle_below_its_speed(params):
    g = SteeringGains()
    path = BoardPath(np.array([0.0, 10.0]), np.array([[0.0, 0.0], [10.0, 0.0]]), np.zeros(2))
    keeper = LineKeeper(path, params, g)
    for _ in range(100):
        keeper.update(1.0, np.array([1.0, 0.5]), 0.3, 1.0, 1 / 30)
    assert keeper.roll_rad == pytest.approx(g.max_roll_rad)  # far off the line: at its bound
    keeper = LineKeeper(path, params, g)
    keeper.update(1.0, np.array([1.0, 0.5]), 0.3, 1.0, 1 / 30)
    assert keeper.roll_rad == pytest.approx(g.max_roll_rate_radps / 30)  # and at its rate
    slow = LineKeeper(path, params, g)
    slow.update(1.0, np.array([1.0, 0.5]), 0.3, 0.1, 1 / 30)
    assert slow.roll_rad == 0.0 and not slow.active


def test_the_horizon_carries_the_roll_the_com_shift_and_the_heading(params):
    """A roll offset moves the MPC's roll reference, and the COM across the deck by the shift that
    holds the deck there (the trucks' torque balanced by the weight)."""
    path = BoardPath(np.array([0.0, 10.0]), np.array([[0.0, 0.0], [10.0, 0.0]]), np.zeros(2))
    keeper = LineKeeper(path, params, SteeringGains(max_roll_rate_radps=10.0))
    keeper.update(1.0, np.array([1.0, -0.01]), -0.01, 1.0, 1 / 30)  # right of the line, turned right
    assert keeper.roll_rad < 0.0  # roll left (its left edge down) to turn left, Eq. (14)
    assert keeper.shift_m > 0.0  # the COM to the left
    m_g_y = params.mass_kg * params.gravity_mps2 * keeper.shift_m
    assert m_g_y == pytest.approx(params.roll_torque(keeper.roll_rad, 0.0))
    n = 4
    h = HorizonRef(np.zeros((n, NX)), np.zeros((n, NU)), np.ones((n, 4), dtype=np.int8), np.ones(n, dtype=bool))
    s = keeper.steer(h)
    assert np.allclose(s.x_ref[:, I_BOARD_ROLL], keeper.roll_rad)
    assert np.allclose(s.x_ref[:, 5], -0.01)  # the robot's yaw turns with the deck's
    left = np.array([-np.sin(-0.01), np.cos(-0.01)])  # across the deck as it heads
    assert np.allclose(s.x_ref[:, 0:2], keeper.shift_m * left)
    assert np.all(h.x_ref == 0.0)  # the reference given is left as it was
