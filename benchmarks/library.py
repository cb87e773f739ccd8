"""The default library (18 start-ups and 25 transitions), ``--no-cache`` with the compiled functions
cached, 2 workers, against the start-ups alone (the library without ``[transitions]``) built the
same way; and a transition entry's solve time against a start-up's, both from the full build."""

from __future__ import annotations

import dataclasses
import statistics
import time
from pathlib import Path
from typing import Any

from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped.config import QuadrupedConfig

from benchmarks.figures import Figure, Measured

LIBRARY = Figure("library", "default library, 18 start-ups + 25 transitions, 2 workers, --no-cache", "s", 100.0,
                 "the 18 start-ups alone")
TRANSITION = Figure("transition-entry", "a transition entry's solves (all strides tried) over a start-up's, means",
                    "x", 2.0, "start-up entry")
FIGURES = (LIBRARY, TRANSITION)


def measure(out: Path) -> list[Measured]:
    """Build the start-ups alone, then the default library into ``out`` (the one kept)."""
    from skatelib.pipeline.build.orchestrate import build_library

    cfg = load_config(None, QuadrupedConfig)
    startups = dataclasses.replace(cfg, transitions=dataclasses.replace(cfg.transitions, speeds_mps=()))
    t_start = time.perf_counter()
    build_library(startups, out, BuildOptions(jobs=2, cache=False))
    t_start = time.perf_counter() - t_start
    t_full = time.perf_counter()
    report = build_library(cfg, out, BuildOptions(jobs=2, cache=False))
    t_full = time.perf_counter() - t_full
    outcomes: list[Any] = list(report.outcomes)
    up = [_time(o) for o in outcomes if not o.result.from_velocity_mps]
    tr = [_time(o) for o in outcomes if o.result.from_velocity_mps]
    ratio = statistics.mean(tr) / statistics.mean(up)
    note = (f"{len(outcomes) - len(report.failed)} of {len(outcomes)} valid, {len(up)} start-ups and {len(tr)} "
            f"transitions, {sum(_iterations(o) for o in outcomes)} IPOPT iterations")
    return [Measured(LIBRARY, t_full, t_start, note),
            Measured(TRANSITION, ratio, 1.0, f"transition {statistics.mean(tr):.2f} s, start-up "
                                              f"{statistics.mean(up):.2f} s per entry (solves, every attempt)")]


def _time(outcome: Any) -> float:
    return float(outcome.result.solve_time_s)


def _iterations(outcome: Any) -> int:
    return int(outcome.result.iterations)
