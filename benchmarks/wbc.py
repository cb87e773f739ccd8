"""The full-physics closed loop's cost: one whole-body update (pinocchio's terms, the tasks, the
QP) along ``v0.50_s2`` ridden on the twin, against the MPC updates of the same run; ``skatelib
track --plant mujoco`` of the default library on two workers, against two entries on one scaled
to all."""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from benchmarks.figures import Figure, Measured

UPDATE = Figure("wbc-update", "whole-body update (terms + tasks + QP), v0.50_s2 on the twin", "ms", 0.3,
                "the MPC updates of the same run")
TRACK = Figure("track-twin", "skatelib track --plant mujoco, default library, 2 workers", "s", 300.0,
               "one worker")
FIGURES = (UPDATE, TRACK)


def measure(path: Path) -> list[Measured]:
    from skatelib.control.mpc import MpcConfig
    from skatelib.control.params import SkateParams
    from skatelib.control.settings import ClosedLoop, TrackSettings
    from skatelib.control.twin_loop import TwinLoop
    from skatelib.pipeline.build.sweep import run_calls
    from skatelib.pipeline.twin_track import twin_jobs
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.plant import TwinPlant
    from threadpoolctl import threadpool_limits

    lib = MotionLibrary.open(path)
    key = lib.select(0.5, 2).key
    p = SkateParams.from_library(lib)
    with threadpool_limits(limits=1, user_api="blas"):
        t0 = time.perf_counter()
        run = TwinLoop(lib, key, ClosedLoop(p, p), TwinPlant(TwinFigures.from_library(lib))).ride()
        wall = time.perf_counter() - t0
    wbc, mpc = statistics.median(run.wbc_times_s) * 1e3, statistics.median(run.mpc_times_s) * 1e3
    jobs = twin_jobs(Path(path), None, "", MpcConfig(), TrackSettings())
    t0 = time.perf_counter()
    results = [out[0] for out in run_calls(jobs, 2)]
    t_two = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_calls(jobs[:2], 1)
    t_one = (time.perf_counter() - t0) * len(jobs) / 2
    simulated = run.measures.ticks * 2 / 1020
    return [Measured(UPDATE, wbc, mpc, f"{len(run.wbc_times_s)} ticks; {simulated / wall:.1f}x real time"),
            Measured(TRACK, t_two, t_one, f"{sum(r.passed for r in results)} of {len(results)} pass")]
