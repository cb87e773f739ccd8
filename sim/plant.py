"""The twin as a plant a controller drives: torques in, the robot's and board's state out, with
what the verdict of a run needs to know that no estimator would tell the controller (which geoms
touch the floor, how hard each wheel presses on it, where each foot's contact point is).

The controller's side does not import this module: it reads a :class:`TwinState`'s fields, and
``skatelib.pipeline`` hands it the plant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from skatelib.library.rotations import roll_of, yaw_of
from skatelib.sim.contacts import FootContacts
from skatelib.sim.errors import TwinErrors
from skatelib.sim.figures import TwinFigures
from skatelib.sim.robot import JOINTS, LEGS
from skatelib.sim.rolling import WHEELS, RollingResistance, step
from skatelib.sim.scene import pose_qpos, scene_spec

if TYPE_CHECKING:  # mujoco is imported where the twin is built (the [sim] extra)
    import mujoco

TIMESTEP_S = 1.0 / 1020.0  # two steps per 510 Hz whole-body tick, 34 per 30 Hz MPC update


@dataclass
class TwinState:
    """One instant of the twin (world frame unless named otherwise).

    Attributes:
        trunk_omega: Angular velocity of the trunk in the trunk frame.
        deck_omega: Angular velocity of the deck in the world frame.
        foot_centres / foot_velocities: (3, 4) the foot spheres' centres and their velocities.
        foot_touch: (4,) per foot NO_CONTACT, ON_DECK or ON_FLOOR.
        contact_points: (3, 4) where each touching foot touches (its centre less a radius along
            the surface normal otherwise).
        foot_spins: (3, 4) the foot spheres' angular velocities (for the slip at the contact point).
        foot_load_N: (4,) each foot's normal force on what it touches.
        wheel_load_N: (4,) normal force of each wheel on the floor.
        wheel_force_N: (3,) the floor's force on all four wheels.
        system_v: (3,) velocity of the centre of mass of robot and board together.
        system_mass_kg: Their mass.
        floor_touches: Names of the geoms other than feet and wheels that touch the floor.
    """

    t: float
    trunk_pos: np.ndarray
    trunk_R: np.ndarray
    trunk_v: np.ndarray
    trunk_omega: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    deck_pos: np.ndarray
    deck_R: np.ndarray
    deck_v: np.ndarray
    deck_omega: np.ndarray
    foot_centres: np.ndarray
    foot_velocities: np.ndarray
    foot_touch: np.ndarray
    contact_points: np.ndarray
    foot_spins: np.ndarray
    foot_load_N: np.ndarray
    wheel_load_N: np.ndarray
    wheel_force_N: np.ndarray
    system_v: np.ndarray
    system_mass_kg: float
    floor_touches: tuple[str, ...]

    @property
    def deck_yaw(self) -> float:
        return yaw_of(self.deck_R)

    @property
    def deck_roll(self) -> float:
        """Roll about the deck's own x axis (Z-Y-X angles)."""
        return roll_of(self.deck_R)


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


class TwinPlant:
    """The twin's ``MjModel`` and ``MjData``, stepped with joint torques."""

    def __init__(self, f: TwinFigures, errors: TwinErrors | None = None):
        import mujoco

        self.f = f
        self.errors = errors or TwinErrors()
        self.m = twin_spec(f, self.errors).compile()
        self.d = mujoco.MjData(self.m)
        m = self.m
        self.qadr = np.array([m.joint(n).qposadr[0] for n in JOINTS])
        self.dadr = np.array([m.joint(n).dofadr[0] for n in JOINTS])
        self.feet = np.array([m.geom(f"{leg}_foot").id for leg in LEGS])
        self.wheels = np.array([m.geom(w).id for w in WHEELS])
        self.floor = m.geom("floor").id
        self.deck_geom = m.geom("deck").id
        self.trunk = m.body("trunk").id
        self.deck = m.body("deck").id
        self.trunk_q = m.joint("trunk_free").qposadr[0]
        self.trunk_v = m.joint("trunk_free").dofadr[0]
        self.deck_q = m.joint("deck_free").qposadr[0]
        self.deck_v = m.joint("deck_free").dofadr[0]
        self.robot_actuators = np.array([m.actuator(n).id for n in JOINTS])
        self.rolling = RollingResistance(m, f.board.rolling_friction_coeff * self.errors.rolling_scale)
        self.contacts = FootContacts(m, self.feet, self.wheels, self.floor, self.deck_geom)
        # the wheels' floor loads :meth:`state` read, for the next step's first rolling torque (None:
        # the contacts have changed since)
        self._wheel_loads: np.ndarray | None = None

    @property
    def timestep_s(self) -> float:
        return float(self.m.opt.timestep)

    @property
    def axle_below_deck_m(self) -> float:
        """The axles (the deck's roll axis) below the deck's top, where the deck's state is given [m]."""
        return float(self.f.board.axle_below_deck_m)

    def qpos(self) -> np.ndarray:
        """The whole configuration (robot and board), as MuJoCo orders it."""
        return np.array(self.d.qpos)

    def place(self, trunk_pos: np.ndarray, trunk_quat_wxyz: np.ndarray, q: np.ndarray, deck_pose: np.ndarray) -> None:
        """Put the robot and board at rest: trunk pose, joint angles (12,), deck (x, y, yaw); the
        deck's height from the stance keyframe."""
        import mujoco

        d = self.d
        mujoco.mj_resetDataKeyframe(self.m, d, self.m.key("stance").id)
        d.qvel[:] = 0.0
        x, y, yaw = deck_pose
        deck_z = d.qpos[self.deck_q + 2]
        d.qpos[:] = pose_qpos(self.m, (trunk_pos, trunk_quat_wxyz), q,
                              (np.array([x, y, deck_z]), np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])))
        mujoco.mj_forward(self.m, d)
        self.contacts_changed()

    def launch(self, speed_mps: float) -> None:
        """Robot and board moving forward along the deck's heading at ``speed_mps``, wheels rolling."""
        import mujoco

        d = self.d
        R = d.xmat[self.deck].reshape(3, 3)
        v = speed_mps * R[:, 0]
        d.qvel[self.trunk_v:self.trunk_v + 3] = v
        d.qvel[self.deck_v:self.deck_v + 3] = v
        for dof, r in zip(self.rolling.dofs, self.rolling.radius, strict=True):
            d.qvel[dof] = speed_mps / r
        mujoco.mj_forward(self.m, d)
        self.contacts_changed()

    def foot_centres(self) -> np.ndarray:
        return np.array(self.d.geom_xpos[self.feet].T)

    def shift_robot(self, dz: float) -> None:
        import mujoco

        self.d.qpos[self.trunk_q + 2] += dz
        mujoco.mj_forward(self.m, self.d)
        self.contacts_changed()

    def contacts_changed(self) -> None:
        """The twin's contacts were computed again (``mj_forward``) since the last :meth:`state`:
        the next step reads the wheels' loads from them."""
        self._wheel_loads = None

    def push(self, force_N: np.ndarray) -> None:
        """A force on the trunk's centre of mass (world frame) [N], held until changed."""
        self.d.xfrc_applied[self.trunk, 0:3] = force_N

    def step(self, tau: np.ndarray, n: int = 1) -> None:
        """``n`` physics steps with the joint torques ``tau`` [N m]. The first rolling torque takes
        the wheels' loads the last :meth:`state` read (the same contacts); the plant's own methods
        that move the twin drop them, and so must a caller that runs ``mj_forward`` on ``d`` itself
        between a state and a step (:meth:`contacts_changed`)."""
        self.d.ctrl[self.robot_actuators] = tau
        loads, self._wheel_loads = self._wheel_loads, None
        step(self.m, self.d, self.rolling, n, loads)

    def state(self) -> TwinState:
        """What the twin is doing now (contact forces evaluated at the last step)."""
        import mujoco

        m, d = self.m, self.d
        R = d.xmat[self.trunk].reshape(3, 3).copy()
        R_deck = d.xmat[self.deck].reshape(3, 3).copy()
        deck_pos = d.xpos[self.deck].copy()
        deck_v = d.qvel[self.deck_v:self.deck_v + 3].copy()
        deck_w = R_deck @ d.qvel[self.deck_v + 3:self.deck_v + 6]
        centres = self.foot_centres()
        vel = np.zeros((3, 4))
        spins = np.zeros((3, 4))
        v6 = np.zeros(6)
        for i, g in enumerate(self.feet):
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, g, v6, 0)
            vel[:, i] = v6[3:]
            spins[:, i] = v6[:3]
        points = centres - np.array([[0.0], [0.0], [self.f.foot_radius_m]])
        loads, wheel_force = self.rolling.floor_forces(d)
        self._wheel_loads = loads  # the next step's first rolling torque reads the same contacts
        touch, foot_loads, others = self.contacts.read(d, points)
        mujoco.mj_subtreeVel(m, d)
        return TwinState(
            t=float(d.time), trunk_pos=d.qpos[self.trunk_q:self.trunk_q + 3].copy(), trunk_R=R,
            trunk_v=d.qvel[self.trunk_v:self.trunk_v + 3].copy(),
            trunk_omega=d.qvel[self.trunk_v + 3:self.trunk_v + 6].copy(),
            q=d.qpos[self.qadr].copy(), qd=d.qvel[self.dadr].copy(), deck_pos=deck_pos, deck_R=R_deck,
            deck_v=deck_v, deck_omega=deck_w, foot_centres=centres, foot_velocities=vel, foot_touch=touch,
            contact_points=points, foot_spins=spins, foot_load_N=foot_loads, wheel_load_N=loads,
            wheel_force_N=wheel_force,
            system_v=d.subtree_linvel[0].copy(), system_mass_kg=float(m.body_subtreemass[0]),
            floor_touches=tuple(sorted(others)))
