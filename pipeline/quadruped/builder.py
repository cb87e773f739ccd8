"""The quadruped's part of a build (``pipeline/build/orchestrate.py``): its options check, its tasks (one
warm-start chain per stride count, the slow-downs from each riding speed and the speed-ups to each,
heaviest first), the library it writes (with the frontier when asked) and the table it prints."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, cast

from rich.markup import escape
from skatelib.library.schema import entry_key
from skatelib.pipeline.build.contract import BuildOptions, Outcome, Written
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.tasks import BuildTask, EntryOutcome, ordered, tasks_for
from skatelib.pipeline.quadruped.transitions.tasks import TransitionTask
from skatelib.pipeline.views.console import console, entry_table, err_console, fmt, frontier_table, label_error


def check(cfg: QuadrupedConfig, opts: BuildOptions) -> None:
    """The build's size within the bounds (or ``--yes``). Compiled stage functions are kept in the
    folder of compiled code (the cache folder unless ``$SKATELIB_COMPILE_DIR`` sets it apart): it
    must be usable even with ``--no-cache`` (with the cache on and compiled code in it,
    ``build.check_options`` checks it next). A twin judge must be able to run, and the robot must
    load from its URDF with the config's joints and feet."""
    from skatelib.library import trust
    from skatelib.pipeline.build.preflight import check_compile_dir
    from skatelib.pipeline.build.size import check_size
    from skatelib.pipeline.quadruped.model.system import robot_of
    from skatelib.pipeline.quadruped.size import build_size
    from skatelib.pipeline.quadruped.transitions.twin_judge import check_twin_judge

    check_size(cfg.path, build_size(cfg), opts.yes)
    check_twin_judge(cfg)
    robot_of(cfg)
    if cfg.optimization.compile and not (opts.cache and trust.compile_dir() == trust.cache_dir()):
        check_compile_dir()


def announce(cfg: QuadrupedConfig) -> None:
    """What the user should know before the solves start: how the stage functions run (the command
    line prints a line when, and only when, they are compiled)."""
    if not cfg.optimization.compile:
        return
    from skatelib.pipeline.ocp.stagewise import c_compiler

    if c_compiler() is None:
        err_console.print("warning: no C compiler found ($CC, gcc, cc): the stage functions run interpreted, "
                          "3-4x slower; install gcc to compile them")


def one_start_up(cfg: QuadrupedConfig, velocity_mps: float, strides: int) -> QuadrupedConfig:
    """``cfg`` cut down to one entry (``skatelib solve``): the start-up to ``velocity_mps`` in
    ``strides`` strides, without the config's other speeds, stride counts and transitions."""
    return replace(cfg, sweep=replace(cfg.sweep, velocities_mps=(velocity_mps,), strides=(strides,)),
                   transitions=replace(cfg.transitions, speeds_mps=()))


def tasks(cfg: QuadrupedConfig, ipopt: tuple[tuple[str, Any], ...] = ()) -> list[BuildTask | TransitionTask]:
    """The transitions' tasks (the slow-downs from each riding speed, the speed-ups to each) and one
    warm-start chain per stride count, the longest first (their ``weight``), so that the workers'
    last tasks are short and end together."""
    from skatelib.pipeline.quadruped.transitions.tasks import transition_tasks

    every: list[BuildTask | TransitionTask] = [*transition_tasks(cfg, ipopt), *tasks_for(cfg, ipopt)]
    return sorted(every, key=lambda t: -t.weight)


def prepare(cfg: QuadrupedConfig, opts: BuildOptions) -> None:
    """Compile the stage functions in this process first (loky), so that parallel workers load them
    instead of all compiling."""
    if cfg.optimization.compile and opts.backend == "loky":
        from skatelib.pipeline.quadruped.problem.pushoff import problem_for

        problem_for(cfg, min(cfg.sweep.strides))


def write(cfg: QuadrupedConfig, out: Path, finished: Sequence[Outcome], opts: BuildOptions) -> Written:
    """Write the library (failed entries included, ``success = false`` with their status); with
    ``opts.frontier`` search the reachable-speed frontier of every stride count and store it.
    The frontier (or None) is the result's ``extra``."""
    from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library
    from skatelib.pipeline.quadruped.frontier import FrontierSearch, find_frontier, frontier_json, library_searches
    from skatelib.pipeline.quadruped.model.system import SkateSystem

    outcomes = ordered(cast("list[EntryOutcome]", list(finished)))
    entries = [entry_from_result(o.result, o.attempts, o.physics, o.cache_key) for o in outcomes]
    solver_options = outcomes[0].result.ipopt_options if outcomes else {}
    search = FrontierSearch() if opts.frontier else None
    points = find_frontier(cfg, library_searches(cfg), search, opts.jobs) if search is not None else None
    stored = frontier_json(points, search) if points is not None and search is not None else None
    path = write_quadruped_library(out, cfg, SkateSystem.from_config(cfg), entries, solver_options, stored)
    return Written(path, outcomes, points)


def summary(written: Written) -> None:
    """One row per entry: status, iterations, tries, time and the independent checks' figures;
    then the frontier, when searched."""
    outcomes = cast("list[EntryOutcome]", list(written.outcomes))
    t = entry_table("entries (time: the entry's solves, every attempt; c = from the cache; momentum: the speed "
                    "robot and board ride at together)",
                    ("entry", "status", "iter", "tries", "time [s]", "board end [m/s]", "momentum [m/s]",
                     "off label [%]", "Coulomb margin [N]", "torque [N m]", "defect [SI]"))
    for o in outcomes:
        r, ph = o.result, o.physics
        status = r.status.replace("Solve_Succeeded", "ok")
        figures = ["-"] * 6  # a failed solve's speeds and margins mean nothing: its status says why
        if r.success:
            momentum = (ph or {}).get("momentum_speed_mps")
            off = label_error(r.target_velocity_mps, momentum, 2)
            figures = [f"{r.final_velocity_mps:.4f}", fmt(ph, "momentum_speed_mps", "{:.4f}"), off,
                       fmt(ph, "min_friction_margin_N", "{:.3f}"), fmt(ph, "max_torque_rigid_legs_Nm", "{:.2f}"),
                       fmt(ph, "max_defect", "{:.1e}")]
        t.add_row(entry_key(r.target_velocity_mps, r.n_strides, r.from_velocity_mps), escape(status), str(r.iterations),
                  str(o.attempts), f"{r.solve_time_s:.2f}" + (" c" if o.cached else ""), *figures)
    console.print(t)
    if written.extra is not None:
        frontier_table(written.extra)
