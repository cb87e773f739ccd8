"""An independent numpy implementation of the paper's equations, for tests only.

Foot positions come from pinocchio (not from skatelib's CasADi chain); rotations, the Euler
rate map and the board equations are written out again from the paper, Eq. (3)-(10).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    # Z-Y-X: R = Rz(y) Ry(p) Rx(r), multiplied out by hand.
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def euler_rates(r: float, p: float, w: np.ndarray) -> np.ndarray:
    # Inverse of the body-rate map omega = E(theta) theta_dot, solved numerically.
    E = np.array([[1, 0, -np.sin(p)], [0, np.cos(r), np.sin(r) * np.cos(p)], [0, -np.sin(r), np.cos(r) * np.cos(p)]])
    return np.linalg.solve(E, w)


def foot_centres_world(system, x: np.ndarray) -> np.ndarray:
    """(4, 3) foot sphere centres via pinocchio forward kinematics."""
    robot = system.robot
    R = rpy_matrix(*x[3:6])
    trunk_origin = x[0:3] - R @ system.srb.com_offset_m
    qp = robot.pin_configuration(trunk_origin, R, x[12:24])
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, qp)
    return np.array([data.oMf[robot.model.getFrameId(f)].translation for f in robot.foot_frames])


def truck_torque(b, phi: float, d: float = 1e-6) -> float:
    """The trucks' torque on the deck as -dE/dphi of their two hinge springs (k = K_B cos^2 / 2
    each), each hanger turned by the angle that keeps its wheels level: a numerical derivative of
    the energy, not the closed form the dynamics use."""
    c = np.cos(b.pivot_rad)

    def energy(p: float) -> float:
        theta = np.arctan(np.tan(p) / c)  # hanger level: sin(p) cos(theta) + cos(p) c sin(theta) = 0
        return 2 * 0.5 * (b.roll_stiffness_Nm_per_rad * c * c / 2) * theta**2

    return -(energy(phi + d) - energy(phi - d)) / (2 * d)


def xdot(system, mode, x: np.ndarray, u: np.ndarray, cr: np.ndarray) -> np.ndarray:
    m, I = system.srb.mass_kg, system.srb.inertia_kgm2
    g = np.array([0, 0, -system.gravity_mps2])
    b = system.board
    r = system.foot_radius_m
    R = rpy_matrix(*x[3:6])
    yaw, phi, psi = x[5], x[26], x[27]
    RB = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]) @ np.array(
        [[1, 0, 0], [0, np.cos(phi), -np.sin(phi)], [0, np.sin(phi), np.cos(phi)]]
    )
    f = u[:12].reshape(4, 3)
    centres = foot_centres_world(system, x)
    F, tau = np.zeros(3), np.zeros(3)
    for i in range(4):
        normal = RB[:, 2] if mode.board_legs[i] else np.array([0, 0, 1.0])
        if mode.robot_legs[i]:
            F += f[i]
            tau += np.cross(centres[i] - r * normal - x[0:3], f[i])
    w = x[9:12]
    vdot = F / m + g
    wdot = np.linalg.solve(I, R.T @ tau - np.cross(w, I @ w))
    tb, fb = np.zeros(3), np.zeros(3)
    h = b.roll_axis_depth_m  # the deck rolls about its axles, h below its top
    for i in range(4):
        if mode.board_legs[i]:
            rb = RB @ np.array([cr[0, i], cr[1, i], h])
            tb += np.cross(rb, f[i])
            fb += f[i]
    psidot = (
        -(RB.T @ tb)[0] + truck_torque(b, phi) - b.roll_damping_Nms_per_rad * psi
        + b.deck_mass_kg * system.gravity_mps2 * h * np.sin(phi)
    ) / b.roll_inertia_kgm2
    if mode.accelerating:
        v_fwd = np.cos(yaw) * x[24] + np.sin(yaw) * x[25]
        load = b.mass_kg * system.gravity_mps2 + fb[2]  # the wheels carry the board and the feet on it
        a = (-(RB.T @ fb)[0] - np.tanh(b.tanh_scale_s_per_m * v_fwd) * b.rolling_coeff * load) / b.mass_kg
        vb = (RB @ np.array([a, 0, 0]))[:2]
    else:
        a = (R.T @ vdot)[0]
        vb = np.array([np.cos(yaw) * a, np.sin(yaw) * a])
    # The wheels roll: the board's velocity turns with its yaw (v_fwd times the yaw rate, across).
    rates = euler_rates(x[3], x[4], w)
    v_fwd = np.cos(yaw) * x[24] + np.sin(yaw) * x[25]
    vb = vb + v_fwd * rates[2] * np.array([-np.sin(yaw), np.cos(yaw)])
    return np.concatenate([x[6:9], rates, vdot, wdot, u[12:24], vb, [psi, psidot]])
