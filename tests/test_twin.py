"""The physical twin (``skatelib.sim``) built from a config's figures: the same masses and limits as
the optimizer's model, a robot that stands still on a board at rest, and ``skatelib model --twin``
writing a model MuJoCo loads."""

from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from skatelib.pipeline.config import load_config  # noqa: E402
from skatelib.pipeline.quadruped.config import QuadrupedConfig  # noqa: E402
from skatelib.pipeline.quadruped.model.system import SkateSystem  # noqa: E402
from skatelib.pipeline.twin import twin_figures  # noqa: E402
from skatelib.sim.robot import JOINTS  # noqa: E402
from skatelib.sim.rolling import WHEELS  # noqa: E402
from skatelib.sim.scene import twin_model  # noqa: E402
from skatelib.sim.stand import StandController  # noqa: E402

from tests.helpers import CLI  # noqa: E402


@pytest.fixture(scope="module")
def built():
    cfg = load_config(None, QuadrupedConfig)
    system = SkateSystem.from_config(cfg)
    f = twin_figures(cfg)
    return cfg, system, f, twin_model(f)


def test_the_twin_has_the_models_masses_and_limits(built):
    """Robot and board weigh what the optimizer's model says (pinocchio's sum of the URDF, the
    board's mass), every leg joint has a motor limited to the torque limit, and the trunk floats."""
    cfg, system, _, m = built
    assert m.body_subtreemass[0] == pytest.approx(system.srb.mass_kg + system.board.mass_kg, rel=1e-9)
    assert m.body_subtreemass[m.body("trunk").id] == pytest.approx(system.srb.mass_kg, rel=1e-9)
    legs = [m.actuator(n).id for n in JOINTS]
    assert np.allclose(m.actuator_ctrlrange[legs], [-cfg.robot.torque_limit_Nm, cfg.robot.torque_limit_Nm])
    assert m.jnt_type[m.joint("trunk_free").id] == mujoco.mjtJoint.mjJNT_FREE
    # 12 leg motors, then one rolling-resistance torque per wheel
    assert [m.actuator(i).name for i in range(m.nu)] == [*JOINTS, *(f"rolling_{w}" for w in WHEELS)]


def test_standing_on_the_deck_stays_put(built):
    """The robot standing on the deck at rest (joint PD and its weight's torques) stays put over
    10 s after a second of settling: trunk and deck drift less than 1 mm, the deck's roll creeps
    less than 1 mrad; the feet stay on the deck. Negative control: without the weight's torques the
    trunk sags by more than 3 mm (the joints' PD alone holds the weight)."""
    _, _, f, m = built

    def run() -> tuple[np.ndarray, np.ndarray, float, int]:
        d = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, d, 0)
        ctl = StandController(m, f.robot_mass_kg, f.gravity_mps2)
        trunk, deck = m.body("trunk").id, m.body("deck").id
        out = []
        for k in range(11_000):
            ctl(d)
            mujoco.mj_step(m, d)
            if k in (999, 10_999):
                R = d.xmat[deck].reshape(3, 3)
                out.append((d.xpos[trunk].copy(), d.xpos[deck].copy(), np.arctan2(R[2, 1], R[2, 2])))
        names = [m.geom(d.contact[i].geom1).name + m.geom(d.contact[i].geom2).name for i in range(d.ncon)]
        feet = sum("foot" in n and "deck" in n for n in names)
        (t0, b0, r0), (t1, b1, r1) = out
        return t1 - t0, b1 - b0, r1 - r0, feet

    dt, db, dr, feet = run()
    assert np.linalg.norm(dt) < 1e-3 and np.linalg.norm(db) < 1e-3 and abs(dr) < 1e-3, (dt, db, dr)
    assert feet >= 4
    d0 = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d0, 0)
    mujoco.mj_forward(m, d0)
    height0 = d0.xpos[m.body("trunk").id][2]
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    ctl = StandController(m, 0.0, f.gravity_mps2)
    for _ in range(2000):
        ctl(d)
        mujoco.mj_step(m, d)
    assert height0 - d.xpos[m.body("trunk").id][2] > 0.003


def test_model_twin_writes_a_loadable_mjcf(tmp_path):
    """`skatelib model --twin OUT.xml` writes MJCF that MuJoCo compiles to the same model as the
    builder's; a second file where the first stands is refused unless it is MJCF."""
    out = tmp_path / "twin.xml"
    env = {**os.environ, "COLUMNS": "200"}
    r = subprocess.run([*CLI, "model", "--twin", str(out)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nu == 16 and m.body("deck").id > 0 and m.joint("truck_front").id > 0
    other = tmp_path / "notes.txt"
    other.write_text("my notes")
    r = subprocess.run([*CLI, "model", "--twin", str(other)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2 and "not a MuJoCo model" in r.stderr and other.read_text() == "my notes"


def test_deck_mass_motor_strength_and_a_shove(built):
    """``board_mass`` scales the deck's mass and inertia, ``motor`` the torque each command
    delivers (the actuators' gear); a shove (``TwinPlant.push`` over one whole-body tick) changes
    the momentum of robot and board along the deck by its impulse (the impulse-momentum theorem,
    within 3 %; the wheels roll freely that way), and no push changes it by less than 1 % of it."""
    from skatelib.sim.errors import parse_twin_perturbation
    from skatelib.sim.plant import TwinPlant

    _, _, f, _ = built
    plain = TwinPlant(f)
    changed = TwinPlant(f, parse_twin_perturbation("board_mass=+20%,motor=-10%", 0.6))
    deck = plain.m.body("deck").id
    assert changed.m.body_mass[deck] == pytest.approx(1.2 * plain.m.body_mass[deck])
    assert np.allclose(changed.m.body_inertia[deck], 1.2 * plain.m.body_inertia[deck])
    trunk = plain.m.body("trunk").id
    assert changed.m.body_mass[trunk] == pytest.approx(plain.m.body_mass[trunk])
    legs = plain.robot_actuators
    assert np.allclose(changed.m.actuator_gear[legs, 0], 0.9) and np.allclose(plain.m.actuator_gear[legs, 0], 1.0)

    def momentum_change(impulse_Ns: float) -> float:
        p = TwinPlant(f)
        mujoco.mj_resetDataKeyframe(p.m, p.d, p.m.key("stance").id)
        mujoco.mj_forward(p.m, p.d)
        before = p.state()
        tick = 2 * p.timestep_s
        p.push(np.array([impulse_Ns / tick, 0.0, 0.0]))
        p.step(np.zeros(12), 2)
        p.push(np.zeros(3))
        mujoco.mj_forward(p.m, p.d)  # the velocities after the last step (state() reads them one step late)
        after = p.state()
        return float(after.system_mass_kg * (after.system_v[0] - before.system_v[0]))

    assert momentum_change(1.0) == pytest.approx(1.0, rel=0.03)
    assert abs(momentum_change(0.0)) < 0.01
