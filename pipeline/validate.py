"""``skatelib validate``: integrity and physics of every entry of a library file."""

from __future__ import annotations

import datetime
import json
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.reader import read_library
from skatelib.pipeline.kinds import ReportFn, kind_named
from skatelib.runtime import MotionLibrary


def validate_library(path: Path | str, report: ReportFn) -> int:
    """Check the file (raises on a corrupt one) and each entry's physics; returns the failures.
    ``report`` gets each entry's key, verdict, message and the figures measured."""
    read_library(path, full=True)  # integrity: checksum, and every attribute and view against the index
    lib = MotionLibrary.open(path)
    return kind_named(lib.kind, lib.path).validate_entries(lib, report)


def closed_loop_verdicts(path: Path, perturb: str, jobs: int) -> list[Any]:
    """Track every successful entry in closed loop against the plant ``perturb`` ('none': exact) and
    store each verdict in the library (entry attribute ``closed_loop_json``); returns the verdicts.

    Raises:
        ImportError: When the controller's packages are missing (names the extra).
    """
    from skatelib.library.amend import amend_library

    try:
        from skatelib.control.track import track_jobs
    except ImportError as e:
        raise ImportError(f"the controller's packages are missing ({e}); pip install 'skatelib[control]'") from e
    from skatelib.pipeline.build.sweep import run_calls

    results = [r for r, _ in run_calls(track_jobs(path, None, "" if perturb == "none" else perturb), jobs)]
    amend_library(path, {"closed_loop_plant": perturb,
                         "closed_loop_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")},
                  {r.key: {schema.A_CLOSED_LOOP: json.dumps(r.as_dict(), sort_keys=True)} for r in results})
    return results
