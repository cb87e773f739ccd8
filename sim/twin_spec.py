"""The quadruped twin's MuJoCo model: the scene (:mod:`skatelib.sim.scene`) with a model-error set
applied (links' masses, motors, trucks, friction, a payload) at the twin's timestep."""

from __future__ import annotations

from typing import TYPE_CHECKING

from skatelib.sim.errors import TwinErrors
from skatelib.sim.figures import TwinFigures
from skatelib.sim.robot import JOINTS, LEGS
from skatelib.sim.scene import scene_spec

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

TIMESTEP_S = 1.0 / 1020.0  # two steps per 510 Hz whole-body tick, 34 per 30 Hz MPC update


def twin_spec(f: TwinFigures, errors: TwinErrors) -> mujoco.MjSpec:
    """The scene with ``errors`` applied (links, floor, trucks, wheels, rotors, a payload)."""
    import mujoco

    spec = scene_spec(f)
    spec.option.timestep = TIMESTEP_S
    robot_bodies = {b.name for b in spec.body("trunk").find_all(mujoco.mjtObj.mjOBJ_BODY)} | {"trunk"}
    for b in spec.bodies:
        scale = errors.mass_scale if b.name in robot_bodies else errors.deck_mass_scale if b.name == "deck" else 1.0
        if scale != 1.0:
            b.mass *= scale
            b.inertia = [scale * i for i in b.inertia]
            b.fullinertia = [scale * i for i in b.fullinertia]
    for name in JOINTS:
        j = spec.joint(name)
        j.armature *= errors.armature_scale
        spec.actuator(name).gear = [errors.motor_scale, 0, 0, 0, 0, 0]
    for name in ("truck_front", "truck_rear"):
        j = spec.joint(name)
        j.stiffness = [j.stiffness[0] * errors.kb_scale, 0, 0]
        j.damping = [j.damping[0] * errors.bb_scale, 0, 0]
    if errors.floor_mu is not None:  # MuJoCo takes the larger of two geoms' friction
        spec.geom("floor").friction = [errors.floor_mu, 0, 0]
        for leg in LEGS:
            g = spec.geom(f"{leg}_foot")
            g.friction = [errors.floor_mu, g.friction[1], g.friction[2]]
        spec.geom("deck").friction = [f.friction_mu, 0.005, 0.0001]
    if errors.payload_kg > 0:
        load = spec.body("trunk").add_body(name="payload", pos=list(errors.payload_pos_m))
        load.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.03, 0.03, 0.01], mass=errors.payload_kg,
                      contype=0, conaffinity=0, rgba=[0.8, 0.3, 0.2, 1])
    return spec
