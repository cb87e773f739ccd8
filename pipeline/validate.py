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


def closed_loop_jobs(path: Path, perturb: str, plant: str = "model") -> list[Any]:
    """The rides of ``validate --closed-loop``: every successful entry against the plant ``perturb``
    ('none': as planned), on the model plant or (``plant="mujoco"``) the twin; made before any work,
    so that what would stop them stops the command at once.

    Raises:
        OutputError: The file is not to be rewritten (read-only, another user's).
        SkatelibError: A bad perturbation (a key out of its range), naming it.
        ImportError: The controller's packages are missing (names the extra).
    """
    from skatelib.library.amend import check_amendable

    check_amendable(path)  # the verdicts are stored in the file
    errors = "" if perturb == "none" else perturb
    try:
        if plant == "mujoco":
            from skatelib.proving.twin.track import twin_jobs

            return list(twin_jobs(path, None, errors))
        from skatelib.proving.track import track_jobs

        return list(track_jobs(path, None, errors))
    except ImportError as e:
        raise ImportError(f"the controller's packages are missing ({e}); pip install 'skatelib[control,sim]'") from e


def closed_loop_verdicts(path: Path, perturb: str, calls: list[Any], jobs: int, plant: str = "model") -> list[Any]:
    """Ride ``calls`` (:func:`closed_loop_jobs`) on ``jobs`` workers and store each verdict in the
    library (entry attribute ``closed_loop_json``, or ``closed_loop_twin_json``, with the plant's
    name ``perturb``), keeping the file's mode; returns the verdicts.

    Raises:
        OutputError: When the file is not to be rewritten (it changed since the rides were made).
    """
    from skatelib.library.amend import amend_library
    from skatelib.pipeline.build.sweep import run_calls

    results = [out[0] for out in run_calls(calls, jobs)]
    prefix, attr = ("closed_loop_twin", schema.A_CLOSED_LOOP_TWIN) if plant == "mujoco" else (
        "closed_loop", schema.A_CLOSED_LOOP)
    amend_library(path, {f"{prefix}_plant": perturb,
                         f"{prefix}_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")},
                  {r.key: {attr: json.dumps(r.as_dict(), sort_keys=True)} for r in results})
    return results
