"""Where a build's time goes (``skatelib build --profile OUT.json``).

While :data:`ENV` names a folder, every process of the build (the build's own and its loky
workers, to which the sweep hands the folder with each task) appends a line per finished span
to ``<folder>/<pid>.jsonl``: its phase, wall-clock start and end (``time.time()``, comparable
between processes of one machine), the process and what the phase knows (an entry's key, an
attempt's success). Without the variable a span costs one dictionary lookup. A dask cluster's
workers are not handed the folder: a profile is of a build on this machine.

:func:`summarize` cuts the spans into the phases a user asks about: the compile, the start-ups'
and transitions' solves, failed attempts, physics checks, twin rides, the candidates the checks
or the twin refused, the library's writing, and the workers' idle time.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ENV = "SKATELIB_PROFILE_DIR"


@contextmanager
def span(phase: str, **fields: Any) -> Iterator[dict[str, Any]]:
    """Record the time spent in the block as a span of ``phase`` (when profiling). Yields a dict
    the block may add fields to (an outcome known only at its end); they are stored with the span."""
    folder = os.environ.get(ENV)
    if not folder:
        yield fields
        return
    t0 = time.time()
    try:
        yield fields
    finally:
        record = {"phase": phase, "start": t0, "end": time.time(), "pid": os.getpid(), **fields}
        with open(Path(folder) / f"{os.getpid()}.jsonl", "a", encoding="utf-8") as f:
            f.write(json.dumps(record, default=str) + "\n")


def profiled() -> bool:
    """Whether this process records spans (a span's fields that cost something to make are added
    only then)."""
    return bool(os.environ.get(ENV))


def profile_to(folder: str) -> None:
    """Record this process's spans in ``folder`` ('': record none)."""
    if folder:
        os.environ[ENV] = folder
    else:
        os.environ.pop(ENV, None)


@contextmanager
def profiling() -> Iterator[list[dict[str, Any]]]:
    """Profile the processes started in the block: yields a list that holds, once the block ends
    (or fails), every span recorded, sorted by start. Sets :data:`ENV` for the block only."""
    spans: list[dict[str, Any]] = []
    before = os.environ.get(ENV)
    with tempfile.TemporaryDirectory(prefix="skatelib-profile-") as tmp:
        os.environ[ENV] = tmp
        try:
            yield spans
        finally:
            if before is None:
                os.environ.pop(ENV, None)
            else:
                os.environ[ENV] = before
            for path in sorted(Path(tmp).glob("*.jsonl")):
                spans.extend(json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line)
            spans.sort(key=lambda s: s["start"])


@dataclass(frozen=True)
class PhaseRow:
    """One phase of a build: its time in seconds of one process, how many spans, and a note."""

    phase: str
    seconds: float
    count: int
    note: str = ""


def _inside(s: dict[str, Any], outer: dict[str, Any]) -> bool:
    return s["pid"] == outer["pid"] and s["start"] >= outer["start"] and s["end"] <= outer["end"]


def _total(spans: list[dict[str, Any]]) -> float:
    return sum(s["end"] - s["start"] for s in spans)


def summarize(spans: list[dict[str, Any]], jobs: int) -> tuple[list[PhaseRow], float]:
    """The build's phases (seconds of one process each) and its wall time, from its spans.

    The rows from the solves to the idle time add up to the sweep's worker time: its wall time
    times its workers (``jobs``, or fewer when the sweep has fewer tasks). A candidate (one stride
    count of a transition) that was not kept (unsolved, or refused by the physics checks or the
    twin) is counted whole under "refused candidates", its solves and rides included; the other
    rows count what was kept.
    """
    def of(phase: str) -> list[dict[str, Any]]:
        return [s for s in spans if s["phase"] == phase]

    builds, sweeps, tasks = of("build"), of("sweep"), of("task")
    if not builds:
        raise ValueError("no build span: the profile is empty (was the build run inside profiling()?)")
    wall = builds[0]["end"] - builds[0]["start"]
    refused = [c for c in of("candidate") if not c.get("accepted")]

    def kept(phase: str, **match: Any) -> list[dict[str, Any]]:
        return [s for s in of(phase) if all(s.get(k) == v for k, v in match.items())
                and not any(_inside(s, c) for c in refused)]

    rows = [PhaseRow("compile (the build's process)", _total(of("prepare")), len(of("prepare")),
                     "stage functions compiled, or loaded from the cache")]
    for label, task_kind in (("start-up solves", "start-up"), ("transition solves", "transition")):
        ok = kept("attempt", success=True, task=task_kind)
        rows.append(PhaseRow(label, _total(ok), len(ok), "the attempt that converged"))
    failed = kept("attempt", success=False)
    rows.append(PhaseRow("failed attempts", _total(failed), len(failed), "retries' earlier tries, entries that failed"))
    checks = kept("checks")
    rows.append(PhaseRow("physics checks", _total(checks), len(checks)))
    twin = kept("twin")
    rows.append(PhaseRow("twin rides", _total(twin), len(twin), "the judge of the transitions kept"))
    rows.append(PhaseRow("refused candidates", _total(refused), len(refused),
                         "stride counts not kept (unsolved, or refused by the checks or the twin): all their work"))
    accounted = sum(r.seconds for r in rows[1:])
    busy = _total(tasks)
    rows.append(PhaseRow("other work in tasks", busy - accounted, len(tasks), "cache reads, problem set-up, events"))
    sweep_wall = _total(sweeps)
    n_workers = max(1, min(jobs, len(tasks)))  # a sweep of fewer tasks than jobs starts fewer workers
    rows.append(PhaseRow("workers idle", max(0.0, n_workers * sweep_wall - busy), 0,
                         f"{n_workers} x {sweep_wall:.1f} s of sweep, less their tasks"))
    rows.append(PhaseRow("writing (the build's process)", _total(of("write")), len(of("write")),
                         "the library file, checked and moved into place"))
    return rows, wall


def write_profile(path: Path, spans: list[dict[str, Any]], jobs: int) -> tuple[list[PhaseRow], float]:
    """Write ``{"jobs", "wall_s", "phases", "spans"}`` to ``path`` (JSON, atomically); returns the phases."""
    from skatelib.library.atomic import atomic_path

    rows, wall = summarize(spans, jobs)
    doc = {"jobs": jobs, "wall_s": wall,
           "phases": [{"phase": r.phase, "seconds": r.seconds, "count": r.count, "note": r.note} for r in rows],
           "spans": spans}
    with atomic_path(Path(path)) as tmp:
        tmp.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return rows, wall
