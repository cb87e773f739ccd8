"""Which entries a request may use (``MotionLibrary.select`` and ``blend``): the successful ones,
certified at ``min_success`` when that is asked, from one start speed, with one stride count; and
the two start-ups that bracket a speed."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Protocol

from skatelib.library.certificate import Certificate
from skatelib.runtime.certified import usable
from skatelib.runtime.entry import Entry, EntryNotFound
from skatelib.runtime.routes import speed_key


class Library(Protocol):
    """What the selection reads of a :class:`~skatelib.runtime.MotionLibrary`."""

    path: Path

    @property
    def certificate(self) -> Certificate | None: ...

    def __iter__(self) -> Iterator[Entry]: ...

    def speeds(self, strides: int | None = None, from_velocity_mps: float = 0.0) -> list[float]: ...

    def start_speeds(self) -> list[float]: ...


def candidates(lib: Library, strides: int | None, from_velocity_mps: float = 0.0,
               min_success: float | None = None) -> tuple[list[Entry], str]:
    """The successful entries (certified at ``min_success``) from ``from_velocity_mps`` with
    ``strides``, and a note on those ``min_success`` left out."""
    v0 = from_velocity_mps
    entries, note = usable(lib, lib.certificate if min_success is not None else None, min_success)
    start = [e for e in entries if speed_key(e.from_velocity_mps) == speed_key(v0)]
    if not start:
        cert = "" if min_success is None else f" certified at min_success {min_success:g}"
        raise EntryNotFound(f"{lib.path}: no successful entry{cert} starts riding at {v0} m/s; entries start at "
                            f"{lib.start_speeds()} m/s (0: from rest){note}")
    c = [e for e in start if strides is None or e.n_strides == strides]
    if not c:
        have = sorted({e.n_strides for e in start})
        raise EntryNotFound(f"{lib.path}: no successful entry from {v0} m/s with strides={strides}; "
                            f"strides available: {have}{note}")
    return c, note


def bracket(lib: Library, target_velocity_mps: float, strides: int | None) -> tuple[Entry, Entry]:
    """The two successful start-ups of one stride count (``strides``, else the fewest whose
    start-ups do) on either side of ``target_velocity_mps`` [m/s], for a blend."""
    # The start-ups' stride counts only: a transition's count may be one no start-up has.
    counts = [strides] if strides is not None else sorted(
        {e.n_strides for e in lib if e.success and speed_key(e.from_velocity_mps) == speed_key(0.0)})
    for s in counts:
        c = sorted(candidates(lib, s)[0], key=lambda e: e.target_velocity_mps)
        lo = [e for e in c if e.target_velocity_mps <= target_velocity_mps]
        hi = [e for e in c if e.target_velocity_mps >= target_velocity_mps]
        if lo and hi:
            return lo[-1], hi[0]
    ranges = {s: lib.speeds(s) for s in counts}
    raise EntryNotFound(f"{lib.path}: {target_velocity_mps} m/s is outside the stored speeds {ranges} "
                        "(per stride count)")
