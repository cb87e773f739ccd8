"""The library's /model as typed records (skatelib.library.model): written and read back to the same
attributes and datasets, one default per quantity, the format 1.1 migration in one place, and the
controller and the twin reading the same record."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from skatelib.control.params import SkateParams
from skatelib.library.errors import LibraryFormatError
from skatelib.library.model import PUBLIC_HANGER_MASS_KG, PUBLIC_PIVOT_RAD, PUBLIC_WHEEL_MASS_KG, HumanoidModel
from skatelib.library.model_io import (
    arrays,
    attributes,
    humanoid_attributes,
    read_humanoid_model,
    read_quadruped_model,
)
from skatelib.runtime import MotionLibrary
from skatelib.sim.figures import TwinFigures

LIBRARY = Path(__file__).resolve().parent / "data" / "tiny-reference.h5"
BOARD_1_2 = ("board_pivot_from_horizontal_rad", "board_roll_axis_height_m", "board_deck_mass_kg",
             "board_wheel_track_m", "board_wheel_load_margin", "board_rolling_coeff", "board_rolling_coeff_plan")


def test_a_record_writes_back_the_attributes_and_datasets_it_was_read_from():
    lib = MotionLibrary.open(LIBRARY)
    record = lib.quadruped_model
    assert attributes(record) == dict(lib.model)
    out = arrays(record)
    assert set(out) == set(lib.model_arrays)
    for k, v in out.items():
        assert np.array_equal(np.asarray(lib.model_arrays[k]).reshape(v.shape), v), k


def test_the_controller_and_the_twin_read_one_board():
    """A library of format 1.2 on: the controller's truck kinematics, roll axis, deck mass and wheel
    track are the twin's."""
    lib = MotionLibrary.open(LIBRARY)
    p, twin = SkateParams.from_library(lib), TwinFigures.from_library(lib)
    assert p.pivot_rad == twin.board.pivot_from_horizontal_rad
    assert p.deck_mass_kg == twin.board.deck_mass_kg
    assert p.wheel_track_m == twin.board.wheel_track_m
    assert math.isclose(p.roll_axis_depth_m, twin.board.deck_height_m - twin.board.wheel_radius_m)


def _format_1_1(lib: MotionLibrary, rake: float | None) -> dict:
    old = {k: v for k, v in lib.model.items() if k not in BOARD_1_2}
    if rake is not None:
        old["board_rake_front_rad"] = rake
    return old


@pytest.mark.parametrize("rake", [1.1904, None])
def test_a_format_1_1_model_is_the_linear_spring_for_the_controller_and_the_public_board_for_the_twin(rake):
    """The migration: the optimizer of a 1.1 library modelled Eq. (6)'s spring about the deck's top
    (the controller's model); the twin builds the board it rode on (the stored truck axis, else the
    public model's 45 degrees; its deck mass and wheels)."""
    lib = MotionLibrary.open(LIBRARY)
    record = read_quadruped_model(_format_1_1(lib, rake), lib.model_arrays)
    assert not record.board.modelled_trucks
    p = SkateParams.from_model(record)
    assert (p.pivot_rad, p.roll_axis_depth_m, p.deck_mass_kg, p.wheel_track_m) == (math.pi / 2, 0.0, 0.0, 0.0)
    twin = TwinFigures.from_record(record, lib.urdf)
    assert twin.board.pivot_from_horizontal_rad == (PUBLIC_PIVOT_RAD if rake is None else rake)
    expected_deck = record.board.mass_kg - 2 * PUBLIC_HANGER_MASS_KG - 4 * PUBLIC_WHEEL_MASS_KG
    assert twin.board.deck_mass_kg == pytest.approx(expected_deck)
    assert (twin.board.wheel_radius_m, twin.board.wheel_track_m) == (0.03, 0.22)
    weight = (record.robot_mass_kg + record.board.mass_kg) * record.gravity_mps2
    assert twin.board.rolling_friction_coeff == pytest.approx(record.board.rolling_friction_N / weight)


def test_a_missing_figure_names_the_file_and_the_attribute():
    lib = MotionLibrary.open(LIBRARY)
    del lib.model["board_mass_kg"]
    with pytest.raises(LibraryFormatError) as e:
        _ = lib.quadruped_model
    assert e.value.field == "/model/board_mass_kg" and e.value.path == LIBRARY
    with pytest.raises(LibraryFormatError, match="no humanoid model"):
        _ = MotionLibrary.open(LIBRARY).humanoid_model


def test_a_humanoid_record_reads_back_what_it_wrote():
    m = HumanoidModel(robot_mass_kg=58.0, gravity_mps2=9.81, com_height_m=0.8, foot_length_m=0.24, foot_width_m=0.14,
                      step_width_m=0.19, friction_mu=0.6, leg_min_m=0.5, leg_max_m=0.9, gpm_nodes=20,
                      gpm_solver="ipopt", motion="walk", source="HRP-2 figures")
    attrs = humanoid_attributes(m)
    assert read_humanoid_model(attrs) == m
    assert isinstance(read_humanoid_model(attrs).gpm_nodes, int)
