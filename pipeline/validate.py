"""``skatelib validate``: integrity and physics of every entry of a library file."""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.library.reader import read_library
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.system import SkateSystem
from skatelib.pipeline.verify import check_trajectory
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


def validate_library(path: Path | str, report: Callable[[str, str], None]) -> int:
    """Check the file (raises on a corrupt one) and each entry's physics; returns the failures."""
    read_library(path, full=True)  # integrity: checksum, and every attribute and view against the index
    lib = MotionLibrary.open(path)
    if lib.kind != "quadruped":
        report("-", f"kind {lib.kind}: only the integrity was checked")
        return 0
    system = system_from_library(lib)
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, f"stored as failed ({e.attrs['status']}): skipped")
            continue
        assert e.contact is not None and e.foot_pos is not None and e.board_pos is not None
        rep = check_trajectory(system, e.t, e.state, e.control, e.contact, e.foot_pos, e.board_pos)
        failures = rep.failures(system)
        bad += bool(failures)
        report(e.key, "ok" if not failures else "; ".join(failures))
    return bad
