"""The twin as a plant a controller drives: torques in, the robot's and board's state out, with
what the verdict of a run needs to know that no estimator would tell the controller (which geoms
touch the floor, how hard each wheel presses on it, where each foot's contact point is).

The controller's side does not import this module: it reads a :class:`TwinState`'s fields, and
``skatelib.pipeline`` hands it the plant.
"""

from __future__ import annotations

import numpy as np
from skatelib.sim.contacts import FootContacts
from skatelib.sim.errors import TwinErrors
from skatelib.sim.figures import TwinFigures
from skatelib.sim.native import S_N_STRAY, S_WHEEL_LOAD, CompiledTwin, readout, stray_geoms, twin_library
from skatelib.sim.robot import JOINTS, LEGS
from skatelib.sim.rolling import WHEELS, RollingResistance, step
from skatelib.sim.scene import pose_qpos
from skatelib.sim.twin_spec import TIMESTEP_S, twin_spec
from skatelib.sim.twin_state import TwinState

__all__ = ["TIMESTEP_S", "TwinPlant", "TwinState", "twin_spec"]


class TwinPlant:
    """The twin's ``MjModel`` and ``MjData``, stepped with joint torques."""

    def __init__(self, f: TwinFigures, errors: TwinErrors | None = None, compiled: bool = True):
        """``compiled``: step and read the twin in C (:mod:`skatelib.sim.native`) where it can be
        built; False keeps the Python path (the same states to the bit, slower)."""
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
        self._system_mass = float(m.body_subtreemass[0])
        self._native: CompiledTwin | None = None
        if compiled:
            lib = twin_library()
            self._native = CompiledTwin(lib, self) if lib is not None else None

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
        loads, self._wheel_loads = self._wheel_loads, None
        if self._native is not None:
            self._native.step(tau, n, loads)
            return
        self.d.ctrl[self.robot_actuators] = tau
        step(self.m, self.d, self.rolling, n, loads)

    def state(self) -> TwinState:
        """What the twin is doing now (contact forces evaluated at the last step)."""
        import mujoco

        if self._native is not None:
            s = self._native.state()
            self._wheel_loads = s[S_WHEEL_LOAD:S_WHEEL_LOAD + 4]  # the next step's first rolling torque
            stray = stray_geoms(s, S_N_STRAY, lambda: self.contacts.stray(self.d))
            return readout(s, self._system_mass, tuple(sorted({self.contacts.name(int(g)) for g in stray})))

        m, d = self.m, self.d
        R = d.xmat[self.trunk].reshape(3, 3).copy()
        R_deck = d.xmat[self.deck].reshape(3, 3).copy()
        deck_pos = d.xpos[self.deck].copy()
        deck_v = d.qvel[self.deck_v:self.deck_v + 3].copy()
        w = d.qvel[self.deck_v + 3:self.deck_v + 6]
        deck_w = R_deck[:, 0] * w[0] + R_deck[:, 1] * w[1] + R_deck[:, 2] * w[2]  # as the C path sums
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
            system_v=d.subtree_linvel[0].copy(), system_mass_kg=self._system_mass,
            floor_touches=tuple(sorted(others)))
