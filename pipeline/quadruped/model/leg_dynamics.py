"""Joint torques of a push-off with the legs' own mass: pinocchio inverse dynamics (RNEA) of the
whole URDF, independent of the optimizer's single-rigid-body model and its massless legs.

The TO limits the quasi-static torques ``-J^T f`` (massless legs). About half of CyberDog2's mass
is in its legs, so fast pushes and swings need more torque than that: here the trunk follows the
stored trajectory (its centre of mass, attitude and their rates, accelerations by differences
between knots), the joints follow the stored angles and velocities (accelerations by central
differences of the held joint velocities, as a tracking controller would smooth them), the
contact forces act at the contact points, and RNEA gives ``tau = M a + h - J_c^T f``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from skatelib.library.channels import S_OMEGA, S_POS, S_Q, S_RPY, S_VEL, SWING, U_QD
from skatelib.pipeline.quadruped.model.system import SkateSystem


def rigid_leg_torques(system: SkateSystem, t: np.ndarray, state: np.ndarray, control: np.ndarray,
                      contact: np.ndarray, foot_pos: np.ndarray) -> np.ndarray:
    """Joint torques [N m] per control interval, (K-1, 12) in channel order, with massive legs."""
    robot = system.robot
    model = robot.model
    data = model.createData()
    c = system.srb.com_offset_m
    v_index = np.array([model.joints[model.getJointId(n)].idx_v for n in robot.joint_names])
    feet = [model.getFrameId(f) for f in robot.foot_frames]
    n = len(control)
    dt = np.diff(t)
    qd = control[:, U_QD]
    qdd = np.gradient(qd, t[:n], axis=0) if n > 1 else np.zeros_like(qd)
    out = np.zeros((n, 12))
    for k in range(n):
        x, x1 = state[k], state[k + 1]
        R = pin.rpy.rpyToMatrix(*x[S_RPY])
        w, w_dot = x[S_OMEGA], (x1[S_OMEGA] - x[S_OMEGA]) / dt[k]
        a_com = (x1[S_VEL] - x[S_VEL]) / dt[k]
        # Trunk origin = COM - R c (the COM is fixed in the trunk frame in the SRB model).
        v_origin = x[S_VEL] - R @ np.cross(w, c)
        a_origin = a_com - R @ (np.cross(w_dot, c) + np.cross(w, np.cross(w, c)))
        q = robot.pin_configuration(x[S_POS] - R @ c, R, x[S_Q])
        v = np.zeros(model.nv)
        a = np.zeros(model.nv)
        v_local = R.T @ v_origin
        v[:3], v[3:6], v[v_index] = v_local, w, qd[k]
        a[:3] = R.T @ a_origin - np.cross(w, v_local)  # pinocchio's spatial acceleration of the base
        a[3:6], a[v_index] = w_dot, qdd[k]
        tau = pin.rnea(model, data, q, v, a).copy()
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        for i, fid in enumerate(feet):
            if contact[k, i] == SWING:
                continue
            J = pin.getFrameJacobian(model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            d = foot_pos[k, i] - data.oMf[fid].translation  # centre -> contact point
            J_point = J[:3] - pin.skew(d) @ J[3:]
            tau -= J_point.T @ control[k, 3 * i: 3 * i + 3]
        out[k] = tau[v_index]
    return out


__all__ = ["rigid_leg_torques"]
