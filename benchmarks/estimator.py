"""The state estimator's cost: one update (IMU and encoders in, the robot's and the board's state
out) timed in the loop along ``v0.50_s2`` ridden on the twin with the controller on the estimate
(default model and sensor errors), against the whole-body update of the same run; and the whole
510 Hz tick the robot runs (estimator + whole-body update) against the same."""

from __future__ import annotations

import statistics
import time
from pathlib import Path
from typing import Any

from benchmarks.figures import Figure, Measured

UPDATE = Figure("estimator-update", "one estimator update (IMU + encoders -> state), v0.50_s2 on the estimate",
                "ms", 0.05, "the whole-body updates of the same run")
TICK = Figure("tick", "the 510 Hz tick: estimator update + whole-body update (median of their sums)", "ms", 0.3,
              "the whole-body updates of the same run")
FIGURES = (UPDATE, TICK)


class _Timed:
    """The estimator, each call's time kept."""

    def __init__(self, estimator: Any, times: list[float]):
        self.estimator, self.times = estimator, times

    def __call__(self, reading: Any) -> Any:
        t0 = time.perf_counter()
        out = self.estimator(reading)
        self.times.append(time.perf_counter() - t0)
        return out


def measure(path: Path) -> list[Measured]:
    from skatelib.control.params import SkateParams
    from skatelib.proving.setup import ClosedLoop
    from skatelib.proving.twin.loop import TwinLoop, TwinLoopSettings
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.errors import DEFAULT_TWIN_PERTURBATION, parse_twin_perturbation
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.plant import TwinPlant
    from threadpoolctl import threadpool_limits

    lib = MotionLibrary.open(path)
    key = lib.select(0.5, 2).key
    p = SkateParams.from_library(lib)
    errors = parse_twin_perturbation(DEFAULT_TWIN_PERTURBATION, p.mu)
    with threadpool_limits(limits=1, user_api="blas"):
        loop = TwinLoop(lib, key, ClosedLoop(p, p), TwinPlant(TwinFigures.from_library(lib), errors),
                        TwinLoopSettings(state="estimate", sensor_errors=errors.sensors))
        est_times: list[float] = []
        feedback: Any = loop.feedback
        feedback.estimator = _Timed(feedback.estimator, est_times)
        run = loop.ride()
    wbc = run.wbc_times_s
    n = min(len(est_times), len(wbc))
    est_ms, wbc_ms = statistics.median(est_times) * 1e3, statistics.median(wbc) * 1e3
    tick_ms = statistics.median(e + w for e, w in zip(est_times[:n], wbc[:n], strict=True)) * 1e3
    note = f"{len(est_times)} updates; {'passed' if not run.fall else run.fall}"
    return [Measured(UPDATE, est_ms, wbc_ms, note), Measured(TICK, tick_ms, wbc_ms, f"{n} ticks")]
