"""``skatelib build``: config -> parallel sweep -> verified, atomically written motion library."""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.kinds import BuildOptions
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library
from skatelib.pipeline.quadruped.frontier import FrontierPoint, FrontierSearch, find_frontier, frontier_json
from skatelib.pipeline.quadruped.pushoff import problem_for
from skatelib.pipeline.quadruped.system import SkateSystem
from skatelib.pipeline.sweep import EntryOutcome, ProgressFn, ordered, run_sweep


@dataclass(frozen=True)
class BuildReport:
    """What a build produced: the file, its entries' outcomes and the wall time."""

    path: Path
    outcomes: list[EntryOutcome]
    wall_time_s: float
    frontier: list[FrontierPoint] | None = None

    @property
    def failed(self) -> list[EntryOutcome]:
        return [o for o in self.outcomes if not o.result.success]


def default_output(config: QuadrupedConfig | HumanoidConfig) -> Path:
    return Path("out") / f"{config.meta.name}.h5"


def build_library(config: QuadrupedConfig, out: Path | None = None, options: BuildOptions | None = None,
                  on_entry: ProgressFn | None = None, ipopt: tuple[tuple[str, Any], ...] = ()) -> BuildReport:
    """Solve every entry of ``config.sweep`` and write the library (failed entries included,
    marked ``success = false`` with their IPOPT status); with ``frontier``, also search the
    reachable-speed frontier of every stride count and store it in the file."""
    t0 = time.perf_counter()
    out = out or default_output(config)
    options = options or BuildOptions()
    if config.optimization.compile and options.backend == "loky":
        # Compile the stage functions once here, so parallel workers load them instead of all compiling.
        problem_for(config, min(config.sweep.strides))
    outcomes = ordered(run_sweep(config, options, on_entry, ipopt))
    system = SkateSystem.from_config(config)
    entries = [entry_from_result(o.result, o.attempts, o.physics, o.cache_key) for o in outcomes]
    solver_options = outcomes[0].result.ipopt_options if outcomes else {}
    search = FrontierSearch() if options.frontier else None
    points = find_frontier(config, config.sweep.strides, search, options.jobs) if search is not None else None
    stored = frontier_json(points, search) if points is not None and search is not None else None
    path = write_quadruped_library(out, config, system, entries, solver_options, stored)
    return BuildReport(path=path, outcomes=outcomes, wall_time_s=time.perf_counter() - t0, frontier=points)
