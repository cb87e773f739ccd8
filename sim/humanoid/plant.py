"""The humanoid twin as a plant: joint angle targets in (the motor drivers' servos track them),
the robot's sensors out as it has them (joint encoders, the waist IMU, the ankles' 6-axis
force/torque sensors, each with noise), and what a verdict needs that no sensor tells the
controller (the COM, the soles' contacts and slip, the links touching the floor)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.sim.humanoid.errors import HumanoidErrors
from skatelib.sim.humanoid.figures import (
    FEET,
    SERVO_KD_NMS_PER_RAD,
    SERVO_KP_NM_PER_RAD,
    SOLE_THICKNESS_M,
    HumanoidFigures,
)
from skatelib.sim.humanoid.robot import ROOT, humanoid_spec, sole_geom
from skatelib.sim.rolling import WHEELS, RollingResistance


@dataclass(frozen=True)
class Readings:
    """The robot's sensors at one instant (noise included).

    Attributes:
        imu_quat_wxyz / imu_gyro: The waist's orientation and its rate in the waist frame.
        ft_force / ft_torque: (2, 3) right then left: the wrench the ground side exerts on the foot
            below each ankle sensor, in the foot frame, about the sensor's point.
    """

    t: float
    q: np.ndarray
    qd: np.ndarray
    imu_quat_wxyz: np.ndarray
    imu_gyro: np.ndarray
    ft_force: np.ndarray
    ft_torque: np.ndarray


@dataclass(frozen=True)
class Truth:
    """What happened (world frame): the COM, each sole's contact and the other links on the floor.

    Attributes:
        sole_force: (2, 3) the floor's (or a skate's deck's) force on each sole box; sole_zmp (2, 2)
            its centre of pressure on the plane of its bottom (NaN without contact); zmp (2,) both
            soles' together, on the plane ``truth``'s ``plane_z`` names.
        sole_pos / sole_yaw: (2, 3) / (2,) the soles' frames; sole_v / sole_wz their velocity and
            yaw rate.
    """

    t: float
    com: np.ndarray
    com_v: np.ndarray
    base_pos: np.ndarray
    base_R: np.ndarray
    sole_force: np.ndarray
    sole_zmp: np.ndarray
    zmp: np.ndarray
    sole_pos: np.ndarray
    sole_yaw: np.ndarray
    sole_v: np.ndarray
    sole_wz: np.ndarray
    torque: np.ndarray
    floor_touches: tuple[str, ...]
    deck_pos: np.ndarray | None = None  # a skate's deck: its top's centre (3,), orientation (3, 3) and velocity (3,)
    deck_R: np.ndarray | None = None
    deck_v: np.ndarray | None = None

    def on_deck(self, p: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the deck's frame (its top's centre, x forward)."""
        if self.deck_pos is None or self.deck_R is None:
            raise ValueError("the twin has no board")
        return np.asarray((np.asarray(p) - self.deck_pos) @ self.deck_R)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b of two 3-vectors (np.cross costs 30 us a call; a contact loop calls it thousands of times)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


class HumanoidPlant:
    """The twin's ``MjModel`` and ``MjData``, stepped with joint angle targets."""

    def __init__(self, f: HumanoidFigures, errors: HumanoidErrors | None = None, seed: int = 0):
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
        self.rolling = RollingResistance(m, f.board.rolling_friction_coeff) if f.board is not None else None
        self.deck = m.body("deck").id if f.board is not None else -1
        self.deck_geom = m.geom("deck").id if f.board is not None else -1
        self.wheels = {m.geom(w).id for w in WHEELS} if f.board is not None else set()
        mujoco.mj_resetDataKeyframe(m, self.d, m.key("initial").id)
        self.d.ctrl[self.act] = f.q0_rad
        mujoco.mj_forward(m, self.d)

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
        self.d.ctrl[self.act] = q_target + extra / SERVO_KP_NM_PER_RAD
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

    def _s(self, name: str) -> np.ndarray:
        a, n = self.sensor[name]
        return np.array(self.d.sensordata[a:a + n])

    def readings(self) -> Readings:
        """The sensors, with the errors' noise (angles, rates, forces and torques; docs/twin.md)."""
        e, r, d = self.errors, self.rng, self.d
        n = len(self.qadr)
        quat = self._s("imu_quat") + r.normal(0, e.imu_noise_rad / 2, 4)
        force = np.array([-self._s(f"{foot}_force") for foot in FEET]) + r.normal(0, e.force_noise_N, (2, 3))
        torque = np.array([-self._s(f"{foot}_torque") for foot in FEET]) + r.normal(0, e.torque_noise_Nm, (2, 3))
        return Readings(float(d.time), d.qpos[self.qadr] + r.normal(0, e.encoder_noise_rad, n),
                        d.qvel[self.dadr] + r.normal(0, 20 * e.encoder_noise_rad, n), quat / np.linalg.norm(quat),
                        self._s("imu_gyro") + r.normal(0, e.gyro_noise_radps, 3), force, torque)

    def truth(self, plane_z: float = 0.0) -> Truth:
        """What happened; the soles' joint ZMP on the plane at height ``plane_z`` [m]."""
        import mujoco

        m, d = self.m, self.d
        force, moment = np.zeros((2, 3)), np.zeros((2, 3))  # moment about the world origin
        others: set[str] = set()
        frame, w = np.zeros(6), np.zeros(6)
        con = d.contact
        empty = np.zeros(0, int)
        g1, g2 = (con.geom1, con.geom2) if d.ncon else (empty, empty)
        # the contacts with the floor or the deck, picked from the arrays (a Python loop over every
        # contact, the board's wheels among them, cost as much as the physics step)
        floor = (g1 == self.floor) | (g2 == self.floor)
        on_deck = (g1 == self.deck_geom) | (g2 == self.deck_geom)  # no board: -1, no geom's id
        pos, frames = (con.pos, con.frame) if d.ncon else (np.zeros((0, 3)), np.zeros((0, 9)))
        for k in np.nonzero(floor | on_deck)[0]:
            base = self.floor if floor[k] else self.deck_geom
            first = int(g1[k]) == base  # the floor or the deck is geom1
            other = int(g2[k]) if first else int(g1[k])
            if other not in self.soles:
                if base == self.floor and other not in self.wheels:
                    others.add(m.geom(other).name or m.body(m.geom_bodyid[other]).name)
                continue
            mujoco.mj_contactForce(m, d, int(k), frame)
            R = frames[k].reshape(3, 3).T
            fw = R @ frame[0:3]  # on geom2 (the sole when the floor or deck is geom1)
            fw = fw if first else -fw
            s = self.soles.index(other)
            force[s] += fw
            moment[s] += _cross(pos[k], fw) + (R @ frame[3:6] * (1 if first else -1))
        zmp = np.full((2, 2), np.nan)
        for s in (0, 1):
            if force[s, 2] > 1.0:
                zmp[s] = _cop(force[s], moment[s], float(d.geom_xpos[self.soles[s]][2]) - SOLE_THICKNESS_M / 2)
        total_f, total_m = force.sum(axis=0), moment.sum(axis=0)
        both = _cop(total_f, total_m, plane_z) if total_f[2] > 1.0 else np.full(2, np.nan)
        pos, yaw, v, wz = np.zeros((2, 3)), np.zeros(2), np.zeros((2, 3)), np.zeros(2)
        for s, g in enumerate(self.soles):
            R = d.geom_xmat[g].reshape(3, 3)
            pos[s], yaw[s] = d.geom_xpos[g], np.arctan2(R[1, 0], R[0, 0])
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_GEOM, g, w, 0)
            v[s], wz[s] = w[3:6], w[2]
        mujoco.mj_subtreeVel(m, d)
        deck: tuple[np.ndarray | None, ...] = (None, None, None)
        if self.deck >= 0:
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, self.deck, w, 0)
            deck = (d.xpos[self.deck].copy(), d.xmat[self.deck].reshape(3, 3).copy(), w[3:6].copy())
        return Truth(float(d.time), d.subtree_com[self.root].copy(), d.subtree_linvel[self.root].copy(),
                     d.xpos[self.root].copy(), d.xmat[self.root].reshape(3, 3).copy(), force, zmp, both, pos, yaw,
                     v, wz, d.actuator_force[self.act].copy(), tuple(sorted(others)), *deck)


def _cop(f: np.ndarray, n: np.ndarray, z: float) -> np.ndarray:
    """The centre of pressure (x, y) on the plane at height ``z`` of a force ``f`` with the moment
    ``n`` about the world origin: the point of that plane about which the moment has no x, y part."""
    return np.array([(z * f[0] - n[1]) / f[2], (n[0] + z * f[1]) / f[2]])

