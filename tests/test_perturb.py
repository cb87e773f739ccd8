"""Every ``--perturb`` key of either plant takes values in a stated range
(``skatelib.library.perturb.BOUNDS``): at its ends accepted, beyond them refused naming the key,
the value and the range. Before, ``mass=1e308`` ran (a speed of nan), ``noise=-1`` was taken as
no noise, ``rolling=-5`` as a board that pushes, and every change of ``inertia`` was refused (its
off-diagonal terms are negative); ``--perturb ''`` ran the plant as planned under the name ''."""

from __future__ import annotations

import math
import re
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
    from skatelib.sim.figures import TwinFigures

    planned = TwinFigures.from_library(MotionLibrary.open(REFERENCE))
    return (lambda text: parse_twin_perturbation(text, planned)), TwinPerturbationError


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


# A plain number of each key that scales a planned figure, in the unit of the model plant's key:
# (key, value, the model plant's field it sets).
ABSOLUTE = [("mass", 9.37, "mass_kg"), ("kb", 60.0, "kb_Nm_per_rad"), ("bb", 4.0, "bb_Nms_per_rad"),
            ("rolling", 2.0, "rolling_N"), ("board_mass", 3.0, "board_mass_kg")]


def _measured(plant, key: str) -> float:
    """``key``'s quantity as the compiled twin has it, in the model plant's unit: the robot's and
    the board's masses summed over their bodies, the deck's roll stiffness and damping from the two
    truck hinges (each K cos(lambda)^2 / 2), the rolling force at the twin's whole weight."""
    m, f = plant.m, plant.f
    cos2 = math.cos(f.board.pivot_from_horizontal_rad) ** 2
    hinges = [m.joint(n) for n in ("truck_front", "truck_rear")]
    return {"mass": lambda: m.body_subtreemass[plant.trunk],
            "board_mass": lambda: m.body_subtreemass[plant.deck],
            "kb": lambda: sum(m.jnt_stiffness[j.id] for j in hinges) / cos2,
            "bb": lambda: sum(m.dof_damping[j.dofadr[0]] for j in hinges) / cos2,
            "rolling": lambda: plant.rolling.coefficient * m.body_subtreemass[0] * -m.opt.gravity[2]}[key]()


@pytest.mark.parametrize(("key", "value", "field"), ABSOLUTE)
def test_a_plain_number_is_the_same_quantity_on_both_plants(key, value, field):
    """``KEY=NUMBER`` is an absolute value in the key's unit on both plants: the model plant's
    figure becomes it, and so does the twin's, measured on the compiled MuJoCo model (not a factor:
    ``mass=9.37`` is a 9.37 kg robot, not one 9.37 times as heavy)."""
    pytest.importorskip("mujoco")
    from skatelib.sim.plant import TwinPlant

    model_parse, _ = _model_parser()
    twin_parse, _ = _twin_parser()
    assert getattr(model_parse(f"{key}={value}")[0], field) == pytest.approx(value, rel=1e-12)
    plant = TwinPlant(_twin_figures(), twin_parse(f"{key}={value}"), compiled=False)
    assert _measured(plant, key) == pytest.approx(value, rel=1e-9)


def test_the_twins_planned_figures_are_the_model_plants():
    """What a plain number is divided by on the twin is the model plant's nominal figure of the same
    key, so that one number means one quantity (measured on the twin as planned)."""
    pytest.importorskip("mujoco")
    from skatelib.sim.errors import planned_figure
    from skatelib.sim.plant import TwinPlant

    model_parse, _ = _model_parser()
    nominal, _ = model_parse("mass=+0%")
    plant = TwinPlant(_twin_figures(), compiled=False)
    for key, _, field in ABSOLUTE:
        planned = planned_figure(key, plant.f)
        assert planned is not None
        assert planned[0] == pytest.approx(getattr(nominal, field), rel=1e-12) == pytest.approx(_measured(plant, key))
    np.testing.assert_allclose(plant.m.dof_armature[plant.dadr], planned_figure("armature", None)[0])


def test_relative_values_keep_their_meaning_on_the_twin():
    """A percentage is a factor of the planned figure as it always was, whether the twin's planned
    figures are given or its friction coefficient alone; the default set parses the same both ways."""
    pytest.importorskip("mujoco")
    from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION, parse_twin_perturbation

    planned = _twin_figures()
    text = "mass=+20%,kb=-30%,bb=+50%,rolling=+50%,board_mass=+10%,armature=+5%,motor=-10%,mu=-20%"
    for e in (parse_twin_perturbation(text, planned), parse_twin_perturbation(text, 0.6)):
        got = (e.mass_scale, e.kb_scale, e.bb_scale, e.rolling_scale, e.deck_mass_scale, e.armature_scale,
               e.motor_scale, e.floor_mu)
        np.testing.assert_allclose(got, (1.2, 0.7, 1.5, 1.5, 1.1, 1.05, 0.9, 0.48), rtol=1e-12)
    assert parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, planned) == \
        parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, 0.6)


def test_a_plain_number_without_the_planned_figures_is_refused_naming_its_unit():
    """Given only the friction coefficient, the twin cannot convert ``mass=9.37``: refused asking
    for a percentage and naming the unit; ``motor`` and ``armature``, whose planned figures are
    every library's, still convert; out of range, the message names the planned figure."""
    parse, error = _twin_parser()
    from skatelib.sim.errors import parse_twin_perturbation

    for key, value, _ in ABSOLUTE:
        with pytest.raises(error, match=rf"give {key} as a percentage .*\[(kg|N m/rad|N m s/rad|N)\]"):
            parse_twin_perturbation(f"{key}={value}", 0.6)
    assert parse_twin_perturbation("motor=0.9", 0.6).motor_scale == 0.9
    assert parse_twin_perturbation("armature=0.00153159", 0.6).armature_scale == pytest.approx(1.0, rel=1e-5)
    with pytest.raises(error, match=r"kb would be 0\.00932.*0\.8 N m/rad of the planned 85\.80"):
        parse("kb=0.8")  # a value the model plant refuses as well
    with pytest.raises(error, match=r"the factor scales the deck's 1\.874 kg"):
        parse("board_mass=0.4")


def _twin_figures():
    from skatelib.sim.figures import TwinFigures

    return TwinFigures.from_library(MotionLibrary.open(REFERENCE))


def test_an_impulse_is_refused_exactly_where_the_loop_would_never_apply_it():
    """``impulse_t`` is refused if and only if no plant step of the run would apply the impulse:
    the plant steps counted from the entry's length, the transfer and the riding, with the loop's
    rule (a step starting within half a step of ``impulse_t``); an impulse of 0 is never refused."""
    parse, error = _model_parser()
    from skatelib.control.mpc import MpcConfig
    from skatelib.control.reference import EntryReference
    from skatelib.control.settings import TrackSettings
    from skatelib.proving.perturb import impulse_checked

    lib = MotionLibrary.open(REFERENCE)
    entry, settings, dt = lib["v0.30_s1"], TrackSettings(), MpcConfig().dt
    plant, _ = parse("mass=+0%")
    ref = EntryReference(lib, entry, plant, settings)
    h = dt / settings.plant_substeps
    updates = round((float(entry.t[-1]) + settings.transfer_s + settings.ride_s) / dt)
    starts = [float(entry.t[0])]
    for _ in range(updates * settings.plant_substeps):  # as the loop steps its clock
        starts.append(starts[-1] + h)
    end = starts.pop()
    # a sweep across the run's end in eighths of a step, off the ties at half a step from a start
    for t_imp in [0.0, 1.0, *(float(t) for t in np.linspace(end - 3 * h, end + h, 33) + h / 64), 30.0]:
        applied = bool(np.any(np.abs(np.array(starts) - t_imp) < h / 2))
        _, dist = parse(f"impulse=20,impulse_t={t_imp!r}")
        if applied:
            impulse_checked(dist, ref, (dt, settings.plant_substeps))
        else:
            with pytest.raises(error, match=rf"impulse_t={t_imp:g}: the run ends at {end:.2f} s"):
                impulse_checked(dist, ref, (dt, settings.plant_substeps))
    impulse_checked(parse("impulse_t=30")[1], ref, (dt, settings.plant_substeps))  # no impulse, nothing to refuse


@pytest.mark.parametrize("ride", [[], ["--ride", "0:0.3"]])
def test_the_command_refuses_an_impulse_after_the_run_before_riding(ride):
    """``track --perturb impulse=20,impulse_t=30`` exits 2 naming ``impulse_t`` and the run's end
    (3.10 s: the 1.2 s entry, 0.4 s of transfer, 1.5 s of riding), an entry's run and a chained
    ride's alike, without riding (a run that never gets the push would pass)."""
    pytest.importorskip("scipy")
    from tests.helpers import run_cli

    entry = [] if ride else ["-e", "v0.30_s1"]
    run = run_cli(["track", str(REFERENCE), *entry, *ride, "-j", "1", "--perturb", "impulse=20,impulse_t=30"])
    assert run.returncode == 2, run.stdout + run.stderr
    assert re.search(r"impulse_t=30: the run (of v0\.30_s1 )?ends at 3\.10 s", " ".join(run.stderr.split())), run.stderr


@pytest.mark.parametrize("perturb", ["impulse=20,impulse_t=0.8", "mass=1.1"])
def test_a_fallen_bodys_legs_are_not_measured(perturb):
    """A run that falls (shoved off the board; a robot too light for its forces): the fall is the
    verdict's reason, and the stance legs' figures are those of the updates before it, not of
    inverse kinematics toward feet the fallen body is metres from (a stance joint 104 rad beyond its
    limit, many turns wound up, and a foot 426 mm beyond its leg's reach were reported). The last
    update before the fall may find the tipping body's joints well past their limits (0.6-1.1 rad
    here), but within a half turn, and its feet within a leg's length of where the legs reach."""
    pytest.importorskip("scipy")
    import skatelib

    (r,) = skatelib.track(REFERENCE, ["v0.30_s1"], perturb=perturb, jobs=1, progress=False)
    assert r.fall and not r.passed
    beyond = re.search(r"a stance joint ([0-9.]+) rad beyond", r.reasons)
    assert beyond is None or float(beyond.group(1)) < math.pi, r.reasons
    reach = re.search(r"a stance foot ([0-9]+) mm beyond", r.reasons)
    assert reach is None or float(reach.group(1)) < 200, r.reasons
