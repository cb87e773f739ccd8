"""The humanoid's kinematics as its stabilizer uses them (pinocchio, the library's URDF): from the
joint encoders and the waist IMU's attitude, the COM and the soles relative to the waist, each
ankle force/torque sensor's pose, and the Jacobians that turn a COM shift and sole rotations
into joint angle corrections with the soles held where they are."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

SOLES = ("R_sole", "L_sole")
FOOT_SENSORS = ("R_ankle_roll", "L_ankle_roll")  # HRP-2's 6-axis sensors sit at the ankles
WAIST = "waist"


class HumanoidKinematics:
    """Pinocchio's floating-base model of the URDF with its soles, waist and ankle frames."""

    def __init__(self, urdf: str, joint_names: tuple[str, ...]):
        self.model: Any = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
        self.data: Any = self.model.createData()
        missing = [n for n in (*SOLES, WAIST) if not self.model.existFrame(n)] + [
            n for n in FOOT_SENSORS if not self.model.existJointName(n)]
        if missing:
            raise ValueError(f"the URDF has no {', '.join(missing)}: the stabilizer reads a humanoid's soles, waist "
                             "and ankle sensors (a library of another kind?)")
        self.soles = [self.model.getFrameId(n) for n in SOLES]
        self.waist = self.model.getFrameId(WAIST)
        self.ankles = [self.model.getJointId(n) for n in FOOT_SENSORS]
        names = [str(self.model.names[j]) for j in range(2, self.model.njoints)]
        if tuple(names) != tuple(joint_names):
            raise ValueError(f"the URDF's joints {names} are not the library's {list(joint_names)}")
        self.mass_kg = float(pin.computeTotalMass(self.model))

    def configuration(self, base_quat_xyzw: np.ndarray, q: np.ndarray, base_pos: np.ndarray | None = None
                      ) -> np.ndarray:
        return np.concatenate([np.zeros(3) if base_pos is None else base_pos, base_quat_xyzw, q])

    def measure(self, qfull: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The COM (3,), the soles (2, 3), the ankle sensors' points (2, 3) and rotations (2, 3, 3)."""
        model, data = self.model, self.data
        c = pin.centerOfMass(model, data, qfull, False)
        pin.updateFramePlacements(model, data)
        soles = np.array([data.oMf[f].translation for f in self.soles])
        pts = np.array([data.oMi[j].translation for j in self.ankles])
        rots = np.array([data.oMi[j].rotation for j in self.ankles])
        return np.array(c), soles, pts, rots

    def rows(self, qfull: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The correction's rows (18, nv) at ``qfull``: the COM's Jacobian, each sole's (world axes,
        linear then angular) and the waist's angular one; and the soles' rotations (2, 3, 3)."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, qfull)
        pin.updateFramePlacements(model, data)
        A = np.vstack([pin.jacobianCenterOfMass(model, data, qfull, False),
                       *(pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED) for f in self.soles),
                       pin.getFrameJacobian(model, data, self.waist, pin.LOCAL_WORLD_ALIGNED)[3:6]])
        return A, np.array([data.oMf[f].rotation for f in self.soles])

    def correction(self, qfull: np.ndarray, dcom: np.ndarray, dtilt: np.ndarray, lift: np.ndarray | None = None
                   ) -> np.ndarray:
        """Joint angle changes (n,) that move the COM by ``dcom`` (3,) and tilt each sole by
        ``dtilt`` (2, 2: roll, pitch about its own axes), holding both soles' positions and
        yaws and the waist's attitude (18 rows for the 18 degrees of freedom, at ``qfull``; the least-norm
        change where those rows are singular)."""
        return solve_rows(*self.rows(qfull), dcom, dtilt, lift)


def solve_rows(A: np.ndarray, R: np.ndarray, dcom: np.ndarray, dtilt: np.ndarray, lift: np.ndarray | None = None
               ) -> np.ndarray:
    """:meth:`HumanoidKinematics.correction` from its rows ``A`` and the soles' rotations ``R``."""
    rhs = [dcom]
    for s in (0, 1):
        up = 0.0 if lift is None else float(lift[s])
        rhs.append(np.concatenate([[0.0, 0.0, up], R[s] @ np.array([dtilt[s, 0], dtilt[s, 1], 0.0])]))
    rhs.append(np.zeros(3))
    b = np.concatenate(rhs)
    try:  # as many rows as the model's degrees of freedom: square, solved by LU
        dq = np.linalg.solve(A, b) if A.shape[0] == A.shape[1] else np.linalg.lstsq(A, b, rcond=None)[0]
    except np.linalg.LinAlgError:  # singular (a knee exactly straight): the least-norm change
        dq = np.linalg.lstsq(A, b, rcond=None)[0]
    return np.asarray(dq[6:])
