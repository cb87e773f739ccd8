"""The humanoid's whole-body motion (the paper's Fig. 5 after the COM optimization): inverse
kinematics of each knot on the multibody model (pinocchio), the multibody ZMP of the result, and
Kajita's dynamics filter that corrects the COM reference until that ZMP follows the plan's.

Inverse kinematics, knot by knot from the previous knot's answer: a damped least-squares
Gauss-Newton on 18 task rows for 18 degrees of freedom: the centre of mass on the GPM's, each
sole's pose (position and yaw; level) on the Foot Coordinates Generator's, the waist upright
with the feet's mean yaw; joints clamped to their limits.

The multibody ZMP follows from the rate of the centroidal momentum (linear m c'', angular about
the COM L'): with f = m (c'' + g z) the contact force, the ZMP on the ground is
p_x = c_x - (c_z f_x + L'_y) / f_z,  p_y = c_y - (c_z f_y - L'_x) / f_z.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from skatelib.pipeline.humanoid.preview import CartTable, preview_gains, track_offset

SOLES = ("R_sole", "L_sole")
WAIST = "waist"
PREVIEW_S = 1.6  # the dynamics filter's preview (Kajita et al. 2003)
MISSED_M = 1e-6  # inverse kinematics that leaves a target this far has missed it
SOLE_LEVER_M = 0.1  # a sole's pose is checked at its centre and this far ahead of and behind it


@dataclass(frozen=True)
class IkResult:
    q: np.ndarray  # (K, nq) pinocchio configurations (free flyer: position, quaternion x y z w, joints)
    com_error_m: np.ndarray  # (K,) |COM - target|
    feet_error_m: np.ndarray  # (K, 2) |sole position - target|
    iterations: int  # the most any knot took


class Humanoid:
    """Pinocchio's floating-base model of the humanoid's URDF, with its soles and waist frames."""

    def __init__(self, urdf: str):
        self.model: Any = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
        self.data: Any = self.model.createData()
        self.soles = [self.model.getFrameId(n) for n in SOLES]
        self.waist = self.model.getFrameId(WAIST)
        self.mass_kg = float(pin.computeTotalMass(self.model))
        self.joint_names = [str(self.model.names[j]) for j in range(2, self.model.njoints)]
        self.lower, self.upper = self.model.lowerPositionLimit.copy(), self.model.upperPositionLimit.copy()

    def standing(self, waist_z: float, knee_rad: float = 0.4) -> np.ndarray:
        """A configuration with bent knees (hip and ankle pitch compensating), the waist at ``waist_z``."""
        q = pin.neutral(self.model)
        q[2] = waist_z
        for side in ("R", "L"):
            for name, angle in (("hip_pitch", -knee_rad / 2), ("knee", knee_rad), ("ankle_pitch", -knee_rad / 2)):
                q[self.model.joints[self.model.getJointId(f"{side}_{name}")].idx_q] = angle
        return q

    def _residual(self, q: np.ndarray, com: np.ndarray, soles: list[Any], waist_R: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        c = pin.centerOfMass(model, data, q, False)
        rows, J = [com - c], [pin.jacobianCenterOfMass(model, data, q, False)]
        for f, target in zip(self.soles, soles, strict=True):
            err = pin.log6(data.oMf[f].actInv(target)).vector
            rows.append(err)
            J.append(pin.Jlog6(data.oMf[f].actInv(target)) @ pin.getFrameJacobian(model, data, f, pin.LOCAL))
        R = data.oMf[self.waist].rotation
        rows.append(pin.log3(R.T @ waist_R))
        J.append(pin.Jlog3(R.T @ waist_R) @ pin.getFrameJacobian(model, data, self.waist, pin.LOCAL)[3:])
        return np.concatenate(rows), np.vstack(J)

    def solve_ik(self, com: np.ndarray, feet: np.ndarray, q0: np.ndarray, tol: float = 1e-9,
                 max_iterations: int = 200, damping: float = 1e-8) -> IkResult:
        """Configurations for COM targets (K, 3) and feet (K, 2, 5: sole centre, yaw, pitch), from ``q0``."""
        q = q0.copy()
        out = np.empty((len(com), self.model.nq))
        worst = 0
        for k in range(len(com)):
            soles = [pin.SE3(pin.rpy.rpyToMatrix(0.0, float(feet[k, s, 4]), float(feet[k, s, 3])), feet[k, s, 0:3])
                     for s in (0, 1)]
            waist_R = pin.rpy.rpyToMatrix(0.0, 0.0, float(np.mean(feet[k, :, 3])))
            used = 0
            while used < max_iterations:
                e, J = self._residual(q, com[k], soles, waist_R)
                if np.max(np.abs(e)) < tol:
                    break
                used += 1
                # Levenberg-Marquardt damping grows with the error (Sugihara): stable near a
                # stretched knee, Gauss-Newton's rate near the answer.
                dq = J.T @ np.linalg.solve(J @ J.T + (damping + 1e-3 * float(e @ e)) * np.eye(len(e)), e)
                q = pin.integrate(self.model, q, dq)
                q[7:] = np.clip(q[7:], self.lower[7:], self.upper[7:])
            worst = max(worst, used)
            out[k] = q
        return IkResult(out, *self.residuals(out, com, feet), worst)

    def residuals(self, q: np.ndarray, com: np.ndarray, feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """|COM - target| (K,) and each sole's distance from its target pose (K, 2), by forward
        kinematics: the largest miss of its centre and of the points ``SOLE_LEVER_M`` ahead of and
        behind it (a turned or pitched sole misses at its toe and heel)."""
        model, data = self.model, self.data
        c_err, f_err = np.empty(len(q)), np.empty((len(q), 2))
        lever = np.array([[0.0, 0.0, 0.0], [SOLE_LEVER_M, 0.0, 0.0], [-SOLE_LEVER_M, 0.0, 0.0]]).T
        for k, qk in enumerate(q):
            pin.framesForwardKinematics(model, data, qk)
            c_err[k] = np.linalg.norm(pin.centerOfMass(model, data, qk, False) - com[k])
            for s, f in enumerate(self.soles):
                want = pin.rpy.rpyToMatrix(0.0, float(feet[k, s, 4]), float(feet[k, s, 3])) @ lever
                got = data.oMf[f].rotation @ lever
                f_err[k, s] = np.linalg.norm(got + data.oMf[f].translation[:, None] - want
                                             - feet[k, s, 0:3, None], axis=0).max()
        return c_err, f_err

    def zmp(self, q: np.ndarray, dt: float, g: float = 9.81, plane_z: np.ndarray | None = None) -> np.ndarray:
        """The multibody ZMP (K, 2) of the configurations ``q`` sampled every ``dt`` (velocities
        and accelerations by second-order differences on the configuration manifold, one-sided at
        the ends: a motion that starts from rest with an acceleration has it at its first knot), on
        the support plane at the height ``plane_z`` (K,) (the ground's 0 if not given; a board
        foot's deck)."""
        model, data = self.model, self.data
        K = len(q)
        d = np.array([pin.difference(model, q[k], q[k + 1]) / dt for k in range(K - 1)])  # over [k, k+1]
        vk = np.vstack([(3 * d[0] - d[1]) / 2, (d[:-1] + d[1:]) / 2, (3 * d[-1] - d[-2]) / 2])  # at the knots
        a = np.gradient(vk, dt, axis=0, edge_order=2)
        out = np.empty((K, 2))
        plane = np.zeros(K) if plane_z is None else np.asarray(plane_z, dtype=np.float64)
        for k in range(K):
            pin.computeCentroidalMomentumTimeVariation(model, data, q[k], vk[k], a[k])
            c = data.com[0] - np.array([0.0, 0.0, plane[k]])
            f = data.dhg.linear + np.array([0.0, 0.0, self.mass_kg * g])
            Ld = data.dhg.angular
            out[k] = (c[0] - (c[2] * f[0] + Ld[1]) / f[2], c[1] - (c[2] * f[1] - Ld[0]) / f[2])
        return out


@dataclass(frozen=True)
class Filtered:
    ik: IkResult  # the motion after the filter
    zmp_before: np.ndarray  # (K, 2) multibody ZMP of the IK on the GPM's COM
    zmp_after: np.ndarray  # (K, 2) after the filter
    com: np.ndarray  # (K, 3) the corrected COM reference


def dynamics_filter(robot: Humanoid, dt: float, plan: tuple[np.ndarray, np.ndarray, np.ndarray], q0: np.ndarray,
                    preview_s: float = PREVIEW_S, plane_z: np.ndarray | None = None) -> Filtered:
    """Kajita's dynamics filter: IK on the planned COM, the multibody ZMP's error against the
    plan's, a cart-table preview servo on that error giving a COM correction, IK again (gravity:
    the model's). ``plan``: the COM (K, 3), feet (K, 2, 4) and ZMP (K, 2) planned; ``plane_z``
    (K,): the height of the plane the plan's ZMP lies on (its support point's; 0 if not given)."""
    com, feet, zmp_ref = plan
    g = float(-robot.model.gravity.linear[2])
    plane = np.zeros(len(com)) if plane_z is None else np.asarray(plane_z, dtype=np.float64)
    first = robot.solve_ik(com, feet, q0)
    before = robot.zmp(first.q, dt, g, plane)
    if max(first.com_error_m.max(), first.feet_error_m.max()) > MISSED_M:
        return Filtered(first, before, before, com)  # a body not where the plan puts it: nothing to filter
    model = CartTable.of(dt, float(np.mean(com[:, 2] - plane)), g)
    gains = preview_gains(model, round(preview_s / dt))
    shift = np.zeros_like(com)
    for axis in (0, 1):
        # The correction starts at rest, offset so that it fits the whole error best (a servo
        # started at zero overshoots the error's first samples by centimetres).
        shift[:, axis] = track_offset(model, gains, zmp_ref[:, axis] - before[:, axis])[:, 0]
    corrected = com + shift
    second = robot.solve_ik(corrected, feet, first.q[0])
    return Filtered(second, before, robot.zmp(second.q, dt, g, plane), corrected)
