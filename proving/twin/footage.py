"""A run on the twin as footage for a video (:mod:`skatelib.sim.video`): the plant's configurations
at the MPC's updates; the plan's pose at the same times as a ghost; on each frame the entry's
name and the model errors, the time, the board's forward speed beside the plan's and the label;
at the end the verdict (pass or fail, and why).

The ghost is the entry's planned state (centre of mass, trunk angles, joints, the board's
position, yaw and roll) where the twin started: the twin is placed at the plan's first state, and
the heights of trunk and deck are matched to the twin's at that instant. After the entry the plan
rides on at its last board speed along its last heading, the legs going to the riding stance over
the transfer (as the controller's reference does, at the plan's speed instead of the measured one).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from skatelib.control.feedback import quat_wxyz
from skatelib.control.params import SkateParams
from skatelib.library import schema
from skatelib.library.channels import I_BOARD_ROLL
from skatelib.library.rotations import rpy_matrices
from skatelib.proving.twin.loop import TwinRun
from skatelib.proving.twin.verdict import TwinResult
from skatelib.runtime import Entry, MotionLibrary
from skatelib.sim.overlay import Caption
from skatelib.sim.scene import pose_qpos
from skatelib.sim.video import Footage

if TYPE_CHECKING:
    import mujoco


def _deck_quat(yaw: float, roll: float) -> np.ndarray:
    """Rz(yaw) Rx(roll) as a quaternion (w, x, y, z)."""
    cy, sy, cr, sr = np.cos(yaw / 2), np.sin(yaw / 2), np.cos(roll / 2), np.sin(roll / 2)
    return np.array([cy * cr, cy * sr, sy * sr, sy * cr])


def plan_state(entry: Entry, t: float, q_ride: np.ndarray, transfer_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The plan's state (28,) and board (x, y, z, yaw) at ``t`` [s]; after the entry riding on at
    its last board speed, joints and trunk angles going to ``q_ride`` and level over ``transfer_s``."""
    end = float(entry.t[-1])
    x = np.array(entry.sample(t).state, dtype=np.float64)
    board = np.array(entry.array_at(schema.D_BOARD_POS, min(t, end)), dtype=np.float64)
    if t <= end:
        return x, board
    w = min((t - end) / max(transfer_s, 1e-9), 1.0)
    heading = np.array([np.cos(board[3]), np.sin(board[3])])
    step = heading * float(np.linalg.norm(x[24:26])) * (t - end)
    x[0:2] += step
    board[0:2] += step
    x[12:24] = (1 - w) * x[12:24] + w * q_ride
    x[3:5] *= 1 - w
    x[I_BOARD_ROLL] *= 1 - w
    return x, board


def plan_qpos(m: mujoco.MjModel, entry: Entry, times: np.ndarray, start: np.ndarray,
              body: tuple[np.ndarray, np.ndarray, float]) -> np.ndarray:
    """The twin's configurations (N, nq) of the plan at ``times`` (:func:`plan_state`), heights
    matched to ``start`` (the twin's configuration at ``times[0]``). ``body``: the centre of mass in
    the trunk frame (3,) [m], the riding stance's joints (12,) [rad], the transfer's length [s]."""
    com_offset, q_ride, transfer_s = body
    trunk_adr, deck_adr = m.joint("trunk_free").qposadr[0], m.joint("deck_free").qposadr[0]
    rows = []
    for t in times:
        x, board = plan_state(entry, float(t), q_ride, transfer_s)
        R = rpy_matrices(x[3:6])
        deck = _deck_quat(board[3], x[I_BOARD_ROLL])
        rows.append((x[0:3] - R @ com_offset, quat_wxyz(R), x[12:24], board[0:3], deck))
    up_trunk = np.array([0.0, 0.0, start[trunk_adr + 2] - rows[0][0][2]])
    up_deck = np.array([0.0, 0.0, start[deck_adr + 2] - rows[0][3][2]])
    return np.array([pose_qpos(m, (p + up_trunk, qt), q, (b + up_deck, qd)) for p, qt, q, b, qd in rows])


def board_speeds(m: mujoco.MjModel, qpos: np.ndarray, dt: float) -> np.ndarray:
    """The deck's forward speed (N,) [m/s] from its positions in ``qpos`` (N, nq) ``dt`` [s] apart
    (central differences along its heading)."""
    a = m.joint("deck_free").qposadr[0]
    xy, q = qpos[:, a:a + 2], qpos[:, a + 3:a + 7]
    yaw = np.arctan2(2 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2))
    v = np.gradient(xy, dt, axis=0) if len(xy) > 1 else np.zeros_like(xy)
    return np.asarray(v[:, 0] * np.cos(yaw) + v[:, 1] * np.sin(yaw))


def verdict_caption(lines: tuple[str, ...], result: TwinResult) -> Caption:
    """The last frame's caption: the verdict and why."""
    label = result.target_velocity_mps
    speed = (f"{result.delivered_mps:.2f} m/s delivered 1 s after the entry (label {label:.2f} m/s, "
             f"{100 * result.speed_error:+.1f} %)" if label else f"{result.delivered_mps:.3f} m/s left after the stop")
    text = f"PASS: {speed}" if result.passed else f"FAIL: {result.reasons}"
    return Caption(lines, text, result.passed)


def _label(t: float, result: TwinResult, stages: Sequence[tuple[float, float]]) -> float:
    """The label at ``t``: a chained ride's stage's target (``stages``: when each stage ends [s] and its
    target [m/s]), else the entry's."""
    return next((v for end, v in stages if t <= end), result.target_velocity_mps)


def run_footage(m: mujoco.MjModel, entry: Entry, run: TwinRun, result: TwinResult, plan: tuple[str, tuple],
                stages: Sequence[tuple[float, float]] = ()) -> Footage:
    """The footage of ``run`` (kept: its configurations and record) of ``entry`` judged ``result``;
    ``plan``: the model errors' text and :func:`plan_qpos`'s ``body``; ``stages``: a chained ride's
    (end [s], target [m/s]) per stage, for the label shown."""
    errors, body = plan
    times = np.array(run.record.t[:len(run.qpos)])
    qpos = np.array(run.qpos[:len(times)])
    dt = float(np.median(np.diff(times))) if len(times) > 1 else 1 / 30
    ghost = plan_qpos(m, entry, times, qpos[0], body)
    speeds = board_speeds(m, qpos, dt)
    planned = [float(np.linalg.norm(plan_state(entry, float(t), body[1], body[2])[0][24:26])) for t in times]
    head = f"{result.key} on the MuJoCo twin, errors: {errors or 'none'}"
    captions = tuple(Caption((head, f"t = {t:5.2f} s   (cyan ghost: the plan)",
                              f"board {v:4.2f} m/s   plan {p:4.2f} m/s   "
                              f"label {_label(float(t), result, stages):.2f} m/s"))
                     for t, v, p in zip(times, speeds, planned, strict=True))
    return Footage(qpos, 1.0 / dt, captions, ghost, verdict_caption(captions[-1].lines, result))


def film_run(lib: MotionLibrary, entry: Entry, ride: tuple[TwinRun, mujoco.MjModel], result: TwinResult,
             how: tuple[str, float, Sequence[tuple[float, float]]], out: Path) -> str:
    """Write the video of ``ride`` (the kept run of ``entry`` and the twin's model) judged ``result``
    to ``out`` (.mp4 or .gif, :func:`skatelib.sim.video.write_run`); ``how``: the model errors'
    text, the transfer's length [s] and a chained ride's (end [s], target [m/s]) per stage (or none).
    Returns the path written."""
    from skatelib.sim.video import write_run

    run, m = ride
    errors, transfer_s, stages = how
    body = (SkateParams.from_library(lib).com_offset_m, lib.quadruped_model.arrays.stance_q_board_rad, transfer_s)
    return str(write_run(m, run_footage(m, entry, run, result, (errors, body), stages), out))
