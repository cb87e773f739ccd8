"""The twin's scene: floor, board and robot standing on the deck in the library's four-leg stance,
with the simulation options that hold contact well (elliptic cones, implicit-fast integration,
1 ms steps, the no-slip pass). ``twin_xml`` is what ``skatelib model --twin`` writes."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from skatelib.sim.board import FLOOR_BIT, add_board
from skatelib.sim.figures import TIMESTEP_S, TwinFigures
from skatelib.sim.robot import JOINTS, robot_spec

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

# The largest frame rendered offscreen (a video's, :mod:`skatelib.sim.video`) [px].
OFFSCREEN_SIZE = (1280, 720)
# Colours that tell robot, board and floor apart in the viewer and in videos (RGBA).
ROBOT_RGBA = (0.93, 0.52, 0.13, 1.0)  # trunk, hip and thigh links
CALF_RGBA = (0.22, 0.22, 0.25, 1.0)
FOOT_RGBA = (0.08, 0.08, 0.08, 1.0)
DECK_RGBA = (0.13, 0.33, 0.72, 1.0)
FLOOR_RGB = ((0.80, 0.82, 0.84), (0.58, 0.61, 0.65))  # the checker's two squares
SKY_RGB = ((0.62, 0.75, 0.92), (0.97, 0.98, 1.0))
# Iterations of MuJoCo's no-slip pass after the main contact solve. MuJoCo's friction is a soft
# constraint: without the pass a foot held inside its friction cone creeps at a speed proportional
# to the tangential load (a point foot under 30 % of its cone's force, mu 0.6, creeps 1.6 mm in
# 10 s; a deck foot through a 10 s ride, about 1 cm). A real foot inside its cone does not creep;
# with the pass it does not either (``tests/test_twin.py``).
NOSLIP_ITERATIONS = 10


def add_scenery(spec: mujoco.MjSpec) -> str:
    """What a video sees besides the robot, nothing that moves or touches: a checkered floor
    material (0.5 m squares: the motion shows under a camera that follows), a sky, a light and a
    headlight that light the robot wherever it goes, and the offscreen buffer's size. Returns the
    floor's material name."""
    import mujoco

    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_SIZE
    spec.add_texture(name="floor", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=list(FLOOR_RGB[0]), rgb2=list(FLOOR_RGB[1]), width=256, height=256)
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=list(SKY_RGB[0]), rgb2=list(SKY_RGB[1]), width=64, height=384)
    grid = spec.add_material(name="floor", texrepeat=[4, 4], texuniform=True)
    grid.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor"
    spec.worldbody.add_light(pos=[0, -1, 3], dir=[0, 0.3, -1])
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    return "floor"


def set_options(spec: mujoco.MjSpec, gravity_mps2: float, timestep_s: float = TIMESTEP_S) -> None:
    """The simulation options of both twins: 1 ms steps, implicit-fast integration, elliptic
    friction cones (impratio 10: friction as stiff as the normal contact) and the no-slip pass."""
    import mujoco

    spec.option.timestep = timestep_s
    spec.option.gravity = [0, 0, -gravity_mps2]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10
    spec.option.noslip_iterations = NOSLIP_ITERATIONS


def scene_spec(f: TwinFigures, with_robot: bool = True) -> mujoco.MjSpec:
    """Floor, board and (``with_robot``) the robot, as an ``MjSpec``."""
    import mujoco

    spec = robot_spec(f) if with_robot else mujoco.MjSpec()
    spec.modelname = "skatelib twin"
    set_options(spec, f.gravity_mps2)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            contype=FLOOR_BIT, conaffinity=0, condim=3,
                            friction=[f.friction_mu, 0.0, 0.0], material=add_scenery(spec))
    add_board(spec, f.board, f.friction_mu)
    spec.geom("deck").rgba = list(DECK_RGBA)
    if with_robot:
        _paint_robot(spec)
        _place_robot(spec, f)
    return spec


def _paint_robot(spec: mujoco.MjSpec) -> None:
    """The robot's links in :data:`ROBOT_RGBA`, its calves and feet darker."""
    import mujoco

    for b in spec.body("trunk").find_all(mujoco.mjtObj.mjOBJ_BODY):
        name = b.name
        rgba = FOOT_RGBA if name.endswith("_foot") else CALF_RGBA if name.endswith("_calf") else ROBOT_RGBA
        for g in b.geoms:
            g.rgba = list(rgba)
    for g in spec.body("trunk").geoms:
        g.rgba = list(ROBOT_RGBA)


def _place_robot(spec: mujoco.MjSpec, f: TwinFigures) -> None:
    """The trunk over the deck at the height where the stance's feet touch it."""
    import mujoco

    m = spec.compile()
    d = mujoco.MjData(m)
    for name, q in zip(JOINTS, f.stance_q_rad, strict=True):
        d.qpos[m.joint(name).qposadr[0]] = q
    mujoco.mj_kinematics(m, d)
    trunk = m.body("trunk").id
    feet = np.array([d.geom_xpos[m.geom(f"{leg}_foot").id] for leg in ("FL", "FR", "RL", "RR")])
    below = d.xpos[trunk][2] - feet[:, 2].mean()  # trunk origin over the foot centres
    xy = d.xpos[trunk][:2] - feet[:, :2].mean(axis=0) + f.deck_points_m.mean(axis=1)
    body = spec.body("trunk")
    body.pos = [xy[0], xy[1], f.board.deck_height_m + f.foot_radius_m + below]
    key = spec.add_key(name="stance")
    m2 = spec.compile()
    qpos = m2.qpos0.copy()
    for name, q in zip(JOINTS, f.stance_q_rad, strict=True):
        qpos[m2.joint(name).qposadr[0]] = q
    key.qpos = qpos.tolist()


def twin_model(f: TwinFigures, with_robot: bool = True) -> mujoco.MjModel:
    """The compiled ``MjModel``."""
    return scene_spec(f, with_robot).compile()


def twin_xml(f: TwinFigures, with_robot: bool = True) -> str:
    """The scene as MJCF text (``python -m mujoco.viewer --mjcf OUT.xml`` opens it)."""
    spec = scene_spec(f, with_robot)
    spec.compile()
    text: str = spec.to_xml()
    return text


def pose_qpos(m: mujoco.MjModel, trunk: tuple[np.ndarray, np.ndarray], q: np.ndarray,
              deck: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The twin's configuration with the trunk at ``trunk`` (position, quaternion w x y z), the
    joints at ``q`` (12,) [rad] and the deck's top centre at ``deck`` (position, quaternion); the
    rest (trucks, wheels) as the stance keyframe has it."""
    qpos = np.array(m.key("stance").qpos, dtype=np.float64)
    t, d = m.joint("trunk_free").qposadr[0], m.joint("deck_free").qposadr[0]
    qpos[t:t + 3], qpos[t + 3:t + 7] = trunk
    qpos[[m.joint(n).qposadr[0] for n in JOINTS]] = q
    qpos[d:d + 3], qpos[d + 3:d + 7] = deck
    return qpos
