"""Z-Y-X Euler angles: rotation matrices and the rate map T(theta) of Eq. (3)."""

from __future__ import annotations

from typing import Any

import casadi as ca


def rot_x(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(a: Any) -> Any:
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rpy_to_matrix(rpy: Any) -> Any:
    """R = Rz(yaw) Ry(pitch) Rx(roll): trunk-frame vectors to the world."""
    return rot_z(rpy[2]) @ rot_y(rpy[1]) @ rot_x(rpy[0])


def euler_rate_map(rpy: Any) -> Any:
    """T(theta) with d(rpy)/dt = T(theta) omega_body for Z-Y-X angles (Eq. 3)."""
    r, p = rpy[0], rpy[1]
    sr, cr, tp, cp = ca.sin(r), ca.cos(r), ca.tan(p), ca.cos(p)
    return ca.vertcat(
        ca.horzcat(1, sr * tp, cr * tp),
        ca.horzcat(0, cr, -sr),
        ca.horzcat(0, sr / cp, cr / cp),
    )
