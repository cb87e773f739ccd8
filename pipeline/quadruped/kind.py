"""The quadruped as a robot kind (:class:`skatelib.pipeline.kinds.RobotKind`): its model summary, the
independent checks of a stored library, and the parts that build (:mod:`.builder`) and show it
(:mod:`.rerun`, :mod:`.plots`), imported when asked."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from rich.markup import escape
from rich.table import Table
from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.kinds import SubpackageKind
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.views.console import (
    console,
    parameter_table,
)
from skatelib.runtime import MotionLibrary

if TYPE_CHECKING:
    from skatelib.pipeline.kinds import ReportFn

# Vendor single-rigid-body figures (docs/sources.md), printed beside ours for comparison.
VENDOR_MASS_KG = 8.3644
VENDOR_INERTIA_KGM2 = (0.07641, 0.17843, 0.19758)


def print_model(cfg: QuadrupedConfig) -> None:
    """SRB mass and inertia from the URDF beside the vendor MPC's, the board's figures, the stance."""
    from skatelib.pipeline.quadruped.model.system import SkateSystem

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
        ("board mass m_B [kg]", b.mass_kg), ("roll inertia I_Bx about the roll axis [kg m^2]", b.roll_inertia_kgm2),
        ("roll stiffness K_B [N m/rad] (calibrated)", b.roll_stiffness_Nm_per_rad),
        ("roll damping B_B [N m s/rad]", b.roll_damping_Nms_per_rad),
        ("rolling friction f_fri [N]", b.rolling_friction_nominal_N),
        ("f_fri the TO plans with [N]", b.rolling_friction_N), ("K_board [m]", b.K_board_m),
        ("truck pivot from the ground [rad]", b.pivot_rad), ("roll axis below the deck top [m]", b.roll_axis_depth_m),
        ("wheel track [m]", b.wheel_track_m),
        ("l_f, l_r [m]", f"{b.l_front_m:.3f}, {b.l_rear_m:.3f}"), ("deck height [m]", b.deck_height_m)], "{:.5g}")
    q = np.round(s.stance.q_board, 3)
    console.print(escape(f"nominal stance q [rad] (FL FR RL RR x abad hip knee): {q.tolist()}"))


def system_from_library(lib: MotionLibrary) -> Any:
    """Rebuild the model from what the file stores: its resolved config and its own URDF.

    Raises:
        LibraryFormatError: A library of the old board model (no truck pivot angle from the
            ground: its steering read that angle as the paper's gamma from the vertical), or a
            stored config this version cannot rebuild.
    """
    from skatelib.pipeline.quadruped.model.system import SkateSystem

    if not lib.quadruped_model.board.modelled_trucks:
        raise LibraryFormatError(lib.path, "/model/@board_pivot_from_horizontal_rad", OLD_BOARD)
    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / "robot.urdf"
        urdf.write_text(lib.urdf)
        try:
            cfg = config_from_json(str(lib.attrs[schema.A_CONFIG_RESOLVED]), lib.path, urdf, QuadrupedConfig)
            return SkateSystem.from_config(cfg)
        except SkatelibError as e:
            raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {e}") from e


OLD_BOARD = ("built with the old board model: its trucks steered by K_board = l tan(pivot angle from the ground), "
             "six times too weakly for the public truck, the deck rolled about its top and no wheel kept a load; "
             "rebuild it (skatelib build CONFIG, with [board] pivot_from_horizontal_rad, roll_axis_height_m, "
             "deck_mass_kg, wheel_track_m and wheel_load_margin)")


def validate_entries(lib: MotionLibrary, report: ReportFn) -> int:
    """The independent physics checks of every successful entry; returns the failures."""
    from skatelib.pipeline.quadruped.checks.verify import Trajectory, check_trajectory

    system = system_from_library(lib)
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        rep = check_trajectory(system, Trajectory.of(e), e.target_velocity_mps, from_velocity_mps=e.from_velocity_mps)
        failures = rep.failures(system)
        bad += bool(failures)
        off = f"{100 * rep.momentum_speed_error:.2f} % off" if e.target_velocity_mps else "a stop"
        ok = (f"ok: rides at {rep.momentum_speed_mps:.3f} m/s ({off}), "
              f"Coulomb margin {rep.min_friction_margin_N:.2f} N, defect {rep.max_defect:.1e}")
        figures = {"momentum_speed_mps": rep.momentum_speed_mps, "momentum_speed_error": rep.momentum_speed_error,
                   "min_friction_margin_N": rep.min_friction_margin_N, "max_defect": rep.max_defect,
                   "max_torque_rigid_legs_Nm": rep.max_torque_rigid_legs_Nm}
        note = stored_figures_note(e.attrs.get(schema.A_PHYSICS), figures)
        report(e.key, "failed" if failures else "ok", (ok if not failures else "; ".join(failures)) + note, figures)
    return bad + validate_chain(lib, report)


def stored_figures_note(stored_json: Any, figures: dict[str, float]) -> str:
    """What a library's stored figures (``physics_json``, which ``info`` and ``diff`` show) say
    otherwise than the checks just made of its arrays: nothing when they agree (the same code gives
    the same numbers), else a note naming each (another version of the checks made them, or the
    file was edited and sealed again)."""
    import json
    import math

    try:
        stored = json.loads(stored_json) if stored_json is not None else {}
    except ValueError:
        return "; its stored figures (physics_json) cannot be read"
    off = [f"{k} {stored[k]:.6g} stored, {v:.6g} now" for k, v in figures.items()
           if isinstance(stored.get(k), (int, float)) and not math.isclose(stored[k], v, rel_tol=1e-9, abs_tol=1e-12)]
    return f"; its stored figures differ from these checks': {', '.join(off)}" if off else ""


def validate_chain(lib: MotionLibrary, report: ReportFn) -> int:
    """Chain continuity (:mod:`.chain`): every end that meets a transition's start agrees with it
    within the end's tolerances; one line for the library, one per junction that does not."""
    from skatelib.pipeline.quadruped.checks.chain import chain_gaps

    gaps = chain_gaps(lib)
    if not gaps:
        return 0
    bad = [g for g in gaps if g.failures()]
    for g in bad:
        report(f"{g.end} -> {g.start}", "failed", "; ".join(g.failures()), g.gaps)
    worst = {k: max(g.gaps[k] / g.limits[k] for g in gaps if g.limits[k] > 0) for k in gaps[0].gaps}
    report("chain", "failed" if bad else "ok",
           f"{len(gaps) - len(bad)} of {len(gaps)} junctions (an end and a transition from its speed) agree within the "
           f"end's tolerances; the closest to its tolerance: {max(worst, key=lambda k: worst[k])}", worst)
    return len(bad)


KIND = SubpackageKind("quadruped", QuadrupedConfig, "skatelib.pipeline.quadruped", print_model, validate_entries)
