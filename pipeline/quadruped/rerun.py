"""The quadruped in a Rerun recording: the robot from the library's URDF posed by pinocchio at
every knot, the board (deck rolling on trucks and wheels), paths, footholds, contact forces as
arrows (blue on the board, orange on the ground) and the plots of its tab."""

from __future__ import annotations

from typing import Any

import numpy as np
import rerun as rr
from skatelib.library.channels import BOARD, GROUND, I_BOARD_ROLL, LEGS, S_Q, S_RPY
from skatelib.library.margins import forward_speed, friction_margins
from skatelib.library.model import BoardModel
from skatelib.library.rotations import board_rotations, rpy_matrices
from skatelib.pipeline.views.rerun_parts import ground, quat_rows, series, time_index
from skatelib.pipeline.views.rerun_robot import Robot, log_robot
from skatelib.runtime import Entry, MotionLibrary

BOARD_COLOR, GROUND_COLOR, SWING_COLOR = (40, 110, 255), (255, 140, 0), (160, 160, 160)
FORCE_SCALE_M_PER_N = 0.004
DECK_THICKNESS_M = 0.02
WHEEL_RADIUS_M = 0.03  # drawn only: the paper gives the deck height with wheels (0.11 m), not the wheels
WHEEL_WIDTH_M = 0.035
PANELS = [("board speed vs target", "board_speed"), ("deck roll", "board_roll"), ("normal forces", "normal_force"),
          ("joint angles", "joints"), ("margins", "margins")]


def log_entry(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, robot: Robot, root: str,
                        offset: np.ndarray) -> None:
    t, x, u = e.t, e.state, e.control
    assert e.contact is not None and e.foot_pos is not None and e.board_pos is not None
    K = len(t)
    R = rpy_matrices(x[:, 3:6])
    m = lib.quadruped_model
    com_off = m.arrays.robot_com_offset_m
    trunk = x[:, 0:3] - np.einsum("kij,j->ki", R, com_off) + offset
    jac = log_robot(rec, robot, f"{root}/robot", t, (trunk, R, x[:, 12:24]))
    # Paths: the board's on the ground, each foot's trail, and where the push foot stood on the ground.
    rec.log(f"{root}/board_path", rr.LineStrips3D([e.board_pos[:, 0:3] * [1, 1, 0] + offset], colors=[(160, 110, 60)]),
            static=True)
    trails = [e.foot_pos[:, i] + offset for i in range(len(LEGS))]  # where each foot went
    rec.log(f"{root}/foot_trails", rr.LineStrips3D(trails, colors=[(120, 120, 120)], radii=0.002), static=True)
    stood = e.contact == GROUND
    if np.any(stood):
        steps = np.unique(np.round(e.foot_pos[stood], 3), axis=0)
        rec.log(f"{root}/footholds", rr.Points3D(steps + offset, radii=0.012, colors=[(230, 120, 30)]), static=True)
    _log_board(rec, m.board, e, root, offset)
    ground(rec, root, e.board_pos[:, :2] + offset[:2], m.board.deck_length_m)
    # Contact forces at the knots where a control acts.
    forces = u[:, :12].reshape(-1, 4, 3)
    for i, leg in enumerate(LEGS):
        c = e.contact[:-1, i]
        colors = np.array([BOARD_COLOR if ci == BOARD else GROUND_COLOR if ci == GROUND else SWING_COLOR for ci in c],
                          dtype=np.uint8)
        rec.send_columns(f"{root}/forces/{leg}", indexes=time_index(t[:-1]),
                         columns=rr.Arrows3D.columns(origins=e.foot_pos[:-1, i] + offset,
                                                     vectors=forces[:, i] * FORCE_SCALE_M_PER_N, colors=colors))
    # Plots.
    series(rec, root, "board_speed/actual", t, forward_speed(x), "board speed [m/s]")
    series(rec, root, "board_speed/target", t, np.full(K, e.target_velocity_mps), "label [m/s]")
    series(rec, root, "board_roll", t, x[:, I_BOARD_ROLL], "deck roll [rad]")
    for i, leg in enumerate(LEGS):
        series(rec, root, f"normal_force/{leg}", t[:-1], forces[:, i, 2], f"{leg} normal force [N]")
    for name, q in zip(e.columns["state"][S_Q], x[:, S_Q].T, strict=True):
        series(rec, root, f"joints/{name}", t, q, f"{name.removeprefix('q_').replace('_', ' ')} [rad]")
    tau_max = m.torque_limit_Nm
    fric, _ = friction_margins(x, u, e.contact, m.friction_mu)
    touching = np.isin(e.contact[:-1], (BOARD, GROUND))
    tau = np.abs(np.einsum("klji,klj->kli", jac[:-1], forces)).max(axis=2)  # |J^T f| per leg
    torque = np.where(touching, tau_max - tau, np.inf).min(axis=1)
    series(rec, root, "margins/friction_N", t[:-1], fric, "Coulomb margin mu f_n - |f_t| [N]")
    series(rec, root, "margins/torque_Nm", t[:-1], torque, "torque margin [N m]")


def log_estimate(rec: rr.RecordingStream, root: str, t: np.ndarray, x: np.ndarray) -> None:
    """What the controller was fed on the estimate (its model state ``x`` at ``t``), plotted beside
    the plant's truth in the entry's tab: the board's speed and the deck's roll."""
    series(rec, root, "board_speed/estimate", t, forward_speed(x), "board speed [m/s]")
    series(rec, root, "board_roll", t, x[:, I_BOARD_ROLL], "deck roll [rad]")


def _log_board(rec: rr.RecordingStream, b: BoardModel, e: Entry, root: str, offset: np.ndarray) -> None:
    """The board: the deck rolls about its x axis on two trucks that stay on the ground, four
    wheels on the trucks' axles; all of it moves and yaws with the board (``board_pos``: the deck
    top's centre, the deck roll)."""
    assert e.board_pos is not None
    t, yaw, roll = e.t, e.state[:, S_RPY][:, 2], e.state[:, I_BOARD_ROLL]
    height = b.deck_height_m  # deck top above the ground, wheels included
    base = e.board_pos[:, :3] * [1.0, 1.0, 0.0] + offset
    heading = quat_rows(board_rotations(yaw, 0 * roll))
    rec.send_columns(f"{root}/board", indexes=time_index(t),
                     columns=rr.Transform3D.columns(translation=base, quaternion=heading))
    half = [b.deck_length_m / 2, b.deck_width_m / 2, DECK_THICKNESS_M / 2]
    rec.log(f"{root}/board/deck", rr.Boxes3D(half_sizes=[half], centers=[[0, 0, -DECK_THICKNESS_M / 2]],
                                             colors=[(160, 110, 60)], fill_mode="solid"), static=True)
    rec.send_columns(f"{root}/board/deck", indexes=time_index(t),
                     columns=rr.Transform3D.columns(translation=np.tile([0.0, 0.0, height], (len(t), 1)),
                                                    quaternion=quat_rows(board_rotations(0 * yaw, roll))))
    axles = [b.l_front_m, -b.l_rear_m]
    half_track = b.truck_width() / 2
    hanger = height - DECK_THICKNESS_M - WHEEL_RADIUS_M
    rec.log(f"{root}/board/trucks", rr.Boxes3D(
        centers=[[x, 0.0, WHEEL_RADIUS_M + hanger / 2] for x in axles],
        half_sizes=[[0.02, half_track - WHEEL_WIDTH_M / 2, hanger / 2]] * 2, colors=[(150, 150, 160)],
        fill_mode="solid"), static=True)
    rec.log(f"{root}/board/wheels", rr.Cylinders3D(
        centers=[[x, side * half_track, WHEEL_RADIUS_M] for x in axles for side in (-1.0, 1.0)],
        lengths=[WHEEL_WIDTH_M] * 4, radii=[WHEEL_RADIUS_M] * 4, colors=[(235, 235, 225)],
        rotation_axis_angles=[rr.RotationAxisAngle(axis=[1.0, 0.0, 0.0], degrees=90.0)] * 4), static=True)


def logger(lib: MotionLibrary) -> Any:
    """``log(rec, e, root, offset)`` for this library's entries (the robot built once)."""
    robot = Robot(lib.urdf)
    return lambda rec, e, root, offset: log_entry(rec, lib, e, robot, root, offset)
