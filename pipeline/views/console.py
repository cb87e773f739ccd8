"""What the commands print: the consoles (wide into a pipe) and the tables both robot kinds share."""

from __future__ import annotations

import os
import shlex
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.table import Table

PIPE_WIDTH = 260


def _console(stderr: bool = False) -> Console:
    """Rich's console; into a pipe or file (no terminal, no COLUMNS) 260 columns instead of rich's
    80, so that tables are not wrapped or their cells cut ("Solve_S...") in a log."""
    c = Console(stderr=stderr)
    if not c.is_terminal and "COLUMNS" not in os.environ:
        c = Console(stderr=stderr, width=PIPE_WIDTH)
    return c


console = _console()
err_console = _console(stderr=True)


def run_with_progress(jobs: Sequence[Callable[[], Any]], n_jobs: int, label: str, enabled: bool = True) -> list[Any]:
    """``sweep.run_calls`` with a progress bar (done / total, elapsed) unless ``enabled`` is False."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from skatelib.pipeline.build.sweep import run_calls

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console, disable=not enabled, transient=True) as bar:
        task = bar.add_task(label, total=len(jobs))
        return run_calls(jobs, n_jobs, lambda n: bar.update(task, completed=n))


def viewer_hint(save: Path) -> str:
    """How to open a recording: the viewer beside this Python (on PATH or not), paths quoted."""
    viewer = Path(sys.executable).parent / "rerun"
    return f"open it with: {shlex.quote(str(viewer))} {shlex.quote(str(save))}"


def left_out(lib: Any) -> None:
    """Say which entries a command left out because they are stored as failed (plot, export)."""
    failed = [e.key for e in lib if not e.success]
    if failed:
        console.print(escape(f"left out {count(len(failed), 'failed entry')} (stored with success = false): "
                             f"{', '.join(failed)}"))


def mesh_note(library: Path) -> None:
    """Say (on stderr) that a library's URDF names mesh files, which skatelib does not read: once, by
    the command that draws or builds the robot (inspect, the twin)."""
    from skatelib.library.urdf import mesh_files
    from skatelib.runtime import MotionLibrary

    names = mesh_files(MotionLibrary.open(library).urdf)
    if names:
        shown = ", ".join(repr(n) for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
        text = (f"the library's URDF names mesh files ({shown}); skatelib draws and builds the robot from its "
                "primitive shapes and reads no mesh file")
        err_console.print(f"[yellow]note:[/] {escape(text)}")


def count(n: int, noun: str) -> str:
    """'1 entry', '18 entries'."""
    plural = noun[:-1] + "ies" if noun.endswith("y") else noun + "s"
    return f"{n} {noun if n == 1 else plural}"


def fmt(figures: dict[str, Any], key: str, pattern: str) -> str:
    """A figure formatted, or "-" where it was not measured."""
    return pattern.format(figures[key]) if key in figures else "-"


def entry_table(title: str, columns: tuple[str, ...]) -> Table:
    """A table with one row per entry: the key and status columns stay whole in a narrow terminal
    (the numbers, right-aligned, give way)."""
    t = Table(title=title)
    for col in columns:
        if col in ("entry", "status"):
            t.add_column(escape(col), no_wrap=col == "entry", min_width=8 if col == "entry" else 6, overflow="fold")
        else:
            t.add_column(escape(col), justify="right")
    return t


def print_failures(results: list[Any], why: Callable[[Any], str]) -> int:
    """Print ``key: why`` for each failed result (``.key``, ``.passed``); returns how many failed."""
    failed = [r for r in results if not r.passed]
    for r in failed:
        console.print(escape(f"{r.key}: {why(r)}"))
    return len(failed)


def parameter_table(title: str, rows: list[tuple[str, Any]], number: str = "{:.4g}", head: str = "parameter") -> None:
    """Print a two-column table of named values (numbers as ``number``)."""
    t = Table(title=title)
    t.add_column(head)
    t.add_column("value", justify="right")
    for name, value in rows:
        t.add_row(escape(name), number.format(value) if isinstance(value, float) else escape(str(value)))
    console.print(t)


def frontier_table(points: list[Any]) -> None:
    """The reachable-speed frontier per search (start-ups, speed-ups from a speed, stops) and stride
    count."""
    t = Table(title="reachable-speed frontier: fastest label that converges and passes the physics checks "
                    "(a stop: the fastest speed it stops from)")
    for col in ("search", "strides", "fastest [m/s]", "first failure [m/s]", "what stops it", "probes"):
        t.add_column(escape(col), justify="left" if col in ("search", "what stops it") else "right")
    for p in points:
        fail = "-" if p.first_failure_mps is None else f"{p.first_failure_mps:.3f}"
        t.add_row(escape(p.lane.label), str(p.n_strides), f"{p.fastest_mps:.3f}", fail, escape(p.limit),
                  str(len(p.probes)))
    console.print(t)


def label_error(label: float, speed: float | None, digits: int = 1) -> str:
    """How far ``speed`` ends from its ``label``: in % of the label, or for a stop (label 0) the speed
    left [m/s]; "-" when there is no speed."""
    if speed is None:
        return "-"
    return f"{(speed - label) / label:+.{digits}%}" if label else f"{speed:+.3f} m/s"


def track_table(results: list[Any], perturb: str) -> int:
    """Print the closed-loop verdicts; returns how many failed."""
    t = Table(title=escape(f"closed loop, plant: {perturb}"))
    for col in ("entry", "label", "p/m end", "v +1 s", "delivered", "error", "roll max", "pos err", "att err",
                "min f_n", "fric margin", "slips", "tau max", "MPC ms med/max", "verdict"):
        t.add_column(escape(col), justify="right")
    for r in results:
        v = r.target_velocity_mps
        t.add_row(r.key, f"{v:.2f}", f"{r.momentum_at_end_mps:.3f}", f"{r.speed_after_1s_mps:.3f}",
                  f"{r.delivered_mps:.3f}", label_error(v, r.delivered_mps), f"{r.max_deck_roll_rad:.3f}",
                  f"{1e3 * r.max_position_error_m:.1f} mm", f"{r.max_attitude_error_rad:.3f}",
                  f"{r.min_normal_N:.1f}", f"{r.min_friction_margin_N:.2f} N", str(r.slips),
                  f"{r.max_joint_torque_Nm:.1f}", f"{r.mpc_median_ms:.1f}/{r.mpc_max_ms:.1f}",
                  "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    console.print(escape("p/m end: momentum speed (m_R v_R + m_B v_B) / (m_R + m_B) when the entry ends [m/s]; "
                         "delivered: the momentum speed 1 s later plus what rolling friction took meanwhile; "
                         "fric margin: the smallest mu f_n - |f_t| of a commanded foot force in the plant's cone "
                         "(< 0: clipped, a slip); tau max: the largest stance-joint torque at the "
                         "inverse-kinematics angles [N m]"))
    return print_failures(results, lambda r: str(r.reasons))


def ride_table(result: Any, perturb: str) -> bool:
    """Print a ride's stages and its verdict; returns whether it passed."""
    t = Table(title=escape(f"ride in closed loop, plant: {perturb}"))
    for col in ("stage", "entries", "ends at [s]", "momentum speed [m/s]", "verdict"):
        t.add_column(escape(col), justify="right")
    for s in result.stages:
        t.add_row(f"{s.from_velocity_mps:g} -> {s.target_velocity_mps:g}", escape(", ".join(s.keys)),
                  f"{s.t_end_s:.2f}", f"{s.momentum_at_end_mps:.3f}", "[green]pass[/]" if s.passed else "[red]FAIL[/]")
    console.print(t)
    r = result.run
    late = [f"{s.from_velocity_mps:g} -> {s.target_velocity_mps:g}" for s in result.stages if not s.passed]
    verdict = "pass" if result.passed else "FAIL: " + "; ".join(
        ([f"stage {', '.join(late)} off its target"] if late else []) + ([r.reasons] if r.reasons else []))
    console.print(escape(f"{r.key}: {verdict} (each stage within 5 % of its target at its end, a stop below "
                         f"0.05 m/s); after the last: delivered {r.delivered_mps:.3f} m/s, deck roll max "
                         f"{r.max_deck_roll_rad:.3f} rad"))
    return bool(result.passed)


def _estimator_table(results: list[Any]) -> None:
    """The estimator's error against the twin's truth, for the runs fed the estimate."""
    estimated = [r for r in results if r.est_trunk_v_rms == r.est_trunk_v_rms]  # not NaN: fed the estimate
    if not estimated:
        return
    e = Table(title="the estimator against the twin's truth (RMS / worst)")
    for col in ("entry", "trunk v [m/s]", "board speed [m/s]", "board roll [rad]"):
        e.add_column(escape(col), justify="right")
    for r in estimated:
        e.add_row(r.key, f"{r.est_trunk_v_rms:.4f} / {r.est_trunk_v_worst:.3f}",
                  f"{r.est_board_speed_rms:.4f} / {r.est_board_speed_worst:.3f}",
                  f"{r.est_board_roll_rms:.4f} / {r.est_board_roll_worst:.3f}")
    console.print(e)


def twin_table(results: list[Any], perturb: str) -> int:
    """Print the verdicts of the runs on the twin; returns how many failed."""
    t = Table(title=escape(f"full physics (MuJoCo twin, MPC 30 Hz + whole-body 510 Hz), errors: {perturb}"))
    for col in ("entry", "label", "p/m end", "delivered", "error", "slip max", "floor", "wheel lift",
                "heading err", "lateral", "crab max", "roll max", "tau max", "sat", "WBC/MPC ms", "verdict"):
        t.add_column(escape(col), justify="right")
    for r in results:
        v = r.target_velocity_mps
        t.add_row(r.key, f"{v:.2f}", f"{r.momentum_at_end_mps:.3f}", f"{r.delivered_mps:.3f}",
                  label_error(v, r.delivered_mps), f"{100 * r.max_slip_m:.2f} cm", str(r.floor_touch_ticks),
                  str(r.wheel_lift_ticks), f"{r.heading_error_rad:+.3f}", f"{100 * r.lateral_drift_m:+.1f} cm",
                  f"{r.max_crab_rad:.3f}", f"{r.max_deck_roll_rad:.3f}", f"{r.max_torque_Nm:.1f}",
                  f"{100 * r.saturated_share:.1f}%", f"{r.wbc_median_ms:.2f}/{r.mpc_median_ms:.1f}",
                  "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    console.print(escape("p/m end, delivered: the momentum speed of robot and board when the entry ends, and 1 s "
                         "later plus what the floor's force on the wheels took [m/s]; slip max: the largest slip "
                         "of a stance at its contact point; floor, wheel lift: ticks (2 ms) of unplanned floor "
                         "contact and with a wheel off the floor; heading err, lateral: the board against the "
                         "plan when the entry ends; crab max: the deck's velocity from its heading [rad]; sat: the "
                         "share of ticks with a joint at its torque limit"))
    _estimator_table(results)
    return print_failures(results, lambda r: str(r.reasons))


def steer_table(results: list[Any], perturb: str) -> int:
    """Print the steering verdicts; returns how many failed."""
    t = Table(title=escape(f"four-leg steering, deck roll 0.1 rad sine, 3 s period; plant: {perturb}"))
    for col in ("speed [m/s]", "roll RMS err [rad]", "roll max [rad]", "torso shift [m]", "min f_n [N]",
                "unloaded", "slips", "MPC ms", "verdict"):
        t.add_column(escape(col), justify="right")
    for r in results:
        t.add_row(f"{r.target_velocity_mps:.2f}", f"{r.roll_rms_error_rad:.4f}", f"{r.max_roll_rad:.3f}",
                  f"{r.max_lateral_shift_m:.3f}", f"{r.min_normal_N:.2f}", str(r.unloaded_steps), str(r.slips),
                  f"{r.mpc_median_ms:.1f}", "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    failed = [r for r in results if not r.passed]
    for r in failed:
        console.print(escape(f"{r.target_velocity_mps:.2f} m/s: {r.reasons}"))
    return len(failed)


def jsonable(v: Any) -> Any:
    """A ``json.dumps`` default: numpy scalars and arrays as JSON numbers and lists."""
    return v.tolist() if hasattr(v, "tolist") else str(v)
