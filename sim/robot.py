"""The CyberDog2 from the URDF the library stores: MuJoCo compiles the URDF's links, joints and
inertias; the trunk gets the free joint the URDF cannot say (MuJoCo welds a root link without one
to the world); each joint a torque motor limited to the torque limit, the rotor's reflected
inertia as armature and a small damping; each foot a sphere of the foot radius with the friction
the optimizer assumed. Only the feet touch the deck; the trunk and legs touch the floor (a fall)."""

from __future__ import annotations

import re
from typing import Any

from skatelib.library.errors import ModelError
from skatelib.library.urdf import without_meshes
from skatelib.sim.board import FLOOR_BIT, FOOT_BIT
from skatelib.sim.figures import GEAR_RATIO, JOINT_DAMPING_NMS, ROTOR_INERTIA_KGM2, TwinFigures

LEGS = ("FL", "FR", "RL", "RR")
JOINTS = tuple(f"{leg}_{j}" for leg in LEGS for j in ("abad", "hip", "knee"))
# A rubber foot gives a millimetre or two under the robot's weight: a contact time constant of
# 5 ms and a high impedance (MuJoCo's defaults let a pushing foot sink more than a centimetre,
# until the calf touches the floor).
FOOT_SOLREF_S = 0.005
FOOT_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)
_IMPORT = ('<mujoco><compiler discardvisual="false" fusestatic="false" balanceinertia="false" '
           'strippath="true" angle="radian"/></mujoco>')


def robot_spec(f: TwinFigures) -> Any:
    """The robot as an ``MjSpec`` (its world holds the trunk, now floating), from the URDF's
    primitive shapes: MuJoCo reads no mesh file named in it (:mod:`skatelib.library.urdf`).

    Raises:
        ModelError: A foot link without a primitive shape (the twin's feet are its spheres).
    """
    import mujoco

    urdf = re.sub(r"(<robot[^>]*>)", r"\1" + _IMPORT, without_meshes(f.urdf), count=1)
    spec = mujoco.MjSpec.from_string(urdf)
    trunk = spec.body("trunk")
    trunk.add_freejoint(name="trunk_free")
    armature = ROTOR_INERTIA_KGM2 * GEAR_RATIO**2
    for name in JOINTS:
        j = spec.joint(name)
        j.armature = armature
        j.damping = [JOINT_DAMPING_NMS, 0, 0]
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.ctrllimited = True
        act.ctrlrange = [-f.torque_limit_Nm, f.torque_limit_Nm]
    for g in spec.geoms:
        body = g.parent.name
        if body.endswith("_foot"):
            g.name = body
            g.size = [f.foot_radius_m, 0, 0]
            g.contype, g.conaffinity, g.condim = FOOT_BIT, FLOOR_BIT, 3
            g.friction = [f.friction_mu, 0.005, 0.0001]
            g.solref = [FOOT_SOLREF_S, 1.0]
            g.solimp = list(FOOT_SOLIMP)
        else:
            g.contype, g.conaffinity = 0, FLOOR_BIT
    shaped = {g.parent.name for g in spec.geoms}
    bare = [f"{leg}_foot" for leg in LEGS if f"{leg}_foot" not in shaped]
    if bare:
        raise ModelError(f"the robot description gives {', '.join(bare)} no primitive shape (a sphere): the twin's "
                         "feet are those shapes (mesh files are not read)")
    return spec
