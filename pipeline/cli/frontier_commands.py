"""``skatelib frontier``: the fastest label each stride count reaches (of the start-ups, the
speed-ups from riding speeds, the stops)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.pipeline.cli.build_commands import STRIDE_RANGE, ConfigArg, YesOpt
from skatelib.pipeline.cli.option_checks import MAX_JOBS, finite
from skatelib.pipeline.views.console import console, count, frontier_table


def frontier(
    config: ConfigArg = None,
    strides: Annotated[list[int] | None, typer.Option("--strides", "-s", min=STRIDE_RANGE[0], max=STRIDE_RANGE[1],
                                                      help="Stride counts (repeatable); "
                                                      "default: the config's sweep (with --from or --stops: "
                                                      "its transitions').")] = None,
    from_speeds: Annotated[list[float] | None, typer.Option(
        "--from", min=0.05, max=3.0, callback=finite,
        help="Search the fastest speed-up from this riding speed instead of the start-ups (repeatable) [m/s].")
                                        ] = None,
    stops: Annotated[bool, typer.Option("--stops", help="Search the fastest speed a stop stops from.")] = False,
    start: Annotated[float, typer.Option(min=0.05, max=3.0, callback=finite, help="First speed tried [m/s].")] = 0.5,
    step: Annotated[float, typer.Option(min=0.01, max=1.0, callback=finite, help="Climbing step [m/s].")] = 0.25,
    resolution: Annotated[float, typer.Option(min=0.001, max=0.5, callback=finite,
                                              help="Bisection resolution [m/s].")] = 0.02,
    max_speed: Annotated[float, typer.Option(min=0.05, max=3.0, callback=finite, help="Highest speed tried [m/s].")
                         ] = 3.0,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Worker processes.")] = 2,
    out: Annotated[Path | None, typer.Option("-o", "--out", help="Also write the frontier as JSON.")] = None,
    yes: YesOpt = False,
) -> None:
    """Find, per stride count, the fastest label that converges and passes the physics checks
    (climb, then bisection): of the start-ups, or of the speed-ups from riding speeds (--from) and
    the stops (--stops)."""
    from skatelib.library.atomic import write_atomic
    from skatelib.pipeline.build.preflight import check_compile_dir, check_output
    from skatelib.pipeline.build.size import check_size
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.frontier import FrontierSearch, Lane, find_frontier, frontier_json
    from skatelib.pipeline.quadruped.size import frontier_size, probes

    if start > max_speed:
        raise typer.BadParameter(f"{start:g} m/s is above --max-speed {max_speed:g} m/s: nothing would be tried",
                                 param_hint="--start")
    cfg = load_config(config, QuadrupedConfig)
    if out is not None:
        check_output(out, [cfg.path], what="frontier")
    if cfg.optimization.compile:
        check_compile_dir()
    search = FrontierSearch(start_mps=start, step_mps=step, resolution_mps=resolution, max_mps=max_speed)
    lanes = [Lane(v) for v in sorted(set(from_speeds or ()))] + ([Lane(stop=True)] if stops else [])
    counts = sorted(set(strides or (cfg.transitions.strides if lanes else cfg.sweep.strides)))
    searches = [(lane, n) for lane in lanes or [Lane()] for n in counts]
    check_size(cfg.path, frontier_size(cfg, [(not lane.start_up, n) for lane, n in searches],
                                       probes(start, step, resolution, max_speed)), yes)
    kinds = ", ".join(sorted({lane.label for lane, _ in searches}))
    console.print(f"searching {count(len(searches), 'frontier')} ({kinds}; {', '.join(map(str, counts))} strides; "
                  "each a climb and a bisection of solves on its own worker, about 10-60 s each)")

    def done(point: Any, finished: int) -> None:
        console.print(escape(f"  {point.lane.label}, {point.n_strides} strides: {point.fastest_mps:.3f} m/s, stopped "
                             f"by {point.limit} ({finished}/{len(searches)} done)"))

    points = find_frontier(cfg, searches, search, jobs, done)
    frontier_table(points)
    if out is not None:
        write_atomic(out, frontier_json(points, search).encode())
        console.print(f"wrote {escape(str(out))}")


COMMANDS = (frontier,)
