"""``skatelib validate``: integrity and physics of every entry of a library file."""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.library.reader import read_library
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.quadruped.system import SkateSystem
from skatelib.pipeline.quadruped.verify import check_trajectory
from skatelib.runtime import MotionLibrary


def system_from_library(lib: MotionLibrary) -> SkateSystem:
    """Rebuild the model from what the file stores: its resolved config and its own URDF."""
    with tempfile.TemporaryDirectory() as tmp:
        urdf = Path(tmp) / "robot.urdf"
        urdf.write_text(lib.urdf)
        try:
            cfg = config_from_json(str(lib.attrs["config_resolved_json"]), lib.path, urdf)
            return SkateSystem.from_config(cfg)
        except SkatelibError as e:
            raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {e}") from e


Report = Callable[[str, str, str, dict[str, float]], None]  # key, "ok" | "failed" | "skipped", message, figures


def validate_library(path: Path | str, report: Report) -> int:
    """Check the file (raises on a corrupt one) and each entry's physics; returns the failures.
    ``report`` gets each entry's key, verdict, message and the figures measured."""
    read_library(path, full=True)  # integrity: checksum, and every attribute and view against the index
    lib = MotionLibrary.open(path)
    if lib.kind == "humanoid":
        return _validate_humanoid(lib, report)
    system = system_from_library(lib)
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        assert e.contact is not None and e.foot_pos is not None and e.board_pos is not None
        rep = check_trajectory(system, e.t, e.state, e.control, e.contact, e.foot_pos, e.board_pos,
                               target_velocity_mps=e.target_velocity_mps)
        failures = rep.failures(system)
        bad += bool(failures)
        ok = (f"ok: rides at {rep.momentum_speed_mps:.3f} m/s ({100 * rep.momentum_speed_error:.2f} % off), "
              f"Coulomb margin {rep.min_friction_margin_N:.2f} N, defect {rep.max_defect:.1e}")
        figures = {"momentum_speed_mps": rep.momentum_speed_mps, "momentum_speed_error": rep.momentum_speed_error,
                   "min_friction_margin_N": rep.min_friction_margin_N, "max_defect": rep.max_defect,
                   "max_torque_rigid_legs_Nm": rep.max_torque_rigid_legs_Nm}
        report(e.key, "failed" if failures else "ok", ok if not failures else "; ".join(failures), figures)
    return bad


def _validate_humanoid(lib: MotionLibrary, report: Report) -> int:
    from skatelib.pipeline.config import humanoid_config_from_json
    from skatelib.pipeline.humanoid.motion import skating_steps, walking_steps
    from skatelib.pipeline.humanoid.verify import check_steps, failures

    try:
        cfg = humanoid_config_from_json(str(lib.attrs["config_resolved_json"]), lib.path)
    except SkatelibError as err:
        raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {err}") from err
    h = cfg.humanoid
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        plan = (walking_steps if cfg.sweep.motion == "walk" else skating_steps)(cfg, e.target_velocity_mps)[1]
        rep = check_steps(plan, e.arrays["nodes_t"], e.arrays["nodes_state"], e.arrays["nodes_control"],
                          h.gravity_mps2, h.leg_min_m, h.leg_max_m)
        fails = failures(rep)
        bad += bool(fails)
        report(e.key, "failed" if fails else "ok", "ok" if not fails else "; ".join(fails), {})
    return bad
