"""The full-physics closed loop's cost: one whole-body update (pinocchio's terms, the tasks, the
QP) along ``v0.50_s2`` ridden on the twin, against the MPC updates of the same run; ``skatelib
track --plant mujoco`` of the default library on two workers, against two entries on one scaled
to all."""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path
from typing import Any

from benchmarks.figures import Figure, Measured

UPDATE = Figure("wbc-update", "whole-body update (terms + tasks + QP), v0.50_s2 on the twin", "ms", 0.3,
                "the MPC updates of the same run")
# The same updates (a second, recorded run) replayed back to back (no simulator step between them
# to evict the caches, as in a controller process of its own): information beside the figure
# above, not a replacement.
REPLAY = Figure("wbc-replay", "the same whole-body updates replayed back to back", "ms", 0.3,
                "the updates in the loop (above)")
TRACK = Figure("track-twin", "skatelib track --plant mujoco --state true, default library, 2 workers", "s", 300.0,
               "one worker")
FIGURES = (UPDATE, REPLAY, TRACK)


class _Capture:
    """The loop's task maker, recording each tick's time, sensed state and MPC forces."""

    def __init__(self, tasks: Any, ticks: list[tuple[float, Any, Any]]):
        self.tasks, self.ticks = tasks, ticks

    def __call__(self, t: float, st: Any, T: Any, feet_v: Any, forces: Any) -> Any:
        self.ticks.append((t, st, forces.copy()))
        return self.tasks(t, st, T, feet_v, forces)


def _replay(ctrl: Any, tasks: Any, ticks: list[tuple[float, Any, Any]]) -> float:
    """The median time of the controller's whole-body updates (terms, tasks, QP) replayed back to back [ms]."""
    times = []
    for t, st, forces in ticks:
        t0 = time.perf_counter()
        qp, vp = ctrl.dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
        T = ctrl.dyn.terms(qp, vp)
        ctrl.wbc.solve(T, tasks(t, st, T, (T.J_feet @ vp).T, forces))
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3


def measure(path: Path) -> list[Measured]:
    from skatelib.control.mpc import MpcConfig
    from skatelib.control.params import SkateParams
    from skatelib.control.settings import TrackSettings
    from skatelib.pipeline.build.sweep import run_calls
    from skatelib.proving.setup import ClosedLoop
    from skatelib.proving.twin.loop import TwinLoop
    from skatelib.proving.twin.track import twin_jobs
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.plant import TwinPlant
    from threadpoolctl import threadpool_limits

    lib = MotionLibrary.open(path)
    key = lib.select(0.5, 2).key
    p = SkateParams.from_library(lib)
    with threadpool_limits(limits=1, user_api="blas"):
        # The figure: the loop as `track` runs it, nothing attached; the replay's ticks come from a
        # second, recorded run.
        loop = TwinLoop(lib, key, ClosedLoop(p, p), TwinPlant(TwinFigures.from_library(lib)))
        t0 = time.perf_counter()
        run = loop.ride()
        wall = time.perf_counter() - t0
        recorded = TwinLoop(lib, key, ClosedLoop(p, p), TwinPlant(TwinFigures.from_library(lib)))
        ticks: list[tuple[float, Any, Any]] = []
        tasks = recorded.ctrl.targets
        recorded.ctrl.targets = _Capture(tasks, ticks)  # type: ignore[assignment]
        recorded.ride()
        replay = _replay(recorded.ctrl, dataclasses.replace(tasks), ticks)
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
            Measured(REPLAY, replay, wbc, f"{len(ticks)} ticks"),
            Measured(TRACK, t_two, t_one, f"{sum(r.passed for r in results)} of {len(results)} pass")]
