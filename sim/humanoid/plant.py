"""The humanoid twin as a plant: joint angle targets in (the motor drivers' servos track them),
the robot's sensors out as it has them (joint encoders, the waist IMU, the ankles' 6-axis
force/torque sensors, each with noise), and what a verdict needs that no sensor tells the
controller (the COM, the soles' contacts and slip, the links touching the floor)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from skatelib.sim.contacts import stray_on_floor
from skatelib.sim.humanoid.errors import SHOVE_S, HumanoidErrors
from skatelib.sim.humanoid.figures import (
    FEET,
    SERVO_KD_NMS_PER_RAD,
    SERVO_KP_NM_PER_RAD,
    SOLE_THICKNESS_M,
    HumanoidFigures,
)
from skatelib.sim.humanoid.robot import ROOT, humanoid_spec, sole_geom
from skatelib.sim.humanoid.state import Readings, Truth, truth_of_row, truth_row
from skatelib.sim.native import CompiledSense, CompiledSteps, CompiledTruth, twin_library
from skatelib.sim.rolling import WHEELS, RollingResistance

__all__ = ["HumanoidPlant", "Readings", "Truth"]


class HumanoidPlant:
    """The twin's ``MjModel`` and ``MjData``, stepped with joint angle targets."""

    def __init__(self, f: HumanoidFigures, errors: HumanoidErrors | None = None, seed: int = 0,
                 compiled: bool = True):
        """``compiled``: the physics steps (the shove, a board's rolling torques), the sensors and
        the ground truth in C (:mod:`skatelib.sim.native`) where it can be built; False keeps the
        Python path (the same states, readings and truths to the bit)."""
        import mujoco

        self.f, self.errors = f, errors or HumanoidErrors()
        self.m = self.errors.apply(humanoid_spec(f)).compile()
        self.d = mujoco.MjData(self.m)
        m = self.m
        self.rng = np.random.default_rng(seed)
        self.qadr = np.array([m.joint(n).qposadr[0] for n in f.joint_names])
        self.dadr = np.array([m.joint(n).dofadr[0] for n in f.joint_names])
        self.act = np.array([m.actuator(n).id for n in f.joint_names])
        self.soles = [m.geom(sole_geom(s)).id for s in (0, 1)]
        self.floor = m.geom("floor").id
        self.root = m.body(ROOT).id
        self.sensor = {n: (m.sensor(n).adr[0], m.sensor(n).dim[0]) for n in
                       ("imu_quat", "imu_gyro", *(f"{foot}_{w}" for foot in FEET for w in ("force", "torque")))}
        self._quat, self._gyro = self._rows("imu_quat"), self._rows("imu_gyro")
        self._force = np.array([self._rows(f"{foot}_force") for foot in FEET])  # (2, 3)
        self._torque = np.array([self._rows(f"{foot}_torque") for foot in FEET])
        e, n = self.errors, len(f.joint_names)
        self._noise_scale = np.concatenate([np.full(4, e.imu_noise_rad / 2), np.full(6, e.force_noise_N),
                                            np.full(6, e.torque_noise_Nm), np.full(n, e.encoder_noise_rad),
                                            np.full(n, 20 * e.encoder_noise_rad), np.full(3, e.gyro_noise_radps)])
        self.rolling = RollingResistance(m, f.board.rolling_friction_coeff) if f.board is not None else None
        self.deck = m.body("deck").id if f.board is not None else -1
        self.deck_geom = m.geom("deck").id if f.board is not None else -1
        self.feet = m.geom_bodyid[self.soles]
        self.on_floor = np.zeros(m.ngeom, dtype=bool)  # the geoms planned on the floor: the soles, the wheels
        self.on_floor[self.soles] = True
        if f.board is not None:
            self.on_floor[[m.geom(w).id for w in WHEELS]] = True
        # truth() reads the soles' wrenches from cfrc_ext, which MuJoCo computes at each step only for
        # sensors that need it (the ankles' force sensors)
        if not (m.sensor_type == mujoco.mjtSensor.mjSENS_FORCE).any() or (
                m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_SENSOR):
            raise ValueError("the humanoid twin needs its ankle force sensors on: its ground truth reads the soles' "
                             "wrenches that MuJoCo computes for them")
        mujoco.mj_resetDataKeyframe(m, self.d, m.key("initial").id)
        self.d.ctrl[self.act] = f.q0_rad
        mujoco.mj_forward(m, self.d)
        # MjData's arrays, each read once: an attribute's read makes a new numpy view each time, some
        # microseconds that a tick's dozens of reads add up
        d = self.d
        self._sd, self._qpos, self._qvel, self._ctrl = d.sensordata, d.qpos, d.qvel, d.ctrl
        self._ext, self._com, self._comvel = d.cfrc_ext, d.subtree_com, d.subtree_linvel
        self._gpos, self._gmat, self._xpos, self._xmat = d.geom_xpos, d.geom_xmat, d.xpos, d.xmat
        self._torques = d.actuator_force
        self._steps: CompiledSteps | None = None
        self._truth: CompiledTruth | None = None
        self._sense: CompiledSense | None = None
        lib = twin_library() if compiled else None
        if lib is not None:
            self._compiled(lib)

    def _compiled(self, lib: Any) -> None:
        """The steps, the sensors and the truth in C (:mod:`skatelib.sim.native`)."""
        e, m, d = self.errors, self.m, self.d
        self._steps = CompiledSteps(lib, m, d, self.rolling, (self.root, e.shove_N, e.shove_t_s, SHOVE_S))
        self._truth = CompiledTruth(lib, self, SOLE_THICKNESS_M / 2)
        # the readings' sources in the noise's order: quaternion, forces, torques, angles, rates, gyro
        parts = ((0, self._quat), (1, self._force.ravel()), (1, self._torque.ravel()), (2, self.qadr),
                 (3, self.dadr), (0, self._gyro))
        self._sense = CompiledSense(lib, d, np.concatenate([np.full(len(i), k) for k, i in parts]),
                                    np.concatenate([i for _, i in parts]))

    @property
    def timestep_s(self) -> float:
        return float(self.m.opt.timestep)

    def step(self, q_target: np.ndarray, n: int = 1, qd_target: np.ndarray | None = None,
             tau_ff: np.ndarray | None = None) -> None:
        """``n`` physics steps with the servos at ``q_target`` [rad], fed the joints' target speed
        [rad/s] and a feed-forward torque [N m] when given: the driver's
        tau = kp (q_t - q) + kd (qd_t - qd) + tau_ff, as the servo's own target
        q_t + (kd qd_t + tau_ff) / kp (the damping stays in MuJoCo's implicit integration)."""
        import mujoco

        extra = np.zeros(len(self.act))
        if qd_target is not None:
            extra += SERVO_KD_NMS_PER_RAD * qd_target
        if tau_ff is not None:
            extra += tau_ff
        self._ctrl[self.act] = q_target + extra / SERVO_KP_NM_PER_RAD
        if self._steps is not None:
            self._steps(n)
            return
        for _ in range(n):
            self.errors.push(self.d, self.root)
            if self.rolling is not None:
                self.rolling.apply(self.d)
            mujoco.mj_step(self.m, self.d)

    def layout(self) -> tuple[int, np.ndarray, int]:
        """Where in ``qpos`` the waist's free joint, the joints (the figures' order) and a skate's
        deck's free joint (-1: no board) begin."""
        deck = int(self.m.joint("deck_free").qposadr[0]) if self.f.board is not None else -1
        return int(self.m.joint("root_free").qposadr[0]), self.qadr.copy(), deck

    def pose_qpos(self, base_pos: np.ndarray, base_quat_wxyz: np.ndarray, q: np.ndarray) -> np.ndarray:
        """A configuration (nq,) of this twin: its waist at ``base_pos`` turned ``base_quat_wxyz``,
        its joints at ``q`` [rad], the rest (a skate's board) as the twin has it now."""
        out = self.d.qpos.copy()
        a = self.m.joint("root_free").qposadr[0]
        out[a:a + 3], out[a + 3:a + 7], out[self.qadr] = base_pos, base_quat_wxyz, q
        return out

    def _rows(self, name: str) -> np.ndarray:
        """Where sensor ``name``'s values are in ``sensordata``."""
        a, n = self.sensor[name]
        return np.arange(a, a + n)

    def readings(self) -> Readings:
        """The sensors, with the errors' noise (angles, rates, forces and torques; docs/twin.md):
        one draw of every sensor's noise a tick, in the order quaternion, forces, torques, angles,
        rates, gyro."""
        sd, d, n = self._sd, self.d, len(self.qadr)
        noise = self.rng.standard_normal(len(self._noise_scale)) * self._noise_scale + 0.0  # normal(0, scale)'s bits
        if self._sense is not None:
            r = self._sense(noise)
            return Readings(float(d.time), r[16:16 + n], r[16 + n:16 + 2 * n], r[0:4], r[16 + 2 * n:],
                            r[4:10].reshape(2, 3), r[10:16].reshape(2, 3))
        quat = sd[self._quat] + noise[0:4]
        force = -sd[self._force] + noise[4:10].reshape(2, 3)
        torque = -sd[self._torque] + noise[10:16].reshape(2, 3)
        q, qd = self._qpos[self.qadr] + noise[16:16 + n], self._qvel[self.dadr] + noise[16 + n:16 + 2 * n]
        norm = math.sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3])  # as the C
        return Readings(float(d.time), q, qd, quat / norm, sd[self._gyro] + noise[16 + 2 * n:], force, torque)

    def _names(self, geoms: Any) -> tuple[str, ...]:
        """The geoms' names (their bodies' for unnamed ones), sorted."""
        m = self.m
        return tuple(sorted({m.geom(int(g)).name or m.body(m.geom_bodyid[int(g)]).name for g in geoms}))

    def _stray(self) -> set[int]:
        """The geoms on the floor other than the soles and the wheels (ids)."""
        d = self.d
        return stray_on_floor(d.contact.geom1, d.contact.geom2, self.floor, self.on_floor) if d.ncon else set()

    def truth(self, plane_z: float = 0.0) -> Truth:
        """What happened; the soles' joint ZMP on the plane at height ``plane_z`` [m]."""
        return self._python_truth(plane_z) if self._truth is None else self.truth_of(self._truth(plane_z))

    def truth_row(self, plane_z: float = 0.0) -> np.ndarray:
        """:meth:`truth` as one row of numbers (a fresh vector: :mod:`skatelib.sim.humanoid.state`'s
        ``TRUTH_LAYOUT``, the geoms on the floor as :meth:`floor_touches` reads them): what a run
        keeps of every tick."""
        if self._truth is not None:
            return self._truth(plane_z)
        stray = self._stray()
        return truth_row(self._python_truth(plane_z, stray), sorted(stray))

    def floor_touches(self, row: np.ndarray) -> tuple[str, ...]:
        """The geoms on the floor other than the soles and the board's wheels, by name, from a
        :meth:`truth_row` taken now."""
        from skatelib.sim import native as n

        return self._names(n.stray_geoms(row, n.H_N_STRAY, self._stray)) if row[n.H_N_STRAY] else ()

    def _python_truth(self, plane_z: float, stray: set[int] | None = None) -> Truth:
        """:meth:`truth` read through MuJoCo's Python bindings (``stray``: :meth:`_stray`, when the
        caller has it)."""
        import mujoco

        m, d = self.m, self.d
        # A sole's box touches the floor and the deck alone (its foot's other geoms touch nothing):
        # its foot's external force is its contacts' (MuJoCo's cfrc_ext, computed for the ankle
        # sensors at each step: a torque about the robot's COM and a force, world axes).
        ext = self._ext[self.feet]
        tau, force = ext[:, 0:3], ext[:, 3:6]
        c, pos, R = self._com[self.root], self._gpos[self.soles], self._gmat[self.soles]
        zmp = np.full((2, 2), np.nan)
        for s in (0, 1):
            if force[s, 2] > 1.0:
                zmp[s] = _cop(force[s], tau[s], c, float(pos[s, 2]) - SOLE_THICKNESS_M / 2)
        total_f, total_tau = force.sum(axis=0), tau.sum(axis=0)
        both = _cop(total_f, total_tau, c, plane_z) if total_f[2] > 1.0 else np.full(2, np.nan)
        yaw = np.array([math.atan2(R[s, 3], R[s, 0]) for s in (0, 1)])  # the C library's, as the C path
        v, wz, w = np.zeros((2, 3)), np.zeros(2), np.zeros(6)
        for s, g in enumerate(self.soles):
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, g, w, 0)
            v[s], wz[s] = w[3:6], w[2]
        mujoco.mj_subtreeVel(m, d)
        deck: tuple[np.ndarray | None, ...] = (None, None, None)
        if self.deck >= 0:
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, self.deck, w, 0)
            deck = (self._xpos[self.deck].copy(), self._xmat[self.deck].reshape(3, 3).copy(), w[3:6].copy())
        return Truth(float(d.time), c.copy(), self._comvel[self.root].copy(), self._xpos[self.root].copy(),
                     self._xmat[self.root].reshape(3, 3).copy(), force, zmp, both, pos, yaw, v, wz,
                     self._torques[self.act], self._names(self._stray() if stray is None else stray), *deck)

    def truth_of(self, s: np.ndarray) -> Truth:
        """A :class:`Truth` of views of a :meth:`truth_row` ``s`` taken now."""
        return truth_of_row(s, self.floor_touches(s), self.deck >= 0)


def _cop(f: np.ndarray, tau: np.ndarray, c: np.ndarray, z: float) -> np.ndarray:
    """The centre of pressure (x, y) on the plane at height ``z`` of a force ``f`` with the moment
    ``tau`` about the point ``c``: the point of that plane about which the moment has no x, y part."""
    h = z - c[2]
    return np.array([c[0] + (h * f[0] - tau[1]) / f[2], c[1] + (tau[0] + h * f[1]) / f[2]])
