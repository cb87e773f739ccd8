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
from skatelib.sim.scene import NOSLIP_ITERATIONS, set_options, twin_model  # noqa: E402
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


def _foot_creep_m(f, share: float, noslip: int) -> float:
    """How far a foot of the twin's radius and friction, on the floor under a quarter of the
    robot's weight, moves in 10 s (after 1 s of settling) under a constant sideways force of
    ``share`` of its friction cone, with the twin's options and ``noslip`` no-slip iterations."""
    spec = mujoco.MjSpec()
    set_options(spec, f.gravity_mps2)
    spec.option.noslip_iterations = noslip
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], friction=[f.friction_mu, 0, 0])
    foot = spec.worldbody.add_body(name="foot", pos=[0, 0, f.foot_radius_m])
    for axis in ([1, 0, 0], [0, 1, 0], [0, 0, 1]):
        foot.add_joint(type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
    weight_N = f.robot_mass_kg * f.gravity_mps2 / 4
    foot.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[f.foot_radius_m, 0, 0],
                  mass=f.robot_mass_kg / 4, friction=[f.friction_mu, 0.005, 0.0001])
    m = spec.compile()
    d = mujoco.MjData(m)
    body = m.body("foot").id
    x = []
    for k in range(11_000):
        d.xfrc_applied[body, 1] = share * f.friction_mu * weight_N if k >= 1000 else 0.0
        mujoco.mj_step(m, d)
        if k in (999, 10_999):
            x.append(d.xpos[body].copy())
    return float(np.linalg.norm(x[1][:2] - x[0][:2]))


@pytest.mark.parametrize("share", [0.1, 0.3, 0.6])
def test_a_foot_inside_its_friction_cone_does_not_creep(built, share):
    """A foot pushed sideways with less force than its friction cone holds stays put, as Coulomb
    says: with the twin's options it moves less than 0.05 mm in 10 s at 10, 30 and 60 % of the
    cone. Negative control: without the no-slip pass MuJoCo's soft friction lets it creep, at a
    speed proportional to the force (more than 0.3 mm at 10 % of the cone, 3x more at 30 %)."""
    _, _, f, _ = built
    assert NOSLIP_ITERATIONS > 0
    assert _foot_creep_m(f, share, NOSLIP_ITERATIONS) < 5e-5
    soft = _foot_creep_m(f, share, 0)
    assert soft > 3e-4 * share / 0.1, soft


def test_a_foot_pushed_past_its_friction_cone_slides_as_coulomb_says(built):
    """The no-slip pass holds only what friction can hold: a foot pushed sideways with 1.2 times
    what its cone holds slides with Coulomb's acceleration, (1.2 - 1) mu g, over 10 s within 0.1 %."""
    _, _, f, _ = built
    analytic_m = 0.5 * 0.2 * f.friction_mu * f.gravity_mps2 * 10.0**2
    assert _foot_creep_m(f, 1.2, NOSLIP_ITERATIONS) == pytest.approx(analytic_m, rel=1e-3)


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


def _plain_contacts(p) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...], np.ndarray, np.ndarray]:
    """What the plant reads of its contacts, by a plain loop over every contact: each foot's touch
    code, contact point and load, the other geoms on the floor, the wheels' loads and the floor's
    force on them."""
    from skatelib.sim.contacts import ON_DECK, ON_FLOOR

    m, d = p.m, p.d
    touch, points, loads = np.zeros(4, dtype=np.int8), np.full((3, 4), np.nan), np.zeros(4)
    wheel_loads, wheel_force, others = np.zeros(4), np.zeros(3), set()
    f6 = np.zeros(6)
    for k in range(d.ncon):
        c = d.contact[k]
        pair = {int(c.geom1), int(c.geom2)}
        mujoco.mj_contactForce(m, d, k, f6)
        for i, g in enumerate(p.feet):
            if g in pair:
                touch[i] = ON_DECK if p.deck_geom in pair else ON_FLOOR
                points[:, i] = c.pos
                loads[i] += f6[0]
        if p.floor in pair:
            other = (pair - {p.floor}).pop()
            if other in p.wheels:
                wheel_loads[list(p.wheels).index(other)] += f6[0]
                on_other = c.frame.reshape(3, 3).T @ f6[0:3] * (1 if int(c.geom2) == other else -1)
                wheel_force += on_other
            elif other not in p.feet:
                others.add(m.geom(other).name or f"geom {other} of body {m.body(m.geom_bodyid[other]).name}")
    return touch, points, loads, tuple(sorted(others)), wheel_loads, wheel_force


def test_the_plants_contact_reads_against_a_plain_loop(built):
    """The plant's state reads its contacts from MuJoCo's arrays, and its first rolling torque after
    a state reads the loads that state read: against a plain loop over every contact, over 0.6 s
    of a robot collapsing on its board with its motors off (feet on the deck, wheels on the floor,
    the trunk and legs landing on the deck and the floor), and against a twin stepped without
    reading its state in between, to the bit, the contacts computed again now and then (a shift by
    nothing: ``mj_forward``). Negative controls: the loads that state hands to the next step
    doubled, or the contacts computed again behind the plant's back, the twins part."""
    from skatelib.control import feedback
    from skatelib.sim import contacts
    from skatelib.sim.plant import TwinPlant

    # the controller reads the touch codes as its own
    assert (contacts.ON_DECK, contacts.ON_FLOOR) == (feedback.ON_DECK, feedback.ON_FLOOR)
    _, _, f, _ = built

    def plant() -> TwinPlant:
        p = TwinPlant(f)
        mujoco.mj_resetDataKeyframe(p.m, p.d, p.m.key("stance").id)
        mujoco.mj_forward(p.m, p.d)
        return p

    a, b, c, stale = plant(), plant(), plant(), plant()
    zero = np.zeros(len(JOINTS))
    seen_others, parted, stale_parted = set(), False, False
    for k in range(300):
        st = a.state()
        c.state()
        c._wheel_loads = 2.0 * c._wheel_loads
        stale.state()
        touch, points, loads, others, wheel_loads, wheel_force = _plain_contacts(a)
        assert np.array_equal(st.foot_touch, touch)
        on = touch > 0
        assert np.array_equal(st.contact_points[:, on], points[:, on])
        assert np.array_equal(st.foot_load_N, loads) and st.floor_touches == others
        assert np.array_equal(st.wheel_load_N, wheel_loads)
        assert np.allclose(st.wheel_force_N, wheel_force, rtol=1e-12, atol=1e-9)
        seen_others |= set(others)
        if k % 50 == 25:  # the contacts computed again: the loads the state read are dropped
            for p in (a, b):
                p.shift_robot(0.0)
            mujoco.mj_forward(stale.m, stale.d)  # behind the plant's back: the stale loads stay
        for p in (a, b, c, stale):
            p.step(zero, 2)
        assert np.array_equal(a.d.qpos, b.d.qpos) and np.array_equal(a.d.qvel, b.d.qvel)
        parted |= not np.array_equal(a.d.qvel, c.d.qvel)
        stale_parted |= not np.array_equal(a.d.qvel, stale.d.qvel)
    assert seen_others, "the collapse put nothing but feet and wheels on the floor: the check saw no stray contact"
    assert parted and stale_parted
