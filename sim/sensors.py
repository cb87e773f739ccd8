"""The robot's sensors on the twin: a 6-axis IMU on the trunk and the twelve joint encoders, read
at every whole-body tick, with their errors (seeded). No foot force sensors: CyberDog2 has none.

IMU (at the trunk frame's origin, its axes the trunk's; CyberDog2's IMU placement is not
published). Its figures are a Bosch BMI088's (datasheet BST-BMI088-DS001, docs/sources.md):

* gyroscope: the mean angular velocity over the tick (the rotation from the last reading to this
  one, as an IMU's delta-angle output gives it), plus white noise of the datasheet's noise density,
  a bias random walk and a constant bias per run;
* accelerometer: the specific force at the IMU, averaged over the tick (the trunk's velocity change
  over the tick plus g, in the trunk frame: what an accelerometer's anti-alias filter passes),
  with white noise, a bias random walk and a constant bias per run.

Encoders: the joint angle from a 14-bit magnetic encoder on the rotor through the 7.75:1 gearbox
(2 pi / 2^14 / 7.75 = 4.9e-5 rad a count), and the joint velocity as the firmware computes it
from those counts: their difference over one tick, low-passed (first order, ``velocity_cutoff_hz``).

A delay of ``delay_s`` (rounded to ticks) holds every reading back.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


class TwinPlant(Protocol):
    """What the sensors read of :class:`skatelib.sim.plant.TwinPlant`: MuJoCo's data and where the
    trunk's free joint and the leg joints sit in it."""

    d: Any  # mujoco.MjData
    trunk_q: int
    trunk_v: int
    qadr: np.ndarray

GRAVITY_MPS2 = 9.81
DEG = math.pi / 180.0
MG = 1e-3 * GRAVITY_MPS2


@dataclass(frozen=True)
class ImuFigures:
    """One IMU's error figures (per axis, 1 sigma).

    Attributes:
        gyro_noise: White noise density [rad/s/sqrt(Hz)] (BMI088: 0.014 deg/s/sqrt(Hz)).
        gyro_bias: Constant bias of a run [rad/s] (BMI088's zero-rate offset: +-1 deg/s; the
            robot averages its gyro while it stands still before it rides).
        gyro_walk: Bias random walk [rad/s/sqrt(s)] (BMI088's bias stability, 2 deg/h, reached
            over about 100 s).
        accel_noise: White noise density [m/s^2/sqrt(Hz)] (BMI088: 175 ug/sqrt(Hz)).
        accel_bias: Constant bias of a run [m/s^2] (2 mg: what a six-face calibration leaves of the
            datasheet's +-20 mg zero-g offset).
        accel_walk: Bias random walk [m/s^2/sqrt(s)] (0.2 mg/K offset drift, a kelvin in 100 s).
    """

    gyro_noise: float = 0.014 * DEG
    gyro_bias: float = 1.0 * DEG
    gyro_walk: float = 2.0 * DEG / 3600.0 / 10.0
    accel_noise: float = 175e-6 * GRAVITY_MPS2
    accel_bias: float = 2.0 * MG
    accel_walk: float = 0.2 * MG / 10.0


@dataclass(frozen=True)
class SensorErrors:
    """The sensors of one run: the IMU's figures scaled, fixed offsets, the delay.

    Attributes:
        noise_scale: Factor on every white noise and random walk.
        gyro_bias_rad_s: Added to the gyroscope's drawn constant bias (x, y, z).
        accel_bias_mps2: Added to the accelerometer's (x, y, z).
        encoder_offset_rad: A fixed offset on joint ``encoder_joint`` (channel order).
        imu_tilt_rad: The IMU mounted rolled by this much about the trunk's x axis.
        delay_s: Every reading this late.
    """

    imu: ImuFigures = ImuFigures()
    noise_scale: float = 1.0
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_bias_mps2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    encoder_offset_rad: float = 0.0
    encoder_joint: int = 1
    imu_tilt_rad: float = 0.0
    encoder_rad: float = 2 * math.pi / 2**14 / 7.75
    velocity_cutoff_hz: float = 200.0
    delay_s: float = 0.0


@dataclass(frozen=True)
class SensorReading:
    """One tick's readings: ``gyro`` [rad/s] and ``accel`` [m/s^2] in the IMU's frame, joint
    angles ``q`` [rad] and velocities ``qd`` [rad/s] in channel order, at time ``t`` [s]."""

    t: float
    gyro: np.ndarray
    accel: np.ndarray
    q: np.ndarray
    qd: np.ndarray


def rotation_log(R: np.ndarray) -> np.ndarray:
    """The rotation vector of a rotation matrix."""
    c = max(-1.0, min(1.0, (float(np.trace(R)) - 1.0) / 2.0))
    a = math.acos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return w / 2.0 if a < 1e-6 else w * (a / (2.0 * math.sin(a)))


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class TwinSensors:
    """The IMU and encoders of a :class:`skatelib.sim.plant.TwinPlant`, read once per tick of
    ``tick_s``; ``seed`` draws the run's biases and noise."""

    def __init__(self, plant: TwinPlant, tick_s: float, errors: SensorErrors, seed: int):
        self.plant, self.dt, self.e = plant, tick_s, errors
        self.rng = np.random.default_rng(seed)
        f, s = errors.imu, errors.noise_scale
        self.gyro_bias = self.rng.normal(0.0, f.gyro_bias, 3) + np.array(errors.gyro_bias_rad_s)
        self.accel_bias = self.rng.normal(0.0, f.accel_bias, 3) + np.array(errors.accel_bias_mps2)
        self.gyro_sd = s * f.gyro_noise / math.sqrt(tick_s)
        self.accel_sd = s * f.accel_noise / math.sqrt(tick_s)
        self.gyro_step = s * f.gyro_walk * math.sqrt(tick_s)
        self.accel_step = s * f.accel_walk * math.sqrt(tick_s)
        c, sn = math.cos(errors.imu_tilt_rad), math.sin(errors.imu_tilt_rad)
        self.mount = np.array([[1.0, 0.0, 0.0], [0.0, c, -sn], [0.0, sn, c]])  # IMU axes in the trunk frame
        self.queue: deque[SensorReading] = deque(maxlen=max(0, round(errors.delay_s / tick_s)) + 1)
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._qd = np.zeros(12)

    def _truth(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        p, d = self.plant, self.plant.d
        R = quat_matrix(d.qpos[p.trunk_q + 3:p.trunk_q + 7])
        return R, d.qvel[p.trunk_v:p.trunk_v + 3].copy(), d.qpos[p.qadr].copy(), float(d.time)

    def _encoders(self, q_true: np.ndarray) -> np.ndarray:
        q = q_true.copy()
        q[self.e.encoder_joint] += self.e.encoder_offset_rad
        return np.asarray(np.round(q / self.e.encoder_rad) * self.e.encoder_rad)

    def standstill(self, n: int) -> list[SensorReading]:
        """``n`` ticks of readings with the robot as it is now but at rest (the robot standing
        still before it rides: what its gyroscope calibration averages)."""
        R, _, q_true, t = self._truth()
        q = self._encoders(q_true)
        out = []
        for k in range(n):
            self._walk()
            gyro = self.gyro_bias + self.rng.normal(0.0, self.gyro_sd, 3)
            accel = R.T @ np.array([0.0, 0.0, GRAVITY_MPS2]) + self.accel_bias + self.rng.normal(0.0, self.accel_sd, 3)
            out.append(SensorReading(t - (n - k) * self.dt, self.mount.T @ gyro, self.mount.T @ accel, q, np.zeros(12)))
        return out

    def _walk(self) -> None:
        self.gyro_bias = self.gyro_bias + self.rng.normal(0.0, self.gyro_step, 3)
        self.accel_bias = self.accel_bias + self.rng.normal(0.0, self.accel_step, 3)

    def read(self) -> SensorReading:
        """This tick's readings (``delay_s`` old); the first call reads a still robot's rates."""
        R, v, q_true, t = self._truth()
        last = self._last or (R, v, q_true)
        R0, v0, q0 = last
        self._last = (R, v, q_true)
        self._walk()
        omega = rotation_log(R0.T @ R) / self.dt  # trunk frame, mean over the tick
        specific = R.T @ ((v - v0) / self.dt + np.array([0.0, 0.0, GRAVITY_MPS2]))
        gyro = self.mount.T @ omega + self.gyro_bias + self.rng.normal(0.0, self.gyro_sd, 3)
        accel = self.mount.T @ specific + self.accel_bias + self.rng.normal(0.0, self.accel_sd, 3)
        q = self._encoders(q_true)
        diff = (q - self._encoders(q0)) / self.dt
        a = 1.0 - math.exp(-2 * math.pi * self.e.velocity_cutoff_hz * self.dt)
        self._qd = self._qd + a * (diff - self._qd)
        self.queue.append(SensorReading(t, gyro, accel, q, self._qd.copy()))
        return self.queue[0]
