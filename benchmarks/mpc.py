"""The closed loop's cost: one MPC update (build + solve with the torque rows) along ``v0.50_s2`` for
each QP backend, the sparse OSQP form as the baseline; ``skatelib track`` of the default library
on two workers, against the same runs on one."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from benchmarks.figures import Figure, Measured

UPDATE = Figure("mpc-update", "MPC update (build + solve, DAQP), v0.50_s2", "ms", 2.0, "build + sparse OSQP")
TRACK = Figure("track", "skatelib track, default library, exact plant, 2 workers", "s", 60.0, "one worker")
FIGURES = (UPDATE, TRACK)


def _time_each(fn: Callable[[Any], object], items: list[Any]) -> list[float]:
    """Seconds of fn(item) for each item, in order."""
    times = []
    for item in items:
        t0 = time.perf_counter()
        fn(item)
        times.append(time.perf_counter() - t0)
    return times


def measure(path: Path) -> list[Measured]:
    import numpy as np
    from skatelib.control.kinematics import LegKinematics
    from skatelib.control.linear_model import Feedback
    from skatelib.control.mpc import Discretizer, MpcConfig, build_problem
    from skatelib.control.mpc_solvers import make_solver
    from skatelib.control.params import SkateParams
    from skatelib.control.qp import SOLVERS
    from skatelib.control.reference import EntryReference
    from skatelib.control.settings import TrackSettings
    from skatelib.library.rotations import board_rotations, rpy_matrices
    from skatelib.pipeline.build.sweep import run_calls
    from skatelib.proving.track import track_jobs
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(path)
    e = lib.select(0.5, 2)
    p = SkateParams.from_library(lib)
    cfg = MpcConfig()
    ref = EntryReference(lib, e, p, TrackSettings())
    disc = Discretizer(p, cfg.dt)
    kin = LegKinematics.from_library(lib)
    updates = []
    for t in np.arange(ref.t0, ref.t_end, cfg.dt):
        x0 = np.asarray(e.sample(t).state, float)
        k = int(np.clip(np.searchsorted(e.t, t), 0, len(e.t) - 1))
        r_board = p.moment_arms(board_rotations(x0[5], x0[26]))
        fb = Feedback(x=x0, r_robot=ref.feet[k].T - x0[0:3, None], r_board=r_board,
                      torque_maps=kin.torque_maps(x0[12:24], rpy_matrices(x0[3:6])))  # with the torque rows
        updates.append((fb, ref.horizon(t, cfg.horizon, cfg.dt, ref.board_xy(t), 0.0, ref.prior_coast_mps2(t))))
    qps = [build_problem(p, cfg, disc, fb, horizon) for fb, horizon in updates]  # warm-up
    # Three timing passes; each figure is the median over the updates of the best pass (timeit's
    # practice: the VM's noise only ever adds time).
    t_build = [min(ts) for ts in zip(*(_time_each(lambda u: build_problem(p, cfg, disc, *u), updates)
                                       for _ in range(3)), strict=True)]
    solve: dict[str, list[float]] = {}
    for name in SOLVERS:
        passes = []
        for _ in range(3 if name != "osqp" else 1):
            solver = make_solver(name)  # warm starts from the same first update
            passes.append(_time_each(solver.solve, qps))
        solve[name] = [min(ts) for ts in zip(*passes, strict=True)]
    def update(name: str) -> float:
        return statistics.median(b + s for b, s in zip(t_build, solve[name], strict=True))

    others = ", ".join(f"{n} {update(n) * 1e3:.2f} ms" for n in SOLVERS if n != "daqp")
    jobs = track_jobs(Path(path), None, "", cfg, TrackSettings())
    t0 = time.perf_counter()
    results = [r for r, _ in run_calls(jobs, 2)]
    t_two = time.perf_counter() - t0
    t0 = time.perf_counter()
    run_calls(jobs[:2], 1)
    t_one = (time.perf_counter() - t0) * len(jobs) / 2  # two entries on one worker, scaled to all
    return [Measured(UPDATE, update("daqp") * 1e3, update("osqp") * 1e3,
                     f"build {statistics.median(t_build) * 1e3:.2f} ms; {others}"),
            Measured(TRACK, t_two, t_one, f"{sum(r.passed for r in results)} of {len(results)} pass")]
