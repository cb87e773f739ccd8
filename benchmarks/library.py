"""The default library (18 entries), ``--no-cache`` with the compiled functions cached: two
workers over warm-start chains against a serial, cold build (the baseline)."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Any

from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.config import QuadrupedConfig

from benchmarks.figures import Figure, Measured

LIBRARY = Figure("library", "default library, 18 entries, 2 workers, --no-cache", "s", 30.0, "serial, cold")
FIGURES = (LIBRARY,)


def measure(out: Path) -> list[Measured]:
    """Build the default library twice into ``out`` (the parallel build is the one kept)."""
    from skatelib.pipeline.build.orchestrate import build_library

    cfg = load_config(None, QuadrupedConfig)
    serial_cfg = dataclasses.replace(cfg, sweep=dataclasses.replace(cfg.sweep, warm_start=False))
    t_serial = time.perf_counter()
    rs = build_library(serial_cfg, out, BuildOptions(jobs=1, cache=False))
    t_serial = time.perf_counter() - t_serial
    t_par = time.perf_counter()
    rp = build_library(cfg, out, BuildOptions(jobs=2, cache=False))
    t_par = time.perf_counter() - t_par
    it_s = sum(_iterations(o) for o in rs.outcomes)
    it_p = sum(_iterations(o) for o in rp.outcomes)
    note = (f"{len(rp.outcomes) - len(rp.failed)} of {len(rp.outcomes)} valid, {it_p} IPOPT iterations "
            f"(serial cold: {it_s})")
    return [Measured(LIBRARY, t_par, t_serial, note)]


def _iterations(outcome: Any) -> int:
    return int(outcome.result.iterations)
