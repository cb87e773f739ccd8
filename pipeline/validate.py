"""``skatelib validate``: integrity and physics of every entry of a library file."""

from __future__ import annotations

import datetime
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.errors import SkatelibError
from skatelib.library.reader import read_library
from skatelib.pipeline.kinds import ReportFn, kind_named
from skatelib.runtime import MotionLibrary


@dataclass(frozen=True)
class EntryVerdict:
    """One entry's (or one junction's between entries) validation: its key, its status (``ok``,
    ``failed``, ``skipped`` for an entry stored as failed), the message ``skatelib validate`` prints
    and the figures measured (each named with its unit)."""

    key: str
    status: str
    message: str
    figures: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class ValidationReport:
    """What :func:`skatelib.validate` found: each entry's verdict, how many failed, and the
    closed-loop verdicts when asked for (``TrackResult`` on the model plant, ``TwinResult`` on the twin)."""

    path: Path
    entries: tuple[EntryVerdict, ...]
    failed: int
    closed_loop: tuple[Any, ...] = ()

    @property
    def usable(self) -> bool:
        """Whether any entry of the library was solved (each stored failure is ``skipped``)."""
        return any(v.status != "skipped" for v in self.entries)

    @property
    def valid(self) -> bool:
        """No entry failed a check (nor a closed-loop run), and some entry is usable."""
        return not self.failed and self.usable and all(r.passed for r in self.closed_loop)


def validate_library(path: Path | str, report: ReportFn) -> int:
    """Check the file (raises on a corrupt one) and each entry's physics; returns the failures.
    ``report`` gets each entry's key, verdict, message and the figures measured."""
    read_library(path, full=True)  # integrity: checksum, and every attribute and view against the index
    lib = MotionLibrary.open(path)
    return kind_named(lib.kind, lib.path).validate_entries(lib, report)


def closed_loop_perturbation(path: Path, perturb: str, default: str) -> str:
    """The model errors ``validate --closed-loop`` rides with: ``perturb``, except that a humanoid
    library given the quadruped's ``default`` takes the humanoid's default set (its keys differ)."""
    if perturb != default or MotionLibrary.open(path).kind != "humanoid":
        return perturb
    from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION

    return DEFAULT_HUMANOID_PERTURBATION


def closed_loop_jobs(path: Path, perturb: str, plant: str = "model") -> list[Any]:
    """The rides of ``validate --closed-loop``: every successful entry against the plant ``perturb``
    ('none': as planned), on the model plant or (``plant="mujoco"``) the twin (a humanoid library's
    on its own twin, under the stabilizer); made before any work, so that what would stop them
    stops the command at once.

    Raises:
        OutputError: The file is not to be rewritten (read-only, another user's).
        SkatelibError: A bad perturbation (a key out of its range), naming it; a humanoid library
            asked for the model plant.
        ImportError: The controller's packages are missing (names the extra).
    """
    from skatelib.library.amend import check_amendable

    check_amendable(path)  # the verdicts are stored in the file
    errors = "" if perturb == "none" else perturb
    humanoid = MotionLibrary.open(path).kind == "humanoid"
    if humanoid and plant != "mujoco":
        raise SkatelibError(f"{path}: a humanoid library is executed on its physical twin: add --plant mujoco "
                            "(the model plant is the quadruped's)")
    try:
        if humanoid:
            from skatelib.proving.humanoid.track import humanoid_jobs

            return list(humanoid_jobs(path, None, errors))
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

    # a quadruped's job returns its verdict with its run (None here), a humanoid's the verdict alone
    results = [out[0] if isinstance(out, tuple) else out for out in run_calls(calls, jobs)]
    prefix, attr = ("closed_loop_twin", schema.A_CLOSED_LOOP_TWIN) if plant == "mujoco" else (
        "closed_loop", schema.A_CLOSED_LOOP)
    amend_library(path, {f"{prefix}_plant": perturb,
                         f"{prefix}_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")},
                  {r.key: {attr: json.dumps(r.as_dict(), sort_keys=True)} for r in results})
    return results
