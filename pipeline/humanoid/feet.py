"""The Foot Coordinates Generator (Takasugi et al., Sec. IV-B): both feet's trajectories for a
solved step plan, sampled at the motion's times.

* Walking: the stance foot stays; the swing foot travels from its foothold to the next one during
  single support along a cycloid (no speed at lift-off and touchdown) rising to ``height_m``; the
  sole's yaw goes linearly from one foothold's to the next.
* Skating: the board foot (the support foot on the board) follows a minimum-jerk path to the
  step's reference position and velocity in the push (accelerating) phase, then moves uniformly
  with the board while sliding and stopping. The pushing foot stays on the ground during the
  push, then swings onto the board beside the board foot at the start of the slide: its toe on a
  minimum-jerk path relative to the board foot (leaving the ground at rest, landing at rest on
  the board), a cycloid rising to ``height_m``; from then on it rides with the board.
* Toe-off (skating, :class:`ToeOff`): over the push's last ``duration_s`` the pushing foot's heel
  rises about its toe edge, which stays on the ground, to ``pitch_rad`` at lift-off (a
  minimum-jerk profile), and the swing lays the sole flat again by touchdown. The ankle rises
  and comes forward with the heel: the reach that lets the leg push until the board is fast
  (without it the leg of an HRP-2-class robot is stretched before a 0.75 m/s push ends).

Feet are (K, 2, 5) arrays: per knot, the right (0) and left (1) sole's centre (x, y, z; on the
ground when flat), its yaw and its pitch (positive: toe down, heel up).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from skatelib.pipeline.humanoid.step import StepSpec

RIGHT, LEFT = 0, 1
POSE = 5  # x, y, z, yaw, pitch


@dataclass(frozen=True)
class ToeOff:
    """The pushing foot's heel lift (module docstring).

    Attributes:
        duration_s: How long before lift-off the heel starts rising [s] (0: the sole stays flat).
        pitch_rad: The sole's pitch at lift-off [rad].
        toe_m: From the sole's centre to its toe edge [m] (half the sole's length).
    """

    duration_s: float = 0.0
    pitch_rad: float = 0.0
    toe_m: float = 0.12

    def centre(self, toe: np.ndarray, pitch: np.ndarray) -> np.ndarray:
        """(K, 3) sole centres of a sole facing +x with its toe edge's middle at ``toe`` (K, 3),
        pitched by ``pitch`` (K,)."""
        return toe + self.toe_m * np.column_stack([-np.cos(pitch), np.zeros_like(pitch), np.sin(pitch)])

    def pitch(self, t: np.ndarray, lift_off_s: float, swing_s: float) -> np.ndarray:
        """The pushing sole's pitch (K,) at times ``t``: flat, then minimum jerk up to ``pitch_rad``
        over the last ``duration_s`` before ``lift_off_s``, then minimum jerk back to flat over the
        ``swing_s`` after it; all zero when either figure is."""
        if self.duration_s <= 0.0 or self.pitch_rad == 0.0:
            return np.zeros_like(t)
        up = np.clip((t - (lift_off_s - self.duration_s)) / self.duration_s, 0.0, 1.0)
        down = np.clip((t - lift_off_s) / swing_s, 0.0, 1.0)
        return self.pitch_rad * (_smooth(up) - _smooth(down))


def _smooth(s: np.ndarray) -> np.ndarray:
    """The rest-to-rest minimum-jerk profile from 0 to 1 for s in [0, 1]."""
    return s**3 * (10 - 15 * s + 6 * s**2)


def sole_poses(feet: np.ndarray) -> np.ndarray:
    """(K, 2, 5) soles from a library's ``feet`` array: (K, 10), or (K, 8) from a file before
    format 1.5 (no pitch: flat)."""
    feet = np.asarray(feet, dtype=np.float64)
    if feet.shape[1] == 2 * POSE:
        return feet.reshape(len(feet), 2, POSE)
    out = np.zeros((len(feet), 2, POSE))
    out[:, :, 0:4] = feet.reshape(len(feet), 2, 4)
    return out


def lowest_point(soles: np.ndarray, half_length_m: float) -> np.ndarray:
    """(K, 2) the height of each sole's lowest edge (its toe or heel, pitched)."""
    return soles[:, :, 2] - half_length_m * np.abs(np.sin(soles[:, :, 4]))


def cycloid(s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """The cycloid's progress along the ground and its height as fractions, at phase ``s`` in
    [0, 1]: (theta - sin theta) / 2 pi and (1 - cos theta) / 2 with theta = 2 pi s. Both start and
    end with zero rate."""
    theta = 2 * np.pi * np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return (theta - np.sin(theta)) / (2 * np.pi), (1 - np.cos(theta)) / 2


Triple = tuple[np.ndarray | Sequence[float], np.ndarray | Sequence[float], np.ndarray | Sequence[float]]


def minimum_jerk(start: Triple, end: Triple, duration_s: float) -> np.ndarray:
    """The quintic of the minimum-jerk path (Flash and Hogan) between two (position, velocity,
    acceleration) triples of n-vectors over ``duration_s``: coefficients c0..c5 of
    p(t) = sum c_i t^i (6, n)."""
    p0, v0, a0 = (np.atleast_1d(np.asarray(x, dtype=np.float64)) for x in start)
    p1, v1, a1 = (np.atleast_1d(np.asarray(x, dtype=np.float64)) for x in end)
    T = duration_s
    # The end conditions on c3, c4, c5 once c0..c2 match the start.
    M = np.array([[T**3, T**4, T**5], [3 * T**2, 4 * T**3, 5 * T**4], [6 * T, 12 * T**2, 20 * T**3]])
    rhs = np.vstack([p1 - (p0 + v0 * T + a0 * T**2 / 2), v1 - (v0 + a0 * T), a1 - a0])
    return np.vstack([p0, v0, a0 / 2, np.linalg.solve(M, rhs)])


def evaluate(coeffs: np.ndarray, t: np.ndarray | float) -> np.ndarray:
    """A polynomial's value at the times ``t`` (clamped to start at 0): (len(t), n)."""
    tt = np.maximum(np.atleast_1d(np.asarray(t, dtype=np.float64)), 0.0)
    return np.stack([tt**i for i in range(len(coeffs))], axis=1) @ coeffs


def walking_feet(plan: Sequence[StepSpec], t: np.ndarray, height_m: float, step_width_m: float) -> np.ndarray:
    """Both feet along a walking plan (module docstring); ``t`` from the plan's start."""
    feet = np.zeros((len(t), 2, POSE))
    foot = {RIGHT: np.array([0.0, -step_width_m / 2, 0.0]), LEFT: np.array([0.0, step_width_m / 2, 0.0])}
    feet[:, RIGHT, 0:3], feet[:, LEFT, 0:3] = foot[RIGHT], foot[LEFT]
    t0 = 0.0
    for spec in plan:
        if spec.terminal == "walk" and len(spec.segments) == 2:  # a step: single, then double support
            stance = np.asarray(spec.segments[0][1].p0)
            swing = LEFT if np.allclose(stance, foot[RIGHT]) else RIGHT
            single = spec.segments[1][0]
            start, end = foot[swing].copy(), np.asarray(spec.p_step, dtype=np.float64)
            along, up = cycloid((t - t0) / single)
            moving = t >= t0
            feet[moving, swing, 0:3] = start + along[moving, None] * (end - start)
            feet[moving, swing, 2] += height_m * up[moving]
            foot[swing] = end
        t0 += spec.duration_s
    return feet


# The swing onto a deck: the pushing sole rises to the deck's height over the swing's first half
# (SWING_RISE) and moves across towards the deck's centre line only over its last part
# (SWING_ACROSS on), so that it is above the deck before any of it is over the deck.
SWING_RISE = 0.5
SWING_ACROSS = 0.3


def skating_feet(plan: Sequence[StepSpec], t: np.ndarray, height_m: float, step_width_m: float,
                 swing_s: float, toe_off: ToeOff | None = None) -> np.ndarray:
    """Both feet along a skating plan (push, slide, stop; module docstring). The board foot stands
    on the deck (the height of its planned support point). The pushing foot's swing takes the
    first ``swing_s`` of the slide, planned for its toe relative to the board foot: it leaves the
    ground at rest (moving backwards relative to the board) and lands at rest on the board where
    the plan's stop stands it (the slide's DCM target is midway between the soles: behind the
    board foot on the deck's line, or beside it); along the board on a
    minimum-jerk path, up to the deck over the swing's first half and across over its last 70 %
    (rest to rest), with the cycloid's ``height_m`` on top; its sole lies flat again when it lands."""
    push, slide = plan[0], plan[1]
    toe_off = toe_off or ToeOff()
    v = np.asarray(push.v_step, dtype=np.float64)
    board_end = np.asarray(push.p_step, dtype=np.float64)
    deck = float(board_end[2])
    board0 = np.array([0.0, -step_width_m / 2, deck])
    ground = np.asarray(push.segments[0][1].p0, dtype=np.float64)  # the pushing foot's foothold
    T1 = push.duration_s
    Ts = min(swing_s, slide.duration_s)
    feet = np.zeros((len(t), 2, POSE))
    path = minimum_jerk((board0, np.zeros(3), np.zeros(3)), (board_end, v, np.zeros(3)), T1)
    board = np.where((t < T1)[:, None], evaluate(path, t), board_end + v * (t - T1)[:, None])
    feet[:, RIGHT, 0:3] = board
    toe = np.array([toe_off.toe_m, 0.0, 0.0])
    # Where the pushing foot lands, relative to the board foot: the slide ends with its DCM midway
    # between the two soles on the board.
    landing = 2 * (np.asarray(slide.p_step, dtype=np.float64) - (board_end + v * slide.duration_s))
    start = ground + toe - board_end
    along = minimum_jerk((start[0:1], -v[0:1], [0.0]), (landing[0:1] + toe[0:1], [0.0], [0.0]), Ts)
    phase = np.clip((t - T1) / Ts, 0.0, 1.0)
    across = _smooth(np.clip((phase - SWING_ACROSS) / (1.0 - SWING_ACROSS), 0.0, 1.0))
    rise = _smooth(np.clip(phase / SWING_RISE, 0.0, 1.0))
    rel = np.column_stack([evaluate(along, t - T1)[:, 0], start[1] + across * (landing[1] - start[1]),
                           start[2] + rise * (landing[2] - start[2])])
    _, up = cycloid(phase)
    swinging = (t >= T1) & (t < T1 + Ts)
    toe_path = np.select([(t < T1)[:, None], swinging[:, None]], [ground + toe, board + rel], board + landing + toe)
    toe_path[:, 2] += height_m * np.where(swinging, up, 0.0)
    pitch = toe_off.pitch(t, T1, Ts)
    feet[:, LEFT, 0:3] = toe_off.centre(toe_path, pitch)
    feet[:, LEFT, 4] = pitch
    return feet
