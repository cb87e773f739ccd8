"""Logging the default library to a Rerun recording with columns (``send_columns``), against
logging the robot's link transforms row by row (``rr.log`` per knot), extrapolated to the library."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from benchmarks.figures import Figure, Measured

RERUN = Figure("rerun", "Rerun recording of the default library", "s", 2.0, "row by row, transforms only")
FIGURES = (RERUN,)


def measure(path: Path) -> list[Measured]:
    import rerun as rr
    from skatelib.library.rotations import rpy_matrices
    from skatelib.pipeline.quadruped.rerun import Robot
    from skatelib.pipeline.views.rerun_inspect import log_library
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(path)
    tmp = Path(tempfile.mkdtemp())
    rec = rr.RecordingStream("skatelib-bench")
    rec.save(str(tmp / "cols.rrd"))
    t0 = time.perf_counter()
    log_library(lib, rec)
    rec.flush()
    t_cols = time.perf_counter() - t0
    rec.disconnect()
    rec2 = rr.RecordingStream("skatelib-bench-rows")
    rec2.save(str(tmp / "rows.rrd"))
    robot = Robot(lib.urdf)
    entries = list(lib)[:2]
    t0 = time.perf_counter()
    for e in entries:
        trans, quats, _ = robot.poses(e.state[:, 0:3], rpy_matrices(e.state[:, 3:6]), e.state[:, 12:24])
        for k, tk in enumerate(e.t):
            rec2.set_time("time", duration=float(tk))
            for i, g in enumerate(robot.geoms.geometryObjects):
                rec2.log(f"/{e.key}/robot/{g.name}", rr.Transform3D(translation=trans[k, i], quaternion=quats[k, i]))
            rec2.log(f"/{e.key}/plots/board_speed", rr.Scalars(float(e.state[k, 24])))
    rec2.flush()
    per_entry = (time.perf_counter() - t0) / len(entries)
    return [Measured(RERUN, t_cols, per_entry * len(lib), f"{len(lib)} entries")]
