"""A humanoid's runs on the twin in a Rerun recording (``skatelib track HUMANOID_LIB --plant mujoco
--save OUT.rrd``): per entry the plan as ``inspect`` draws it at ``/<key>/plan`` and the twin
beside it at ``/<key>/twin`` (the robot posed from its MuJoCo configuration, its COM, the ZMP of
its soles' contact forces, its soles and, for a skate, its board's deck), with the plots of the
plan's tab: COM height and speed, the ZMP's x and y, the twin's (relative to the board sole for a
skate, as its verdict takes them) beside the plan's; a skate adds the board's speed."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
from skatelib.library.rotations import quaternion_matrices
from skatelib.pipeline.humanoid.rerun import log_entry
from skatelib.pipeline.views.rerun_inspect import _log_summary, _write_stream, blueprint
from skatelib.pipeline.views.rerun_parts import ground, series, time_index
from skatelib.runtime import MotionLibrary

BESIDE_M = 1.2  # the twin this far to the plan's left (+y)
ENTRY_SPACING_M = 3.0  # entries this far apart along y
TWIN_RGB = (230, 120, 20)  # the twin's COM and ZMP: orange (the plan's: red COM, green ZMP)
BOARD_RGB = (150, 100, 50)
SOLE_THICKNESS_M = 0.02


def log_twin(rec: rr.RecordingStream, lib: MotionLibrary, run: Any, root: str, offset: np.ndarray) -> None:
    """One run (:class:`skatelib.proving.humanoid.loop.HumanoidRun`, kept with its poses) at ``root``."""
    from skatelib.pipeline.views.rerun_robot import Robot, log_robot

    t, n = run.t, len(run.t)
    shift = np.zeros((n, 2)) if run.board_shift is None else run.board_shift
    world = np.column_stack([shift, np.zeros(n)])  # the verdict's frame back to the world's
    com = run.com - world + offset
    ground(rec, root, com[:, 0:2], 0.5)
    rec.send_columns(f"{root}/com", indexes=time_index(t), columns=rr.Points3D.columns(
        positions=com, radii=np.full(n, 0.03), colors=np.tile(np.array([TWIN_RGB], dtype=np.uint8), (n, 1))))
    rec.log(f"{root}/com_path", rr.LineStrips3D([com], colors=[TWIN_RGB]), static=True)
    zmp = np.column_stack([run.zmp - shift, np.zeros(n)]) + offset  # NaN while airborne: drawn nowhere
    rec.send_columns(f"{root}/zmp", indexes=time_index(t), columns=rr.Points3D.columns(
        positions=np.nan_to_num(zmp, nan=0.0), radii=np.where(np.isnan(zmp[:, 0]), 0.0, 0.025),
        colors=np.tile(np.array([TWIN_RGB], dtype=np.uint8), (n, 1))))
    m = lib.humanoid_model
    half = [m.foot_length_m / 2, m.foot_width_m / 2, SOLE_THICKNESS_M / 2]
    for s, name in enumerate(("right_sole", "left_sole")):
        rec.log(f"{root}/{name}", rr.Boxes3D(half_sizes=[half], colors=[(90, 90, 160)]), static=True)
        yaw = run.sole_yaw[:, s]
        quat = np.column_stack([np.zeros(n), np.zeros(n), np.sin(yaw / 2), np.cos(yaw / 2)])
        rec.send_columns(f"{root}/{name}", indexes=time_index(t), columns=rr.Transform3D.columns(
            translation=run.sole_pos[:, s] + offset, quaternion=quat))
    if run.qpos is not None and run.layout is not None:
        root_adr, qadr, deck_adr = run.layout
        base = run.qpos[:, root_adr:root_adr + 7]
        log_robot(rec, Robot(lib.urdf), f"{root}/robot", t,
                  (base[:, 0:3] + offset, quaternion_matrices(base[:, [4, 5, 6, 3]]), run.qpos[:, qadr]))
        if m.board is not None and deck_adr >= 0:
            b, deck = m.board, run.qpos[:, deck_adr:deck_adr + 7]  # the deck's top centre, quaternion w, x, y, z
            rec.log(f"{root}/board", rr.Boxes3D(half_sizes=[[b.deck_length_m / 2, b.deck_width_m / 2, 0.0075]],
                                                centers=[[0.0, 0.0, -0.0075]], colors=[(160, 110, 60)]), static=True)
            rec.send_columns(f"{root}/board", indexes=time_index(t), columns=rr.Transform3D.columns(
                translation=deck[:, 0:3] + offset, quaternion=deck[:, [4, 5, 6, 3]]))
    for name, col, label in (("com_z", run.com[:, 2], "COM height [m]"),
                             ("com_vx", np.gradient(run.com[:, 0] - shift[:, 0], t) if n > 1 else np.zeros(n),
                              "COM speed [m/s]"),
                             ("zmp_x", run.zmp[:, 0], "ZMP x (contact forces) [m]"),
                             ("zmp_y", run.zmp[:, 1], "ZMP y (contact forces) [m]")):
        series(rec, root, name, t, col, label)
        rec.log(f"{root}/plots/{name}", rr.SeriesLines.from_fields(colors=[TWIN_RGB]), static=True)  # beside the plan's
    if run.deck_v is not None:
        series(rec, root, "com_vx/board", t, np.linalg.norm(run.deck_v[:, 0:2], axis=1), "board speed [m/s]")
        rec.log(f"{root}/plots/com_vx/board", rr.SeriesLines.from_fields(colors=[BOARD_RGB]), static=True)


def save_humanoid_runs(lib: MotionLibrary, runs: list[Any], save: Path) -> list[str]:
    """Each entry's plan beside its run on the twin (``runs``: kept runs), with the views of
    ``inspect`` (a tab per entry); written atomically."""
    rec = rr.RecordingStream(f"skatelib-track-{lib.path.stem}")
    stream = rr.binary_stream(recording=rec)  # in memory, then written whole (a full device: one clear error)
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    roots = []
    for n, run in enumerate(runs):
        offset = np.array([0.0, ENTRY_SPACING_M * n, 0.0])
        e = lib[run.key]
        rec.log(f"/{run.key}", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)  # its tab's 3D view
        log_entry(rec, lib, e, f"/{run.key}/plan", offset)
        _log_summary(rec, f"/{run.key}/plan", e)
        log_twin(rec, lib, run, f"/{run.key}/twin", offset + np.array([0.0, BESIDE_M, 0.0]))
        roots += [f"/{run.key}/plan", f"/{run.key}/twin"]
    rec.send_blueprint(blueprint(lib, roots))
    _write_stream(stream, save)
    return roots
