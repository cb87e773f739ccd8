"""The push-off TO, 0.5 m/s x 2 strides, dt 0.03 s: build + solve cold and warm-started from the
0.45 m/s solution, against the same NLP with its stage functions interpreted by CasADi's virtual
machine (the baseline). Both evaluate their stage derivatives on a thread per core this process may
use, as a solve on its own does (``make bench`` otherwise holds every part to one thread); IPOPT and
MUMPS run on one."""

from __future__ import annotations

import dataclasses
import os
import statistics
import time
from typing import Any

from skatelib.pipeline.config import load_config
from skatelib.pipeline.ocp import threads
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.problem import pushoff

from benchmarks.figures import Figure, Measured

COLD = Figure("pushoff-cold", "push-off 0.5 m/s x 2 strides, build + solve, cold", "s", 1.0,
              "stage functions interpreted")
WARM = Figure("pushoff-warm", "the same, warm-started from 0.45 m/s, fresh build", "s", 0.5,
              "stage functions interpreted, cold")
CHAIN = Figure("pushoff-warm-built", "the same, warm, on the problem built before (a chain)", "s", 0.5,
               "stage functions interpreted, cold")
FIGURES = (COLD, WARM, CHAIN)


def _build_and_solve(cfg: QuadrupedConfig, v: float, strides: int, warm: Any = None, build: bool = True
                     ) -> tuple[float, pushoff.SolveResult, float]:
    """Wall time of build + solve (``build=False``: the solve on the problem built before, as a warm
    chain runs), the result, and the part of the solve spent in CasADi's function evaluations
    (IPOPT's own work, MUMPS included, is the rest)."""
    if build:
        pushoff._PROBLEMS.clear()  # measure the build too (the compiled stage functions stay cached on disk)
    t0 = time.perf_counter()
    spec = pushoff.PushoffSpec(cfg, v, strides, warm=warm)
    r = pushoff.solve(spec)
    elapsed = time.perf_counter() - t0
    stats = pushoff.problem_for(cfg, strides).solver(pushoff.solver_options(spec)).stats()
    evals = sum(t for k, t in stats.items() if k.startswith("t_wall_nlp_"))
    return elapsed, r, evals


def measure(repeats: int = 3) -> list[Measured]:
    """Medians of ``repeats`` runs of each variant (the first build compiles on a cold cache), the
    stage derivatives on every core this process may use."""
    held = os.environ.pop(threads.ENV, None)
    try:
        n_threads = threads.stage_threads()
        on = f"stage derivatives on {n_threads} threads"
        return [dataclasses.replace(m, note=f"{m.note}, {on}") for m in _measure(repeats)]
    finally:
        if held is not None:
            os.environ[threads.ENV] = held


def _measure(repeats: int) -> list[Measured]:
    cfg = load_config(None, QuadrupedConfig)
    vm = dataclasses.replace(cfg, optimization=dataclasses.replace(cfg.optimization, compile=False))
    t0 = time.perf_counter()
    pushoff.problem_for(cfg, 2)
    print(f"first build incl. C compilation (cached afterwards): {time.perf_counter() - t0:.1f} s")
    _, prev, _ = _build_and_solve(cfg, 0.45, 2)
    rows = {}
    for name, c, warm, build in (("vm", vm, None, True), ("cold", cfg, None, True), ("warm", cfg, prev.warm, True),
                                 ("chain", cfg, prev.warm, False)):
        runs = [_build_and_solve(c, 0.5, 2, warm, build) for _ in range(repeats)]
        failed = [r.status for _, r, _ in runs if not r.success]
        if failed:
            raise RuntimeError(f"push-off benchmark: a solve failed ({failed})")
        rows[name] = tuple(statistics.median(x) for x in zip(*((t, r.iterations, e) for t, r, e in runs), strict=True))
    base = rows["vm"][0]

    def note(k: str) -> str:
        return f"{rows[k][1]:.0f} IPOPT iterations, evaluations {rows[k][2]:.2f} s"

    return [Measured(COLD, rows["cold"][0], base, note("cold")), Measured(WARM, rows["warm"][0], base, note("warm")),
            Measured(CHAIN, rows["chain"][0], base, note("chain"))]
