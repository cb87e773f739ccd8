"""The humanoid's row of the kind table (``pipeline/kinds.py``): its model summary, its build and
summary table, and the independent checks of a stored library."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from rich.markup import escape
from rich.table import Table
from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.kinds import BuildOptions, BuildRun
from skatelib.pipeline.report import console, err_console, parameter_table
from skatelib.runtime import MotionLibrary

CONFIG_CLASS = HumanoidConfig
DEFAULTS = BuildOptions()


def print_model(cfg: HumanoidConfig) -> None:
    """The point-mass model and its LIP/DCM time constant."""
    h = cfg.humanoid
    omega = math.sqrt(h.gravity_mps2 / h.com_height_m)
    rows: list[tuple[str, Any]] = [(f.name, float(getattr(h, f.name))) for f in dataclasses.fields(h)
                                   if f.name != "source"]
    rows += [("LIP natural frequency omega = sqrt(g / z) [1/s]", omega), ("DCM time constant 1 / omega [s]", 1 / omega)]
    parameter_table(f"{cfg.meta.name}: humanoid point-mass model (Takasugi et al.)", rows, head="quantity")
    if h.source:
        console.print(escape(f"source: {h.source}"))


def run_build(cfg: HumanoidConfig, out: Path, opts: BuildOptions) -> BuildRun:
    """Solve every motion in this process (milliseconds per step) and print one row per step.
    Refuses the options for a cluster or the frontier, and says which options are moot."""
    from skatelib.pipeline.humanoid.entries import build_humanoid_library, motion_key

    if opts.backend != "loky" or opts.scheduler is not None or opts.frontier:
        raise SkatelibError(f"{cfg.path} is a humanoid config: its steps solve in milliseconds in this process; "
                            "--backend dask, --scheduler and --frontier are for quadruped configs")
    moot = [flag for flag, given in (("--jobs", opts.jobs != DEFAULTS.jobs), ("--no-cache", not opts.cache),
                                     ("--no-progress", not opts.progress)) if given]
    if moot:
        err_console.print(f"note: {', '.join(moot)} do{'es' if len(moot) == 1 else ''} not apply to a humanoid "
                          "build (solved in this process, milliseconds per step, no cache)")
    report = build_humanoid_library(cfg, out)
    t = Table(title=f"{cfg.meta.name}: {cfg.sweep.motion} ({cfg.gpm.nodes} LG nodes, {cfg.gpm.solver})")
    for col in ("entry", "step", "status", "iter", "time [ms]", "cost"):
        t.add_column(escape(col))
    for m in report.motions:
        for r in m.steps:
            t.add_row(motion_key(cfg, m)[0], r.spec.name, r.status, str(r.iterations),
                      f"{1e3 * r.solve_time_s:.1f}", f"{r.objective:.4f}")
    console.print(t)
    console.print(f"wrote {escape(str(report.path))} in {report.wall_time_s:.2f} s")
    return BuildRun(report.path, len(report.failed))


def validate_entries(lib: MotionLibrary, report: Any) -> int:
    """Every step's GPM nodes against the plan stored with the entry; returns the failures."""
    from skatelib.pipeline.humanoid.motion import step_model, stored_plan
    from skatelib.pipeline.humanoid.verify import check_steps, failures

    try:
        cfg = config_from_json(str(lib.attrs["config_resolved_json"]), lib.path, None, HumanoidConfig)
    except SkatelibError as err:
        raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {err}") from err
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        plan = stored_plan(lib, e)  # as solved, not as today's code would plan it
        rep = check_steps(plan, e.arrays["nodes_t"], e.arrays["nodes_state"], e.arrays["nodes_control"],
                          step_model(cfg))
        fails = failures(rep)
        bad += bool(fails)
        report(e.key, "failed" if fails else "ok", "ok" if not fails else "; ".join(fails), {})
    return bad
