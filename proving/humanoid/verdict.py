"""The verdict of a humanoid run on the twin: no fall; the COM's tracking error; the ZMP of the
soles' contact forces against the plan's and inside the plan's support polygon; each support
sole's slip and yaw slip on the ground; the joint torques against their limits. A skate's adds
the board's speed when the push ends against the label (5 %), the pushing sole's slip on the
ground and the soles' slip on the deck (its COM, ZMP and polygon relative to the board sole)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from skatelib.proving.humanoid.loop import HumanoidRun

ZMP_OUTSIDE_TOL_M = 0.02  # the contact ZMP may leave the planned polygon by this much (a sole landed off its place)
SLIP_TOL_M = 0.02
YAW_SLIP_TOL_RAD = 0.05
BOARD_SPEED_TOL = 0.05  # a skate's board speed at the push's end, relative to its label
SETTLE_TICKS = 25  # 50 ms after touchdown: the landing settles


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
    label_mps: float | None = None  # the speed the skate was planned to reach
    push_slip_m: float = 0.0  # a skate's pushing sole over the ground while it pushed
    deck_slip_m: float = 0.0  # a skate's soles over the deck while they stood on it
    deck_yaw_slip_rad: float = 0.0

    @property
    def board_error(self) -> float | None:
        """The board's speed at the push's end against the label, relative (None: no board)."""
        if self.board_mps is None or not self.label_mps:
            return None
        return abs(self.board_mps - self.label_mps) / self.label_mps

    def failures(self) -> list[str]:
        out = [f"fell: {self.fell}"] if self.fell else []
        err = self.board_error
        if err is not None and not err <= BOARD_SPEED_TOL:
            out.append(f"board at {self.board_mps:.3f} m/s when the push ends, {err * 100:.1f} % off its "
                       f"{self.label_mps:g} m/s")
        if self.deck_slip_m > SLIP_TOL_M:
            out.append(f"a sole slipped {self.deck_slip_m * 100:.1f} cm on the deck")
        if self.zmp_outside_m > ZMP_OUTSIDE_TOL_M:
            out.append(f"ZMP {self.zmp_outside_m * 100:.1f} cm outside the support polygon")
        if self.slip_m > SLIP_TOL_M:
            out.append(f"a sole slipped {self.slip_m * 100:.1f} cm")
        if self.yaw_slip_rad > YAW_SLIP_TOL_RAD:
            out.append(f"a sole turned {self.yaw_slip_rad:.3f} rad")
        if self.torque_ratio >= 1.0:
            out.append("a joint at its torque limit")
        return out


def _slips(run: HumanoidRun, support: np.ndarray, pos: np.ndarray, yaw_: np.ndarray) -> tuple[float, float]:
    """Per sole, over each stretch of ``support`` (N, 2): how far it moved and turned from where the
    stretch began (its place ``pos`` (N, 2, 3) and yaw ``yaw_`` (N, 2) in the frame that counts)."""
    slip, yaw = 0.0, 0.0
    for s in (0, 1):
        start = None
        for k in range(len(run.t)):
            if not support[k, s]:
                start = None
                continue
            if start is None:
                start = k + SETTLE_TICKS
            if k >= start:
                slip = max(slip, float(np.linalg.norm(pos[k, s, 0:2] - pos[start, s, 0:2])))
                yaw = max(yaw, abs(float(yaw_[k, s] - yaw_[start, s])))
    return slip, yaw


def _skate(run: HumanoidRun, v: HumanoidVerdict, label_mps: float | None) -> HumanoidVerdict:
    """``v`` with a skate's figures: the board's speed when the push ends, the pushing sole's slip
    on the ground while it pushed and the soles' slip on the deck while they stood on it."""
    if run.sole_plane is None or run.sole_deck_pos is None or run.sole_deck_yaw is None or run.deck_v is None:
        return v
    on_deck = run.support & (run.sole_plane > 0.0)
    on_ground = run.support & (run.sole_plane == 0.0)
    push, _ = _slips(run, on_ground, run.sole_pos, run.sole_yaw)
    deck, deck_yaw = _slips(run, on_deck, run.sole_deck_pos, run.sole_deck_yaw)
    board = None
    if run.push_end_s is not None and len(run.t) and run.t[-1] >= run.push_end_s:
        k = int(np.searchsorted(run.t, run.push_end_s))
        board = float(np.linalg.norm(run.deck_v[k, 0:2]))
    return replace(v, push_slip_m=push, deck_slip_m=deck, deck_yaw_slip_rad=deck_yaw, board_mps=board,
                   label_mps=label_mps)


def verdict(run: HumanoidRun, label_mps: float | None = None) -> HumanoidVerdict:
    """The run's verdict (``label_mps``: a skate's planned board speed)."""
    ok = ~np.isnan(run.zmp).any(axis=1)
    ez = np.linalg.norm(run.zmp[ok] - run.zmp_ref[ok], axis=1) if ok.any() else np.array([np.inf])
    ec = np.linalg.norm(run.com[:, 0:2] - run.com_ref[:, 0:2], axis=1)
    ground = run.support if run.sole_plane is None else run.support & (run.sole_plane == 0.0)
    slip, yaw = _slips(run, ground, run.sole_pos, run.sole_yaw)
    v = HumanoidVerdict(
        key=run.key, fell=run.fall_reason, com_rms_m=float(np.sqrt(np.mean(ec**2))), com_max_m=float(ec.max()),
        zmp_rms_m=float(np.sqrt(np.mean(ez**2))), zmp_max_m=float(ez.max()),
        zmp_outside_m=float(max(0.0, -run.zmp_margin[ok].min())) if ok.any() else np.inf,
        zmp_outside_clock_m=float(max(0.0, -run.zmp_margin_clock[ok].min())) if ok.any() else np.inf, slip_m=slip,
        yaw_slip_rad=yaw, torque_ratio=float(np.abs(run.torque / run.torque_limit).max()))
    return _skate(run, v, label_mps)
