"""The legs' terms the estimator needs at every tick: the foot centres and their linear and
angular Jacobians in the trunk frame at the measured joints (pinocchio, the fixed-trunk model)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from skatelib.control.kinematics import LegKinematics


@dataclass
class LegTerms:
    """The legs at the measured joints (trunk frame): foot centres (3, 4), their linear and angular
    Jacobians in the legs' joints (4, 3, 3 each)."""

    r: np.ndarray
    J: np.ndarray
    Jw: np.ndarray


def leg_terms(kin: LegKinematics, q: np.ndarray) -> LegTerms:
    """Foot centres and Jacobians of the fixed-trunk model at ``q`` (channel order)."""
    qp = pin.neutral(kin.model)
    qp[kin.q_index] = q
    pin.computeJointJacobians(kin.model, kin.data, qp)
    pin.updateFramePlacements(kin.model, kin.data)
    r, J, Jw = np.empty((3, 4)), np.empty((4, 3, 3)), np.empty((4, 3, 3))
    for i, f in enumerate(kin.feet):
        r[:, i] = kin.data.oMf[f].translation
        full = pin.getFrameJacobian(kin.model, kin.data, f, pin.LOCAL_WORLD_ALIGNED)[:, kin.v_index[3 * i:3 * i + 3]]
        J[i], Jw[i] = full[:3], full[3:]
    return LegTerms(r, J, Jw)


class LegTermsBuffer:
    """:func:`leg_terms` for every tick: its configuration and outputs kept, each leg's Jacobian
    columns a plain slice (the legs' joints follow each other in the model, as CyberDog2's do; else
    :func:`leg_terms` itself)."""

    def __init__(self, kin: LegKinematics):
        self.kin = kin
        self.qp = pin.neutral(kin.model)
        v = [int(i) for i in kin.v_index]
        self.cols = [slice(v[3 * i], v[3 * i] + 3) if v[3 * i:3 * i + 3] == list(range(v[3 * i], v[3 * i] + 3))
                     else None for i in range(4)]
        self.frames = list(enumerate(kin.feet))

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Foot centres (3, 4), linear and angular Jacobians (4, 3, 3) at ``q`` (channel order)."""
        kin = self.kin
        if any(c is None for c in self.cols):
            legs = leg_terms(kin, q)
            return legs.r, legs.J, legs.Jw
        m, d = kin.model, kin.data
        self.qp[kin.q_index] = q
        pin.computeJointJacobians(m, d, self.qp)
        pin.updateFramePlacements(m, d)
        r, J = np.empty((3, 4)), np.empty((4, 6, 3))
        for i, f in self.frames:
            r[:, i] = d.oMf[f].translation
            J[i] = pin.getFrameJacobian(m, d, f, pin.LOCAL_WORLD_ALIGNED)[:, self.cols[i]]
        return r, J[:, :3], J[:, 3:]
