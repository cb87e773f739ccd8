"""The humanoid's skate on its twin: the board under the board sole built by the quadruped's board
builder (a free deck held by friction alone, trucks on their pivot axes, wheels that roll), the
1.0 m/s skate ridden under the stabilizer as planned and under the default model errors (no fall,
the board within 5 % of its label when the push ends, no slip on the deck), and the negative
controls: without the stabilizer it falls, a doctored label fails the board's check, and a skate
library planned without a deck is refused."""

from __future__ import annotations

import numpy as np
import pytest
from skatelib.control.humanoid_stabilizer import StabilizerGains
from skatelib.library.errors import SkatelibError
from skatelib.proving.humanoid.loop import figures_for, run_entry
from skatelib.proving.humanoid.track import humanoid_jobs
from skatelib.proving.humanoid.verdict import BOARD_SPEED_TOL, SLIP_TOL_M, verdict
from skatelib.runtime import MotionLibrary
from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION, parse_humanoid_perturbation
from skatelib.sim.humanoid.plant import HumanoidPlant
from skatelib.sim.humanoid.robot import sole_geom
from skatelib.sim.rolling import WHEELS

mujoco = pytest.importorskip("mujoco")
KEY = "skate_v1.00"


@pytest.fixture(scope="module")
def skate(hrp2_skate_v100):
    """The shipped skate config's 1.0 m/s entry alone, as a library (tests/conftest.py)."""
    return hrp2_skate_v100


@pytest.fixture(scope="module")
def default_errors_run(skate):
    lib = MotionLibrary.open(skate)
    return run_entry(lib, KEY, parse_humanoid_perturbation(DEFAULT_HUMANOID_PERTURBATION))


def test_the_board_is_free_under_the_board_sole(skate):
    """The deck is a free body with its top under the board sole (1 mm), trucks and wheels on
    hinges, and nothing but contact joins it to the robot (no equality constraint)."""
    lib = MotionLibrary.open(skate)
    plant = HumanoidPlant(figures_for(lib, KEY))
    m, d = plant.m, plant.d
    assert m.neq == 0 and m.jnt_type[m.joint("deck_free").id] == mujoco.mjtJoint.mjJNT_FREE
    for name in ("truck_front", "truck_rear", *WHEELS):
        assert m.jnt_type[m.joint(name).id] == mujoco.mjtJoint.mjJNT_HINGE
    board = lib.humanoid_model.board
    assert board is not None
    g = m.geom(sole_geom(0)).id
    assert d.xpos[m.body("deck").id][2] == pytest.approx(board.deck_height_m, abs=1e-3)
    assert d.geom_xpos[g][2] - m.geom_size[g][2] == pytest.approx(board.deck_height_m, abs=1e-3)


def test_the_humanoid_board_rolls(skate):
    """The board alone (the same builder, the humanoid's figures), launched at 0.5 m/s on a floor:
    after 0.5 s each wheel's rim speed is the deck's within 1 % (rolling, not sliding) and the
    deck has lost the rolling resistance's c_rr g t of its speed (within 0.01 m/s; a 3.5 kg
    board's own load)."""
    from skatelib.sim import rolling
    from skatelib.sim.board import add_board
    from skatelib.sim.humanoid.figures import board_figures

    board = MotionLibrary.open(skate).humanoid_model.board
    assert board is not None
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.001
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], contype=1,
                            conaffinity=0)
    add_board(spec, board_figures(board), board.deck_mu)
    m = spec.compile()
    d = mujoco.MjData(m)
    res = rolling.RollingResistance(m, board.rolling_coeff)
    rolling.step(m, d, res, 200)  # settle on the wheels
    v0 = 0.5
    d.qvel[m.joint("deck_free").dofadr[0]] = v0
    for w in WHEELS:
        d.qvel[m.joint(w).dofadr[0]] = v0 / board.wheel_radius_m
    rolling.step(m, d, res, 500)
    deck_v = d.qvel[m.joint("deck_free").dofadr[0]]
    rims = np.array([d.qvel[m.joint(w).dofadr[0]] * board.wheel_radius_m for w in WHEELS])
    assert np.abs(rims / deck_v - 1.0).max() < 0.01
    assert deck_v == pytest.approx(v0 - board.rolling_coeff * 9.81 * 0.5, abs=0.01)


@pytest.mark.parametrize("errors", ["none", "default"])
def test_the_one_metre_per_second_skate_is_ridden(skate, errors, default_errors_run):
    """As planned and under the default errors, with the stabilizer: no fall, the board within 5 %
    of 1.0 m/s when the push ends, the soles' slip on the deck and the pushing sole's on the ground
    under 2 cm, the contact ZMP within 5 mm of the soles' polygon, nothing else failed."""
    lib = MotionLibrary.open(skate)
    run = run_entry(lib, KEY) if errors == "none" else default_errors_run
    v = verdict(run, 1.0)
    assert not v.fell and run.t[-1] > 4.9
    assert v.board_mps is not None and abs(v.board_mps - 1.0) <= BOARD_SPEED_TOL
    assert v.deck_slip_m < SLIP_TOL_M and v.push_slip_m < SLIP_TOL_M
    assert v.zmp_outside_m < 0.005
    assert not v.failures()


def test_a_doctored_label_fails_the_board_check(default_errors_run):
    """The same run judged against a label 10 % above 1.0 m/s fails on the board's speed."""
    failures = verdict(default_errors_run, 1.1).failures()
    assert any(f.startswith("board at") for f in failures), failures


def test_without_the_stabilizer_the_skate_falls(skate):
    """Negative control: under the default errors, the stabilizer off, the 1.0 m/s skate falls
    (in its stop, both soles on the board)."""
    lib = MotionLibrary.open(skate)
    off = run_entry(lib, KEY, parse_humanoid_perturbation(DEFAULT_HUMANOID_PERTURBATION),
                    StabilizerGains(enabled=False))
    v = verdict(off, 1.0)
    assert v.fell and off.fell_at is not None and off.fell_at > 3.0, (v.fell, off.fell_at)


def test_a_skate_library_without_its_board_is_refused(tmp_path, monkeypatch):
    """A skate library that stores no board (as every skate library written before the board: both
    soles planned on the ground) is refused by track with what to do; so is a skate config
    without its [board] table."""
    from skatelib.library.errors import ConfigError
    from skatelib.pipeline.build.contract import BuildOptions
    from skatelib.pipeline.build.orchestrate import build_library
    from skatelib.pipeline.config import CONFIG_DIR, load_config
    from skatelib.pipeline.humanoid import entries

    cfg = tmp_path / "skate.toml"
    cfg.write_text(f'extends = "{(CONFIG_DIR / "hrp2_skate.toml").as_posix()}"\n[sweep]\nvelocities_mps = [0.5]\n')
    monkeypatch.setattr(entries, "board_record", lambda config: None)
    out = tmp_path / "no_board.h5"
    assert not build_library(load_config(cfg), out, BuildOptions(jobs=1, cache=False)).failed
    assert MotionLibrary.open(out).humanoid_model.board is None
    with pytest.raises(SkatelibError, match="planned without a board"):
        humanoid_jobs(out, None, "")
    bare = tmp_path / "bare.toml"
    bare.write_text((CONFIG_DIR / "hrp2_skate.toml").read_text().split("[board]")[0].replace(
        'extends = "hrp2_walk.toml"', f'extends = "{(CONFIG_DIR / "hrp2_walk.toml").as_posix()}"')
        + '[sweep]\nmotion = "skate"\nvelocities_mps = [0.5]\n')
    with pytest.raises(ConfigError, match="board"):
        load_config(bare)


def test_the_soles_wrenches_are_their_contacts(skate):
    """The twin's truth takes each sole's force and centre of pressure from its foot's external
    wrench (MuJoCo's cfrc_ext): along the stabilized push and slide they are the sole's floor and
    deck contacts summed one by one (mj_contactForce); the same sum leaving one contact out does
    not match (the comparison sees a lost contact)."""
    from skatelib.control.humanoid_kinematics import HumanoidKinematics
    from skatelib.control.humanoid_reference import HumanoidReference
    from skatelib.control.humanoid_stabilizer import LipStabilizer
    from skatelib.sim.humanoid.figures import SOLE_THICKNESS_M

    lib = MotionLibrary.open(skate)
    f = figures_for(lib, KEY)
    plant = HumanoidPlant(f, parse_humanoid_perturbation(DEFAULT_HUMANOID_PERTURBATION))
    ref = HumanoidReference(lib[KEY], lib.humanoid_model)
    stab = LipStabilizer(HumanoidKinematics(lib.urdf, f.joint_names), 0.002)
    m, d = plant.m, plant.d
    frame, both, missed = np.zeros(6), 0, 0.0
    for _ in range(1500):
        r = plant.readings()
        s = ref.sample(r.t)
        plant.step(stab.tick(s, r.q, r.imu_quat_wxyz[[1, 2, 3, 0]], r.ft_force, r.ft_torque).q_target, 2)
        tr = plant.truth()
        wrenches = []  # (sole, force, moment about the world origin) of each sole's contact
        for k in range(d.ncon):
            c = d.contact[k]
            pair = (int(c.geom1), int(c.geom2))
            sole = [g for g in pair if g in plant.soles]
            if sole and {plant.floor, plant.deck_geom} & set(pair):
                mujoco.mj_contactForce(m, d, k, frame)
                R = c.frame.reshape(3, 3).T
                sign = 1.0 if pair[1] == sole[0] else -1.0  # the contact's force is on geom2
                fw = sign * (R @ frame[0:3])
                wrenches.append((plant.soles.index(sole[0]), fw, np.cross(c.pos, fw) + sign * (R @ frame[3:6])))
        force, moment = np.zeros((2, 3)), np.zeros((2, 3))
        for i, fw, mw in wrenches:
            force[i] += fw
            moment[i] += mw
        assert tr.sole_force == pytest.approx(force, abs=1e-9)
        for i in (0, 1):
            if force[i, 2] > 1.0:
                z = float(d.geom_xpos[plant.soles[i]][2]) - SOLE_THICKNESS_M / 2
                cop = np.array([(z * force[i, 0] - moment[i, 1]) / force[i, 2],
                                (moment[i, 0] + z * force[i, 1]) / force[i, 2]])
                assert tr.sole_zmp[i] == pytest.approx(cop, abs=1e-9)
        if wrenches:
            i, fw, _ = wrenches[0]
            missed = max(missed, float(np.abs(tr.sole_force[i] - (force[i] - fw)).max()))
        both += int((force[:, 2] > 1.0).all())
    assert both > 300 and missed > 1.0  # both soles loaded (452 ticks); one contact's loss seen (newtons)


def test_a_twin_without_its_force_sensors_is_refused(skate, monkeypatch):
    """The truth's wrenches need MuJoCo to compute the feet's external forces, which it does for
    the ankles' force sensors: a twin with its sensors disabled is refused, not read as weightless."""
    from skatelib.sim.humanoid import plant as humanoid_plant

    real = humanoid_plant.humanoid_spec

    def without_sensors(f):
        spec = real(f)
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_SENSOR
        return spec

    monkeypatch.setattr(humanoid_plant, "humanoid_spec", without_sensors)
    with pytest.raises(ValueError, match="ankle force sensors"):
        HumanoidPlant(figures_for(MotionLibrary.open(skate), KEY))
