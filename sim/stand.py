"""Standing still on the deck: the twin's simplest controller, for the checks that the twin itself
holds (a robot at rest on a board at rest stays put). Each joint a PD to the stance angles plus
the torques that carry the robot's weight, shared by the four feet (-J^T f, f = m g / 4 up), plus
the legs' own gravity and bias forces."""

from __future__ import annotations

from typing import Any

import numpy as np
from skatelib.sim.robot import JOINTS, LEGS

KP_NM_PER_RAD = 150.0
KD_NMS_PER_RAD = 3.0


class StandController:
    """Holds the stance of ``qpos_ref`` (the model's ``stance`` keyframe by default)."""

    def __init__(self, m: Any, mass_kg: float, gravity_mps2: float, q_ref: np.ndarray | None = None):
        self.m = m
        self.qadr = np.array([m.joint(n).qposadr[0] for n in JOINTS])
        self.dadr = np.array([m.joint(n).dofadr[0] for n in JOINTS])
        self.q_ref = np.array(m.key("stance").qpos[self.qadr] if q_ref is None else q_ref, dtype=np.float64)
        self.feet = [m.geom(f"{leg}_foot").id for leg in LEGS]
        self.weight = np.array([0.0, 0.0, mass_kg * gravity_mps2 / 4])
        self.actuators = np.array([m.actuator(n).id for n in JOINTS])
        self.limit = m.actuator_ctrlrange[self.actuators, 1].copy()
        self._jac = np.zeros((3, m.nv))

    def __call__(self, d: Any) -> np.ndarray:
        """The joint torques for the state in ``d`` (also written to ``d.ctrl``)."""
        import mujoco

        tau = KP_NM_PER_RAD * (self.q_ref - d.qpos[self.qadr]) - KD_NMS_PER_RAD * d.qvel[self.dadr]
        tau += d.qfrc_bias[self.dadr]
        for g in self.feet:
            mujoco.mj_jacGeom(self.m, d, self._jac, None, g)
            tau -= self._jac[:, self.dadr].T @ self.weight
        d.ctrl[self.actuators] = np.clip(tau, -self.limit, self.limit)
        return np.asarray(d.ctrl[self.actuators])
