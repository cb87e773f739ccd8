"""A robot from a library's URDF in a Rerun recording: pinocchio's model and visual shapes, posed
at every knot (both robot kinds use it)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import rerun as rr
from skatelib.library.channels import LEGS
from skatelib.library.urdf import without_meshes
from skatelib.pipeline.views.rerun_parts import time_index


class Robot:
    """Pinocchio model and visual shapes from the URDF stored in the library: its primitive shapes
    only (mesh files named in it are not read, :mod:`skatelib.library.urdf`)."""

    def __init__(self, urdf_text: str):
        urdf_text = without_meshes(urdf_text)
        self.model = pin.buildModelFromXML(urdf_text, pin.JointModelFreeFlyer())
        self.geoms = pin.buildGeomFromUrdfString(self.model, urdf_text, pin.GeometryType.VISUAL)
        self.data = self.model.createData()
        self.gdata = pin.GeometryData(self.geoms)
        self.q_idx = np.array([self.model.joints[j].idx_q for j in range(2, self.model.njoints)])
        feet = [f.name for f in self.model.frames if f.name.endswith("_foot")]
        self.foot_ids = [self.model.getFrameId(f"{leg}_foot") for leg in LEGS] if len(feet) >= 4 else []

    def shape(self, g: Any) -> Any:
        geo = g.geometry
        name = type(geo).__name__
        if name == "Box":
            return rr.Boxes3D(half_sizes=[geo.halfSide], colors=[(90, 90, 100)])
        if name == "Cylinder":
            return rr.Cylinders3D(lengths=[2 * geo.halfLength], radii=[geo.radius], colors=[(120, 120, 130)])
        if name == "Sphere":
            return rr.Ellipsoids3D(half_sizes=[[geo.radius] * 3], colors=[(30, 30, 30)], fill_mode="solid")
        return None

    def poses(self, base_pos: np.ndarray, base_rot: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per knot and shape: translations (K, G, 3) and xyzw quaternions (K, G, 4); per knot and
        leg the feet's translational Jacobians over the leg's joints (K, 4, 3, 3) (zeros without
        foot frames)."""
        K, G = len(q), len(self.geoms.geometryObjects)
        trans, quats = np.zeros((K, G, 3)), np.zeros((K, G, 4))
        tau = np.zeros((K, 4, 3, 3))
        qp = pin.neutral(self.model)
        for k in range(K):
            qp[:3] = base_pos[k]
            qp[3:7] = pin.Quaternion(base_rot[k]).coeffs()
            qp[self.q_idx] = q[k]
            pin.forwardKinematics(self.model, self.data, qp)
            pin.updateGeometryPlacements(self.model, self.data, self.geoms, self.gdata)
            for i in range(G):
                M = self.gdata.oMg[i]
                trans[k, i] = M.translation
                quats[k, i] = pin.Quaternion(M.rotation).coeffs()
            if self.foot_ids:
                pin.computeJointJacobians(self.model, self.data, qp)
                pin.updateFramePlacements(self.model, self.data)
                for leg, fid in enumerate(self.foot_ids):
                    J = pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED)[:3, 6:]
                    tau[k, leg] = J[:, 3 * leg: 3 * leg + 3]  # this leg's columns: d foot / d q_leg
        return trans, quats, tau



def log_robot(rec: rr.RecordingStream, robot: Robot, path: str, t: np.ndarray,
              pose: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Each visual shape once and its transform at every knot; ``pose``: base positions (K, 3),
    base rotations (K, 3, 3), joint angles (K, n) in the model's order. Returns the feet's
    Jacobians of :meth:`Robot.poses`."""
    trans, quats, jac = robot.poses(*pose)
    for i, g in enumerate(robot.geoms.geometryObjects):
        shape = robot.shape(g)
        if shape is not None:
            rec.log(f"{path}/{g.name}", shape, static=True)
        rec.send_columns(f"{path}/{g.name}", indexes=time_index(t),
                         columns=rr.Transform3D.columns(translation=trans[:, i], quaternion=quats[:, i]))
    return jac
