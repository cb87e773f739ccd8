"""The whole-body controller's share of a closed-loop run, as far as the MPC's verdict needs it:
stance-leg joint angles by inverse kinematics and the joint torques that give the commanded
foot forces.

The robot's kinematics come from the URDF stored in the library (pinocchio, fixed trunk), the
joint order and foot frames from the stored config. Legs are massless here (the force MPC's
single rigid body holds their mass): tau = -J(q)^T f per loaded leg, with f the force the
ground or deck exerts on the foot, both in the trunk frame.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from skatelib.library import schema
from skatelib.runtime import MotionLibrary


@dataclass
class LegKinematics:
    """Pinocchio model of the robot with its trunk fixed; legs in channel order FL FR RL RR.

    Attributes:
        foot_radius_m: Sphere radius of each foot (IK places its centre above the contact point).
        torque_limit_Nm: |tau| bound of every joint.
        lower_rad / upper_rad: (12,) joint limits.
    """

    model: pin.Model
    data: pin.Data
    q_index: np.ndarray
    v_index: np.ndarray
    feet: tuple[int, ...]
    foot_radius_m: float
    torque_limit_Nm: float
    lower_rad: np.ndarray
    upper_rad: np.ndarray

    @staticmethod
    def from_library(lib: MotionLibrary) -> LegKinematics:
        m = lib.quadruped_model  # a library of another kind is refused, named
        robot = json.loads(str(lib.attrs[schema.A_CONFIG_RESOLVED]))["robot"]
        model = pin.buildModelFromXML(lib.urdf)
        joints = [model.getJointId(n) for n in robot["joint_names"]]
        return LegKinematics(
            model=model, data=model.createData(),
            q_index=np.array([model.joints[j].idx_q for j in joints]),
            v_index=np.array([model.joints[j].idx_v for j in joints]),
            feet=tuple(model.getFrameId(f) for f in robot["foot_frames"]),
            foot_radius_m=m.foot_radius_m, torque_limit_Nm=m.torque_limit_Nm,
            lower_rad=m.arrays.joint_lower_rad, upper_rad=m.arrays.joint_upper_rad,
        )

    def _configuration(self, q: np.ndarray) -> np.ndarray:
        qp = pin.neutral(self.model)
        qp[self.q_index] = q
        return qp

    def foot_positions(self, q: np.ndarray) -> np.ndarray:
        """(3, 4) foot centres in the trunk frame."""
        pin.framesForwardKinematics(self.model, self.data, self._configuration(q))
        return np.column_stack([self.data.oMf[f].translation for f in self.feet])

    def inverse(self, targets: np.ndarray, q0: np.ndarray, legs: np.ndarray,
                iterations: int = 20) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles placing the foot centres of ``legs`` (bool (4,)) at ``targets`` (3, 4, trunk
        frame) by damped Newton from ``q0``; the other legs keep ``q0``. Returns (q, residual per
        leg [m])."""
        q = np.array(q0, dtype=float)
        residual = np.zeros(4)
        for _ in range(iterations):
            qp = self._configuration(q)
            pin.computeJointJacobians(self.model, self.data, qp)
            pin.updateFramePlacements(self.model, self.data)
            done = True
            for i in np.nonzero(legs)[0]:
                err = targets[:, i] - self.data.oMf[self.feet[i]].translation
                residual[i] = float(np.linalg.norm(err))
                if residual[i] < 1e-7:
                    continue
                done = False
                J = pin.getFrameJacobian(self.model, self.data, self.feet[i], pin.LOCAL_WORLD_ALIGNED)
                J = J[:3, self.v_index[3 * i:3 * i + 3]]
                q[3 * i:3 * i + 3] += np.linalg.solve(J.T @ J + 1e-6 * np.eye(3), J.T @ err)
            if done:
                break
        final = self.foot_positions(q)
        residual = np.where(legs, np.linalg.norm(targets - final, axis=0), 0.0)
        return q, residual

    def torque_maps(self, q: np.ndarray, R: np.ndarray) -> np.ndarray:
        """(4, 3, 3) per leg -J(q)^T R^T: its joint torques from its foot force in the world."""
        qp = self._configuration(q)
        pin.computeJointJacobians(self.model, self.data, qp)
        pin.updateFramePlacements(self.model, self.data)
        out = np.zeros((4, 3, 3))
        for i in range(4):
            J = pin.getFrameJacobian(self.model, self.data, self.feet[i], pin.LOCAL_WORLD_ALIGNED)
            out[i] = -J[:3, self.v_index[3 * i:3 * i + 3]].T @ R.T
        return out

    def torques(self, q: np.ndarray, forces_trunk: np.ndarray, legs: np.ndarray) -> np.ndarray:
        """(12,) joint torques that make each loaded leg's foot hold the contact force
        ``forces_trunk`` (3, 4; what the ground or deck exerts on the foot) with massless legs."""
        maps = self.torque_maps(q, np.eye(3))
        return np.concatenate([maps[i] @ forces_trunk[:, i] if legs[i] else np.zeros(3) for i in range(4)])
