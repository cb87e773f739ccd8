"""The joint torques a humanoid's planned motion needs (inverse dynamics, pinocchio), fed forward to
its position servos: a stiff position servo still gives under load (a 100 N m knee torque bends a
3000 N m/rad servo by 0.03 rad, the COM sags and lags), so the driver is told the torque the joint
will carry and the position loop corrects only what the plan did not foresee.

The floating base's six rows of M(q) a + h(q, v) = S^T tau + sum_s J_s^T w_s are balanced by the
support soles' wrenches w_s; in double support they are shared by the planned ZMP's place between
the soles (a sole's share of the force alpha_s, each sole's wrench weighted 1 / alpha_s in a least
norm, its moment scaled by :data:`MOMENT_ARM_M`), and the joints carry the rest. After the motion
ends the robot holds its last posture: the gravity torques of that posture, no motion.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from skatelib.control.humanoid_kinematics import HumanoidKinematics
from skatelib.control.humanoid_reference import HumanoidReference
from skatelib.control.humanoid_stabilizer import TOE_OFF_RAD

MOMENT_ARM_M = 0.1  # a sole's moment counts in the least norm as a force at this arm
MIN_SHARE = 0.02  # a support sole carries at least this share of the force in the least norm


def support_shares(support: np.ndarray, soles: np.ndarray, zmp: np.ndarray) -> np.ndarray:
    """Each sole's share (2,) of the contact force: 1 for the only support sole; in double support
    by the ZMP's place along the segment between the soles' centres."""
    if support.all():
        a, b = soles[0][0:2], soles[1][0:2]
        t = float(np.clip(np.dot(zmp - a, b - a) / max(float(np.dot(b - a, b - a)), 1e-12), 0.0, 1.0))
        return np.clip(np.array([1.0 - t, t]), MIN_SHARE, 1.0 - MIN_SHARE)
    return np.asarray(support, dtype=float)


class PlannedTorques:
    """The feed-forward joint torques (K, n) of a planned motion on its knots, and the joints'
    planned speeds (K, n), sampled at any time (linear between knots; after the end the static
    hold: the last posture's gravity torques, no speed)."""

    def __init__(self, kin: HumanoidKinematics, ref: HumanoidReference):
        model = kin.model
        t, base, q, zmp = ref.t, ref.base, ref.q, ref.zmp
        support, soles = ref.support, ref.feet[:, :, 0:3]
        self.t = np.asarray(t, dtype=float)
        configs = [np.concatenate([base[k, 0:3], base[k, 3:7] / np.linalg.norm(base[k, 3:7]), q[k]])
                   for k in range(len(t))]
        dt = np.diff(self.t)
        # the velocity on each interval (pinocchio's tangent: the base's in its own frame), at the knots
        # the mean of the neighbouring intervals'; the acceleration likewise from the velocities
        vi = np.array([pin.difference(model, configs[k], configs[k + 1]) / dt[k] for k in range(len(dt))])
        v = np.vstack([vi[0], (vi[:-1] + vi[1:]) / 2, vi[-1]])
        a = np.gradient(v, self.t, axis=0)
        self.qd = v[:, 6:]
        # A sole on a skate's deck stands on a board that rolls along x: while a sole on the ground
        # pushes, that one carries the robot's force along the board (the board's own inertia and
        # rolling resistance left out).
        rolling = ref.support & (ref.plane > 0.0)
        pushing = rolling & (ref.support & (ref.plane == 0.0)).any(axis=1, keepdims=True)
        # A sole on its toe (a skate's toe-off) presses at its toe edge's middle.
        on_toe = ref.support & (np.abs(ref.feet[:, :, 4]) > TOE_OFF_RAD) if ref.feet.shape[2] > 4 else \
            np.zeros_like(ref.support)
        toe = ref.model.foot_length_m / 2
        self.tau = np.array([self._torque(kin, configs[k], v[k], a[k], support_shares(support[k], soles[k], zmp[k]),
                                          (pushing[k], on_toe[k], toe)) for k in range(len(t))])
        zero = np.zeros(model.nv)
        self.hold = self._torque(kin, configs[-1], zero, zero, support_shares(support[-1], soles[-1], ref.com[-1, 0:2]))

    @staticmethod
    def _torque(kin: HumanoidKinematics, qf: np.ndarray, v: np.ndarray, a: np.ndarray, share: np.ndarray,
                soles: tuple[np.ndarray, np.ndarray, float] | None = None) -> np.ndarray:
        """The joint torques of the motion (qf, v, a) with the base's wrench carried by the soles
        by ``share``. ``soles``: which soles carry no force along x (on a rolling board), which
        press at their toe edge alone (a force there, no moment about it), and the toe's distance
        from the sole's centre [m]."""
        model, data = kin.model, kin.data
        b = pin.rnea(model, data, qf, v, a)
        pin.computeJointJacobians(model, data, qf)
        pin.updateFramePlacements(model, data)
        free_x, on_toe, toe = soles if soles is not None else (np.zeros(2, bool), np.zeros(2, bool), 0.0)
        on = [s for s in (0, 1) if share[s] > 0.0]
        J = [pin.getFrameJacobian(model, data, kin.soles[s], pin.LOCAL_WORLD_ALIGNED) for s in on]
        scale = np.diag([1.0, 1.0, 1.0, 1 / MOMENT_ARM_M, 1 / MOMENT_ARM_M, 1 / MOMENT_ARM_M])
        bases = []  # each sole's wrench (world axes, at its frame) from its unknowns
        for s in on:
            if on_toe[s]:
                r = data.oMf[kin.soles[s]].rotation @ np.array([toe, 0.0, 0.0])
                bases.append(np.vstack([np.eye(3), pin.skew(r)]))
            else:
                bases.append(scale[:, 1:] if free_x[s] else scale)
        A = np.hstack([J[i][:, 0:6].T @ B for i, B in enumerate(bases)])  # base rows
        w = np.concatenate([np.full(B.shape[1], share[s]) for s, B in zip(on, bases, strict=True)])
        y = w * (A.T @ np.linalg.solve((A * w) @ A.T, b[0:6]))  # the weighted least norm
        tau = b[6:].copy()
        start = 0
        for i, B in enumerate(bases):
            tau -= J[i][:, 6:].T @ (B @ y[start:start + B.shape[1]])
            start += B.shape[1]
        return np.asarray(tau)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The joints' planned speeds [rad/s] and feed-forward torques [N m] at ``t`` (linear between knots);
        a ValueError for a ``t`` that is not finite."""
        if not math.isfinite(t):
            raise ValueError(f"sample(t): t must be a finite time in seconds, got {t!r}")
        if t >= self.t[-1]:
            return np.zeros(self.qd.shape[1]), self.hold.copy()
        k = min(max(int(np.searchsorted(self.t, t, side="right")) - 1, 0), len(self.t) - 2)
        w = min(max(float((t - self.t[k]) / (self.t[k + 1] - self.t[k])), 0.0), 1.0)
        return (1 - w) * self.qd[k] + w * self.qd[k + 1], (1 - w) * self.tau[k] + w * self.tau[k + 1]

