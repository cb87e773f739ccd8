"""Rotations in numpy, for every part of skatelib that is not a CasADi expression (the runtime,
the physics checks, the views and the reference controller): the trunk's Z-Y-X Euler angles, the
deck's yaw-then-roll (Eq. 7), unit quaternions, the Euler-rate map of Eq. (3) and the cross-product matrix. The
optimizer's symbolic twins are in ``skatelib.pipeline.ocp.rotations``; a test holds the two equal."""

from __future__ import annotations

import math

import numpy as np


def rpy_matrices(rpy: np.ndarray) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), trunk frame to world, for Z-Y-X angles (..., 3): (..., 3, 3)."""
    if np.ndim(rpy) == 1:  # one attitude (a controller's hot path): no stacking
        cr, sr, cp, sp, cy, sy = (f(float(a)) for a in (rpy[0], rpy[1], rpy[2]) for f in (math.cos, math.sin))
        return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                         [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], [-sp, cp * sr, cp * cr]])
    r, p, y = rpy[..., 0], rpy[..., 1], rpy[..., 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack([np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
                     np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
                     np.stack([-sp, cp * sr, cp * cr], -1)], axis=-2)


def board_rotations(yaw: np.ndarray | float, roll: np.ndarray | float) -> np.ndarray:
    """R_B = Rz(yaw) Rx(roll) for arrays of angles (or scalars): (..., 3, 3), deck frame to world."""
    if np.ndim(yaw) == 0 and np.ndim(roll) == 0:  # one attitude (a controller's hot path): no stacking
        c, s, c_r, s_r = math.cos(yaw), math.sin(yaw), math.cos(roll), math.sin(roll)
        return np.array([[c, -s * c_r, s * s_r], [s, c * c_r, -c * s_r], [0.0, s_r, c_r]])
    cy, sy, cr, sr = np.cos(yaw), np.sin(yaw), np.cos(roll), np.sin(roll)
    z = np.zeros_like(yaw)
    return np.stack([np.stack([cy, -sy * cr, sy * sr], -1), np.stack([sy, cy * cr, -cy * sr], -1),
                     np.stack([z, sr, cr], -1)], axis=-2)


def quaternion_matrices(q_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrices (K, 3, 3) of unit quaternions (K, 4) given as x, y, z, w."""
    x, y, z, w = (np.asarray(q_xyzw, dtype=np.float64)[:, i] for i in range(4))
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                     np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                     np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def euler_rate_map(rpy: np.ndarray) -> np.ndarray:
    """T(theta): d(rpy)/dt = T omega for the body-frame angular velocity omega (Z-Y-X angles, Eq. 3)."""
    r, p = rpy[0], rpy[1]
    sr, cr, cp, tp = np.sin(r), np.cos(r), np.cos(p), np.tan(p)
    return np.array([[1.0, sr * tp, cr * tp], [0.0, cr, -sr], [0.0, sr / cp, cr / cp]])


def skew(v: np.ndarray) -> np.ndarray:
    """[v]x, with skew(a) @ b = a x b."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def yaw_of(R: np.ndarray) -> float:
    """The heading of a rotation R = Rz(yaw) Rx(roll) (a deck's) [rad]."""
    return float(np.arctan2(R[1, 0], R[0, 0]))


def roll_of(R: np.ndarray) -> float:
    """The roll about the rotated x axis of R = Rz(yaw) Ry(pitch) Rx(roll) [rad] (Z-Y-X angles)."""
    return float(np.arctan2(R[2, 1], R[2, 2]))
