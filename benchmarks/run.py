"""``make bench``: speed figures as ratios against a baseline run in the same process.

Push-off TO (issue #3): build + solve of 0.5 m/s, 2 strides, dt 0.03 s, one core:
 * baseline: the same NLP with the stage functions interpreted by CasADi's virtual machine;
 * compiled: stage functions compiled with the C compiler (cached on disk; the first run
   compiles, which is reported separately);
 * warm: the compiled solve warm-started from the 0.45 m/s solution.
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from skatelib.pipeline import pushoff
from skatelib.pipeline.config import load_config


def _build_and_solve(cfg, v: float, strides: int, warm=None) -> tuple[float, pushoff.SolveResult]:
    pushoff._PROBLEMS.clear()  # measure the build too
    t0 = time.perf_counter()
    if warm is not None:
        pushoff.problem_for(cfg, strides)
        t0 = time.perf_counter()
    r = pushoff.solve(pushoff.PushoffSpec(cfg, v, strides, warm=warm))
    return time.perf_counter() - t0, r


def bench_pushoff(repeats: int = 3) -> None:
    cfg = load_config()
    vm = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))
    t0 = time.perf_counter()
    pushoff.problem_for(cfg, 2)  # compiles on a cold cache
    print(f"first build incl. C compilation (cached afterwards): {time.perf_counter() - t0:.1f} s")
    rows = {}
    for name, c in (("baseline (VM)", vm), ("compiled", cfg)):
        times, its = [], []
        for _ in range(repeats):
            dt, r = _build_and_solve(c, 0.5, 2)
            assert r.success, r.status
            times.append(dt)
            its.append(r.iterations)
        rows[name] = (statistics.median(times), statistics.median(its))
    _, prev = _build_and_solve(cfg, 0.45, 2)
    wt, wi = [], []
    for _ in range(repeats):
        dt, r = _build_and_solve(cfg, 0.5, 2, warm=prev.warm)
        wt.append(dt)
        wi.append(r.iterations)
    rows["compiled, warm from 0.45 m/s (solve only)"] = (statistics.median(wt), statistics.median(wi))
    base = rows["baseline (VM)"][0]
    print(f"push-off TO, 0.5 m/s, 2 strides, dt 0.03 s (median of {repeats})")
    print(f"{'variant':45s} {'build+solve [s]':>16s} {'IPOPT iter':>10s} {'speed-up':>9s}")
    for name, (t, it) in rows.items():
        print(f"{name:45s} {t:16.2f} {it:10.0f} {base / t:8.1f}x")
    print("target (issue #3): build + solve <= 1.5 s median")


if __name__ == "__main__":
    bench_pushoff()
