"""The board alone: the twin (a MuJoCo board of real joints, ``skatelib.sim``) against what the
optimizer's board model predicts (``pipeline/quadruped/model/board_statics.py``), each measured in its
own code, within 5 %: steering, roll under a lateral load, coasting deceleration, the load offset
at which a wheel lifts. Each check also fails against the board model as the paper's equations
read before it was corrected (the negative controls)."""

from __future__ import annotations

import dataclasses
import math

import pytest

pytest.importorskip("mujoco")

from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.model import board_statics as model
from skatelib.pipeline.quadruped.model.board import BoardModel
from skatelib.pipeline.quadruped.model.system import SkateSystem
from skatelib.pipeline.twin import twin_figures
from skatelib.sim import board_checks as twin

PUBLIC_PIVOT_RAD = 1.1904  # the public quadruped-skateboard model's truck axis, from the ground


def _setup(pivot_rad: float | None = None):
    cfg = load_config(None, QuadrupedConfig)
    if pivot_rad is not None:
        cfg = dataclasses.replace(cfg, board=dataclasses.replace(cfg.board, pivot_from_horizontal_rad=pivot_rad))
    system = SkateSystem.from_config(cfg)
    board = BoardModel.from_config(cfg.board, system.srb.mass_kg, system.gravity_mps2, cfg.stance.foot_y_m)
    return twin_figures(cfg), board, system.srb.mass_kg * system.gravity_mps2


@pytest.fixture(scope="module")
def default():
    return _setup()


@pytest.mark.parametrize("pivot_rad", [None, PUBLIC_PIVOT_RAD])
def test_steering_matches_eq_14(pivot_rad):
    """At 0.5 m/s with the deck held at 0.05 and 0.1 rad, the twin's yaw rate is Eq. (14)'s within
    5 %, for the default 45-degree trucks and the public model's steeper ones; read as the paper's
    gamma from the vertical (K = l cot(gamma) with gamma the angle from the ground, what the
    optimizer used before), the public truck's K_board is six times too large."""
    figures, board, _ = _setup(pivot_rad)
    for roll in (0.05, 0.1):
        s = twin.steering(figures, roll, 0.5)
        predicted = model.yaw_rate(board, roll, s.speed_mps)
        assert s.yaw_rate_radps == pytest.approx(predicted, rel=0.05), (roll, s)
    if pivot_rad is not None:
        old_k = board.l_front_m * math.tan(pivot_rad)
        assert abs(old_k / s.k_board_m(0.1) - 1.0) > 5.0


def test_roll_under_a_lateral_load(default):
    """The robot's weight pressing on the deck's top 3 and 6 cm off the centre line rolls the twin's
    deck as the model predicts (the physical roll axis at the axles, the trucks' kinematics, the
    deck's weight) within 5 %; about the deck's top with a linear spring (Eq. 6-8 as the paper
    writes them) the prediction is more than 5 % off."""
    figures, board, weight = default
    for y in (0.03, 0.06):
        measured = twin.static_roll(figures, weight, y)
        predicted = model.static_roll(board, weight, y)
        assert predicted is not None
        assert measured == pytest.approx(predicted, rel=0.05), y
        assert abs(-weight * y / board.roll_stiffness_Nm_per_rad / measured - 1.0) > 0.05


def test_coasting_deceleration(default):
    """Coasting from 1 m/s and from 0.2 m/s (for 0.5 s), bare and with the robot's mass on it, the
    twin slows down as the model's rolling resistance (proportional to the wheels' load, nearly
    independent of the speed) says within 5 %; a constant f_fri of the whole weight (Eq. 9b as
    written) is five times too much for the bare board."""
    figures, board, _ = default
    for payload in (0.0, figures.robot_mass_kg):
        for speed, duration in ((1.0, 1.0), (0.2, 0.5)):
            measured = twin.coast_deceleration(figures, payload, speed, duration)
            assert measured == pytest.approx(model.coast_deceleration(board, payload), rel=0.05), (payload, speed)
    constant = board.rolling_friction_nominal_N / board.mass_kg
    assert constant / twin.coast_deceleration(figures, 0.0) > 4.0


def test_a_wheel_lifts_where_the_wheel_load_limit_says(default):
    """The offset of the robot's weight on the deck at which a twin wheel lifts lies within 5 % of
    the model's wheel-load limit (margin 0); a model without the limit allows any offset."""
    figures, board, weight = default
    measured = twin.lifting_offset(figures, weight)
    assert measured == pytest.approx(model.lifting_offset(board, weight), rel=0.05)
    assert measured < board.deck_width_m / 2  # a limit inside the deck: without it any foothold passes


def test_the_calibration_case_survives(default):
    """K_B is calibrated to the paper's Fig. 5 (about 0.12 rad with the whole weight on one side's
    feet): in the twin that case keeps every wheel on the ground and settles within 5 % of 0.12 rad."""
    figures, _, weight = default
    y = 0.11  # the stance's feet
    assert y < twin.lifting_offset(figures, weight)
    assert -twin.static_roll(figures, weight, y) == pytest.approx(0.12, rel=0.05)


def test_a_library_of_the_old_board_model_is_refused(tmp_path):
    """A library whose /model has no truck pivot angle from the ground (the old steering reading:
    format 1.1's ``board_rake_front_rad``) is refused by the checks that rebuild its model, naming
    the attribute and what to do."""
    from pathlib import Path

    from skatelib.library.errors import LibraryFormatError
    from skatelib.pipeline.quadruped.kind import system_from_library
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(Path(__file__).resolve().parent / "data" / "tiny-reference.h5")
    for k in ("board_pivot_from_horizontal_rad", "board_roll_axis_height_m", "board_deck_mass_kg",
              "board_wheel_track_m", "board_wheel_load_margin", "board_rolling_coeff", "board_rolling_coeff_plan"):
        del lib.model[k]
    lib.model["board_rake_front_rad"] = 1.1904
    with pytest.raises(LibraryFormatError, match=r"old board model.*rebuild") as e:
        system_from_library(lib)
    assert "board_pivot_from_horizontal_rad" in str(e.value)
