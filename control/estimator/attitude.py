"""The trunk's attitude from the IMU: the gyroscope integrated on SO(3), its bias from the robot
standing still before it rides, the tilt held to the accelerometer's gravity by a slow
nonlinear complementary filter (Mahony et al. 2008, "Nonlinear complementary filters on the
special orthogonal group", Eq. 13 without the bias integrator):

    R_{k+1} = R_k Exp((omega_m - b_g + k_P e) dt)

The accelerometer reads gravity plus the trunk's acceleration: a board coasting down at 0.2 m/s^2
tilts its gravity 0.02 rad. A ride on a board slows down nearly all the time (rolling friction,
brakes), so taken for gravity that tilt would pull the attitude backwards at every tick, by
k_P * a / g (0.4 mrad/s at 0.2 m/s^2), and the tilt would read the deceleration as gravity (g times
the attitude's error: 4-13 mm/s^2 after 1-3 s, a coast that seems to slow down less than it does).
So the reference is the reading less the trunk's acceleration as the position filter knows it
(``accel_world``, its velocity's change over the last tick, world frame) and its estimate of the
accelerometer's bias ``b_a``:

    e = (f / |f|) x (R_k^T e_z),   f = a_m - b_a - R_k^T a_world

Where only the IMU knows the acceleration (no foot on the floor) f is the gravity the filter
already holds and e is zero: the gyroscope carries the attitude. Where the legs correct the
velocity (a foot on the floor, the robot standing), what they correct is the tilt's error (an
attitude off by d makes the integrated velocity drift by g d), and e pulls the attitude back.
The gain is low (a time constant of ``1 / k_P`` = 50 s) and references more than 10 % from g
are left out. After the standstill calibration the gyroscope's bias is the calibration's
residual.

The calibration (the robot standing still before it rides) also levels the filter: its roll and
pitch are those that put the mean accelerometer reading on gravity (its heading is kept). The
accelerometer's bias then tilts the attitude by b / g, and the two cancel in the horizontal
acceleration the position filter integrates, as long as the trunk's attitude stays near the
calibration's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from skatelib.control.estimator.vec3 import cross, exp_so3

__all__ = ["AttitudeFilter", "AttitudeSettings", "exp_so3"]


@dataclass(frozen=True)
class AttitudeSettings:
    """Gain [1/s] and acceleration gate of the tilt correction; gravity [m/s^2]."""

    k_tilt: float = 0.02
    gate: float = 0.1
    gravity_mps2: float = 9.81


def _onto(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` onto unit vector ``b``."""
    w = np.cross(a, b)
    norm = float(np.linalg.norm(w))
    return exp_so3(w / norm * math.atan2(norm, float(a @ b))) if norm > 1e-12 else np.eye(3)


class AttitudeFilter:
    """The trunk's rotation (trunk to world) and angular velocity (trunk frame)."""

    def __init__(self, R0: np.ndarray, settings: AttitudeSettings | None = None, mount: np.ndarray | None = None):
        self.R = np.array(R0, dtype=float)
        self.s = settings or AttitudeSettings()
        self.gyro_bias = np.zeros(3)
        self.mount = np.eye(3) if mount is None else mount  # the IMU's axes in the trunk frame
        self.turned = mount is not None and not np.array_equal(mount, np.eye(3))  # readings to turn
        self.omega = np.zeros(3)
        self.accel = np.zeros(3)  # the last specific force (trunk frame)

    def calibrate(self, gyro: Sequence[np.ndarray], accel: Sequence[np.ndarray]) -> None:
        """The gyroscope's bias and the tilt from readings taken standing still (module docstring)."""
        self.gyro_bias = np.mean(np.asarray(gyro), axis=0)
        up = self.mount @ np.mean(np.asarray(accel), axis=0)
        self.still_up = up / np.linalg.norm(up)  # gravity's direction at the standstill (trunk frame)
        self._level(self.still_up)

    def align_mount(self, up: np.ndarray) -> None:
        """After :meth:`calibrate`: the trunk's up known otherwise (``up``, trunk frame, unit): the
        IMU's mounting turned so that the standstill's gravity reads along it (a tilted mount,
        and the accelerometer's bias with it), the filter levelled on it."""
        self.mount = _onto(self.still_up, up) @ self.mount
        self.turned = True
        self.still_up = up
        self._level(up)

    def _level(self, up: np.ndarray) -> None:
        # The smallest rotation that turns the filter's up (R^T e_z) onto ``up``.
        w = np.cross(self.R[2], up)
        angle = math.atan2(float(np.linalg.norm(w)), float(self.R[2] @ up))
        if angle > 1e-12:
            self.R = self.R @ exp_so3(-w / np.linalg.norm(w) * angle)

    def update(self, gyro: np.ndarray, accel: np.ndarray, dt: float, accel_world: np.ndarray | None = None,
               accel_bias: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One reading (IMU frame) over ``dt`` [s], with the trunk's acceleration as known besides
        (world frame [m/s^2]; None: taken as zero) and the accelerometer's bias as estimated
        besides (trunk frame [m/s^2]; None: zero): the rotation and the angular velocity."""
        omega, a = gyro - self.gyro_bias, accel
        if self.turned:
            omega, a = self.mount @ omega, self.mount @ a
        f = a if accel_world is None else a - self.R.T @ accel_world
        if accel_bias is not None:
            f = f - accel_bias
        norm = math.sqrt(float(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]))
        w = omega
        if abs(norm - self.s.gravity_mps2) < self.s.gate * self.s.gravity_mps2:
            w = omega + self.s.k_tilt * cross(f / norm, self.R[2])  # R^T e_z is R's third row
        self.R = self.R @ exp_so3(w * dt)
        self.omega, self.accel = omega, a
        return self.R, omega
