"""The riding stance: three feet on the deck, the push foot lifted beside it, the body where each
deck foot carries a share of the weight. Every entry ends there (within ``[terminal]``'s
tolerances) and every transition from riding starts there, so that entries chain.

Statics decide where the body can be: on three feet without a moment at the feet, the centre of
mass divides the weight among them by its barycentric coordinates in their triangle. The stance's
nominal body sits over the line between the push foot's diagonal neighbours, which loads one deck
foot too little once the push foot is lifted; the riding body is the pose nearest the four-leg
stance (:func:`riding_pose`: trunk x, y, roll and pitch, joint angles) at the stance's trunk height
whose centre of mass gives each deck foot at least ``[stance] ride_load_fraction`` of the weight,
with the feet on their deck points, the push foot at its lifted point and the joints inside their
limits by the planning margin.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
from skatelib.library.errors import ModelError
from skatelib.pipeline.build import interrupt
from skatelib.pipeline.ocp.rotations import rpy_to_matrix

ATTITUDE_MAX_RAD = 0.02  # the riding trunk's roll and pitch: near level, inside the end's tolerance


def barycentric(triangle: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (3,) of ``point`` (2,) in ``triangle`` (3, 2): the weight shares of
    three feet at the vertices carrying a body whose centre of mass is over ``point``."""
    a, b, c = triangle
    T = np.column_stack([b - a, c - a])
    lb, lc = np.linalg.solve(T, point - a)
    return np.array([1.0 - lb - lc, lb, lc])


def riding_pose(robot: Any, targets: np.ndarray, com_offset: np.ndarray, push: int, q_nominal: np.ndarray,
                limits: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Trunk (x, y, roll, pitch) and joint angles (12,) of the riding stance, by a small NLP (IPOPT).

    Args:
        robot: The :class:`~skatelib.pipeline.quadruped.model.robot.Quadruped`.
        targets: (4, 3) foot centres relative to the nominal trunk origin (the four-leg stance's
            frame, the push foot at its lifted point) [m].
        com_offset: The centre of mass in the trunk frame [m].
        push: The push leg's index; the other three stand on the deck.
        q_nominal: The four-leg stance's joint angles, what the pose stays near [rad].
        limits: The least share of the weight on each deck foot [-] and the distance kept from the
            joint limits [rad].

    Raises:
        ModelError: When no such pose exists (the message says what to change).
    """
    fraction, margin_rad = limits
    deck = [i for i in range(4) if i != push]
    z = ca.SX.sym("z", 16)  # trunk x, y, roll, pitch; joints
    R = rpy_to_matrix(ca.vertcat(z[2], z[3], 0))
    trunk = ca.vertcat(z[0], z[1], 0)
    feet = trunk + R @ robot.foot_positions_body(z[4:])
    com = (trunk + R @ ca.DM(com_offset))[0:2]
    tri = targets[deck, 0:2]
    a, T = tri[0], np.column_stack([tri[1] - tri[0], tri[2] - tri[0]])
    lam = ca.DM(np.linalg.inv(T)) @ (com - ca.DM(a))
    shares = ca.vertcat(1 - lam[0] - lam[1], lam[0], lam[1])
    g = ca.vertcat(ca.vec(feet - ca.DM(targets.T)), shares)
    lo_q, hi_q = robot.lower_limits + margin_rad, robot.upper_limits - margin_rad
    lbx = np.r_[-0.2, -0.2, -ATTITUDE_MAX_RAD, -ATTITUDE_MAX_RAD, lo_q]
    ubx = np.r_[0.2, 0.2, ATTITUDE_MAX_RAD, ATTITUDE_MAX_RAD, hi_q]
    f = ca.sumsqr(z[4:] - ca.DM(q_nominal)) + 100 * ca.sumsqr(z[:4])
    solver = ca.nlpsol("riding", "ipopt", {"x": z, "f": f, "g": g},
                       {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-10})
    x0 = np.r_[0.0, 0.0, 0.0, 0.0, np.clip(q_nominal, lo_q, hi_q)]
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=np.r_[np.zeros(12), np.full(3, fraction)],
                 ubg=np.r_[np.zeros(12), np.full(3, np.inf)])
    interrupt.check()  # not a stance that failed: Ctrl-C, which CasADi swallowed
    if not solver.stats()["success"]:
        raise ModelError(f"no riding stance with each deck foot carrying {fraction:.0%} of the weight, the trunk "
                         f"near level and the joints {margin_rad} rad inside their limits "
                         f"({solver.stats()['return_status']}): lower [stance] ride_load_fraction or change the stance")
    zs = np.asarray(sol["x"]).reshape(-1)
    return zs[:4], zs[4:]
