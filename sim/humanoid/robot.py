"""The humanoid twin as an ``MjSpec``: MuJoCo compiles the URDF's links, joints and inertias; the
waist gets the free joint the URDF cannot say; each joint a position servo (the motor driver's PD,
HRP-2 is position controlled) limited to the joint's torque limit, the rotor's reflected inertia as
armature and a damping; each foot a sole box of the library's sole size under its sole frame, with
the floor's friction and a torsional friction (yaw slip is a torsional effect), and a 6-axis
force/torque sensor at its ankle; an IMU (orientation, rate) on the waist. Only the soles touch
the floor as support: any other link touching it is a fall. A skate's twin has the quadruped's
skateboard (:func:`skatelib.sim.board.add_board`: a free deck, trucks on their pivot axes, rolling
wheels) under the board sole, which it holds by friction alone."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from skatelib.library.urdf import without_meshes
from skatelib.sim.board import FLOOR_BIT, FOOT_BIT, add_board
from skatelib.sim.humanoid.figures import (
    ANKLES,
    FEET,
    GEAR_RATIO,
    JOINT_DAMPING_NMS,
    ROTOR_INERTIA_KGM2,
    SERVO_KD_NMS_PER_RAD,
    SERVO_KP_NM_PER_RAD,
    SOLE_THICKNESS_M,
    SOLES,
    TIMESTEP_S,
    HumanoidFigures,
)
from skatelib.sim.scene import add_scenery, set_options

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

SOLE_BIT = FOOT_BIT  # the board's deck touches what its builder calls feet: the soles
ROOT = "waist"
# A rubber sole gives a millimetre or so under the robot's weight: a 5 ms contact time constant.
SOLE_SOLREF_S = 0.005
SOLE_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
_IMPORT = ('<mujoco><compiler discardvisual="false" fusestatic="false" balanceinertia="false" '
           'strippath="true" angle="radian"/></mujoco>')


def sole_geom(side: int) -> str:
    return f"{SOLES[side]}_box"


def ft_site(side: int) -> str:
    return f"{FEET[side]}_ft"


def humanoid_spec(f: HumanoidFigures) -> mujoco.MjSpec:
    """Floor and robot (standing in the first knot's posture, keyframe ``initial``) as an ``MjSpec``."""
    import mujoco

    urdf = re.sub(r"(<robot[^>]*>)", r"\1" + _IMPORT, without_meshes(f.urdf), count=1)
    spec = mujoco.MjSpec.from_string(urdf)
    spec.modelname = "skatelib humanoid twin"
    set_options(spec, f.gravity_mps2, TIMESTEP_S)
    spec.body(ROOT).add_freejoint(name="root_free")
    for g in spec.geoms:  # the links' shapes: drawn, and touching the floor only in a fall
        g.contype, g.conaffinity = 0, FLOOR_BIT
    _add_motors(spec, f)
    _add_soles(spec, f)
    imu = spec.body(ROOT).add_site(name="imu", pos=[0, 0, 0])
    spec.add_sensor(name="imu_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                    objname=imu.name)
    spec.add_sensor(name="imu_gyro", type=mujoco.mjtSensor.mjSENS_GYRO, objtype=mujoco.mjtObj.mjOBJ_SITE,
                    objname=imu.name)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            contype=FLOOR_BIT, conaffinity=0, condim=4,
                            friction=[f.friction_mu, f.torsional_friction_m, 0.0], material=add_scenery(spec))
    if f.board is not None:  # the skate's board under the board sole, its deck's top at the deck height
        add_board(spec, f.board, f.deck_mu, (f.deck_xy[0], f.deck_xy[1], 0.0))
    key = spec.add_key(name="initial")
    m = spec.compile()
    qpos = m.qpos0.copy()
    x, y, z, qx, qy, qz, qw = f.base0
    qpos[0:7] = [x, y, z, qw, qx, qy, qz]
    for name, q in zip(f.joint_names, f.q0_rad, strict=True):
        qpos[m.joint(name).qposadr[0]] = q
    key.qpos = qpos.tolist()
    return spec


def _add_motors(spec: mujoco.MjSpec, f: HumanoidFigures) -> None:
    import mujoco

    for name, limit in zip(f.joint_names, f.torque_limit_Nm, strict=True):
        j = spec.joint(name)
        j.armature = ROTOR_INERTIA_KGM2 * GEAR_RATIO**2
        j.damping = [JOINT_DAMPING_NMS, 0, 0]
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm = [SERVO_KP_NM_PER_RAD] + [0.0] * 9
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.biasprm = [0.0, -SERVO_KP_NM_PER_RAD, -SERVO_KD_NMS_PER_RAD] + [0.0] * 7
        act.forcelimited = True
        act.forcerange = [-float(limit), float(limit)]


def _add_soles(spec: mujoco.MjSpec, f: HumanoidFigures) -> None:
    """Per foot: the sole box (its bottom face on the sole frame), the ankle's force/torque sensor."""
    import mujoco

    for side, (foot, sole) in enumerate(zip(FEET, SOLES, strict=True)):
        body = spec.body(foot)
        for g in body.geoms:
            g.conaffinity = 0  # the foot's drawn shape; the sole box touches the floor
        p = list(spec.body(sole).pos)
        body.add_geom(name=sole_geom(side), type=mujoco.mjtGeom.mjGEOM_BOX,
                      size=[f.foot_length_m / 2, f.foot_width_m / 2, SOLE_THICKNESS_M / 2],
                      pos=[p[0], p[1], p[2] + SOLE_THICKNESS_M / 2], mass=0.0, contype=SOLE_BIT,
                      conaffinity=FLOOR_BIT, condim=4, friction=[f.friction_mu, f.torsional_friction_m, 0.0],
                      solref=[SOLE_SOLREF_S, 1.0], solimp=list(SOLE_SOLIMP), rgba=[0.2, 0.2, 0.25, 1])
        ankle = spec.joint(ANKLES[side])
        site = body.add_site(name=ft_site(side), pos=list(ankle.pos))
        spec.add_sensor(name=f"{foot}_force", type=mujoco.mjtSensor.mjSENS_FORCE,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
        spec.add_sensor(name=f"{foot}_torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)


def humanoid_xml(f: HumanoidFigures) -> str:
    """The twin as MJCF text (``python -m mujoco.viewer --mjcf OUT.xml`` opens it)."""
    spec = humanoid_spec(f)
    spec.compile()
    text: str = spec.to_xml()
    return text
