"""The humanoid in a Rerun recording: COM and its path, ZMP, the contact point, the soles and the
support polygons of the entry's stored plan, and the plots of its tab; with a whole body (format
1.3), the robot from the library's URDF posed at every knot, its soles' paths and the multibody
ZMP after the dynamics filter."""

from __future__ import annotations

from typing import Any

import numpy as np
import rerun as rr
from skatelib.library import schema
from skatelib.library.rotations import quaternion_matrices
from skatelib.pipeline.humanoid.feet import sole_poses
from skatelib.pipeline.views.rerun_parts import ground, series, time_index
from skatelib.runtime import Entry, MotionLibrary

BOARD_HALF_M = (0.4, 0.12, 0.01)  # a drawn deck (the plan puts the board sole on the ground)
PANELS = [("COM height", "com_z"), ("COM speed", "com_vx"), ("ZMP x", "zmp_x"), ("ZMP y", "zmp_y")]


def log_entry(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, root: str, offset: np.ndarray) -> None:
    t, x = e.t, e.state
    zmp = e.arrays[schema.D_ZMP]
    cp = e.arrays[schema.D_CONTACT_POINT]
    m = lib.humanoid_model
    rec.send_columns(f"{root}/com", indexes=time_index(t),
                     columns=rr.Points3D.columns(positions=x[:, 0:3] + offset, radii=np.full(len(t), 0.03)))
    rec.log(f"{root}/com_path", rr.LineStrips3D([x[:, 0:3] + offset], colors=[(200, 40, 40)]), static=True)
    ground(rec, root, x[:, 0:2] + offset[:2], 0.5)
    zmp3 = np.column_stack([zmp, np.zeros(len(zmp))]) + offset
    green = np.tile(np.array([[20, 160, 60]], dtype=np.uint8), (len(t), 1))
    rec.send_columns(f"{root}/zmp", indexes=time_index(t),
                     columns=rr.Points3D.columns(positions=zmp3, radii=np.full(len(t), 0.02), colors=green))
    rec.send_columns(f"{root}/contact_point", indexes=time_index(t),
                     columns=rr.Points3D.columns(positions=cp + offset, radii=np.full(len(t), 0.015)))
    # Soles under the contact point (the footprints of the plan), static.
    feet = np.unique(np.round(cp[:, :2], 4), axis=0)
    half = [m.foot_length_m / 2, m.foot_width_m / 2, 0.005]
    rec.log(f"{root}/soles", rr.Boxes3D(centers=np.column_stack([feet, np.zeros(len(feet))]) + offset,
                                        half_sizes=[half] * len(feet), colors=[(120, 120, 200)]), static=True)
    _log_support_polygons(rec, lib, e, root, offset)
    if schema.D_JOINTS in e.arrays and lib.urdf:
        _log_body(rec, lib, e, root, offset)
    for name, col, label in (("com_z", x[:, 2], "COM height [m]"), ("com_vx", x[:, 3], "COM speed [m/s]"),
                             ("zmp_x", zmp[:, 0], "ZMP x [m]"), ("zmp_y", zmp[:, 1], "ZMP y [m]")):
        series(rec, root, name, t, col, label)


def _log_support_polygons(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, root: str,
                          offset: np.ndarray) -> None:
    """The support polygon of each contact segment of the entry's stored plan, on the ground where it starts."""
    from skatelib.pipeline.humanoid.motion import stored_plan

    plan = stored_plan(lib, e)
    strips = []
    for spec in plan:
        for _, sup in spec.segments:
            poly = np.asarray(sup.polygon) + np.asarray(sup.p0)[:2]
            ring = np.vstack([poly, poly[:1]])
            strips.append(np.column_stack([ring, np.full(len(ring), 0.002)]) + offset)
    rec.log(f"{root}/support_polygons", rr.LineStrips3D(strips, colors=[(60, 60, 200)]), static=True)


def _log_body(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, root: str, offset: np.ndarray) -> None:
    """The posed robot, the soles' paths and the multibody ZMP (black), with its plot beside the plan's."""
    from skatelib.pipeline.views.rerun_robot import Robot, log_robot

    t, base = e.t, e.arrays[schema.D_BASE_POSE]
    log_robot(rec, Robot(lib.urdf), f"{root}/robot", t, (base[:, 0:3] + offset, quaternion_matrices(base[:, 3:7]),
                                                          e.arrays[schema.D_JOINTS]))
    feet = sole_poses(e.arrays[schema.D_FEET])
    rec.log(f"{root}/sole_paths", rr.LineStrips3D([feet[:, s, 0:3] + offset for s in (0, 1)],
                                                  colors=[(120, 120, 120)], radii=0.003), static=True)
    zmp = e.arrays[schema.D_ZMP_WHOLEBODY]
    rec.send_columns(f"{root}/zmp_wholebody", indexes=time_index(t), columns=rr.Points3D.columns(
        positions=np.column_stack([zmp, np.zeros(len(t))]) + offset, radii=np.full(len(t), 0.015),
        colors=np.zeros((len(t), 3), dtype=np.uint8)))
    series(rec, root, "zmp_x_wholebody", t, zmp[:, 0], "multibody ZMP x [m]")
    if str(e.attrs.get("motion", "")) == "skate":  # the board under the board (right) sole, drawn only
        rec.log(f"{root}/board", rr.Boxes3D(half_sizes=[BOARD_HALF_M], colors=[(160, 110, 60)]), static=True)
        centre = feet[:, 0, 0:3] + offset + np.array([BOARD_HALF_M[0] / 3, 0.0, -BOARD_HALF_M[2]])
        rec.send_columns(f"{root}/board", indexes=time_index(t), columns=rr.Transform3D.columns(translation=centre))


def logger(lib: MotionLibrary) -> Any:
    """``log(rec, e, root, offset)`` for this library's entries."""
    return lambda rec, e, root, offset: log_entry(rec, lib, e, root, offset)
