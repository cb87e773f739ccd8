"""The whole-body stage of a humanoid build (the paper's Fig. 5 after the COM optimization): the
feet of the Foot Coordinates Generator, inverse kinematics and Kajita's dynamics filter on a
solved motion, and its checks, in code apart from the stages they check:

* inverse kinematics: the whole-body COM on the (filtered) COM reference within 1 cm, each sole on
  its path within 2 mm (forward kinematics of the stored joints);
* joint limits of the robot description: angles and velocities;
* the multibody ZMP inside the plan's support polygon at every knot after the filter, and its RMS
  error against the planned ZMP smaller than without the filter;
* swing clearance: a sole is never under the ground;
* skating: the board sole moves with the board while the plan's support rides it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from skatelib.library import schema
from skatelib.pipeline.humanoid.feet import POSE, ToeOff, lowest_point, skating_feet, sole_poses, walking_feet
from skatelib.pipeline.humanoid.wholebody import Humanoid, dynamics_filter

if TYPE_CHECKING:
    from skatelib.pipeline.humanoid.config import HumanoidBoardConfig, HumanoidConfig
    from skatelib.pipeline.humanoid.geometry import Support
    from skatelib.pipeline.humanoid.motion import Motion
    from skatelib.pipeline.humanoid.step import StepSpec

COM_TOL_M = 0.01  # the whole-body COM on its reference
FEET_TOL_M = 0.002  # each sole on its path
ZMP_MARGIN_M = 0.0  # the multibody ZMP inside the support polygon
START_WAIST_M, START_KNEE_RAD = 0.70, 0.4  # the first knot's inverse kinematics starts from this stance


@dataclass(frozen=True)
class BodyMotion:
    """A motion's whole body at its knots."""

    joint_names: tuple[str, ...]
    q: np.ndarray  # (K, 12) joint angles [rad]
    qd: np.ndarray  # (K, 12) joint velocities [rad/s] (central differences)
    base: np.ndarray  # (K, 7) waist position [m] and orientation quaternion (x, y, z, w)
    feet: np.ndarray  # (K, 10) right then left sole: x, y, z [m], yaw, pitch [rad]
    com_reference: np.ndarray  # (K, 3) the filtered COM reference [m]
    zmp_unfiltered: np.ndarray  # (K, 2) the multibody ZMP of inverse kinematics on the GPM's COM [m]
    zmp_wholebody: np.ndarray  # (K, 2) after the dynamics filter [m]
    figures: dict[str, float] = field(default_factory=dict)


def robot_for(cfg: HumanoidConfig) -> Humanoid:
    return Humanoid(cfg.wholebody.urdf_path(cfg.path).read_text())


def stored_body(arrays: dict[str, np.ndarray], columns: dict[str, tuple[str, ...]], figures: dict[str, float]
                ) -> BodyMotion:
    """A library entry's whole body, from its arrays (format 1.3; soles without pitch before 1.5)."""
    feet = sole_poses(arrays[schema.D_FEET])
    return BodyMotion(tuple(columns[schema.D_JOINTS]), arrays[schema.D_JOINTS], arrays[schema.D_JOINT_VELOCITIES],
                      arrays[schema.D_BASE_POSE], feet.reshape(len(feet), 2 * POSE), arrays[schema.D_COM_REFERENCE],
                      arrays[schema.D_ZMP_UNFILTERED], arrays[schema.D_ZMP_WHOLEBODY], figures)


def feet_for(cfg: HumanoidConfig, m: Motion) -> np.ndarray:
    """(K, 2, 5) both soles along the motion's plan."""
    w, h = cfg.wholebody, cfg.humanoid
    if cfg.sweep.motion == "walk":
        return walking_feet(m.plan, m.t, w.swing_height_m, h.step_width_m)
    toe_off = ToeOff(cfg.skate.toe_off_s, cfg.skate.toe_off_rad, h.foot_length_m / 2)
    return skating_feet(m.plan, m.t, w.swing_height_m, h.step_width_m, w.skate_swing_s, toe_off)


def whole_body(cfg: HumanoidConfig, m: Motion, robot: Humanoid) -> BodyMotion:
    """Feet, inverse kinematics and the dynamics filter of a solved motion on ``robot`` (the
    config's, :func:`robot_for`), with the time of each."""
    t0 = time.perf_counter()
    feet = feet_for(cfg, m)
    t1 = time.perf_counter()
    dt = cfg.gpm.sample_dt_s
    f = dynamics_filter(robot, dt, (m.state[:, 0:3], feet, m.zmp), robot.standing(START_WAIST_M, START_KNEE_RAD),
                        cfg.wholebody.preview_s, m.contact_point[:, 2])
    t2 = time.perf_counter()
    q = f.ik.q[:, 7:]
    err = [np.linalg.norm(z - m.zmp, axis=1) for z in (f.zmp_before, f.zmp_after)]
    figures = {
        "feet_s": t1 - t0, "ik_and_filter_s": t2 - t1, "ik_iterations_max": float(f.ik.iterations),
        "com_error_max_m": float(f.ik.com_error_m.max()), "feet_error_max_m": float(f.ik.feet_error_m.max()),
        "com_shift_max_m": float(np.linalg.norm(f.com - m.state[:, 0:3], axis=1).max()),
        "zmp_rms_unfiltered_m": float(np.sqrt(np.mean(err[0] ** 2))), "zmp_max_unfiltered_m": float(err[0].max()),
        "zmp_rms_m": float(np.sqrt(np.mean(err[1] ** 2))), "zmp_max_m": float(err[1].max()),
    }
    return BodyMotion(tuple(robot.joint_names), q, np.gradient(q, dt, axis=0), f.ik.q[:, 0:7],
                      feet.reshape(len(feet), 2 * POSE), f.com, f.zmp_before, f.zmp_after, figures)


def _supports(plan: list[StepSpec], t: np.ndarray) -> list[tuple[StepSpec, float, Support]]:
    """At each time: its step, the time into its contact segment, and that segment's support."""
    starts = np.cumsum([0.0] + [s.duration_s for s in plan])
    out = []
    for tk in t:
        j = min(int(np.searchsorted(starts, tk, side="right")) - 1, len(plan) - 1)
        local = float(tk - starts[j])
        start, sup = [seg for seg in plan[j].segments if seg[0] <= local + 1e-9][-1]
        out.append((plan[j], local - start, sup))
    return out


def zmp_margins(plan: list[StepSpec], t: np.ndarray, zmp: np.ndarray) -> np.ndarray:
    """Each knot's ZMP distance inside its support polygon (negative: outside) [m]."""
    out = np.empty(len(t))
    for k, (_, since, sup) in enumerate(_supports(plan, t)):
        p = zmp[k] - (np.asarray(sup.p0[0:2]) + np.asarray(sup.velocity[0:2]) * since)
        poly = np.asarray(sup.polygon)
        inside = []
        for i in range(len(poly)):
            a, b = poly[i], poly[(i + 1) % len(poly)]
            cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
            inside.append(cross / max(float(np.linalg.norm(b - a)), 1e-12))
        out[k] = min(inside)
    return out


def body_failures(robot: Humanoid, plan: list[StepSpec], t: np.ndarray, body: BodyMotion, sole_half_m: float,
                  board: tuple[HumanoidBoardConfig, float] | None = None) -> list[str]:
    """The whole-body checks (module docstring), from the stored joints by forward kinematics
    (``sole_half_m``: half the sole's length, for its lowest edge when pitched; ``board``: a
    skate's board and half the sole's width: the deck the pushing sole must not enter)."""
    q = np.hstack([body.base, body.q])
    feet = body.feet.reshape(-1, 2, POSE)
    com_err, feet_err = robot.residuals(q, body.com_reference, feet)
    lo, hi = robot.lower[7:], robot.upper[7:]
    out = _joint_limits(robot, t, body)
    off = (com_err > COM_TOL_M) | (feet_err.max(axis=1) > FEET_TOL_M)
    if off.any():  # the rest would measure a body that is not where the plan puts it
        k = int(np.argmax(off))
        held = [n for n, x, a, b in zip(body.joint_names, body.q[k], lo, hi, strict=True) if min(x - a, b - x) < 1e-6]
        at_limits = ", ".join(held) or "none"
        return [*out, f"the joints miss the body's targets from t = {t[k]:.2f} s on (COM {com_err[k] * 100:.1f} cm, "
                      f"a sole {feet_err[k].max() * 1e3:.0f} mm off; joints at their limits: {at_limits})"]
    margin = zmp_margins(plan, t, body.zmp_wholebody)
    if margin.min() < ZMP_MARGIN_M:
        out.append(f"multibody ZMP {-margin.min() * 100:.1f} cm outside the support polygon at "
                   f"t = {t[margin.argmin()]:.2f} s")
    if body.figures["zmp_rms_m"] >= body.figures["zmp_rms_unfiltered_m"]:
        out.append("the dynamics filter did not reduce the multibody ZMP's error")
    if lowest_point(feet, sole_half_m).min() < -1e-9:
        out.append("a sole under the ground")
    out += _board_foot(plan, t, feet)
    if board is not None:
        out += deck_failures(t, feet, (sole_half_m, board[1]), board[0])
    return out


def deck_failures(t: np.ndarray, feet: np.ndarray, sole_half: tuple[float, float], board: HumanoidBoardConfig
                  ) -> list[str]:
    """Skating on a deck: the board (right) sole stands on the deck's top whenever it is down, and
    the pushing (left) sole, wherever any of it is over the deck (the deck under the board sole,
    ``board.foot_ahead_m`` behind it), has its lowest edge on or above the deck's top (1 mm);
    ``sole_half``: half the sole's length and width [m]."""
    right, left = feet[:, 0], feet[:, 1]
    centre = right[:, 0:2] - np.array([board.foot_ahead_m, 0.0])
    sole_half_m, sole_half_width_m = sole_half
    out = []
    if np.abs(right[:, 2] - board.deck_height_m).max() > 1e-3:
        out.append(f"the board sole leaves the deck's top ({board.deck_height_m} m) by "
                   f"{np.abs(right[:, 2] - board.deck_height_m).max() * 1e3:.1f} mm")
    reach_x = board.deck_length_m / 2 + sole_half_m * np.abs(np.cos(left[:, 4]))
    reach_y = board.deck_width_m / 2 + sole_half_width_m
    over = (np.abs(left[:, 0] - centre[:, 0]) < reach_x) & (np.abs(left[:, 1] - centre[:, 1]) < reach_y)
    low = left[:, 2] - sole_half_m * np.abs(np.sin(left[:, 4]))
    inside = over & (low < board.deck_height_m - 1e-3)
    if inside.any():
        k = int(np.argmax(inside))
        out.append(f"the pushing sole enters the deck at t = {t[k]:.2f} s (its lowest edge "
                   f"{(board.deck_height_m - low[k]) * 100:.1f} cm under the deck's top, over the deck)")
    return out


def _joint_limits(robot: Humanoid, t: np.ndarray, body: BodyMotion) -> list[str]:
    """The joints' angles within the URDF's range and their rates within its velocity limits."""
    lo, hi, fast = robot.lower[7:], robot.upper[7:], robot.model.velocityLimit[6:]
    out = []
    beyond = (body.q < lo - 1e-9) | (body.q > hi + 1e-9)
    if beyond.any():
        k, j = (int(x[0]) for x in np.nonzero(beyond))
        out.append(f"{body.joint_names[j]} beyond its limit at t = {t[k]:.2f} s ({body.q[k, j]:+.3f} rad, "
                   f"range {lo[j]:+.2f} to {hi[j]:+.2f})")
    over = np.abs(body.qd) > fast
    if over.any():
        k, j = (int(x[0]) for x in np.nonzero(over))
        out.append(f"{body.joint_names[j]} faster than its limit at t = {t[k]:.2f} s ({body.qd[k, j]:+.2f} rad/s, "
                   f"limit {fast[j]:.1f})")
    return out


def _board_foot(plan: list[StepSpec], t: np.ndarray, feet: np.ndarray) -> list[str]:
    """Skating: while the plan's support rides the board (a support velocity), the board (right)
    sole moves with it (1 mm/s)."""
    rate = np.gradient(feet[:, 0, 0:2], t, axis=0)
    worst = 0.0
    for k, (spec, _, sup) in enumerate(_supports(plan, t)):
        v = np.asarray(sup.velocity[0:2], dtype=np.float64)
        if 0 < k < len(t) - 1 and spec.terminal != "skate" and np.any(v != 0.0):
            worst = max(worst, float(np.abs(rate[k] - v).max()))
    return [f"the board sole leaves the board's speed by {worst:.4f} m/s"] if worst > 1e-3 else []
