"""The robot as the whole-body controller sees it: the URDF the library stores as a floating-base
multibody (pinocchio), with the rotors' reflected inertia on the joints, and the quantities one
whole-body update needs at the measured state: mass matrix, bias forces, and for the feet and the
centre of mass (the whole robot's, legs included: the point whose acceleration is the contact
forces' sum over the mass, as the library's channels define it) the Jacobians and J-dot v, all in
the world frame.

Conventions: pinocchio's free-flyer configuration (position, quaternion x y z w, the 12 joints in
the library's channel order after a permutation) and velocity (the trunk's linear and angular
velocity in the trunk frame, then the joints).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from skatelib.library import schema

# The twin's rotor inertia reflected through the 7.75:1 gearbox (docs/twin.md): part of what the
# controller knows of its robot, as any model-based controller of a geared leg does.
ROTOR_ARMATURE_KGM2 = 2.55e-5 * 7.75**2


@dataclass
class DynamicsTerms:
    """One state's terms (nv = 18)."""

    M: np.ndarray  # (18, 18)
    h: np.ndarray  # (18,) Coriolis, centrifugal and gravity
    J_feet: np.ndarray  # (4, 3, 18) foot centres' linear Jacobians, world axes
    dJv_feet: np.ndarray  # (4, 3) their classical accelerations at zero joint acceleration
    J_com: np.ndarray  # (3, 18) of the centre of mass
    dJv_com: np.ndarray  # (3,)
    feet: np.ndarray  # (3, 4) foot centres
    com: np.ndarray  # (3,) the centre of mass
    com_v: np.ndarray  # (3,) its velocity


class RobotDynamics:
    """Pinocchio's floating-base model of the library's robot."""

    def __init__(self, urdf: str, joint_names: list[str], foot_frames: list[str],
                 armature_kgm2: float = ROTOR_ARMATURE_KGM2):
        self.model: Any = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
        model = self.model
        joints = [model.getJointId(n) for n in joint_names]
        self.q_index = np.array([model.joints[j].idx_q for j in joints])
        self.v_index = np.array([model.joints[j].idx_v for j in joints])
        # the joints in channel order are pinocchio's (a URDF's legs in order): joined, not scattered
        self._in_order = (np.array_equal(self.q_index, np.arange(7, model.nq))
                          and np.array_equal(self.v_index, np.arange(6, model.nv)))
        model.armature[6:] = armature_kgm2
        self.feet = [model.getFrameId(f) for f in foot_frames]
        self.data: Any = model.createData()
        self.mass_kg = float(pin.computeTotalMass(model))
        below = np.tril_indices(model.nv, -1)  # M's lower triangle, as flat indices, and its mirror
        self._below = np.ravel_multi_index(below, (model.nv, model.nv))
        self._above = np.ravel_multi_index(below[::-1], (model.nv, model.nv))

    @staticmethod
    def from_library(lib: Any) -> RobotDynamics:
        _ = lib.quadruped_model  # a library of another kind is refused, named
        robot = json.loads(str(lib.attrs[schema.A_CONFIG_RESOLVED]))["robot"]
        return RobotDynamics(lib.urdf, robot["joint_names"], robot["foot_frames"])

    def configuration(self, trunk_pos: np.ndarray, trunk_R: np.ndarray, q: np.ndarray,
                      trunk_v_world: np.ndarray, trunk_omega: np.ndarray, qd: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Pinocchio's (q, v) from a trunk pose, world-frame trunk velocity, trunk-frame angular
        velocity and the joints in channel order."""
        quaternion = pin.Quaternion(trunk_R).coeffs()
        if self._in_order:
            return (np.concatenate((trunk_pos, quaternion, q)),
                    np.concatenate((trunk_R.T @ trunk_v_world, trunk_omega, qd)))
        qp = np.zeros(self.model.nq)
        qp[0:3] = trunk_pos
        qp[3:7] = quaternion
        qp[self.q_index] = q
        vp = np.zeros(self.model.nv)
        vp[0:3] = trunk_R.T @ trunk_v_world
        vp[3:6] = trunk_omega
        vp[self.v_index] = qd
        return qp, vp

    def terms(self, qp: np.ndarray, vp: np.ndarray) -> DynamicsTerms:
        model, data = self.model, self.data
        # M (its upper triangle), h, the joint Jacobians, the COM and its Jacobian; its bias pass
        # (the recursive Newton-Euler at zero qdd) leaves the bodies' accelerations at zero qdd in
        # data.a, from which J-dot v follows (a test holds it to the rate of J(q) v along the motion).
        pin.computeAllTerms(model, data, qp, vp)
        M = data.M.copy()
        flat = M.reshape(-1)
        flat[self._below] = flat[self._above]
        h, J_com, com, com_v = data.nle.copy(), data.Jcom.copy(), data.com[0].copy(), data.vcom[0].copy()
        world = pin.LOCAL_WORLD_ALIGNED
        # Each foot's frame placed (only theirs: what the frames below read), then its Jacobian and
        # classical acceleration.
        feet = np.array([pin.updateFramePlacement(model, data, f).translation for f in self.feet]).T
        J_feet = np.array([pin.getFrameJacobian(model, data, f, world)[:3] for f in self.feet])
        dJv = np.array([pin.getFrameClassicalAcceleration(model, data, f, world).linear for f in self.feet])
        pin.centerOfMass(model, data, pin.KinematicLevel.ACCELERATION, False)
        return DynamicsTerms(M=M, h=h, J_feet=J_feet, dJv_feet=dJv, J_com=J_com, dJv_com=data.acom[0].copy(),
                             feet=feet, com=com, com_v=com_v)
