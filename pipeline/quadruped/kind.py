"""The quadruped's row of the kind table (``pipeline/kinds.py``): its model summary, its build
with progress and summary table, and the independent checks of a stored library."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from rich.markup import escape
from rich.table import Table
from skatelib.library.errors import Interrupted, LibraryFormatError, SkatelibError
from skatelib.library.schema import entry_key
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.kinds import BuildOptions, BuildRun
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.report import (
    console,
    count,
    entry_table,
    err_console,
    fmt,
    frontier_table,
    parameter_table,
)
from skatelib.runtime import MotionLibrary

CONFIG_CLASS = QuadrupedConfig
# Vendor single-rigid-body figures (ROBOT_DATA.md), printed beside ours for comparison.
VENDOR_MASS_KG = 8.3644
VENDOR_INERTIA_KGM2 = (0.07641, 0.17843, 0.19758)


def print_model(cfg: QuadrupedConfig) -> None:
    """SRB mass and inertia from the URDF beside the vendor MPC's, the board's figures, the stance."""
    from skatelib.pipeline.quadruped.system import SkateSystem

    s = SkateSystem.from_config(cfg)
    t = Table(title=f"{cfg.meta.name}: single rigid body at the nominal stance (pinocchio ccrba)")
    t.add_column("quantity")
    t.add_column("skatelib (from URDF)", justify="right")
    t.add_column("vendor MPC", justify="right")
    t.add_row(escape("mass [kg]"), f"{s.srb.mass_kg:.4f}", f"{VENDOR_MASS_KG:.4f}")
    for i, axis in enumerate("xyz"):
        t.add_row(escape(f"I{axis}{axis} [kg m^2]"), f"{s.srb.inertia_kgm2[i, i]:.5f}", f"{VENDOR_INERTIA_KGM2[i]:.5f}")
    t.add_row(escape("COM in trunk frame [m]"), escape(np.array2string(s.srb.com_offset_m, precision=4)), "-")
    console.print(t)
    b = s.board
    parameter_table("skateboard (Eq. 6, 9-14)", [
        ("board mass m_B [kg]", b.mass_kg), ("roll inertia I_Bx [kg m^2]", b.roll_inertia_kgm2),
        ("roll stiffness K_B [N m/rad] (calibrated)", b.roll_stiffness_Nm_per_rad),
        ("roll damping B_B [N m s/rad]", b.roll_damping_Nms_per_rad),
        ("rolling friction f_fri [N]", b.rolling_friction_nominal_N),
        ("f_fri the TO plans with [N]", b.rolling_friction_N), ("K_board [m]", b.K_board_m),
        ("l_f, l_r [m]", f"{b.l_front_m:.3f}, {b.l_rear_m:.3f}"), ("deck height [m]", b.deck_height_m)], "{:.5g}")
    q = np.round(s.stance.q_board, 3)
    console.print(escape(f"nominal stance q [rad] (FL FR RL RR x abad hip knee): {q.tolist()}"))


def _announce(cfg: QuadrupedConfig, total: int, out: Path) -> None:
    console.print(f"building {count(total, 'entry')} of {escape(str(cfg.path))} -> {escape(str(out))}")
    if cfg.optimization.compile:
        from skatelib.pipeline.ocp.stagewise import c_compiler, cache_dir

        cc = c_compiler()
        if cc is None:
            err_console.print("warning: no C compiler found ($CC, gcc, cc): the stage functions run interpreted, "
                              "3-4x slower; install gcc to compile them")
        else:
            console.print(escape(f"stage functions: compiled with {cc} on first use of a model (about 35 s, "
                                 f"once; cached in {cache_dir()})"))


class _Progress:
    """The progress bar's text: the entries being solved and the last one finished."""

    def __init__(self, bar: Any, task: Any):
        self.bar, self.task = bar, task
        self.done: list[str] = []
        self.flying: list[str] = []  # oldest first

    def __call__(self, event: Any) -> None:
        if not event.done:
            self.flying.append(event.key)
        else:
            self.done.append(event.key)
            if event.key in self.flying:
                self.flying.remove(event.key)
        text = f"solving {', '.join(self.flying)}" if self.flying else "solving"
        if event.done:
            status = "ok" if event.success else event.status.split(":")[0]
            text += f" (last: {event.key} {'cached, ' if event.cached else ''}{status})"
        self.bar.update(self.task, advance=1 if event.done else 0, description=escape(text))


def run_build(cfg: QuadrupedConfig, out: Path, opts: BuildOptions) -> BuildRun:
    """Sweep the config's speeds x strides (``pipeline/build.py``) with a progress bar, then print
    the entries' table (and the frontier)."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from skatelib.pipeline.build import build_library
    from skatelib.pipeline.preflight import check_cache_dir, check_scheduler
    from skatelib.pipeline.sweep import chains_for

    if opts.backend == "dask":
        if opts.scheduler is None:
            raise SkatelibError("--backend dask needs --scheduler tcp://HOST:PORT")
        check_scheduler(opts.scheduler)
    if opts.cache or cfg.optimization.compile:
        check_cache_dir()
    total = sum(len(c.velocities) for c in chains_for(cfg))
    _announce(cfg, total, out)
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("eta"), TimeRemainingColumn(), console=console, disable=not opts.progress) as bar:
        progress = _Progress(bar, bar.add_task("solving", total=total))
        try:
            report = build_library(cfg, out, opts, on_entry=progress)
        except KeyboardInterrupt:
            kept = (f"{len(progress.done)} of {total} entries are cached" if opts.cache
                    else "nothing is cached (--no-cache)")
            raise Interrupted(f"interrupted: {kept}; no library was written. Run the same command to resume.") from None
    summary(report.outcomes)
    if report.frontier is not None:
        frontier_table(report.frontier)
    console.print(f"wrote {escape(str(report.path))} in {report.wall_time_s:.1f} s")
    return BuildRun(report.path, len(report.failed))


def summary(outcomes: list[Any]) -> None:
    """One row per entry: status, iterations, tries, time and the independent checks' figures."""
    t = entry_table("entries (time: c = from the cache; momentum: the speed robot and board ride at together)",
                    ("entry", "status", "iter", "tries", "time [s]", "board end [m/s]", "momentum [m/s]", "off label",
                     "Coulomb margin [N]", "torque [N m]", "defect"))
    for o in outcomes:
        r, ph = o.result, o.physics
        status = r.status.replace("Solve_Succeeded", "ok")
        t.add_row(entry_key(r.target_velocity_mps, r.n_strides), escape(status), str(r.iterations), str(o.attempts),
                  f"{r.solve_time_s:.2f}" + (" c" if o.cached else ""), f"{r.final_velocity_mps:.4f}",
                  fmt(ph, "momentum_speed_mps", "{:.4f}"), fmt(ph, "momentum_speed_error", "{:.2%}"),
                  fmt(ph, "min_friction_margin_N", "{:.3f}"), fmt(ph, "max_torque_rigid_legs_Nm", "{:.2f}"),
                  fmt(ph, "max_defect", "{:.1e}"))
    console.print(t)
    for o in outcomes:
        if o.note:
            console.print(f"[yellow]note:[/] {escape(o.note)}")


def system_from_library(lib: MotionLibrary) -> Any:
    """Rebuild the model from what the file stores: its resolved config and its own URDF."""
    from skatelib.pipeline.quadruped.system import SkateSystem

    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / "robot.urdf"
        urdf.write_text(lib.urdf)
        try:
            cfg = config_from_json(str(lib.attrs["config_resolved_json"]), lib.path, urdf, QuadrupedConfig)
            return SkateSystem.from_config(cfg)
        except SkatelibError as e:
            raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {e}") from e


def validate_entries(lib: MotionLibrary, report: Any) -> int:
    """The independent physics checks of every successful entry; returns the failures."""
    from skatelib.pipeline.quadruped.verify import Trajectory, check_trajectory

    system = system_from_library(lib)
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        rep = check_trajectory(system, Trajectory.of(e), e.target_velocity_mps)
        failures = rep.failures(system)
        bad += bool(failures)
        ok = (f"ok: rides at {rep.momentum_speed_mps:.3f} m/s ({100 * rep.momentum_speed_error:.2f} % off), "
              f"Coulomb margin {rep.min_friction_margin_N:.2f} N, defect {rep.max_defect:.1e}")
        figures = {"momentum_speed_mps": rep.momentum_speed_mps, "momentum_speed_error": rep.momentum_speed_error,
                   "min_friction_margin_N": rep.min_friction_margin_N, "max_defect": rep.max_defect,
                   "max_torque_rigid_legs_Nm": rep.max_torque_rigid_legs_Nm}
        report(e.key, "failed" if failures else "ok", ok if not failures else "; ".join(failures), figures)
    return bad
