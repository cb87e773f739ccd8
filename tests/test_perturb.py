"""Every ``--perturb`` key of either plant takes values in a stated range
(``skatelib.library.perturb.BOUNDS``): at its ends accepted, beyond them refused naming the key,
the value and the range. Before, ``mass=1e308`` ran (a speed of nan), ``noise=-1`` was taken as
no noise, ``rolling=-5`` as a board that pushes, and every change of ``inertia`` was refused (its
off-diagonal terms are negative); ``--perturb ''`` ran the plant as planned under the name ''."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from skatelib.library.perturb import BOUNDS, FACTOR, bounds_text
from skatelib.runtime import MotionLibrary

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
MODEL_KEYS = ("mass", "inertia", "board_mass", "kb", "bb", "rolling", "mu", "tanh", "com", "noise", "impulse",
              "impulse_t", "init")
TWIN_KEYS = ("mass", "mu", "kb", "bb", "rolling", "armature", "board_mass", "motor", "payload", "payload_x",
             "payload_y", "payload_z", "noise", "delay", "gyro_bias", "accel_bias", "imu_noise", "encoder_offset",
             "imu_tilt", "sensor_delay")


def _model_parser():
    pytest.importorskip("scipy")
    from skatelib.control.params import SkateParams
    from skatelib.proving.perturb import PerturbationError, parse_perturbation

    nominal = SkateParams.from_library(MotionLibrary.open(REFERENCE))
    return (lambda text: parse_perturbation(text, nominal)), PerturbationError


def _twin_parser():
    pytest.importorskip("mujoco")
    from skatelib.sim.errors import TwinPerturbationError, parse_twin_perturbation

    return (lambda text: parse_twin_perturbation(text, 0.6)), TwinPerturbationError


def _inside_and_beyond(key: str) -> tuple[list[str], list[str]]:
    """Items a key must take (its range's ends) and items it must refuse (just beyond them, and
    +-1e308); a factor as a percentage (a plain number is a value in kg, N m/rad... for most of the
    model plant's keys)."""
    bound = BOUNDS[key]
    span = bound.high - bound.low
    inside = [bound.high] + ([] if bound.low_open else [bound.low])
    beyond = [bound.high + 0.01 * span, bound.low - 0.01 * span] + ([bound.low] if bound.low_open else [])

    def item(v: float) -> str:
        return f"{key}={(v - 1) * 100!r}%" if bound.unit == FACTOR else f"{key}={v!r}"

    return [item(v) for v in inside], [item(v) for v in beyond] + [f"{key}=1e308", f"{key}=-1e308"]


@pytest.mark.parametrize("plant", ["model", "twin"])
def test_every_key_takes_its_range_and_refuses_beyond_it(plant):
    """Each key of the plant: its range's ends parse, values beyond them are refused with a message
    naming the key, the value and the range."""
    parse, error = _model_parser() if plant == "model" else _twin_parser()
    for key in MODEL_KEYS if plant == "model" else TWIN_KEYS:
        inside, beyond = _inside_and_beyond(key)
        for text in inside:
            parse(text)
        for text in beyond:
            with pytest.raises(error, match=f"'{text}': {key} would be .*; allowed: ") as e:
                parse(text)
            assert str(BOUNDS[key]) in str(e.value)


@pytest.mark.parametrize("plant", ["model", "twin"])
@pytest.mark.parametrize("text", ["noise=-1", "mass=1e308", "rolling=-500%", "mu=0", "noise=1e6"])
def test_the_reported_values_are_refused(plant, text):
    parse, error = _model_parser() if plant == "model" else _twin_parser()
    with pytest.raises(error, match="allowed"):
        parse(text)


def test_model_plant_absolute_values_are_judged_as_factors():
    """``mass=12`` [kg] is a factor 12 / nominal of the plan; ``rolling=-5`` [N] a negative one;
    ``inertia=2`` and ``inertia=+10%`` scale the trunk's inertia matrix (both were refused)."""
    parse, error = _model_parser()
    nominal, _ = parse("mass=+0%")
    assert parse("mass=12")[0].mass_kg == 12.0
    with pytest.raises(error, match="mass would be"):
        parse(f"mass={nominal.mass_kg * 10.5!r}")
    with pytest.raises(error, match="rolling would be -"):
        parse("rolling=-5")
    assert parse("rolling=-100%")[0].rolling_N == 0.0
    for text, factor in (("inertia=2", 2.0), ("inertia=+10%", 1.1)):
        np.testing.assert_allclose(parse(text)[0].inertia_kgm2, factor * nominal.inertia_kgm2)


def test_the_help_states_every_range():
    text = bounds_text(BOUNDS)
    for key, bound in BOUNDS.items():
        assert key in text and str(bound) in text
