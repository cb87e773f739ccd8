"""The humanoid's part of a build (``pipeline/build/orchestrate.py``): its options check, its tasks (one motion
per velocity), the library it writes and the table it prints."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

from rich.markup import escape
from rich.table import Table
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.build.contract import BuildOptions, Outcome, Written
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.humanoid.tasks import BuildTask, EntryOutcome
from skatelib.pipeline.views.console import console


def check(cfg: HumanoidConfig, opts: BuildOptions) -> None:
    """Refuse what a humanoid build has not: the reachable-speed frontier (a quadruped search); and
    a build beyond the size bounds (or ``--yes``): one entry per velocity, each a chain of step NLPs
    of (nodes + 1) x 9 variables (the COM's position and velocity, its acceleration)."""
    from skatelib.pipeline.build.size import BuildSize, check_size

    steps = cfg.walk.steps + 2 if cfg.sweep.motion == "walk" else 3  # start, steps, stop; push, slide, stop
    entries, knots = len(cfg.sweep.velocities_mps), cfg.gpm.nodes + 1
    check_size(cfg.path, BuildSize(entries, knots, 9, entries * steps * knots * 9), opts.yes)
    if opts.frontier:
        raise SkatelibError(f"{cfg.path} is a humanoid config: --frontier searches the quadruped's "
                            "reachable-speed frontier; drop it")


def announce(cfg: HumanoidConfig) -> None:
    console.print(escape(f"{cfg.sweep.motion}: {cfg.gpm.nodes} LG nodes per step, {cfg.gpm.solver}"))


def tasks(cfg: HumanoidConfig, ipopt: tuple[tuple[str, Any], ...] = ()) -> list[BuildTask]:
    """One task per velocity (a motion's steps chain through their states, so they stay together)."""
    return [BuildTask(cfg, v) for v in sorted(cfg.sweep.velocities_mps)]


def prepare(cfg: HumanoidConfig, opts: BuildOptions) -> None:
    """Nothing to share: a step NLP builds in milliseconds in each worker."""


def write(cfg: HumanoidConfig, out: Path, finished: Sequence[Outcome], opts: BuildOptions) -> Written:
    """Write the library in velocity order; returns the file and the ordered outcomes."""
    from skatelib.pipeline.humanoid.entries import write_humanoid_library

    outcomes = sorted(cast("list[EntryOutcome]", list(finished)), key=lambda o: o.motion.velocity_mps)
    return Written(write_humanoid_library(out, cfg, outcomes), outcomes)


def summary(written: Written) -> None:
    """One row per step of every motion: status, iterations, time and cost; then the checks' failures."""
    outcomes = cast("list[EntryOutcome]", list(written.outcomes))
    t = Table(title="entries (time: c = from the cache)")
    for col in ("entry", "step", "status", "iter", "time [ms]", "cost"):
        t.add_column(escape(col))
    for o in outcomes:
        for r in o.motion.steps:
            t.add_row(o.key, r.spec.name, r.status, str(r.iterations),
                      f"{1e3 * r.solve_time_s:.1f}" + (" c" if o.cached else ""), f"{r.objective:.4f}")
    console.print(t)
    for o in outcomes:
        if o.failures:
            console.print(escape(f"{o.key}: {o.status}"))
