"""The verdict of a humanoid run on the twin: no fall; the COM's tracking error; the ZMP of the
soles' contact forces against the plan's and inside the plan's support polygon; each support
sole's slip and yaw slip; the joint torques against their limits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.proving.humanoid.loop import HumanoidRun

ZMP_OUTSIDE_TOL_M = 0.02  # the contact ZMP may leave the planned polygon by this much (a sole landed off its place)
SLIP_TOL_M = 0.02
YAW_SLIP_TOL_RAD = 0.05


@dataclass(frozen=True)
class HumanoidVerdict:
    key: str
    fell: str  # "" when it did not
    com_rms_m: float
    com_max_m: float
    zmp_rms_m: float
    zmp_max_m: float
    zmp_outside_m: float  # the most the contact ZMP left the support polygon (0: never)
    slip_m: float  # the most a support sole moved over the floor while it supported
    yaw_slip_rad: float
    torque_ratio: float  # the largest |tau| / limit
    zmp_outside_clock_m: float = 0.0  # the same against the soles the plan's clock alone has down
    board_mps: float | None = None  # a skate's board speed when its push ends (None: no board)

    def failures(self) -> list[str]:
        out = [f"fell: {self.fell}"] if self.fell else []
        if self.zmp_outside_m > ZMP_OUTSIDE_TOL_M:
            out.append(f"ZMP {self.zmp_outside_m * 100:.1f} cm outside the support polygon")
        if self.slip_m > SLIP_TOL_M:
            out.append(f"a sole slipped {self.slip_m * 100:.1f} cm")
        if self.yaw_slip_rad > YAW_SLIP_TOL_RAD:
            out.append(f"a sole turned {self.yaw_slip_rad:.3f} rad")
        if self.torque_ratio >= 1.0:
            out.append("a joint at its torque limit")
        return out


def _slips(run: HumanoidRun) -> tuple[float, float]:
    """Per sole, over each stretch of planned support: how far it moved and turned from where the
    stretch began."""
    slip, yaw = 0.0, 0.0
    for s in (0, 1):
        start = None
        for k in range(len(run.t)):
            if not run.support[k, s]:
                start = None
                continue
            if start is None:
                start = k + 25  # 50 ms after touchdown: the landing settles
            if k >= start:
                slip = max(slip, float(np.linalg.norm(run.sole_pos[k, s, 0:2] - run.sole_pos[start, s, 0:2])))
                yaw = max(yaw, abs(float(run.sole_yaw[k, s] - run.sole_yaw[start, s])))
    return slip, yaw


def verdict(run: HumanoidRun) -> HumanoidVerdict:
    ok = ~np.isnan(run.zmp).any(axis=1)
    ez = np.linalg.norm(run.zmp[ok] - run.zmp_ref[ok], axis=1) if ok.any() else np.array([np.inf])
    ec = np.linalg.norm(run.com[:, 0:2] - run.com_ref[:, 0:2], axis=1)
    slip, yaw = _slips(run)
    return HumanoidVerdict(
        key=run.key, fell=run.fall_reason, com_rms_m=float(np.sqrt(np.mean(ec**2))), com_max_m=float(ec.max()),
        zmp_rms_m=float(np.sqrt(np.mean(ez**2))), zmp_max_m=float(ez.max()),
        zmp_outside_m=float(max(0.0, -run.zmp_margin[ok].min())) if ok.any() else np.inf,
        zmp_outside_clock_m=float(max(0.0, -run.zmp_margin_clock[ok].min())) if ok.any() else np.inf, slip_m=slip,
        yaw_slip_rad=yaw, torque_ratio=float(np.abs(run.torque / run.torque_limit).max()))
